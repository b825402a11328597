"""Can the data tell an out-of-vocabulary event from a noise term? Separability of the independent generator's hard kinds.

On the independent benchmark (``diagnose_independent.py``) three kinds outside
the vocabulary are mostly taken by a noise term: a **mode hop** (one bias
step per run, at a different time in each), a **transient** (one bump per
run, likewise) and **popcorn** (random telegraph noise). This script asks,
for each such case of the given seeds, whether the pair of runs holds the
evidence that would refuse the noise term, by the test made for that purpose,
independently of what the diagnosis selected:

* **one event per run** (mode hop: a step at every block; transient: a
  raised-cosine bump at every centre and width; the columns of
  :mod:`gyrocomp.diagnose.competing`, which the report's competing
  explanations use): the noise term (random walk
  or flicker, fitted on the fit run by :func:`gyrocomp.diagnose.select.extend`
  and refitted on each run) is refused as a stand-in when, beside the most
  likely single event of the run, it gains less in ``-2 log L`` than it
  does in draws of the fitted model itself. ``p`` is the share of
  ``--draws`` Gaussian draws with the run's fitted covariance whose gain
  beside their own best event is at most the run's (``(1 + k) / (1 +
  draws)``). A walk at the level fitted to one event per run makes one such
  excursion in 8 h with that probability: a large ``p`` says the data cannot
  tell the event from the walk.
* **two levels** (popcorn): the signature's own two-level statistic
  (:func:`gyrocomp.diagnose.signature.check` of a ``bias_instability``
  fitted on the fit run, its Markov form where that fits better), per run
  and pooled over the runs, against the z the signature's share of its
  family asks (about 3.5).

The likelihood is that of the diagnosis (:mod:`gyrocomp.effects.likelihood`)
on at most 240 merged blocks per run (the signature's ``max_blocks``).

Writes ``benchmarks/results/oov_separability.json`` (with the commit, machine and
load) and the table as ``benchmarks/_data/oov_separability.md``.

Usage: ``python benchmarks/oov_separability.py --seeds 1010 1011 ... [--draws 60] [--workers 2]``
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from scipy import linalg  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import independent_gen as gen  # noqa: E402
import provenance  # noqa: E402
from gyrocomp.diagnose import problems  # noqa: E402
from gyrocomp.diagnose.competing import bump_columns, step_columns  # noqa: E402
from gyrocomp.effects.likelihood import fit_noise, merge_blocks  # noqa: E402
from gyrocomp.diagnose.select import extend, fit_baseline  # noqa: E402
from gyrocomp.diagnose.settings import ChecksSettings, CompetingSettings  # noqa: E402
from gyrocomp.diagnose.signature import TERMS, check, column_scores, innovations  # noqa: E402
from gyrocomp.recordings import Recording  # noqa: E402

KINDS = {"bias_step/mode_hop": "step", "transient/gaussian_bump": "bump", "telegraph_noise/popcorn": "levels"}
"""The generator's kinds measured here, and the event each is tested as."""
MIN_BLOCKS = ChecksSettings().min_step_blocks
"""An event spans at least this many merged blocks (the signature's, as its step scan)."""
BUMP_WIDTHS = CompetingSettings().bump_widths
"""The bump's widths, log-spaced from `MIN_BLOCKS` to half the run, as the report's (:func:`gyrocomp.diagnose.competing.bump_columns`)."""


def gain_beside_event(y, X, basis, noise, term, G):
    """``-2 log L`` gained by `term` beside the most likely column of `G` (found under the model without `term`).

    :func:`gyrocomp.diagnose.confirm.gain_beside` without its parameter
    charge, on block means `y` given here (the run's, or a draw's).
    """
    free = ("arw",) + tuple(t for t in TERMS if getattr(noise, t) > 0.0)
    less = tuple(f for f in free if f != term)
    without = dataclasses.replace(noise, **{term: 0.0})
    bare = fit_noise(y, X, basis, without, less)[0]
    e, Xw, lower = innovations(y, X, basis.covariance(bare))
    z, _, _ = column_scores(e, Xw, lower, G)
    Xg = np.column_stack([X, G[:, int(np.argmax(np.abs(z)))]])
    return float(fit_noise(y, Xg, basis, without, less)[1] - fit_noise(y, Xg, basis, noise, free)[1])


