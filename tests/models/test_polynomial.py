"""PolynomialDrift: exact recovery and agreement with numpy.polynomial."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.models import PolynomialDrift


def test_recovers_cubic_and_rate_term_exactly():
    rng = np.random.default_rng(0)
    T = rng.uniform(-40, 60, 500)
    rate = rng.uniform(-0.05, 0.05, 500)
    coef = np.array([0.3, 2e-3, -4e-5, 6e-7])
    bias = np.polynomial.polynomial.polyval(T - 25.0, coef) + 1.7 * rate
    model = PolynomialDrift().fit(np.column_stack([T, rate]), bias)
    assert_allclose(model.coef_, coef, rtol=1e-8)
    assert_allclose(model.rate_coef_, 1.7, rtol=1e-8)
    assert_allclose(model.predict(np.column_stack([T, rate])), bias, rtol=1e-10, atol=1e-12)


def test_matches_numpy_polyfit_without_rate():
    rng = np.random.default_rng(1)
    T = rng.uniform(-40, 60, 300)
    y = np.cos(T / 30) + rng.normal(0, 0.01, 300)
    model = PolynomialDrift(degree=3, reference_temperature=10.0, rate_term=False).fit(T[:, None], y)
    reference = np.polynomial.polynomial.polyfit(T - 10.0, y, 3)
    assert_allclose(model.coef_, reference, rtol=1e-7)
    assert model.rate_coef_ == 0.0


def test_rate_term_needs_second_column():
    with pytest.raises(ValueError, match="rate_term"):
        PolynomialDrift().fit(np.linspace(0, 1, 10)[:, None], np.ones(10))


@pytest.mark.parametrize("params, name", [({"degree": -1}, "degree"), ({"rate_term": "yes"}, "rate_term"),
                                           ({"reference_temperature": float("nan")}, "reference_temperature")])
def test_invalid_parameters_name_themselves(params, name):
    with pytest.raises(ValueError, match=name):
        PolynomialDrift(**params).fit(np.ones((5, 2)) * np.arange(5)[:, None], np.ones(5))
