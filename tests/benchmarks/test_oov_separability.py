"""The separability measures of ``benchmarks/oov_separability.py`` on clear cases of the independent generator.

4 h runs at 1 Hz (seed 11): a transient and a mode hop drawn large (z = 40)
are one event per run, beside which a random walk fitted to them gains
nothing, where draws of that walk leave it a large gain; a true random walk
keeps its gain beside its best single event, as its own draws do. Popcorn
drawn large switches between two levels by the signature's statistic; a true
flicker and a Gauss-Markov bias do not.
"""

import pytest

import independent_gen as gen
import oov_separability as sep
from gyrocomp.diagnose import problems
from gyrocomp.diagnose.select import extend, fit_baseline

DRAWS = 20


def _pair(key, index, z=None):
    case = gen.draw_case(11, index, key, fs_hz=1.0, duration_s=4 * 3600.0)
    if z is not None:
        case = case | {"z_target": z}
    runs, _ = gen.generate_pair(case)
    fit_p, (hold_p,), _ = problems(sep._recording(runs["fit"], "fit"), [sep._recording(runs["holdout"], "holdout")])
    return case, fit_p, hold_p


def _event_tests(key, index, event, z=None):
    _, fit_p, hold_p = _pair(key, index, z)
    model = extend(fit_p, fit_baseline(fit_p), "rate_random_walk")
    return [sep.event_test(p, model, "rate_random_walk", event, DRAWS, [0, k]) for k, p in enumerate((fit_p, hold_p))]


@pytest.mark.parametrize(("key", "index", "event"), [("transient/gaussian_bump", 27, "bump"), ("bias_step/mode_hop", 25, "step")])
def test_a_large_event_leaves_the_walk_no_gain_beside_it(key, index, event):
    for run in _event_tests(key, index, event, z=40.0):
        # at most one of 20 draws of the fitted walk is described by one event as well
        assert run["p"] <= 2.0 / (1 + DRAWS) and run["null_median"] > 50.0, run


def test_a_true_walk_keeps_its_gain_beside_one_event():
    for run in _event_tests("rate_random_walk/random_walk", 22, "bump"):
        assert run["gain"] > 50.0 and run["p"] > 0.1, run


def test_large_popcorn_switches_between_two_levels_and_a_gaussian_bias_does_not():
    case, _, _ = _pair("telegraph_noise/popcorn", 30, 40.0)
    assert sep.measure(case, DRAWS)["pooled_z"] > 5.0
    for key, index in (("bias_instability/flicker", 19), ("bias_instability/gauss_markov", 20)):
        result = sep.measure(gen.draw_case(11, index, key, fs_hz=1.0, duration_s=4 * 3600.0), DRAWS, "levels")
        assert all(abs(run["z"]) < 3.0 for run in result["runs"]) and abs(result["pooled_z"]) < 3.0, (key, result)