def event_test(problem, model, term, event, draws, seed):
    """The run's gain of `term` beside its best single event, and the share of draws of the fitted model at or below it."""
    X = problem.design_blocks(model.spec)[0]
    y, Xm, basis = merge_blocks(problem.y, X, problem.basis, ChecksSettings().agreement_max_blocks)
    free = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    noise = fit_noise(y, Xm, basis, model.noise, free)[0]
    G = (step_columns(y.size, MIN_BLOCKS) if event == "step" else bump_columns(y.size, MIN_BLOCKS, BUMP_WIDTHS))[0]
    gain = gain_beside_event(y, Xm, basis, noise, term, G)
    lower = linalg.cholesky(basis.covariance(noise), lower=True)
    rng = np.random.default_rng(seed)
    null = np.array([gain_beside_event(lower @ rng.standard_normal(y.size), Xm, basis, noise, term, G) for _ in range(draws)])
    return {"gain": gain, "p": float((1 + np.sum(null <= gain + 1e-9)) / (1 + draws)),
            "null_median": float(np.median(null)), "level": float(getattr(noise, term))}


def _recording(cols, name):
    t = cols["time"]
    return Recording({"time": t, "rate": cols["rate"], "temperature": cols["temperature"]}, name, "", float(1.0 / np.median(np.diff(t))))


def measure(case, draws, event=None):
    """Every measurement of one case (a dict for the JSON); `event` ("step", "bump", "levels") defaults to its kind's."""
    runs, realised = gen.generate_pair(case)
    fit_p, (hold_p,), _ = problems(_recording(runs["fit"], "fit"), [_recording(runs["holdout"], "holdout")])
    base = fit_baseline(fit_p)
    event = event or KINDS[case["key"]]
    out = {"seed": case["seed"], "index": case["index"], "key": case["key"], "fs_hz": case["fs_hz"],
           "z": realised.get("z"), "params": case["params"]}
    if event == "levels":
        model = extend(fit_p, base, "bias_instability")
        levels = check("bias_instability", [fit_p, hold_p], model).stats["levels"]
        two = levels["two_levels"] if levels is not None else {"z": None, "runs": []}
        return out | {"runs": [{"z": t["z"]} for t in two["runs"]], "pooled_z": two["z"],
                      "correlation_s": model.noise.bias_correlation_s}
    for term in TERMS:
        model = extend(fit_p, base, term)
        out[term] = [event_test(p, model, term, event, draws, [case["seed"], case["index"], k])
                     for k, p in enumerate((fit_p, hold_p))]
    return out


def table(results):
    """The results as Markdown."""
    lines = ["| seed | # | kind | Hz | z | random walk beside one event: gain (p) fit, holdout | flicker beside one event: gain (p) | two levels: z per run, pooled |",
             "|---|---|---|---|---|---|---|---|"]
    for r in results:
        def cell(term):
            return ", ".join(f"{t['gain']:.1f} ({t['p']:.2f})" for t in r[term]) if term in r else ""
        levels = ", ".join(f"{t['z']:.1f}" for t in r["runs"]) + f"; {r['pooled_z']:.1f}" if r.get("pooled_z") is not None else ""
        lines.append(f"| {r['seed']} | {r['index']} | {r['key']} | {r['fs_hz']:g} | {r['z']:.1f} | {cell('rate_random_walk')} | "
                     f"{cell('bias_instability')} | {levels} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", required=True)
    ap.add_argument("--draws", type=int, default=60)
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    cases = [c for s in args.seeds for c in gen.case_plan(s) if c["key"] in KINDS]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(measure, cases, [args.draws] * len(cases)))
    provenance.write("oov_separability", {"seeds": args.seeds, "draws": args.draws, "cases": results})
    provenance.detail_path("oov_separability.md").write_text(
        f"# Separability of the hard out-of-vocabulary kinds (seeds {', '.join(map(str, args.seeds))}; {args.draws} draws)\n\n"
        + table(results))
    print(table(results))


if __name__ == "__main__":
    main()
