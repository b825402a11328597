"""Score `gyrocomp diagnose` on simulated fit/holdout pairs whose effects are withheld.

Each pair is one gyro (the default gyro's baseline: offset, cubic in
temperature, ARW 1 deg/sqrt(h), 1e-4 deg/s LSB; the measured temperature has
the profile's sensor noise and LSB) carrying none, one or two effects drawn at
random, with amplitudes drawn log-uniformly from the ranges below, whose
lower ends sit near the edge of detectability for an 8-hour run. The fit and
holdout runs share the gyro and the profile and differ in their noise seed.
Only the two recordings go to :func:`gyrocomp.diagnose.diagnose`; its
selection is scored against the hidden truth.

Prints and writes (``benchmarks/results/diagnose.json``; another ``--seed S``
writes ``diagnose-seedS.json``): the confusion
matrix (rows: true effect present, columns: effect selected), the exact-match
rate, false positives on effect-free pairs, the held-out gap shrink
``1 - G_selected / G_baseline`` on pairs with an effect, and the time per
pair. Timings are noisy: other processes share the cores.

Usage: ``python benchmarks/diagnose_withheld.py [--pairs N] [--workers W] [--seed S]``
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from gyrocomp.sim import EFFECTS  # the vocabulary of DESIGN.md, in report order

HERE = Path(__file__).resolve().parent
PROFILES = ("oven-paper", "oven-reverse")
RATES_HZ = (1.0, 2.0)
DURATION_S = 8 * 3600.0


def draw_effect(name, rng):
    """Parameters of one effect (log-uniform amplitude, random sign)."""

    def lu(lo, hi):
        return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))

    sign = float(rng.choice([-1.0, 1.0]))
    if name == "thermal_lag":
        return {"tau_s": lu(60.0, 900.0)}
    if name == "temp_rate":
        return {"coefficient_dps_per_c_per_s": sign * lu(0.15, 2.0)}
    if name == "hysteresis":
        return {"amplitude_dps": lu(0.002, 0.02), "deadband_c": lu(0.3, 2.0)}
    if name == "warmup":
        return {"amplitude_dps": sign * lu(0.005, 0.05), "tau_s": lu(300.0, 1800.0)}
    if name == "rate_ramp":
        return {"slope_dps_per_s": sign * lu(1e-7, 1e-6)}
    if name == "periodic":
        return {"amplitude_dps": lu(0.002, 0.01), "period_s": lu(300.0, 3600.0), "phase_rad": float(rng.uniform(0, 2 * np.pi))}
    if name == "bias_instability":
        return {"b_deg_per_h": lu(6.0, 30.0)}
    return {"k_deg_per_h_per_sqrt_h": lu(6.0, 30.0)}


def make_case(index, seed):
    """The hidden truth of pair `index`: profile, rate, effects and their parameters."""
    rng = np.random.default_rng([seed, index])
    k = int(rng.choice([0, 1, 2], p=[0.25, 0.4, 0.35]))
    effects = sorted(rng.choice(EFFECTS, size=k, replace=False).tolist(), key=EFFECTS.index)
    return {
        "index": index,
        "profile": PROFILES[int(rng.integers(len(PROFILES)))],
        "fs_hz": float(RATES_HZ[int(rng.integers(len(RATES_HZ)))]),
        "effects": {e: draw_effect(e, rng) for e in effects},
        "seeds": [int(s) for s in rng.integers(0, 2**31, size=2)],
    }


def simulate_pair(case):
    """Two recordings (fit, holdout) of the case's gyro."""
    from gyrocomp.config import bind, load_config
    from gyrocomp.io import recording_from_frame
    from gyrocomp.sim.model import GyroSettings
    from gyrocomp.sim.profile import ProfileSettings
    from gyrocomp.sim.simulate import simulate

    table = load_config("configs/gyro/default.toml" if Path("configs").is_dir() else HERE.parent / "configs/gyro/default.toml")["gyro"]
    for e in EFFECTS:
        table[e] = {"enabled": e in case["effects"], **case["effects"].get(e, {})}
    gyro = bind(GyroSettings, table, "benchmark gyro")
    profile = bind(ProfileSettings, load_config(HERE.parent / f"configs/profiles/{case['profile']}.toml")["profile"], "profile")
    recs = []
    for name, seed in zip(("fit", "holdout"), case["seeds"]):
        frame, _ = simulate(gyro, profile, fs_hz=case["fs_hz"], seed=seed, duration_s=DURATION_S)
        recs.append(recording_from_frame(frame[["time", "rate", "temperature"]], name=name))
    return recs


