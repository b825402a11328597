"""A small fixed set of the in-sim benchmark's cases (``benchmarks/diagnose_withheld.py``), guarded.

Each case is rebuilt exactly as the benchmark builds it (8-hour oven runs,
one gyro, three noise seeds: the selection runs fit and A, the holdout B)
and must be diagnosed exactly, with the held-out gap at least halved. The
set holds look-alikes near the edge of detectability (thermal lag beside
temperature-rate sensitivity, hysteresis or a warm-up beside a noise term,
flicker alone just above its edge) and pairs of a slow shape beside a noise
term. What each case once exposed is in ``benchmarks/LEDGER.md``;
the rules of the selection are tested on constructed cases in
``test_selection_rules.py``.
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
    (fit, a, b), _ = _benchmark().simulate_pair(case)
    report = diagnose(fit, [a, b])
    assert set(report["selected_effects"]) == set(case["effects"]), case
    gap = report["gap"]
    assert gap["selected"]["holdout"] <= 0.5 * gap["baseline"]["holdout"], gap


@pytest.mark.parametrize(
    "seed, index, strength",
    [(2024, 23, None),
     (2024, 24, None), (2024, 34, {"bias_instability": 1.2}), (2024, 0, None),
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


_BELOW_LIMIT = pytest.mark.xfail(
    strict=False,
    reason="fails since 840e5ab (hysteresis' power-on level per run): its hysteresis, drawn below the detection limit the report "
           "states beside the noise term, no longer pays; benchmarks/LEDGER.md, "
           "withheld row of 2026-11-23 17:40")


@pytest.mark.slow
@pytest.mark.parametrize("seed, index", [
    (2024, 4), (2024, 19), pytest.param(2024, 23, marks=_BELOW_LIMIT), (2024, 28), pytest.param(7, 9, marks=_BELOW_LIMIT)])
def test_former_benchmark_misses(seed, index):
    _check(_benchmark().make_case(index, seed, draw="absolute"))
