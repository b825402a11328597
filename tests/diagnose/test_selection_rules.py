"""The selection criterion and its moves, each on a constructed case.

Every rule of :class:`gyrocomp.diagnose.select.Search` is checked on a
recording built here from numpy draws and closed-form shapes (a static run:
white noise plus the effect), small enough to run in seconds. The
withheld-effect benchmark (``benchmarks/diagnose_withheld.py``) and the
independent generator measure the selection as a whole.
"""

import dataclasses

import numpy as np
import pandas as pd
from numpy.testing import assert_allclose

from gyrocomp.diagnose import DiagnoseSettings, diagnose, reduce_recording
from gyrocomp.diagnose.effects import Run
from gyrocomp.diagnose.select import Problem, Search, extend, fit_baseline
from gyrocomp.recordings import recording_from_frame

HOURS = 2.0
SIGMA = 0.02  # white noise per 1 Hz sample [deg/s]


def _rate(seed, warmup=0.0, ramp=0.0, walk=0.0, offset=0.05):
    """Two hours at 1 Hz: offset + warm-up (tau 500 s) + ramp [deg/s/h] + random walk [deg/s/sqrt(s)] + white."""
    rng = np.random.default_rng(seed)
    t = np.arange(HOURS * 3600.0)
    rate = offset + warmup * np.exp(-t / 500.0) + ramp * t / 3600.0 + rng.normal(0.0, SIGMA, t.size)
    rate += walk * np.cumsum(rng.normal(0.0, 1.0, t.size))
    return t, rate


def _problem(t, rate, settings=DiagnoseSettings(), name="run"):
    return Problem(Run(name, t, rate, None, 1.0, 10), settings, None, 0)


CANDIDATES = ["warmup", "rate_ramp", "periodic", "bias_instability", "rate_random_walk"]


def test_white_noise_alone_selects_nothing():
    search = Search([_problem(*_rate(1))], CANDIDATES)
    assert search.run().order == ()
    assert search.steps[0]["move"] == "forward" and search.steps[0]["accepted"] is None


def test_forward_adds_an_effect_that_earns_its_place():
    search = Search([_problem(*_rate(2, warmup=0.01))], CANDIDATES)
    assert search.run().order == ("warmup",)
    assert search.steps[0]["delta"]["warmup"] < -search.margin
    assert search.earns(search.model, "warmup")


def test_an_effect_below_the_margin_stays_out():
    """The same warm-up, with a margin above its evidence: the forward move refuses it."""
    problem = _problem(*_rate(2, warmup=0.01))
    evidence = -Search([problem], ["warmup"]).score(extend(problem, fit_baseline(problem), "warmup"))
    evidence += Search([problem], ["warmup"]).score(fit_baseline(problem))
    strict = Search([_problem(*_rate(2, warmup=0.01), dataclasses.replace(DiagnoseSettings(), bic_margin=evidence + 1.0))], ["warmup"])
    assert strict.run().order == ()
    lenient = Search([_problem(*_rate(2, warmup=0.01), dataclasses.replace(DiagnoseSettings(), bic_margin=evidence - 1.0))], ["warmup"])
    assert lenient.run().order == ("warmup",)


def test_backward_drops_an_effect_that_no_longer_earns_its_place():
    """A random walk that stood in for the warm-up goes once the warm-up is in."""
    problem = _problem(*_rate(3, warmup=0.02))
    search = Search([problem], CANDIDATES)
    search.model = extend(problem, extend(problem, search.baseline, "rate_random_walk"), "warmup")
    assert search.backward("warmup") == ["rate_random_walk"]
    assert search.model.order == ("warmup",)


def test_backward_does_not_leave_an_inadmissible_noise_term():
    """A warm-up that no longer earns its place beside a random walk is dropped, unless the walk alone
    would fail its admissibility check (here: admissible only beside the warm-up); forward would never accept that model."""
    problem = _problem(*_rate(5, walk=2e-4))
    model = extend(problem, extend(problem, fit_baseline(problem), "warmup"), "rate_random_walk")
    free = Search([problem], CANDIDATES)
    free.model = model
    assert free.backward("rate_random_walk") == ["warmup"]
    guarded = Search([problem], CANDIDATES, admissible=lambda runs, m, effect: "warmup" in m.order)
    guarded.model = model
    assert guarded.backward("rate_random_walk") == []
    assert guarded.model.order == ("warmup", "rate_random_walk")


