"""Noise generators against IEEE Std 952 Allan signatures (REFERENCES.md 2.2, 2.9).

The Allan deviation is computed with allantools.oadev, independent of gyrocomp.
"""

import allantools
import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.errors import InputError
from gyrocomp.effects import noise

FS = 10.0
N_SAMPLES = 2**17


def _oadev(x, fs=FS):
    taus, adev, _, _ = allantools.oadev(x, rate=fs, data_type="freq", taus="octave")
    return taus, adev


def _slope(taus, adev, lo, hi):
    sel = (taus >= lo) & (taus <= hi)
    return np.polyfit(np.log(taus[sel]), np.log(adev[sel]), 1)[0]


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_white_gives_slope_minus_half_and_arw(seed):
    arw = 1.0  # deg/sqrt(h)
    taus, adev = _oadev(noise.white(N_SAMPLES, FS, arw, np.random.default_rng(seed)))
    assert _slope(taus, adev, 0.1, 100.0) == pytest.approx(-0.5, abs=0.05)
    # sigma(tau) = N / sqrt(tau) [deg/s]; N back in deg/sqrt(h) = * 60.
    n_fit = np.exp(np.mean(np.log(adev[taus <= 100] * np.sqrt(taus[taus <= 100])))) * 60.0
    assert_allclose(n_fit, arw, rtol=0.10)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_flicker_gives_flat_floor_of_0664_b(seed):
    b = 20.0  # deg/h
    taus, adev = _oadev(noise.flicker(N_SAMPLES, FS, b, np.random.default_rng(seed)))
    assert abs(_slope(taus, adev, 0.4, 200.0)) < 0.05
    sel = (taus >= 0.4) & (taus <= 200.0)
    b_fit = np.median(adev[sel]) * 3600.0 / np.sqrt(2 * np.log(2) / np.pi)
    assert_allclose(b_fit, b, rtol=0.10)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_random_walk_gives_slope_plus_half_and_k(seed):
    k = 30.0  # deg/h/sqrt(h)
    taus, adev = _oadev(noise.random_walk(N_SAMPLES, FS, k, np.random.default_rng(seed)))
    assert _slope(taus, adev, 0.4, 200.0) == pytest.approx(0.5, abs=0.05)
    # sigma(tau) = K sqrt(tau / 3) [deg/s]; K in deg/h/sqrt(h) = * 3600 * 60.
    sel = (taus >= 0.4) & (taus <= 200.0)
    k_fit = np.exp(np.mean(np.log(adev[sel] / np.sqrt(taus[sel] / 3.0)))) * 216000.0
    assert_allclose(k_fit, k, rtol=0.10)


def test_all_three_combined_read_off_points():
    """The sum reads back N at tau=1 s and K at large tau, as in IEEE 952 Annex C."""
    rng = np.random.default_rng(7)
    x = noise.white(N_SAMPLES, FS, 0.5, rng) + noise.random_walk(N_SAMPLES, FS, 100.0, rng)
    taus, adev = _oadev(x)
    assert_allclose(np.interp(0.0, np.log(taus), np.log(adev)), np.log(0.5 / 60.0), atol=0.10)


def test_same_generator_state_same_bytes_and_units_scale_linearly():
    a = noise.flicker(1000, 1.0, 10.0, np.random.default_rng(3))
    b = noise.flicker(1000, 1.0, 20.0, np.random.default_rng(3))
    assert_allclose(b, 2 * a, rtol=1e-12)
    assert noise.white(5, 1.0, 1.0, np.random.default_rng(3)).tobytes() == noise.white(
        5, 1.0, 1.0, np.random.default_rng(3)
    ).tobytes()


def test_unit_conversions():
    assert noise.arw_to_dps_sqrt_s(60.0) == 1.0
    assert noise.rrw_to_dps_per_sqrt_s(216000.0) == 1.0


@pytest.mark.parametrize("args", [(-1, 1.0, 1.0), (10, 0.0, 1.0), (10, 1.0, -1.0)])
def test_bad_arguments_raise_input_error(args):
    with pytest.raises(InputError):
        noise.white(*args, np.random.default_rng(0))
