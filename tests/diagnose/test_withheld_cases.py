"""Pairs of the withheld-effect benchmark, guarded: look-alikes near the edge, and former misses.

Each case is rebuilt exactly as ``benchmarks/diagnose_withheld.py`` builds
it (8-hour oven runs, one gyro, two noise seeds) from its seed, index and
amplitude draw, and must be diagnosed exactly, with the held-out gap at
least halved.

Near the edge of detectability (``draw="edge"``; run by ``make test``),
from seed 2024:

* #23 hysteresis (1.3x its edge) + flicker: a random walk stood in for both
  and the joint criterion then admitted flicker beside it, locking the
  stand-in in; swaps now come before the joint criterion;
* #24 warm-up + random walk (2.1x): the random walk, too weak to pass on
  the fit run beside the warm-up, enters on the joint likelihood of both
  runs;
* #34 flicker alone, set to 1.2x its edge (B = 3.8 deg/h; the draw is
  1.8x): a 2.3 h sinusoid fitted to the slowest wander beat flicker by BIC
  and replicated on the holdout's own wander; a shape now waits when a noise
  term explains the holdout better (without that rule it is named up to
  1.4x);
* #0 thermal lag + temperature-rate sensitivity, the classic look-alikes;

and from other seeds:

* seed 7 #8 rate ramp + random walk (1.2x): the ramp's fit-run estimate
  took the fit run's weak random walk to zero, so the frozen model failed
  the holdout; the joint criterion now asks each run to agree at the joint
  estimate, and a noise term fitted to nothing restarts above the flat
  floor of the likelihood;
* seed 99 #15 thermal lag of 5.5 h + flicker: the time-constant grid ended
  at 2 h, and a random walk stood in; the grid now spans the 8-hour run,
  and a swap weighs the fit run's BIC plus the holdout's ``-2 log L``
  (the holdout was nearly indifferent, the fit run was not);
* seed 99 #28 warm-up (1.3x) + rate ramp (1.8x): the joint criterion now
  refits the warm-up's time constant beside the ramp, as a fit-run step
  does;
* seed 5 #17 temperature-rate sensitivity + warm-up, both strong: a 4 h
  sinusoid entered beside them on the joint likelihood, charged for one
  phase and amplitude while each run fitted its own; the joint criterion
  now counts them once per run.

Former misses with the absolute amplitude ranges (``draw="absolute"``;
slow, ``make test-slow``):

* #4 warm-up + rate ramp: the warm-up fitted alone stretched its time
  constant over the ramp, hiding it; adding an effect now refits the
  nonlinear parameters of those already in;
* #19 flicker + warm-up and #23 flicker + hysteresis: one random-walk term
  absorbed both causes and greedy steps stopped there; the swap step
  replaces it by flicker + the deterministic effect;
* #28 flicker + warm-up: the warm-up amplitude fitted under flicker
  over-predicted the held-out run; the holdout check now asks that the
  shape replicate (amplitude refitted, non-negative) instead;
* seed 7 #9 random walk + hysteresis: under the random walk the hysteresis
  earned -5 BIC on the fit run alone; the joint likelihood of both runs
  (the random walk does not repeat, the hysteresis does) admits it.
"""

import importlib.util
from pathlib import Path

import pytest

from gyrocomp.diagnose import diagnose

_BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "diagnose_withheld.py"


def _benchmark():
    spec = importlib.util.spec_from_file_location("diagnose_withheld", _BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _check(case):
    (fit, holdout), _ = _benchmark().simulate_pair(case)
    report = diagnose(fit, holdout)
    assert set(report["selected_effects"]) == set(case["effects"]), case
    gap = report["gap"]
    assert gap["selected"]["holdout"] <= 0.5 * gap["baseline"]["holdout"], gap


@pytest.mark.parametrize(
    "seed, index, strength",
    [(2024, 23, None), (2024, 24, None), (2024, 34, {"bias_instability": 1.2}), (2024, 0, None),
     (7, 8, None), (99, 15, None), (99, 28, None), (5, 17, None)],
)
def test_look_alikes_near_the_edge(seed, index, strength):
    bench = _benchmark()
    case = bench.make_case(index, seed, draw="edge")
    for effect, multiple in (strength or {}).items():
        case["effects"][effect]["strength_x_edge"] = multiple
    case = bench.resolve_case(case)
    assert all(p["detection"] >= bench.POWER - 1e-6 for p in case["effects"].values()), case
    _check(case)


@pytest.mark.slow
@pytest.mark.parametrize("seed, index", [(2024, 4), (2024, 19), (2024, 23), (2024, 28), (7, 9)])
def test_former_benchmark_misses(seed, index):
    _check(_benchmark().make_case(index, seed, draw="absolute"))
