"""The grey-box drift model (issue 34): recovery, identifiability, causal streaming, gaps, JSON.

Recordings come from :func:`_gyro`, written here with plain NumPy loops (an
element lag by exponential Euler steps, dT/dt by central differences, the
play by its definition), not from gyrocomp's simulator or shapes.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp.cli import app
from gyrocomp.effects import shapes
from gyrocomp.effects._stateful import advance, new_state
from gyrocomp.errors import InputError
from gyrocomp.models.greybox import GreyBoxDrift, TrainingRun


def _chamber(t, knots_t, knots_c, tau_s=300.0):
    """A piecewise-linear set-point through a first-order chamber (Euler, exact per step)."""
    T = np.interp(t, knots_t, knots_c)
    out = np.empty_like(T)
    out[0] = T[0]
    a = np.exp(-(t[1] - t[0]) / tau_s)
    for i in range(1, T.size):
        out[i] = a * out[i - 1] + (1 - a) * T[i]
    return out


CYCLE = ([0, 1800, 5400, 7200, 12600, 14400, 18000, 21600], [20, 20, 60, 60, -10, -10, 40, 40])
STEPS = ([0, 1200, 3000, 6000, 8400, 11000, 14000, 21600], [25, 25, -5, -5, 50, 50, 10, 10])
TRUTH = {"tau_e": 400.0, "rate": 1.5, "asym": 0.5, "play": 0.01, "width": 4.0, "warm": 0.03, "tau_w": 900.0}


def _lag(t, T, tau):
    Te = np.empty_like(T)
    Te[0] = T[0]
    for i in range(1, T.size):
        Te[i] = Te[i - 1] + (T[i] - Te[i - 1]) * (1 - np.exp(-(t[i] - t[i - 1]) / tau)) if tau else T[i]
    return Te


def _relay(T, width, start=1.0):
    """A direction relay by its definition: heating once T has risen `width` above its lowest since the last switch, and so on."""
    out, branch, hi, lo = np.empty_like(T), start, T[0], T[0]
    for i, x in enumerate(T):
        hi, lo = max(hi, x), min(lo, x)
        if branch > 0 and hi - x > width:
            branch, lo = -1.0, x
        elif branch < 0 and x - lo > width:
            branch, hi = 1.0, x
        out[i] = branch
    return out


def _gyro(t, T, seed, *, tau_e=400.0, rate=1.5, asym=0.5, play=0.01, width=4.0, warm=0.03, tau_w=900.0, rrw=2e-6,
          relay=0.0, lag2=0.0, tau_e2=3000.0, warm2=0.0, tau_w2=4000.0, sat=0.0, series=False, play2=0.0, width2=12.0,
          on_element=False, play_start=0.0):
    rng = np.random.default_rng(seed)
    Te = _lag(t, T, tau_e)
    if series:  # the die behind a second stage: the cubic of the lag of T_e
        Te = _lag(t, Te, tau_e2)
    d = Te - 25.0
    bias = 0.05 + 2e-3 * d - 3e-5 * d**2 + 4e-7 * d**3
    r = np.gradient(T, t)
    if sat:  # a sensitivity that saturates at `sat` degC/s
        r = sat * np.tanh(r / sat)
    bias += rate * r + asym * np.abs(r)
    x = Te if on_element else T  # what the hysteresis switches on
    for amplitude, w in ((play, width), (play2, width2)):
        p, out = x[0] - play_start * w / 2, np.empty_like(x)  # play_start: the output at power-on, -1 to 1
        for i in range(x.size):
            p = min(max(p, x[i] - w / 2), x[i] + w / 2)
            out[i] = (x[i] - p) / (w / 2)
        bias += amplitude * out
    bias += warm * np.exp(-(t - t[0]) / tau_w) + warm2 * np.exp(-(t - t[0]) / tau_w2)
    bias += relay * _relay(T, width) + (lag2 * (_lag(t, T, tau_e2) - 25.0) if lag2 else 0.0)
    noise = 0.003 * rng.normal(size=t.size) + np.cumsum(rrw * rng.normal(size=t.size))
    return bias + noise, bias


def _run(t, T, y, name="run", power_on=True):
    return TrainingRun(t, T, y, [slice(0, t.size)], float(t[0]) if power_on else None, name)


def _block_std_deg_h(x, block=100):
    k = x.size // block
    means = x[: k * block].reshape(k, block).mean(axis=1)
    return float(np.std(means - means.mean()) * 3600)


@pytest.fixture(scope="module")
def cycle_model():
    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    y, _ = _gyro(t, T, 1)
    return GreyBoxDrift(grid_points=12).fit([_run(t, T, y, "cycle")])


ALONE = {  # each term by itself on the cycle run: its parameters, and the truth's
    "thermal_lag": (dict(rate=0.0, asym=0.0, play=0.0, warm=0.0), {"spec:tau_e_s": 400.0}),
    "temp_rate": (dict(tau_e=0.0, play=0.0, warm=0.0), {"coef:rate": 1.5, "coef:rate_abs": 0.5}),
    "hysteresis": (dict(tau_e=0.0, rate=0.0, asym=0.0, warm=0.0), {"spec:width_c": 4.0, "coef:play": 0.01}),
    "warmup": (dict(tau_e=0.0, rate=0.0, asym=0.0, play=0.0), {"spec:tau_w_s": 900.0, "coef:warmup": 0.03}),
}


@pytest.mark.parametrize("term", list(ALONE))
def test_each_term_alone_is_identified_and_recovered_within_10_percent(term):
    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    zeroed, truth = ALONE[term]
    y, _ = _gyro(t, T, 1, **zeroed)
    m = GreyBoxDrift(grid_points=12, terms=(term,)).fit([_run(t, T, y, "cycle")])
    assert [s["term"] for s in m.selection_][:1] == [term] and m.not_fitted_ == []
    for key, value in truth.items():
        where, name = key.split(":")
        assert (m.spec_ if where == "spec" else m.coef_)[name] == pytest.approx(value, rel=0.1), key


SECOND = {  # the forms a single term cannot hold, each with its own term beside the first
    "relay": (dict(tau_e=0.0, rate=0.0, asym=0.0, warm=0.0, play=0.0, relay=0.01), ("hysteresis",),
              {"spec:width_c": 4.0, "coef:relay": 0.01}),
    "second_lag": (dict(rate=0.0, asym=0.0, play=0.0, warm=0.0, lag2=2e-3), ("thermal_lag", "second_lag"),
                   {"spec:tau_e_s": 400.0, "spec:tau_e2_s": 3000.0}),
    "second_warmup": (dict(tau_e=0.0, rate=0.0, asym=0.0, play=0.0, warm=0.03, warm2=0.02), ("warmup", "second_warmup"), {}),
    "series_lags": (dict(tau_e=300.0, rate=0.0, asym=0.0, play=0.0, warm=0.0, series=True, tau_e2=1500.0), ("thermal_lag", "second_lag"),
                    {"spec:tau_e_s": 300.0, "spec:tau_e2_s": 1500.0}),
    "rate_saturation": (dict(tau_e=0.0, asym=0.0, play=0.0, warm=0.0, sat=0.005), ("temp_rate", "rate_saturation"),
                        {"spec:rate_saturation_c_per_s": 0.005, "coef:rate": 1.5}),
    "two_plays": (dict(tau_e=0.0, rate=0.0, asym=0.0, warm=0.0, play2=0.015), ("hysteresis", "second_hysteresis"),
                  {"spec:width_c": 4.0, "coef:play": 0.01, "spec:width2_c": 12.0, "coef:play2": 0.015}),
    "play_on_the_element": (dict(rate=0.0, asym=0.0, warm=0.0, play=0.05, width=8.0, on_element=True), ("thermal_lag", "hysteresis"),
                            {"spec:tau_e_s": 400.0, "spec:width_c": 8.0, "coef:play": 0.05}),
}


@pytest.mark.parametrize("form", list(SECOND))
def test_a_relay_and_second_time_constants_are_selected_and_recovered_within_10_percent(form):
    """A direction relay (the two-branch hysteresis), two parallel heat paths, a two-exponential warm-up, a dT/dt
    sensitivity that saturates at 0.3 degC/min (the cycle ramps at up to 0.67), plays of 4 and 12 degC, an 8 degC play
    switching on the element's temperature (400 s behind the sensor's)."""
    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    changes, terms, truth = SECOND[form]
    y, _ = _gyro(t, T, 1, **changes)
    m = GreyBoxDrift(grid_points=12, terms=terms).fit([_run(t, T, y, "cycle")])
    assert sorted(s["term"] for s in m.selection_) == sorted(terms) and m.not_fitted_ == []
    if form == "relay":
        assert m.spec_["hysteresis_operator"] == "relay"
    assert m.spec_["second_lag_path"] == ("series" if form == "series_lags" else "parallel")
    assert m.spec_["hysteresis_input"] == ("element" if form == "play_on_the_element" else "temperature")
    if form == "second_warmup":
        # The curve within 3 % of its amplitude (measured 1.4-3.1 deg/h of 180 on three seeds), the time constants
        # within 25 %: the slow one trades against the cubic in T, the cycle heating from its 30th minute
        # (4.7-4.9 ks against 4 ks on three seeds, with or without the random walk).
        model = m.coef_["warmup"] * np.exp(-t / m.spec_["tau_w_s"]) + m.coef_["warmup2"] * np.exp(-t / m.spec_["tau_w2_s"])
        true = 0.03 * np.exp(-t / 900.0) + 0.02 * np.exp(-t / 4000.0)
        assert np.max(np.abs(model - true - np.mean(model - true))) < 0.03 * 0.05
        assert [m.spec_["tau_w_s"], m.spec_["tau_w2_s"]] == pytest.approx([900.0, 4000.0], rel=0.25)
        return
    if form == "second_lag":  # the second path's sensitivity: lag2 = k2 (T_e2 - T_e) / half_range
        assert m.coef_["lag2"] == pytest.approx(2e-3 * m.half_range_c_, rel=0.1)
    for key, value in truth.items():
        where, name = key.split(":")
        assert (m.spec_ if where == "spec" else m.coef_)[name] == pytest.approx(value, rel=0.1), key


PLAIN = {  # one form of a term and the refinement it must not get: the zeroed effects, the refinement's entry, the truth
    "linear_dtdt": (dict(tau_e=0.0, asym=0.0, play=0.0, warm=0.0), ("temp_rate", "rate_saturation"), "rate_saturation_c_per_s", {"coef:rate": 1.5}),
    "single_play": (dict(tau_e=0.0, rate=0.0, asym=0.0, warm=0.0), ("hysteresis", "second_hysteresis"), "width2_c", {"spec:width_c": 4.0}),
}


@pytest.mark.parametrize("form", list(PLAIN))
def test_a_linear_dtdt_is_not_saturated_and_a_single_play_gets_no_second(form):
    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    zeroed, terms, refinement, truth = PLAIN[form]
    y, _ = _gyro(t, T, 2, **zeroed)
    m = GreyBoxDrift(grid_points=12, terms=terms).fit([_run(t, T, y)])
    assert [s["term"] for s in m.selection_] == [terms[0]] and m.spec_[refinement] == 0.0
    for key, value in truth.items():
        where, name = key.split(":")
        assert (m.spec_ if where == "spec" else m.coef_)[name] == pytest.approx(value, rel=0.1), key


def test_a_second_time_constant_is_not_fitted_where_its_first_cannot_be():
    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    y, _ = _gyro(t, T, 1, tau_e=0.0, rate=0.0, asym=0.0, play=0.0, warm=0.03, warm2=0.02)
    m = GreyBoxDrift(grid_points=12, terms=("warmup", "second_warmup")).fit([_run(t, T, y, power_on=False)])
    assert [r["term"] for r in m.not_fitted_] == ["warmup", "second_warmup"]
    assert m.not_fitted_[1]["reason"].startswith("second_warmup not fitted: warmup is not (a training run does not start at power-on")


def test_all_terms_together_are_selected_and_recovered(cycle_model):
    """Within 10 %, but the warm-up within 20 %: the causal dT/dt (a 10 s filter) and the generator's central
    differences differ at the ramps' corners, and the first corner (1800 s) falls in the warm-up's tail. That
    misfit widens the warm-up's spread (775 and 868-937 s on two seeds; 894-906 s alone, above), and on this
    seed a second warm-up time constant takes it (518 and 1259 s, 0.016 deg/s each): the transient is
    checked as a whole, its value at power-on and its area. Until the play's unknown power-on state had two
    columns (2026-11-27), one constant until the first 4 degC excursion took that misfit instead."""
    m = cycle_model
    assert {"thermal_lag", "temp_rate", "hysteresis", "warmup"} <= {s["term"] for s in m.selection_} <= {
        "thermal_lag", "temp_rate", "hysteresis", "warmup", "second_warmup"}
    assert m.spec_["rate_form"] == 2 and m.not_fitted_ == []
    assert m.spec_["tau_e_s"] == pytest.approx(TRUTH["tau_e"], rel=0.1)
    assert m.spec_["width_c"] == pytest.approx(TRUTH["width"], rel=0.1)
    warmups = [(m.coef_["warmup"], m.spec_["tau_w_s"]), (m.coef_.get("warmup2", 0.0), m.spec_["tau_w2_s"])]
    assert sum(a for a, _ in warmups) == pytest.approx(TRUTH["warm"], rel=0.1)
    assert sum(a * tau for a, tau in warmups) == pytest.approx(TRUTH["warm"] * TRUTH["tau_w"], rel=0.2)
    for name, key in (("rate", "rate"), ("rate_abs", "asym"), ("play", "play")):
        assert m.coef_[name] == pytest.approx(TRUTH[key], rel=0.1), name
    assert m.coef_about_reference_[1] == pytest.approx(2e-3, rel=0.1)  # the cubic about T_ref = 25 degC


def test_held_out_profile_is_compensated_far_better_than_by_the_cubic(cycle_model):
    t = np.arange(0, 21600.0)
    T = _chamber(t, *STEPS)
    y, bias = _gyro(t, T, 2)
    greybox = _block_std_deg_h(bias - cycle_model.predict(t, T))
    train_T = _chamber(t, *CYCLE)
    train_y, _ = _gyro(t, train_T, 1)
    A = lambda T: np.column_stack([np.ones_like(T), T - 25, (T - 25) ** 2, (T - 25) ** 3])
    cubic = _block_std_deg_h(bias - A(T) @ np.linalg.lstsq(A(train_T), train_y, rcond=None)[0])
    assert greybox < 5.0 and cubic > 5 * greybox, (greybox, cubic)


def test_effect_free_runs_select_nothing_and_match_the_cubic():
    t = np.arange(0, 21600.0)
    T1, T2 = _chamber(t, *CYCLE), _chamber(t, *STEPS)
    free = dict(tau_e=0.0, rate=0.0, asym=0.0, play=0.0, warm=0.0, rrw=2e-5)
    (y1, _), (y2, _) = _gyro(t, T1, 3, **free), _gyro(t, T2, 103, **free)
    m = GreyBoxDrift(grid_points=12).fit([_run(t, T1, y1)])
    assert m.selection_ == []
    A = lambda T: np.column_stack([np.ones_like(T), T - 25, (T - 25) ** 2, (T - 25) ** 3])
    cubic = _block_std_deg_h(y2 - A(T2) @ np.linalg.lstsq(A(T1), y1, rcond=None)[0])
    assert _block_std_deg_h(y2 - m.predict(t, T2)) <= 1.1 * cubic


def _warmup_run(seed=0, tau=900.0):
    rng = np.random.default_rng(seed)
    t = np.arange(0, 3 * 3600.0)
    T = 55 - 50 * np.exp(-t / tau)
    d = T - 25
    return t, T, 0.05 + 2e-3 * d - 3e-5 * d**2 + 4e-7 * d**3 + 0.003 * rng.normal(size=t.size)


def test_dtdt_in_a_single_warmup_is_refused_with_its_reason():
    t, T, y = _warmup_run()
    m = GreyBoxDrift(grid_points=8, terms=("temp_rate",)).fit([_run(t, T, y)])
    assert m.spec_["rate_form"] == 0
    (refusal,) = m.not_fitted_
    assert refusal["term"] == "temp_rate" and "linear function of T, T^2, T^3 (1 - R^2 = " in refusal["reason"]


@pytest.mark.parametrize("direction", ["cooling", "heating"])
def test_heating_and_cooling_apart_is_refused_on_runs_of_one_direction(direction):
    """A run that only cools identifies the cooling sensitivity (rate - asym: 1.0) and nothing of the heating one."""
    t = np.arange(0, 21600.0)
    knots = [60, 60, 35, 35, 10, 10, -10, -10]
    T = _chamber(t, [0, 1800, 5400, 7200, 10800, 12600, 16200, 21600], knots if direction == "cooling" else knots[::-1])
    y, _ = _gyro(t, T, 3, tau_e=0.0, play=0.0, warm=0.0)
    m = GreyBoxDrift(grid_points=8, terms=("temp_rate",)).fit([_run(t, T, y)])
    assert m.spec_["rate_form"] == 1
    assert m.coef_["rate"] == pytest.approx(1.0 if direction == "cooling" else 2.0, rel=0.05)
    (refusal,) = m.not_fitted_
    seen, unseen = ("cool", "heating") if direction == "cooling" else ("heat", "cooling")
    assert refusal["term"] == "temp_rate_heating_cooling_apart"
    assert refusal["reason"].startswith(f"temp_rate_heating_cooling_apart not fitted: the training runs only {seen} ")
    assert f"applied to {unseen} too" in refusal["reason"]


def test_heating_and_cooling_apart_is_not_refused_where_the_runs_heat_and_cool(cycle_model):
    assert cycle_model.spec_["rate_form"] == 2 and cycle_model.not_fitted_ == []


@pytest.mark.parametrize("start", [0.9, -0.9, 0.4])
def test_a_play_that_powers_on_off_centre_is_recovered_within_5_percent(start):
    """The training run's power-on state is unknown: a play started near a branch follows the temperature at once,
    where the model's centred play waits half the width. With one constant for the samples before the first
    excursion (until 2026-11-27), the misfit after it read as a random walk (8.5e-5 deg/s/sqrt(s) for a start at
    -0.9) and the amplitude came out 22 % low (start 0.9); with the columns of both branches' starts it is
    within 5 %."""
    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    y, _ = _gyro(t, T, 5, tau_e=0.0, rate=0.0, asym=0.0, warm=0.0, play=0.02, width=6.0, play_start=start)
    m = GreyBoxDrift(grid_points=12, terms=("hysteresis",)).fit([_run(t, T, y, "cycle")])
    assert m.spec_["width_c"] == pytest.approx(6.0, rel=0.05)
    assert m.coef_["play"] == pytest.approx(0.02, rel=0.05)
    assert m.noise_["rate_random_walk"] < 2e-6  # the truth has none: no misfit left for it


def test_the_power_on_columns_are_a_play_started_on_either_branch_less_the_centred_play():
    from gyrocomp.effects._stateful import play_start_spread

    x = np.array([20.0, 20.5, 21.0, 22.0, 23.0, 22.0, 20.0, 25.0])
    restart = np.zeros(x.size, dtype=bool)
    restart[0] = True
    out = np.empty((x.size, 2))
    play_start_spread(x, restart, 1.5, out)

    def play(p):  # by its definition: p held within 1.5 degC of x
        values = []
        for v in x:
            p = min(max(p, v - 1.5), v + 1.5)
            values.append((v - p) / 1.5)
        return np.array(values)

    np.testing.assert_allclose(out[:, 0], play(18.5) - play(20.0), atol=1e-12)
    np.testing.assert_allclose(out[:, 1], play(21.5) - play(20.0), atol=1e-12)
    assert out[0].tolist() == [1.0, -1.0] and np.all(out[4:] == 0.0)  # 3 degC one way: every start agrees


def test_a_hysteresis_whose_branch_never_changes_is_refused():
    t, T, y = _warmup_run()
    play = (T - np.maximum(T[0], T - 1.0)) / 1.0  # a 2 degC play on a monotonic heat-up
    m = GreyBoxDrift(grid_points=8, terms=("hysteresis", "second_hysteresis")).fit([_run(t, T, y + 0.02 * play)])
    refusal, second = m.not_fitted_
    assert m.spec_["width_c"] == 0 and "never reverses by more than 0.5 degC" in refusal["reason"]
    assert m.spec_["width2_c"] == 0 and second["reason"].startswith("second_hysteresis not fitted: hysteresis is not (the temperature never reverses")


def test_a_warmup_is_refused_on_a_log_that_does_not_start_at_power_on():
    t, T, y = _warmup_run()
    m = GreyBoxDrift(grid_points=8, terms=("warmup",)).fit([_run(t, T, y + 0.03 * np.exp(-t / 900.0), power_on=False)])
    assert m.spec_["tau_w_s"] == 0 and "does not start at power-on" in m.not_fitted_[0]["reason"]


def test_a_lag_shorter_than_a_smooth_transition_is_refused():
    """T = 30 + 20 tanh(...): T_e - T ~ -tau dT/dt + tau^2 d2T/dt2, a cubic in T while tau << 1800 s."""
    rng = np.random.default_rng(0)
    t = np.arange(0, 4 * 3600.0)
    T = 30 + 20 * np.tanh((t - 7200) / 1800.0)
    d = T - 25
    y = 0.05 + 2e-3 * d + 4e-7 * d**3 + 0.003 * rng.normal(size=t.size)
    m = GreyBoxDrift(grid_points=8, lag_tau_s=(10.0, 300.0), terms=("thermal_lag",)).fit([_run(t, T, y)])
    (refusal,) = m.not_fitted_
    assert m.spec_["tau_e_s"] == 0 and refusal["reason"].startswith("thermal_lag (T_e - T) not fitted")


def test_the_stateful_kernel_equals_the_registry_shapes_and_chunks_give_the_same_bytes():
    t = np.arange(0.0, 3000.0)
    T = _chamber(t, [0, 500, 1500, 2000, 3000], [20, 30, 22, 28, 21], tau_s=60.0)
    for relay, operator, series in ((False, shapes.hysteresis_play, False), (True, shapes.hysteresis_branch, True)):
        out = np.empty((t.size, 5))
        advance(t, T, new_state(), 120.0, 30.0, 1.5, relay, 700.0, series, 0.8, False, out)
        te = shapes.element_temperature(t, T, 120.0)
        np.testing.assert_allclose(out[:, 0], te, rtol=0, atol=1e-10)
        np.testing.assert_allclose(out[:, 3], shapes.element_temperature(t, te if series else T, 700.0), rtol=0, atol=1e-10)
        np.testing.assert_allclose(out[:, 1], (T - shapes.element_temperature(t, T, 30.0)) / 30.0, rtol=0, atol=1e-10)
        first = shapes.first_excursion(T, 3.0)  # the relay's branch is unknown (0) before it; the play starts centred
        np.testing.assert_allclose(out[first:, 2], operator(t, T, 3.0)[first:], rtol=0, atol=1e-12)
        assert not relay or (np.all(out[:first, 2] == 0.0) and first > 0)
        second = shapes.first_excursion(T, 1.6)  # the second play, 1.6 degC wide
        np.testing.assert_allclose(out[second:, 4], shapes.hysteresis_play(t, T, 1.6)[second:], rtol=0, atol=1e-12)
        state, chunks = new_state(), np.empty_like(out)
        for lo in range(0, t.size, 777):
            advance(t[lo : lo + 777], T[lo : lo + 777], state, 120.0, 30.0, 1.5, relay, 700.0, series, 0.8, False, chunks[lo : lo + 777])
        assert np.array_equal(chunks, out)
        advance(t, T, new_state(), 120.0, 30.0, 1.5, relay, 700.0, series, 0.8, True, out)  # switching on T_e
        first = shapes.first_excursion(te, 3.0)
        np.testing.assert_allclose(out[first:, 2], operator(t, te, 3.0)[first:], rtol=0, atol=1e-12)


def test_a_gap_is_bridged_exactly_for_a_temperature_linear_through_it(cycle_model):
    """Samples removed inside a ramp: the states bridge the gap with the temperature linear, so the bias after it is unchanged."""
    t = np.arange(0.0, 21600.0)
    T = np.interp(t, *CYCLE)  # piecewise linear, corners at whole seconds
    whole = cycle_model.predict(t, T)
    keep = (t < 2500) | (t >= 4000)  # inside the 1800..5400 s ramp
    gapped = cycle_model.predict(t[keep], T[keep], segments=[slice(0, 2500), slice(2500, int(keep.sum()))])
    np.testing.assert_allclose(gapped, whole[keep], rtol=0, atol=1e-9)
    restarted = GreyBoxDrift.from_dict({**cycle_model.to_dict(), "params": {**cycle_model.to_dict()["params"], "bridge_gaps": False}})
    cold = restarted.predict(t[keep], T[keep], segments=[slice(0, 2500), slice(2500, int(keep.sum()))])
    assert np.max(np.abs(cold - whole[keep])) > 1e-4  # without the bridge the element restarts at T: a visible error


def test_json_round_trip_is_exact_and_bad_files_are_refused(cycle_model):
    t = np.arange(0.0, 5000.0)
    T = _chamber(t, *STEPS)
    again = GreyBoxDrift.from_dict(json.loads(json.dumps(cycle_model.to_dict())))
    assert np.array_equal(again.predict(t, T), cycle_model.predict(t, T))
    d = cycle_model.to_dict()
    version_2 = json.loads(json.dumps(d))  # before the saturation: a version-2 file has no such entry, and loads as linear
    version_2["version"] = 2
    del version_2["fitted"]["spec_"]["rate_saturation_c_per_s"]
    del version_2["params"]["rate_saturation_c_per_s"]
    assert np.array_equal(GreyBoxDrift.from_dict(version_2).predict(t, T), cycle_model.predict(t, T))
    with pytest.raises(InputError, match="newer than this gyrocomp reads"):
        GreyBoxDrift.from_dict({**d, "version": 99}, "m.json")
    with pytest.raises(InputError, match="non-finite"):
        GreyBoxDrift.from_dict({**d, "fitted": {**d["fitted"], "offset_": float("nan")}}, "m.json")
    with pytest.raises(InputError, match="corrupted greybox model"):
        GreyBoxDrift.from_dict({**d, "fitted": {k: v for k, v in d["fitted"].items() if k != "coef_"}}, "m.json")


def test_train_on_two_runs_then_compensate_streamed_and_whole_give_the_same_bytes(tmp_path):
    t = np.arange(0.0, 21600.0)
    for name, knots, seed in (("heat", CYCLE, 5), ("cool", STEPS, 6)):
        T = _chamber(t, *knots)
        y, _ = _gyro(t, T, seed)
        pd.DataFrame({"time": t, "gx": y, "gy": -y, "temperature": T}).to_csv(tmp_path / f"{name}.csv", index=False)
    runner = CliRunner()
    model = tmp_path / "m.json"
    result = runner.invoke(app, ["train", str(tmp_path / "heat.csv"), str(tmp_path / "cool.csv"), "--rate-col", "gx,gy",
                                 "--config", "greybox", "--set", "greybox.grid_points=8", "--out", str(model)])
    assert result.exit_code == 0, result.output
    obj = json.loads(model.read_text())
    assert obj["axes"]["gx"]["kind"] == "greybox" and obj["axes"]["gx"]["training"]["n_runs"] == 2
    fitted = obj["axes"]["gx"]["greybox"]["fitted"]
    assert len(fitted["run_offsets_"]) == 2 and fitted["spec_"]["tau_e_s"] == pytest.approx(400, rel=0.15)
    streamed, whole = tmp_path / "s.csv", tmp_path / "w.csv"
    assert runner.invoke(app, ["compensate", str(tmp_path / "cool.csv"), str(model), "--rate-col", "gx,gy", "--out", str(streamed)]).exit_code == 0
    assert runner.invoke(app, ["compensate", str(tmp_path / "cool.csv"), str(model), "--rate-col", "gx,gy", "--plot", str(tmp_path / "p.png"),
                               "--out", str(whole)]).exit_code == 0
    assert streamed.read_bytes() == whole.read_bytes()
    out = pd.read_csv(whole)
    assert np.std(out["gx_compensated"]) < 0.2 * np.std(out["gx"])


CC = shutil.which("cc")
C_PROGRAM = r"""
#define GYROCOMP_TEST_VECTORS
#include <stdio.h>
#include "model.h"
int main(void) {
    gyrocomp_state s;
    long i;
    double worst = 0;
    gyrocomp_init(&s);
    for (i = 0; i < GYROCOMP_N_VECTORS; ++i) {
        double y = (double)gyrocomp_update(&s, (gyrocomp_real)gyrocomp_vector_time_s[i], (gyrocomp_real)gyrocomp_vector_temperature_c[i],
                                           (gyrocomp_real)gyrocomp_vector_rate_dps[i]);
        double err = fabs(y - gyrocomp_vector_compensated_dps[i]);
        if (err > worst) worst = err;
    }
    printf("%.3e\n", worst);
    return 0;
}
"""


def _relay_and_second_time_constants(model, path="parallel"):
    """The fitted cycle model with a relay for its play, a second play, a second lag and warm-up and a saturating dT/dt
    (C against Python needs no fit)."""
    d = json.loads(json.dumps(model.to_dict()))
    d["fitted"]["spec_"] |= {"hysteresis_operator": "relay", "tau_e2_s": 2500.0, "tau_w2_s": 3000.0, "rate_saturation_c_per_s": 0.004,
                             "second_lag_path": path, "width2_c": 9.0, "hysteresis_input": "element" if path == "series" else "temperature"}
    coef = d["fitted"]["coef_"]
    coef |= {"relay": coef.pop("play"), "warmup2": 0.02, "play2": 0.004} | ({"lag2": 0.05} if path == "parallel" else {})
    return GreyBoxDrift.from_dict(d)


@pytest.mark.parametrize("variant", ["fitted", "relay_and_second_time_constants", "series"])
def test_the_compiled_evaluation_is_the_design_columns_times_their_coefficients(cycle_model, variant):
    """The stream sums the model in one compiled pass; the fit sees its columns: both must be one model (1e-12 deg/s)."""
    from gyrocomp.models._greybox_state import columns_of, kernel

    m = cycle_model if variant == "fitted" else _relay_and_second_time_constants(cycle_model, "series" if variant == "series" else "parallel")
    t = np.arange(0.0, 20000.0, 0.5)
    T = _chamber(t, [0, 3000, 9000, 12000, 20000], [20, 45, -5, 30, 30])  # within the training range: no clamp
    raw = kernel(t, T, new_state(), m.spec())
    columns = columns_of(raw, t, m.spec(), t[0], m.centre_c_, m.half_range_c_, m.degree)
    assert set(columns) == set(m.coef_)
    expected = m.offset_ + sum(m.coef_[name] * column for name, column in columns.items())
    np.testing.assert_allclose(m.predict(t, T), expected, rtol=0, atol=1e-12)


@pytest.mark.skipif(CC is None, reason="no C compiler")
@pytest.mark.parametrize("variant", ["fitted", "relay_and_second_time_constants", "series"])
def test_c_header_compiles_strictly_and_reproduces_python(cycle_model, tmp_path, variant):
    """-std=c99 -Wall -Werror -pedantic; 1e-9 deg/s in double over a sweep beyond the range with a gap."""
    from gyrocomp.export import ExportOptions, export_model
    from gyrocomp.pipeline.greybox import GreyBoxModel

    obj = {"training": {"temperature_c": {"min": -10.0, "max": 60.0}}, "static_part": {"cost_deg_h": {"rms": 1.0, "max": 2.0}}}
    estimator = cycle_model if variant == "fitted" else _relay_and_second_time_constants(cycle_model, "series" if variant == "series" else "parallel")
    model = GreyBoxModel(obj, "m.json", estimator, True)
    header, summary = export_model(model, "c", ExportOptions(n_vectors=1500))
    assert summary["n_vectors"] == 1500
    (tmp_path / "model.h").write_text(header)
    (tmp_path / "main.c").write_text(C_PROGRAM)
    for real, bound in (("double", 1e-9), ("float", 1e-3)):
        exe = tmp_path / f"check_{real}"
        subprocess.run([CC, "-std=c99", "-Wall", "-Werror", "-pedantic", f"-DGYROCOMP_REAL={real}", "-o", str(exe), str(tmp_path / "main.c"), "-lm"],
                       check=True, capture_output=True, text=True)
        worst = float(subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout)
        assert worst < bound, (real, worst)
    if variant != "fitted":
        assert "s->br" in header and "s->te2" in header and header.count("exp(-(t - s->t_on)") == 2 and "tanh(r / " in header
        assert " - s->p2) / (gyrocomp_real)4.5" in header
        assert ("te = s->te2;" in header) == (variant == "series")
        assert ("s->hi - s->te >" in header) == (variant == "series")  # the relay switches on T_e
        return
    with pytest.raises(InputError, match=r"--static-part writes its cubic in T alone, which leaves 1 deg/h RMS"):
        export_model(model, "px4", ExportOptions())
    text, summary = export_model(model, "px4", ExportOptions(static_part=True, device_id=1))
    assert "TC_G0_X3_0" in text and summary["added_error_deg_h"] == {"rms": 1.0, "max": 2.0}


def test_diagnose_model_out_fits_the_selected_effects_it_can_hold():
    """greybox_of: the diagnosis' selected effects that are grey-box terms, fitted with selection "all"; the rest named as left out."""
    from gyrocomp.commands.diagnose import greybox_of
    from gyrocomp.recordings import recording_from_frame

    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    y, _ = _gyro(t, T, 1, rate=0.0, asym=0.0, play=0.0)
    run = recording_from_frame(pd.DataFrame({"time": t, "rate": y, "temperature": T}), name="fit")
    body = {"selected_effects": ["thermal_lag", "warmup", "bias_instability", "periodic"], "unexplained": {"present": True},
            "models": {"selected": {"params": {"warmup": {"tau_s": {"value": 900.0, "unit": "s"}}}}}}
    models, units, left_out = greybox_of(body, [run])
    fitted = models["rate"]["greybox"]["fitted"]
    assert models["rate"]["greybox"]["params"]["selection"] == "all"
    assert fitted["spec_"]["tau_e_s"] == pytest.approx(400.0, rel=0.1)
    assert fitted["spec_"]["tau_w_s"] > 0 and fitted["coef_"]["warmup"] == pytest.approx(0.03, rel=0.1)
    assert left_out == {"terms": ["thermal_lag", "warmup"], "not_held": ["bias_instability", "periodic"], "not_fitted": [],
                        "unexplained_structure": True}