def run_case(case):
    from gyrocomp.diagnose import diagnose, get_config

    fit, holdout = simulate_pair(case)
    t0 = time.perf_counter()
    report = diagnose(fit, holdout, get_config())
    elapsed = time.perf_counter() - t0
    return {
        **case,
        "selected": report["selected_effects"],
        "gap_baseline_holdout": report["gap"]["baseline"]["holdout"],
        "gap_selected_holdout": report["gap"]["selected"]["holdout"],
        "seconds": elapsed,
    }


def score(results):
    """Confusion matrix, exact-match rate, false positives, held-out shrink."""
    labels = list(EFFECTS)
    confusion = {t: {p: 0 for p in labels + ["(none)"]} for t in labels + ["(none)"]}
    exact = 0
    fp_free = 0
    n_free = 0
    shrinks = []
    for r in results:
        truth = set(r["effects"])
        sel = set(r["selected"])
        exact += truth == sel
        for t in truth or {"(none)"}:
            for p in sel or {"(none)"}:
                confusion[t][p] += 1
        if not truth:
            n_free += 1
            fp_free += bool(sel)
        else:
            base = r["gap_baseline_holdout"]
            shrinks.append(1.0 - r["gap_selected_holdout"] / base if base else 0.0)
    shrinks = np.array(shrinks)
    return {
        "pairs": len(results),
        "exact_match_rate": exact / len(results),
        "effect_free_pairs": n_free,
        "false_positive_pairs": fp_free,
        "holdout_shrink_median": float(np.median(shrinks)) if shrinks.size else None,
        "holdout_shrink_at_least_half": float(np.mean(shrinks >= 0.5)) if shrinks.size else None,
        "seconds_per_pair_median": float(np.median([r["seconds"] for r in results])),
        "confusion": confusion,
    }


def confusion_markdown(confusion):
    """The confusion matrix as a markdown table (rows: truth, columns: selected)."""
    cols = list(next(iter(confusion.values())))
    short = {c: c.replace("bias_instability", "bias_inst").replace("rate_random_walk", "rrw") for c in cols}
    lines = ["| true \\ selected | " + " | ".join(short[c] for c in cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for t, row in confusion.items():
        lines.append(f"| {short[t]} | " + " | ".join(str(row[c]) if row[c] else "." for c in cols) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=2024)
    args = parser.parse_args(argv)
    cases = [make_case(i, args.seed) for i in range(args.pairs)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(run_case, cases))
    for r in results:
        ok = "ok " if set(r["effects"]) == set(r["selected"]) else "MISS"
        print(f"{ok} #{r['index']:3d} {r['profile']:12s} {r['fs_hz']:.0f} Hz truth={sorted(r['effects'])} selected={r['selected']}")
    summary = score(results)
    print(confusion_markdown(summary["confusion"]))
    for key, value in summary.items():
        if key != "confusion":
            print(f"{key}: {value}")
    # The default seed is the one the selection was tuned on; others (seeds 7
    # and 99 are the reported checks; 99 was never used for tuning)
    # go to their own file.
    out = HERE / "results" / ("diagnose.json" if args.seed == 2024 else f"diagnose-seed{args.seed}.json")
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"summary": summary, "cases": results}, indent=2, default=float) + "\n")
    return 0 if summary["exact_match_rate"] >= 0.95 and summary["false_positive_pairs"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
