"""Score `gyrocomp diagnose` on recordings of the independent generator (``independent_gen.py``).

Each case of a seed's plan (every form of every effect once, four effect-free
pairs, and speed twins: one case drawn at 2 Hz and at 100 Hz) is written to
Parquet and handed to the command line the way a user runs it::

    gyrocomp diagnose fit.parquet --holdout holdout.parquet --out report.json

one process per pair, one BLAS thread per worker (``--workers`` pairs at a
time). The report is scored against the hidden truth:

* ``sim_form`` / ``real_form``: exactly right -- the effect's vocabulary name
  and nothing else in ``selected_effects``;
* ``oov`` (no vocabulary name fits): ``unexplained.present`` and no
  vocabulary name (a report without an ``unexplained`` object counts as not
  flagged);
* ``none``: a false positive is any selected effect, a false alarm any
  ``unexplained.present``.

Goals (issue 16, "Done when"): >= 95 % / 90 % / 90 % on sim forms / real forms
/ out-of-vocabulary, 0 false positives and 0 false ``unexplained`` on the
effect-free pairs; the 100 Hz twin at most twice its 2 Hz twin's time (both
timed back to back in one worker) and a 2 Hz pair under a minute.

Writes the summary to ``benchmarks/results/diagnose_independent.json`` (one
entry per seed, with the commit, machine and load) and
``benchmarks/_data/independent/seed<S>.json`` (summary, confusion matrix,
every case with its truth and verdict) and ``.md`` (the summary as tables). Exits 1 while a goal is missed.

Each verdict is also appended to ``benchmarks/_data/independent/seed<S>-progress.jsonl``
as it comes; ``--resume`` keeps those and runs the rest.

Usage: ``python benchmarks/diagnose_independent.py --seed 1 [--workers 2] [--twins 1] [--only KEY ...] [--resume]``
(seed 1 is the tuning seed; see benchmarks/README.md for the check seeds).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import independent_gen as gen  # noqa: E402
import provenance  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = HERE / "_data" / "independent"
GOALS = {"sim_form": 0.95, "real_form": 0.90, "oov": 0.90}
"""Fraction of cases exactly right per category (issue 16)."""
SPEED_RATIO_GOAL = 2.0
"""A 100 Hz pair at most this many times its 2 Hz twin."""
TWO_HZ_SECONDS_GOAL = 60.0
CATEGORIES = ("sim_form", "real_form", "oov", "none")


def run_diagnose(fit, holdout, out):
    """Run the command line on one pair; return (report or None, wall s, CPU s, exit code, stderr tail)."""
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p])}
    cmd = [sys.executable, "-m", "gyrocomp", "diagnose", str(fit), "--holdout", str(holdout), "--out", str(out)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    report = json.loads(Path(out).read_text()) if proc.returncode == 0 and Path(out).exists() else None
    return report, wall, cpu, proc.returncode, proc.stderr.strip().splitlines()[-1:] if proc.returncode else []


def run_case(case):
    """Generate, diagnose and describe one case (the truth, the realised strength and the report's verdict)."""
    folder = DATA / f"seed{case['seed']}" / f"case{case['index']:03d}-{case['fs_hz']:g}hz"
    try:
        (fit, holdout), realised = gen.write_pair(case, folder)
        report, wall, cpu, code, err = run_diagnose(fit, holdout, folder / "report.json")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    result = case | {"realised": realised, "seconds": wall, "cpu_seconds": cpu, "exit_code": code, "error": err}
    if report is None:
        return result | {"selected": None, "unexplained": None}
    unexplained = report.get("unexplained")
    gap = report.get("gap", {})
    return result | {
        "selected": report.get("selected_effects"),
        "unexplained": unexplained,
        "gap_baseline_holdout": gap.get("baseline", {}).get("holdout"),
        "gap_selected_holdout": gap.get("selected", {}).get("holdout"),
    }


def run_twin(pair):
    """The speed twins of one case, back to back in one worker (same load for both)."""
    return [run_case(case) for case in pair]


def flagged(result):
    """Whether the report says the vocabulary leaves something unexplained (False when it has no such object)."""
    u = result.get("unexplained")
    return bool(isinstance(u, dict) and u.get("present"))


def correct(result):
    """The case's verdict is right (see the module docstring)."""
    selected = result["selected"]
    if selected is None:
        return False
    if result["category"] == "oov":
        return flagged(result) and not selected
    if result["category"] == "none":
        return not selected and not flagged(result)
    return set(selected) == set(result["expected"])


def score(results):
    """Per-category rates, effect-free false positives / alarms, the confusion matrix and the timing."""
    by_cat = {}
    for cat in CATEGORIES:
        rs = [r for r in results if r["category"] == cat]
        entry = {"cases": len(rs), "correct": sum(correct(r) for r in rs)}
        entry["rate"] = entry["correct"] / len(rs) if rs else None
        if cat in ("sim_form", "real_form"):
            entry["correct_and_not_flagged"] = sum(correct(r) and not flagged(r) for r in rs)
            entry["flagged_unexplained"] = sum(flagged(r) for r in rs)
        if cat == "oov":
            entry["flagged_unexplained"] = sum(flagged(r) for r in rs)
            entry["no_vocabulary_name"] = sum(r["selected"] == [] for r in rs)
        if cat == "none":
            entry["false_positive_pairs"] = sum(bool(r["selected"]) for r in rs)
            entry["false_unexplained_pairs"] = sum(flagged(r) for r in rs)
        by_cat[cat] = entry
    failed = [r["index"] for r in results if r["selected"] is None]
    return {
        "pairs": len(results),
        "failed_runs": failed,
        "categories": by_cat,
        "unexplained_in_reports": any(r.get("unexplained") is not None for r in results),
        "confusion": confusion(results),
        "timing": timing(results),
    }


def confusion(results):
    """Rows: true effect/form; columns: vocabulary names selected, ``(none)``, ``unexplained``; counts of cases."""
    columns = list(gen.VOCABULARY) + ["(none)", "unexplained", "(failed)"]
    rows = {}
    for r in sorted(results, key=lambda r: (CATEGORIES.index(r["category"]), r["key"])):
        row = rows.setdefault(r["key"], dict.fromkeys(columns, 0))
        if r["selected"] is None:
            row["(failed)"] += 1
            continue
        for name in r["selected"] or ["(none)"]:
            row[name if name in row else "(none)"] += 1
        row["unexplained"] += flagged(r)
    return rows


def timing(results):
    """Median / max seconds per sample rate, and the 100 Hz / 2 Hz ratio of each speed twin."""
    per_rate = {}
    for fs in sorted({r["fs_hz"] for r in results}):
        wall = [r["seconds"] for r in results if r["fs_hz"] == fs]
        cpu = [r["cpu_seconds"] for r in results if r["fs_hz"] == fs]
        per_rate[f"{fs:g}"] = {"pairs": len(wall), "median_s": float(np.median(wall)), "max_s": float(np.max(wall)),
                               "median_cpu_s": float(np.median(cpu)), "max_cpu_s": float(np.max(cpu))}
    twins = {}
    for r in results:
        if "twin" in r:
            twins.setdefault(r["twin"], {})[f"{r['fs_hz']:g}"] = r
    ratios = []
    for k, pair in sorted(twins.items()):
        if {"2", "100"} <= set(pair):
            ratios.append({"case": pair["2"]["key"], "seconds_2hz": pair["2"]["seconds"], "seconds_100hz": pair["100"]["seconds"],
                           "ratio_wall": pair["100"]["seconds"] / pair["2"]["seconds"],
                           "ratio_cpu": pair["100"]["cpu_seconds"] / pair["2"]["cpu_seconds"]})
    return {"per_rate_hz": per_rate, "twins_100_over_2": ratios}


def goals_met(summary):
    cats = summary["categories"]
    ok = all((cats[c]["rate"] or 0.0) >= goal for c, goal in GOALS.items())
    none = cats["none"]
    ok &= none["false_positive_pairs"] == 0 and none["false_unexplained_pairs"] == 0
    t = summary["timing"]
    ok &= all(x["ratio_wall"] <= SPEED_RATIO_GOAL for x in t["twins_100_over_2"])
    ok &= t["per_rate_hz"].get("2", {}).get("max_s", 0.0) < TWO_HZ_SECONDS_GOAL
    return bool(ok and not summary["failed_runs"])


def markdown(summary, results, seed):
    """The summary, the per-case verdicts and the confusion matrix as markdown."""
    cats = summary["categories"]
    out = [f"# diagnose on the independent generator, seed {seed}", ""]
    if not summary.get("complete", True):
        out += [f"**Interrupted run: {summary['pairs']} of {summary['planned_pairs']} planned pairs.**", ""]
    if not summary["unexplained_in_reports"]:
        out += ["The reports have no `unexplained` object yet: out-of-vocabulary cases count as not flagged.", ""]
    out += ["| category | cases | exactly right | goal |", "|---|---|---|---|"]
    for c in CATEGORIES:
        e = cats[c]
        goal = f"≥ {GOALS[c]:.0%}" if c in GOALS else "0 false positives, 0 false `unexplained`"
        extra = ""
        if c == "oov":
            extra = f" (flagged {e['flagged_unexplained']}, no vocabulary name {e['no_vocabulary_name']})"
        if c == "none":
            extra = f" (false positives {e['false_positive_pairs']}, false `unexplained` {e['false_unexplained_pairs']})"
        out.append(f"| {c} | {e['cases']} | {e['correct']} ({(e['rate'] or 0):.0%}){extra} | {goal} |")
    t = summary["timing"]
    out += ["", "| rate [Hz] | pairs | median s | max s | median CPU s |", "|---|---|---|---|---|"]
    for fs, x in t["per_rate_hz"].items():
        out.append(f"| {fs} | {x['pairs']} | {x['median_s']:.1f} | {x['max_s']:.1f} | {x['median_cpu_s']:.1f} |")
    for x in t["twins_100_over_2"]:
        out.append(f"\nSpeed twin ({x['case']}): 2 Hz {x['seconds_2hz']:.1f} s, 100 Hz {x['seconds_100hz']:.1f} s: "
                   f"ratio {x['ratio_wall']:.2f} wall, {x['ratio_cpu']:.2f} CPU (goal ≤ {SPEED_RATIO_GOAL:g}).")
    out += ["", "| # | category | effect/form | Hz | z | selected | unexplained | right |", "|---|---|---|---|---|---|---|---|"]
    for r in results:
        z = r["realised"].get("z")
        strength = f"{z:.1f}" if z is not None else (f"cross {r['realised']['cross_s']:.0f} s" if "cross_s" in r["realised"] else "")
        sel = "failed" if r["selected"] is None else (", ".join(r["selected"]) or "—")
        out.append(f"| {r['index']} | {r['category']} | {r['key']} | {r['fs_hz']:g} | {strength} | {sel} | "
                   f"{'yes' if flagged(r) else 'no'} | {'✓' if correct(r) else '✗'} |")
    columns = list(next(iter(summary["confusion"].values())))
    short = {c: c.replace("bias_instability", "bias_inst").replace("rate_random_walk", "rrw") for c in columns}
    out += ["", "Confusion (rows: truth; columns: what the report says; a case counts in every column it names):", "",
            "| true \\ reported | " + " | ".join(short[c] for c in columns) + " |", "|---" * (len(columns) + 1) + "|"]
    for key, row in summary["confusion"].items():
        out.append(f"| {key} | " + " | ".join(str(row[c]) if row[c] else "." for c in columns) + " |")
    return "\n".join(out) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=gen.TUNING_SEED)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--twins", type=int, default=1, help="cases drawn at both 2 Hz and 100 Hz (timed back to back)")
    parser.add_argument("--only", nargs="*", help="effect/form keys, categories or `twins` to run; default all")
    parser.add_argument("--resume", action="store_true", help="keep the cases already in this seed's progress file")
    parser.add_argument("--score-only", action="store_true", help="score the progress file as it stands (an interrupted run), run nothing")
    args = parser.parse_args(argv)
    plan = gen.case_plan(args.seed, speed_twins=args.twins)
    if args.only:
        plan = [c for c in plan if c["key"] in args.only or c["category"] in args.only or ("twin" in c and "twins" in args.only)]
    rank = {}
    for c in plan:  # interleave the categories, so that an interrupted run has covered each
        rank[c["index"]] = (sum(d["category"] == c["category"] and d["index"] < c["index"] for d in plan), CATEGORIES.index(c["category"]))
    singles = [[c] for c in sorted(plan, key=lambda c: rank[c["index"]]) if "twin" not in c]
    twins = {}
    for c in plan:
        if "twin" in c:
            twins.setdefault(c["twin"], []).append(c)
    tasks = list(twins.values()) + singles  # the long twins first
    suffix = "" if not args.only else "-partial"
    progress = DATA / f"seed{args.seed}{suffix}-progress.jsonl"
    progress.parent.mkdir(parents=True, exist_ok=True)
    keep = args.resume or args.score_only
    done = [json.loads(line) for line in progress.read_text().splitlines()] if keep and progress.exists() else []
    seen = {(r["index"], r["fs_hz"]) for r in done}
    tasks = [t for t in tasks if any((c["index"], c["fs_hz"]) not in seen for c in t)]
    results = [r for r in done if any(r["index"] == c["index"] and r["fs_hz"] == c["fs_hz"] for c in plan)]
    if args.score_only:
        tasks = []
    elif not args.resume:
        progress.write_text("")
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for future in as_completed([pool.submit(run_twin, t) for t in tasks]):
            for r in future.result():
                results.append(r)
                with progress.open("a") as fh:
                    fh.write(json.dumps(r, default=float) + "\n")
                print(f"{'ok  ' if correct(r) else 'MISS'} #{r['index']:3d} {r['key']:40s} {r['fs_hz']:g} Hz "
                      f"selected={r['selected']} unexplained={flagged(r)} {r['seconds']:.0f} s", flush=True)
    results.sort(key=lambda r: (r["index"], r["fs_hz"]))
    wall = time.perf_counter() - t0
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    if not commit and (ROOT / ".commit").exists():  # a `git archive` snapshot of the tree (a benchmark that other landings cannot change)
        commit = (ROOT / ".commit").read_text().strip()
    summary = score(results) | {"seed": args.seed, "workers": args.workers, "wall_s": wall, "commit": commit,
                                "planned_pairs": len(plan), "complete": len(results) == len(plan)}
    text = markdown(summary, results, args.seed)
    print(text)
    print(f"wall time {wall:.0f} s on {args.workers} workers")
    out = DATA / f"seed{args.seed}{suffix}"
    Path(f"{out}.json").write_text(json.dumps({"summary": summary, "cases": results}, indent=1, default=float) + "\n")
    Path(f"{out}.md").write_text(text)
    provenance.write("diagnose_independent", {"summary": {k: v for k, v in summary.items() if k != "commit"}}, key=f"{args.seed}{suffix}")
    return 0 if goals_met(summary) else 1


if __name__ == "__main__":
    raise SystemExit(main())
