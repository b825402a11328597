"""LCD (Cao et al. 2021 eqs. (4)-(11)): reconstruction, tones, ISC conditions."""

import numpy as np
import pytest

from gyrocomp.decompose import DecomposeSettings, decompose
from gyrocomp.decompose.emd import _extrema
from gyrocomp.decompose.lcd import baseline_points, lcd


def test_reconstruction_and_tones(tones, best_correlation):
    x, (fast, slow) = tones
    d = decompose(x, DecomposeSettings(method="lcd"))
    assert d.names[0] == "isc1" and d.names[-1] == "trend"
    assert len(d.names) <= 11
    assert np.max(np.abs(d.components.sum(0) - x)) <= 1e-9 * np.max(np.abs(x))
    assert best_correlation(d.components[:-1], fast) > 0.95
    assert best_correlation(d.components[:-1], slow) > 0.95


def test_baseline_point_exact():
    """Eqs. (5)-(6) by hand: neighbours (0, 1) and (4, 3), extremum (1, -1): C = 1.5, L = 0.25."""
    assert baseline_points([0.0, 1.0, 4.0], [1.0, -1.0, 3.0], q=0.5)[0] == pytest.approx(0.25)


def test_isc_conditions(tones):
    """Cheng's ISC conditions on ISC1: (I) maxima positive, minima negative;
    (II) the baseline points L_u of eq. (6) vanish (|L| < 5 % of the local amplitude)."""
    x, _ = tones
    isc = lcd(x)[0]
    imax, imin = _extrema(isc[None])
    assert np.mean(isc[imax[0]] > 0) > 0.98
    assert np.mean(isc[imin[0]] < 0) > 0.98
    pos = np.flatnonzero(imax[0] | imin[0])
    inner = slice(5, -5)  # away from the end effects
    level = baseline_points(pos, isc[pos])[inner]
    amplitude = np.abs(isc[pos])[1:-1][inner]
    assert np.median(np.abs(level) / amplitude) < 0.05


def test_trend_is_monotonic_or_bounded():
    x = np.random.default_rng(1).standard_normal(3000).cumsum()
    c = lcd(x, max_components=10)
    imax, imin = _extrema(c[-1][None])
    assert c.shape[0] == 11 or imax.sum() + imin.sum() < 3


def test_q_out_of_range():
    with pytest.raises(ValueError, match="q"):
        lcd(np.arange(10.0), q=1.0)


def test_components_equal_the_isc_by_isc_definition():
    """LCD fills its output in place (issue 38, memory): each ISC is the sifting of the trend left
    by the ones before it, and the trend is that minus the ISC, bit for bit."""
    from gyrocomp.decompose.emd import Sifting, _sift
    from gyrocomp.decompose.lcd import _baseline

    rng = np.random.default_rng(8)
    x = rng.standard_normal(4000) + np.cumsum(rng.standard_normal(4000)) * 0.05
    out = lcd(x, max_components=4)
    trend = x.copy()
    sifting = Sifting(stop="sd", sd_threshold=0.3, max_sift=10)
    for k in range(out.shape[0] - 1):
        isc = _sift(trend[None], sifting, _baseline, energy_stop=0.3, q=0.5)[0]
        np.testing.assert_array_equal(out[k], isc)
        trend = trend - isc
    np.testing.assert_array_equal(out[-1], trend)
    assert out.shape[0] == 5 and out.flags.c_contiguous