def test_diagnose_model_out_holds_a_warm_up_of_two_time_constants_in_second_warmup():
    """A diagnosis' ``warmup`` in its form of two time constants (``slow_tau_s`` reported) is exported as ``warmup`` and
    ``second_warmup``, both time constants within 25 % (the trade against the cubic in T measured in the test above)."""
    from gyrocomp.commands.diagnose import greybox_of
    from gyrocomp.recordings import recording_from_frame

    t = np.arange(0, 21600.0)
    T = _chamber(t, *CYCLE)
    y, _ = _gyro(t, T, 1, tau_e=0.0, rate=0.0, asym=0.0, play=0.0, warm=0.03, warm2=0.02)
    run = recording_from_frame(pd.DataFrame({"time": t, "rate": y, "temperature": T}), name="fit")
    warmup = {"form": {"value": "two_time_constants", "unit": ""}, "tau_s": {"value": 900.0, "unit": "s"}, "slow_tau_s": {"value": 4000.0, "unit": "s"}}
    body = {"selected_effects": ["warmup"], "unexplained": {"present": False}, "models": {"selected": {"params": {"warmup": warmup}}}}
    models, units, left_out = greybox_of(body, [run])
    spec = models["rate"]["greybox"]["fitted"]["spec_"]
    assert left_out["terms"] == ["warmup", "second_warmup"] and left_out["not_fitted"] == []
    assert [spec["tau_w_s"], spec["tau_w2_s"]] == pytest.approx([900.0, 4000.0], rel=0.25)


def test_train_names_every_selected_term_and_its_parameters_in_one_line():
    from gyrocomp.cli.train import greybox_line

    spec = {"tau_e_s": 297.0, "tau_e2_s": 1502.0, "second_lag_path": "series", "rate_form": 2, "rate_tau_s": 12.0,
            "rate_saturation_c_per_s": 0.01, "width_c": 4.0, "hysteresis_operator": "relay", "width2_c": 12.0, "tau_w_s": 900.0,
            "tau_w2_s": 4000.0}
    assert greybox_line({"spec_": spec}) == (
        "greybox: cubic in T_e + thermal_lag tau 297 s + second_lag tau 1502 s (series)"
        " + temp_rate heating/cooling apart (filter 12 s, saturating at 0.6 degC/min)"
        " + hysteresis relay width 4 degC and play width 12 degC + warmup tau 900 s and 4000 s"
    )
