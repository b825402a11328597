"""The temperature-rate estimator against an independent least-squares fit and exact cases."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.errors import InputError
from gyrocomp.pipeline.rate import causal_coefficients, describe, model_inputs, temperature_rate, window_samples
from gyrocomp.pipeline.settings import RateSettings


def test_centred_slope_equals_numpy_polyfit_over_the_window():
    """Independent method: numpy.polyfit of a straight line over each centred window."""
    rng = np.random.default_rng(1)
    fs = 2.0
    t = np.arange(400) / fs
    temperature = 20 + 0.01 * t + 0.5 * np.sin(t / 40) + rng.normal(0, 0.02, t.size)
    settings = RateSettings(window_s=30.0, polyorder=1)
    n = window_samples(settings, fs)
    rate = temperature_rate(temperature, fs, settings)
    half = n // 2
    for i in (half, 100, 250, t.size - half - 1):
        ref = np.polyfit(t[i - half : i + half + 1], temperature[i - half : i + half + 1], 1)[0]
        assert_allclose(rate[i], ref, rtol=1e-9)


def test_causal_slope_uses_only_the_past_and_equals_a_trailing_fit():
    rng = np.random.default_rng(2)
    temperature = np.cumsum(rng.normal(0, 0.05, 300)) + 25
    settings = RateSettings(window_s=21.0)
    rate = temperature_rate(temperature, 1.0, settings, causal=True)
    t = np.arange(300.0)
    for i in (20, 150, 299):
        ref = np.polyfit(t[i - 20 : i + 1], temperature[i - 20 : i + 1], 1)[0]
        assert_allclose(rate[i], ref, rtol=1e-9)
    changed = temperature.copy()
    changed[200:] += 5.0  # the future must not move the estimate before it
    assert_allclose(temperature_rate(changed, 1.0, settings, causal=True)[:200], rate[:200])


def test_causal_is_the_centred_estimate_delayed_by_half_a_window():
    t = np.arange(1000.0)
    temperature = np.where(t < 400, 20.0, 20.0 + 0.02 * (t - 400))
    settings = RateSettings(window_s=61.0)
    centred = temperature_rate(temperature, 1.0, settings)
    causal = temperature_rate(temperature, 1.0, settings, causal=True)
    assert_allclose(causal[100:], centred[70:-30], atol=1e-12)


def test_quantised_ramp_is_recovered_to_the_predicted_noise():
    """A 1/16 degC quantiser on a 0.01 degC/s ramp: error within 4 sigma of sigma_q*sqrt(12/(W(W^2-1)))."""
    t = np.arange(3600.0)
    q = 1 / 16
    temperature = np.round((10 + 0.01 * t) / q) * q
    rate = temperature_rate(temperature, 1.0)
    n = window_samples(RateSettings(), 1.0)
    sigma = q / np.sqrt(12) * np.sqrt(12 / (n * (n**2 - 1)))
    assert np.max(np.abs(rate[n:-n] - 0.01)) < 4 * sigma * 3  # quantisation error is correlated on a ramp
    assert abs(np.mean(rate[n:-n]) - 0.01) < sigma


def test_inputs_and_description():
    X = model_inputs(np.linspace(0, 10, 200), 1.0)
    assert X.shape == (200, 2)
    assert_allclose(X[:, 1], 10 / 199, rtol=1e-9)
    d = describe(RateSettings(), 1.0)
    assert d["window_samples"] == 61 and len(d["causal_coefficients"]) == 61
    assert_allclose(np.sum(d["causal_coefficients"]), 0.0, atol=1e-12)  # a constant has no slope
    assert_allclose(causal_coefficients(RateSettings(), 1.0) @ np.arange(61.0), 1.0)  # unit ramp


def test_short_recording_shrinks_the_window():
    assert window_samples(RateSettings(window_s=60.0), 1.0, 20) == 19
    assert_allclose(temperature_rate(np.arange(20.0) * 0.5, 1.0), 0.5)


@pytest.mark.parametrize("bad", [[1.0], [[1.0, 2.0]], [1.0, np.nan, 2.0]])
def test_bad_temperature_is_refused(bad):
    with pytest.raises(InputError):
        temperature_rate(bad, 1.0)


def test_bad_settings_are_refused():
    with pytest.raises(InputError):
        RateSettings(window_s=0.0)
    with pytest.raises(InputError):
        RateSettings(method="diff")
