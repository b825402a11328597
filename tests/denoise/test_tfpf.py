"""Time-frequency peak filtering: exact cases and the window-length trade-off."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.denoise import tfpf
from gyrocomp.errors import InputError


def test_linear_signal_passes_unbiased():
    """The PWVD of an FM signal with linear IF peaks at that IF: a line is returned exactly."""
    t = np.arange(3000.0)
    line = 0.02 * t - 7.0
    for window in (11, 101):
        assert_allclose(tfpf(line, window), line, atol=1e-8 * np.ptp(line))


def test_reduces_noise_on_smooth_signal_and_long_window_smooths_more():
    rng = np.random.default_rng(0)
    t = np.arange(4000.0)
    clean = np.sin(2 * np.pi * t / 800)
    noisy = clean + 0.3 * rng.standard_normal(t.size)
    rms = lambda e: float(np.sqrt(np.mean(e**2)))
    short, long = tfpf(noisy, 21), tfpf(noisy, 101)
    assert rms(short - clean) < 0.5 * rms(noisy - clean)
    assert rms(long - clean) < rms(short - clean)
    assert np.std(np.diff(long)) < np.std(np.diff(short))  # rougher with the short window


def test_constant_and_offset_scale_invariance():
    assert_allclose(tfpf(np.full(100, 3.5), 11), 3.5)
    x = np.random.default_rng(1).standard_normal(500)
    assert_allclose(tfpf(10 * x + 4, 21), 10 * tfpf(x, 21) + 4, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize(
    "kwargs", [dict(window=10), dict(window=1), dict(scale=(0.2, 0.6)), dict(scale=(0.3, 0.2)), dict(lag_window="nope")]
)
def test_bad_settings(kwargs):
    with pytest.raises(InputError):
        tfpf(np.arange(50.0), **{"window": 11, **kwargs})


def test_window_longer_than_signal():
    with pytest.raises(InputError, match="needs at least"):
        tfpf(np.arange(10.0), 41)
