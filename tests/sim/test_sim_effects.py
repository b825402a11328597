"""Deterministic effect shapes: exact cases and a per-sample reference implementation."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from gyrocomp.errors import InputError
from gyrocomp.effects import shapes as effects


def test_thermal_lag_decays_with_its_time_constant_after_a_step():
    tau = 300.0
    t = np.arange(0.0, 3000.0, 0.5)
    step = np.where(t >= 100.0, 60.0, 20.0)
    element = effects.element_temperature(t, step, tau)
    after = t >= 100.0
    # The sampled step is a ramp over one interval; its exact response is
    # 60 - 40 (tau/h)(1 - e^{-h/tau}) e^{-(t - t1)/tau} with t1 = 100 s (the ramp from 99.5 s ends there).
    h = 0.5
    expected = 60.0 - 40.0 * tau / h * -np.expm1(-h / tau) * np.exp(-(t[after] - 100.0) / tau)
    assert_allclose(element[after], expected, rtol=1e-10)
    # Read the time constant back from the log-slope of the remaining difference.
    slope = np.polyfit(t[after], np.log(60.0 - element[after]), 1)[0]
    assert_allclose(-1.0 / slope, tau, rtol=1e-6)
    assert_allclose(element[t < 100.0], 20.0)


def test_thermal_lag_follows_a_ramp_exactly():
    """First-order-hold discretisation: exact for a piecewise-linear input."""
    tau, m = 120.0, 0.05
    t = np.arange(0.0, 2000.0, 2.0)
    element = effects.element_temperature(t, 10.0 + m * t, tau)
    assert_allclose(element, 10.0 + m * t - m * tau * (1.0 - np.exp(-t / tau)), rtol=1e-12, atol=1e-12)


def test_thermal_lag_zero_tau_is_identity():
    t = np.arange(5.0)
    assert_allclose(effects.element_temperature(t, t**2, 0.0), t**2)


def _branch_reference(temperature, deadband):
    """Per-sample play operator, the definition `hysteresis_branch` vectorises."""
    n = len(temperature)
    first = next((i for i in range(n) if abs(temperature[i] - temperature[0]) > deadband), None)
    state = 1.0 if first is None or temperature[first] > temperature[0] else -1.0
    extreme = temperature[0]
    out = []
    for x in temperature:
        if state > 0:
            if x < extreme - deadband:
                state, extreme = -1.0, x
            else:
                extreme = max(extreme, x)
        else:
            if x > extreme + deadband:
                state, extreme = 1.0, x
            else:
                extreme = min(extreme, x)
        out.append(state)
    return np.array(out)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=1, max_size=300),
    st.floats(0.0, 3.0, allow_nan=False),
)
def test_hysteresis_branch_matches_the_per_sample_definition(steps, deadband):
    temperature = 20.0 + np.cumsum(steps)
    t = np.arange(temperature.size, dtype=float)
    assert_allclose(effects.hysteresis_branch(t, temperature, deadband), _branch_reference(temperature, deadband))


def test_hysteresis_keeps_its_branch_through_a_soak_until_the_direction_reverses():
    rng = np.random.default_rng(0)
    # heat 20 -> 60, soak (with sensor-size noise), heat to 70, soak, cool to 40, soak.
    temperature = np.concatenate(
        [np.linspace(20, 60, 400), 60 + 0.05 * rng.standard_normal(3600), np.linspace(60, 70, 100),
         70 + 0.05 * rng.standard_normal(3600), np.linspace(70, 40, 300), 40 + 0.05 * rng.standard_normal(3600)]
    )
    t = np.arange(temperature.size, dtype=float)
    branch = effects.hysteresis_branch(t, temperature, 0.5)
    cooling_starts = 400 + 3600 + 100 + 3600
    assert np.all(branch[: cooling_starts + 1] == 1.0)
    # Switches once the temperature has fallen more than the deadband below its peak.
    switch = int(np.flatnonzero(branch < 0)[0])
    assert cooling_starts < switch < cooling_starts + 10
    assert np.all(branch[switch:] == -1.0)


def test_temp_rate_vanishes_in_a_soak():
    t = np.arange(0.0, 4000.0)
    housing = effects.element_temperature(t, np.interp(t, [0, 600, 660, 4000], [25, 25, 35, 35]), 120.0)
    rate = effects.temperature_rate(t, housing)
    assert rate.max() > 0.05
    assert np.all(np.abs(rate[t > 660 + 25 * 120]) < 1e-9)
    assert np.all(rate[t < 600] == 0.0)


def test_temperature_rate_smoothed_recovers_a_ramp_under_noise():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 3000.0)
    noisy = np.round((20 + 0.01 * t + 0.02 * rng.standard_normal(t.size)) / 0.0625) * 0.0625
    rate = effects.temperature_rate(t, noisy, smooth_s=300.0)
    assert_allclose(np.median(rate), 0.01, rtol=0.02)


def test_warmup_ramp_periodic_exact_values():
    t = np.array([10.0, 110.0, 210.0])
    assert_allclose(effects.warmup(t, 0.03, 100.0), 0.03 * np.exp(-np.array([0.0, 1.0, 2.0])))
    assert_allclose(effects.rate_ramp(t, 1e-4), [0.0, 0.01, 0.02])
    assert_allclose(effects.periodic(np.array([0.0, 25.0, 50.0]), 2.0, 100.0, 0.0), [0.0, 2.0, 0.0], atol=1e-12)


def test_bias_polynomial_is_zero_at_reference_and_cubic():
    temperature = np.array([25.0, 35.0, 15.0])
    assert_allclose(effects.bias_polynomial(temperature, [1.0, 0.1, 0.01]), [0.0, 10 + 10 + 10, -10 + 10 - 10])


@pytest.mark.parametrize(
    "call",
    [
        lambda: effects.element_temperature([0, 1], [1, 2], -1.0),
        lambda: effects.element_temperature([0, 1], [1, 2, 3], 1.0),
        lambda: effects.hysteresis_branch([0, 1], [1, 2], -0.1),
        lambda: effects.warmup([0, 1], 1.0, 0.0),
        lambda: effects.periodic([0, 1], 1.0, 0.0),
    ],
)
def test_bad_arguments_raise_input_error(call):
    with pytest.raises(InputError):
        call()
