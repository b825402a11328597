"""Which candidates the selection runs can identify (gyrocomp.diagnose.identify), on constructed runs.

A 2 h, 1 Hz static gyro: white noise and a cubic in temperature. A
hysteresis whose branch never changes (the temperature only falls) is a
constant after its first excursion, which the offset and its power-on
indicator take: not identifiable at any amplitude. On a run whose
temperature reverses it is.
"""

import numpy as np
import pytest

from gyrocomp.diagnose import DiagnoseSettings
from gyrocomp.diagnose.effects import Run, TemperatureScale
from gyrocomp.diagnose.identify import holdout_needs, unidentifiable
from gyrocomp.diagnose.select import Problem, extend, fit_baseline

PROFILES = {
    # a soak at 25 degC, then 1 degC/min down to 0 degC and a soak: the branch never changes after the first degrees
    "falls": [(0, 25), (20, 25), (45, 0), (120, 0)],
    # 25 -> 50 -> 20 -> 35 degC: three reversals
    "cycles": [(0, 25), (10, 25), (35, 50), (50, 50), (80, 20), (90, 20), (105, 35), (120, 35)],
}


def _problem(profile, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(7200, dtype=float)
    kt, kc = np.array(PROFILES[profile], dtype=float).T
    temp = np.interp(t / 60.0, kt, kc)
    x = 0.005 * rng.standard_normal(t.size) + 0.002 * ((temp - 25.0) / 25.0) ** 3
    return Problem(Run(profile, t, x, temp, 1.0, 10, 60.0), DiagnoseSettings(), TemperatureScale.of(temp), 3)


@pytest.mark.parametrize(("profile", "expected"), [("falls", False), ("cycles", True)])
def test_a_hysteresis_is_identifiable_only_where_its_branch_changes(profile, expected):
    problem = _problem(profile)
    start = fit_baseline(problem)
    why = unidentifiable([problem], start, extend(problem, start, "hysteresis"), "hysteresis", DiagnoseSettings().identifiable_min_unique)
    assert (why is None) == expected, why
    if not expected:
        assert why.startswith("not identifiable from these runs") and "--holdout" in why


def test_a_noise_term_is_always_judged_by_its_detection_limit():
    problem = _problem("falls")
    start = fit_baseline(problem)
    assert unidentifiable([problem], start, extend(problem, start, "rate_random_walk"), "rate_random_walk", 0.01) is None


def _with_play(profile, amp, seed, scale=None, deadband_c=4.0):
    """`_problem`'s run with a play hysteresis of +-`amp` deg/s (heating +, cooling -), written here as a numpy loop."""
    rng = np.random.default_rng(seed)
    t = np.arange(7200, dtype=float)
    kt, kc = np.array(PROFILES[profile], dtype=float).T
    temp = np.interp(t / 60.0, kt, kc)
    play = np.empty_like(temp)
    state = temp[0]
    for i, c in enumerate(temp):
        state = min(max(state, c - deadband_c / 2), c + deadband_c / 2)
        play[i] = state
    x = 0.005 * rng.standard_normal(t.size) + 0.002 * ((temp - 25.0) / 25.0) ** 3 + amp * (temp - play) / (deadband_c / 2)
    scale = scale or TemperatureScale.of(temp)
    return Problem(Run(profile, t, x, temp, 1.0, 10, 60.0), DiagnoseSettings(), scale, 3)


@pytest.mark.parametrize(("holdout", "amp", "needed"), [("cycles", 0.002, True), ("cycles", 0.0, False), ("falls", 0.002, False)])
def test_a_holdout_that_needs_what_the_fit_run_cannot_identify(holdout, amp, needed):
    # a 7.2 deg/h play of 4 degC deadband on both runs; the fit run only falls, so its branch never changes there
    fit = _with_play("falls", amp, seed=0)
    held = _with_play(holdout, amp, seed=1, scale=fit.scale)
    selected = fit_baseline(fit)
    assert unidentifiable([fit], selected, extend(fit, selected, "hysteresis"), "hysteresis", 0.01) is not None
    p = holdout_needs(fit, held, selected, "hysteresis", 0.01, 0.01)
    assert (p is not None) == needed, p
    if needed:
        assert p < 1e-6
