"""EMD core: splines, extrema, and agreement with PyEMD."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.interpolate import CubicSpline

from gyrocomp.decompose import emd as E


@pytest.mark.parametrize("m", [2, 3, 4, 7, 60])
def test_spline_equals_scipy_not_a_knot(m):
    """The stacked gtsv spline equals scipy's not-a-knot CubicSpline (rtol 1e-12)."""
    rng = np.random.default_rng(m)
    t = np.r_[-7, np.sort(rng.choice(np.arange(1, 300), m - 2, replace=False)), 305]
    z = rng.standard_normal(m)
    got = E._splines((np.r_[t, t], np.r_[z, -z], np.array([m, m])), 300)
    grid = np.arange(300)
    ref = CubicSpline(t, z)(grid) if m > 2 else z[0] + (grid - t[0]) * (z[1] - z[0]) / (t[1] - t[0])
    assert_allclose(got[0], ref, rtol=1e-12, atol=1e-12)
    assert_allclose(got[1], -ref, rtol=1e-12, atol=1e-12)


def test_plateau_is_one_extremum_at_its_middle():
    """Rilling's extr: a flat top between a rise and a fall is one maximum at round-half-up of its middle."""
    x = np.array([[0.0, 1.0, 2.0, 2.0, 2.0, 2.0, 1.0, 0.0, -1.0, -1.0, 0.0]])
    imax, imin = E._extrema(x)
    assert np.flatnonzero(imax[0]).tolist() == [4]
    assert np.flatnonzero(imin[0]).tolist() == [9]


def test_rows_of_a_batch_do_not_mix():
    """A row sifted alone or in a batch gives the same bytes (the basis of worker-independence).

    Both sifts run in this process: exact bytes hold within one machine and one process type.
    """
    rng = np.random.default_rng(3)
    rows = rng.standard_normal((4, 700))
    batch = E.sift(rows)
    for i in range(4):
        assert E.sift(rows[i:i + 1])[0].tobytes() == batch[i].tobytes()


def test_reconstruction_and_tones(tones, best_correlation):
    x, (fast, slow) = tones
    imfs, residue = E.emd(x)
    assert np.max(np.abs(imfs.sum(0) + residue - x)) <= 1e-9 * np.max(np.abs(x))
    assert best_correlation(imfs, fast) > 0.95
    assert best_correlation(imfs, slow) > 0.95
    assert E.count_extrema(residue[None])[0] < 3


def test_agrees_with_pyemd_under_matched_settings():
    """Same IMFs as PyEMD's EMD with 8 fixed siftings per IMF.

    Settings matched: PyEMD ``EMD(spline_kind="cubic", nbsym=2,
    extrema_detection="simple", FIXE=8)``; here Rilling's rule with
    thresholds (0, 0, 0), which never passes, and ``max_sift = 8``. Both then
    sift exactly 8 times with mirrored extrema and not-a-knot splines.
    Tolerance: 1e-8 of the signal's peak on the first three IMFs.
    """
    pyemd = pytest.importorskip("PyEMD")
    t = np.arange(1000)
    x = np.sin(2 * np.pi * t / 23) + 0.7 * np.sin(2 * np.pi * t / 170 + 0.3) + 0.3 * np.cos(2 * np.pi * t / 600)
    ref = pyemd.EMD(spline_kind="cubic", nbsym=2, extrema_detection="simple", FIXE=8)(x, max_imf=3)
    imfs, _ = E.emd(x, E.Sifting(thresholds=(0.0, 0.0, 0.0), max_sift=8), max_imfs=3)
    assert_allclose(imfs[:3], ref[:3], atol=1e-8 * np.max(np.abs(x)))


def test_sd_stop_reconstructs(tones, best_correlation):
    x, (fast, _) = tones
    imfs, residue = E.emd(x, E.Sifting(stop="sd", sd_threshold=0.2))
    assert np.max(np.abs(imfs.sum(0) + residue - x)) <= 1e-9 * np.max(np.abs(x))
    assert best_correlation(imfs, fast) > 0.95


def test_bad_sifting_settings():
    with pytest.raises(ValueError, match="stop"):
        E.Sifting(stop="cauchy")
    with pytest.raises(ValueError, match="max_sift"):
        E.Sifting(max_sift=0)


@pytest.mark.parametrize(
    "sifting",
    [
        E.Sifting(),
        E.Sifting(max_sift=200),
        E.Sifting(stop="sd"),
        E.Sifting(stop="s_number", s_number=3, max_sift=50),
        E.Sifting(stop="fixed", max_sift=7),
    ],
    ids=["rilling", "rilling200", "sd", "s_number", "fixed"],
)
def test_compiled_kernel_equals_numpy_path(sifting):
    """The numba kernel computes the numpy path's sift (same algorithm and order): same bytes.

    Rows: white noise, random walks and coarsely rounded walks (plateaus).
    """
    kernel = pytest.importorskip("gyrocomp.decompose._compiled")
    rng = np.random.default_rng(11)
    rows = np.vstack([rng.standard_normal((3, 400)), rng.standard_normal((3, 400)).cumsum(1)])
    rows = np.vstack([rows, np.round(rows[3:], 1)])
    ref = E._sift(rows, sifting, E._mean_envelope, E._energy_stop(sifting))
    theta1, theta2, alpha = sifting.thresholds
    got = kernel.sift_rows(
        rows, kernel.STOPS[sifting.stop], theta1, theta2, alpha, sifting.sd_threshold, sifting.s_number, sifting.max_sift
    )
    assert_allclose(got, ref, rtol=0, atol=1e-12 * np.max(np.abs(rows)))


def test_s_number_stops_on_a_proto_imf():
    """A pure tone already satisfies S-number's count condition: S sifts later the IMF is the tone."""
    t = np.arange(2000)
    x = np.sin(2 * np.pi * t / 50)[None]
    imf = E.sift(x, E.Sifting(stop="s_number", s_number=4, max_sift=100))
    assert np.max(np.abs(imf[0, 100:-100] - x[0, 100:-100])) < 0.01