def test_swap_replaces_a_stand_in():
    """A noise term put in place of a ramp is swapped for the ramp, which scores lower and earns its place."""
    problem = _problem(*_rate(4, ramp=0.01))
    search = Search([problem], CANDIDATES)
    search.model = extend(problem, search.baseline, "rate_random_walk")
    assert search.swap()
    assert "rate_ramp" in search.model.order and "rate_random_walk" not in search.model.order
    assert search.steps[-1]["swapped"]["out"] == ["rate_random_walk"]


def test_a_noise_term_that_fails_its_signature_check_is_not_selected():
    problem = _problem(*_rate(5, walk=2e-4))
    assert "rate_random_walk" in Search([problem], CANDIDATES).run().order
    refused = []

    def admissible(runs, model, effect):
        refused.append(effect)
        return False

    search = Search([problem], CANDIDATES, admissible=admissible)
    assert not {"rate_random_walk", "bias_instability"} & set(search.run().order)
    assert "rate_random_walk" in refused


def test_score_of_two_runs_adds_their_deviances():
    """A run and its copy shifted by 0.3 deg/s (per-run offsets): twice the deviance, parameters counted per run."""
    t, rate = _rate(6, warmup=0.01)
    one, shifted = _problem(t, rate), _problem(t, rate + 0.3, name="shifted")
    model = extend(one, fit_baseline(one), "warmup")
    n = 2 * one.y.size
    k = model.n_params + 1 + 1  # the offset and the white level, once more
    assert_allclose(Search([one, shifted], CANDIDATES).score(model), 2 * model.deviance + k * np.log(n), rtol=1e-6)


def _recording(t, rate, name):
    return recording_from_frame(pd.DataFrame({"time": t, "rate": rate}), name=name)


def test_the_reported_holdout_takes_no_part_in_the_selection():
    fit = _recording(*_rate(7, warmup=0.01), "fit")
    a = _recording(*_rate(8, warmup=0.01), "a")
    b1 = _recording(*_rate(9, warmup=0.01), "b1")
    b2 = _recording(*_rate(10, walk=3e-4), "b2")
    r1, r2 = diagnose(fit, [a, b1]), diagnose(fit, [a, b2])
    assert r1["selected_effects"] == r2["selected_effects"] == ["warmup"]
    assert r1["models"]["selected"] == r2["models"]["selected"]
    assert r1["gap"]["protocol"]["selection_runs"] == ["fit", "a"]
    assert r1["gap"]["protocol"]["holdout_run"] == "b1"
    one = diagnose(fit, b1)
    assert one["gap"]["protocol"]["selection_runs"] == ["fit"]


def test_reduction_keeps_the_block_means():
    """Averaging 100 Hz to 1 Hz at entry leaves every 10 s block mean unchanged."""
    rng = np.random.default_rng(11)
    t = np.arange(100 * 600) / 100.0
    rate = rng.normal(0.0, 0.1, t.size) + np.sin(t / 50.0)
    temperature = 25.0 + t / 60.0
    tr, rr, cr, fs = reduce_recording(t, rate, temperature, 100.0, 100)
    assert fs == 1.0 and rr.size == 600
    assert_allclose(rr.reshape(60, 10).mean(axis=1), rate.reshape(60, 1000).mean(axis=1), rtol=1e-12)
    assert_allclose(cr, 25.0 + tr / 60.0, rtol=1e-12)
    slow_rate = rate[:600]
    same = reduce_recording(t[:600], slow_rate, None, 1.0, 1)
    assert same[1] is slow_rate and same[2] is None


def test_a_fast_recording_is_diagnosed_like_its_average():
    """A warm-up at 20 Hz: the same selection and nearly the same gap as the same data averaged to 1 Hz."""
    rng = np.random.default_rng(12)
    t = np.arange(20 * 3600 * 2) / 20.0
    rate = 0.05 + 0.01 * np.exp(-t / 500.0) + rng.normal(0.0, SIGMA * np.sqrt(20.0), t.size)
    fast = diagnose(_recording(t, rate, "fast"))
    slow = diagnose(_recording(t.reshape(-1, 20).mean(axis=1), rate.reshape(-1, 20).mean(axis=1), "slow"))
    assert fast["selected_effects"] == slow["selected_effects"] == ["warmup"]
    assert_allclose(fast["gap"]["baseline"]["fit"], slow["gap"]["baseline"]["fit"], rtol=1e-6)
    assert_allclose([fast["blocks"]["reduced_fs_hz"], fast["blocks"]["fs_hz"]], [1.0, 20.0], rtol=1e-9)
    assert_allclose(fast["blocks"]["arw_sample"]["fit"], SIGMA, rtol=0.05)
