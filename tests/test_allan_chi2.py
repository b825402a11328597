"""The chi-square quantiles of the Allan deviation's interval, against scipy (the reference it replaces at start-up)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.special import gammaincinv

from gyrocomp.allan.chi2 import chi2_ppf


@pytest.mark.parametrize("p", [0.001, 0.025, 0.1585, 0.5, 0.8415, 0.975, 0.999])
def test_chi2_ppf_equals_scipy_gammaincinv(p):
    """2 gammaincinv(nu/2, p) from nu = 0.1 to 10^9: the edf of a few clusters up to 10^9 samples."""
    nu = np.concatenate([np.geomspace(0.1, 1e9, 61), np.random.default_rng(7).uniform(0.5, 40.0, 20), [1.0, 2.0, 29.99, 30.0, 30.01]])
    assert_allclose(chi2_ppf(p, nu), 2.0 * gammaincinv(nu / 2.0, p), rtol=1e-12)


def test_chi2_ppf_exact_cases():
    """nu = 2 is the exponential of mean 2: x = -2 ln(1 - p)."""
    p = np.array([0.001, 0.1585, 0.5, 0.8415, 0.999])
    assert_allclose([chi2_ppf(q, [2.0])[0] for q in p], -2.0 * np.log1p(-p), rtol=1e-14)


def test_chi2_ppf_refuses_and_propagates():
    assert np.isnan(chi2_ppf(0.5, [np.nan, np.inf, 0.0, -1.0])).all()
    with pytest.raises(ValueError, match="p = 1.0"):
        chi2_ppf(1.0, [3.0])
