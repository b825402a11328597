"""The temperature-rate estimator against an independent least-squares fit and exact cases."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.errors import InputError
from gyrocomp.pipeline.rate import CausalRate, causal_coefficients, describe, model_inputs, temperature_rate, window_samples
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


def _oven_like(n, fs, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    return 25 + 10 * np.sin(t / 3000) + np.round(rng.normal(0, 0.05, n) * 16) / 16


@pytest.mark.parametrize("fs", [1.0, 100.0])
def test_causal_equals_the_stored_fir_to_1e_12(fs):
    """The FIR with the closed-form line-slope taps A (k - kbar), A = 12 fs / (W (W^2 - 1)), in extended precision."""
    temperature = _oven_like(12_000, fs, 3)
    settings = RateSettings()
    n = window_samples(settings, fs)
    k = np.arange(n, dtype=np.longdouble)
    taps = 12 * np.longdouble(fs) / (n * (np.longdouble(n) ** 2 - 1)) * (k - (n - 1) / 2)
    assert_allclose(causal_coefficients(settings, fs), taps.astype(float), rtol=1e-12, atol=1e-15 * float(np.abs(taps).max()))
    primed = np.concatenate([np.full(n - 1, temperature[0]), temperature]).astype(np.longdouble)
    reference = np.convolve(primed, taps[::-1], mode="valid").astype(float)
    rate = temperature_rate(temperature, fs, settings, causal=True)
    assert np.max(np.abs(rate - reference)) <= 1e-12 * np.max(np.abs(reference))


@pytest.mark.parametrize("order", [2, 3, 4])
def test_higher_orders_equal_savgol(order):
    """Centred against scipy's savgol_filter; causal against a trailing numpy.polyfit."""
    from scipy.signal import savgol_filter

    temperature = _oven_like(3000, 10.0, order)
    settings = RateSettings(window_s=20.0, polyorder=order)
    n = window_samples(settings, 10.0)
    reference = savgol_filter(temperature, n, order, deriv=1, delta=0.1, mode="interp")
    assert_allclose(temperature_rate(temperature, 10.0, settings), reference, rtol=0, atol=1e-10 * np.abs(reference).max())
    causal = temperature_rate(temperature, 10.0, settings, causal=True)
    x = np.arange(n) / 10.0
    for i in (n - 1, 1500, 2999):
        fit = np.polyfit(x - x[-1], temperature[i - n + 1 : i + 1], order)
        assert_allclose(causal[i], fit[-2], rtol=1e-8)


def test_a_stream_in_chunks_equals_the_whole_series():
    temperature = _oven_like(5000, 10.0, 4)
    settings = RateSettings(window_s=30.0)
    whole = temperature_rate(temperature, 10.0, settings, causal=True)
    estimator = CausalRate(settings, 10.0)
    parts = [estimator(temperature[a:b]) for a, b in ((0, 1), (1, 250), (250, 251), (251, 4000), (4000, 5000))]
    assert_allclose(np.concatenate(parts), whole, rtol=0, atol=1e-14 * np.abs(whole).max())


def test_the_documented_per_sample_recursion_gives_the_same_rate():
    """The firmware form of the module notes (ring buffer, N and S, fresh sums every W samples), sample by sample."""
    temperature = _oven_like(4000, 1.0, 5)
    settings = RateSettings(window_s=61.0)
    d = describe(settings, 1.0)
    n, kbar, gain = d["window_samples"], d["recursion"]["kbar"], d["recursion"]["slope_gain"]
    ring = np.zeros(n)  # temperatures minus the first reading: the priming reading is 0
    big_n = big_s = fresh_n = fresh_s = 0.0
    out = np.empty(temperature.size)
    for t, value in enumerate(temperature - temperature[0]):
        oldest = ring[t % n]
        big_n += -big_s + kbar * value + (kbar + 1) * oldest
        big_s += value - oldest
        ring[t % n] = value
        k = t % n
        fresh_n += (k - kbar) * value
        fresh_s += value
        if k == n - 1:
            big_n, big_s, fresh_n, fresh_s = fresh_n, fresh_s, 0.0, 0.0
        out[t] = gain * big_n
    rate = temperature_rate(temperature, 1.0, settings, causal=True)
    assert_allclose(out, rate, rtol=0, atol=1e-12 * np.abs(rate).max())
