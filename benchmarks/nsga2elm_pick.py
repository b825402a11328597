"""NSGA-II-ELM's pick against a plain ELM: held-out RMSE ratios over 50 seeds on three problems.

Each seed fits ``NSGA2ELM`` with the settings of ``configs/models.toml``
``[nsga2elm]`` (pop 40, 15 generations, crossover 0.8, mutation 0.15, the
pick and its ``rmse_tolerance``) and, on the same training data, ten plain
``ELM()`` (configured defaults, seeds 0-9). The figure per seed is

    ratio = RMSE(pick, held out) / mean_k RMSE(ELM(seed=k), held out)

and, beside it, ``ratio_same_weights``: the ratio to the one plain ELM
that shares the pick's random hidden weights (``ELM(seed=elm_seed_)``,
what the same fit gives without the search; 1 exactly when the pick
keeps it). The goal (issue #20): at most 1.1 on all 150 seeds. The
default ELMs' own spread (``plain_max_over_mean``: the worst of the ten
over their mean) is recorded beside it: where it exceeds 1.1, a pick
that is a default ELM can miss the first ratio by that much.

Problems (inputs normalised to about [-1, 1]; held-out inputs held inside
the training range as the pipeline's ``clip_inputs`` does; errors in
units of the training target's std):

``sample``
    The sample data's drift problem: the rate of
    ``sample_data/oven_train.parquet`` against (T, dT/dt) in means of
    2000 blocks (``[model] max_samples``), held out on
    ``oven_test.parquet`` (cools first, then heats). Fixed data; the seed
    varies the search and the split.
``smooth``
    An independent smooth function of (T, dT/dt),
    ``sin(2.5 T') + 0.5 exp(-(T' - 0.3)^2 / 0.1) + 0.6 tanh(2 R')``, on the
    synthetic oven run of tests/models/test_nsga2elm.py (60 -> -40 degC,
    10 degC steps through a first-order chamber, 600 samples of 10 s,
    noise std 0.02); held out on a run with a faster chamber (100 s against
    150 s). Data drawn from the seed.
``noisy``
    The test's own problem: its cubic-plus-dT/dt drift with white noise of
    std 0.1 (validation RMSE is then mostly noise), held out against the
    clean drift of the faster-chamber run.

Writes ``benchmarks/results/nsga2elm_pick.json`` (every ratio and their
quantiles per problem). ``--seeds N`` and ``--workers W`` change the
defaults (50, 2); one BLAS thread per worker.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PROBLEMS = ("sample", "smooth", "noisy")
GOAL = 1.1
NOISY_STD = 0.1  # the default of oven_run in tests/models/test_nsga2elm.py


def _test_module():
    """tests/models/test_nsga2elm.py: its oven run and smooth drift (one generator for both)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_oven", ROOT / "tests" / "models" / "test_nsga2elm.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def synthetic(problem: str, seed: int):
    """(X, y, X_test, target_test) of the `smooth` or `noisy` problem for `seed`."""
    test = _test_module()
    oven_run, smooth_function = test.oven_run, test.smooth_function
    X, y, _ = oven_run(10_000 + seed, noise=NOISY_STD)
    X_test, _, target = oven_run(20_000 + seed, tau_s=100.0)
    if problem == "smooth":
        rng = np.random.default_rng(30_000 + seed)
        y = smooth_function(X) + rng.normal(0, 0.02, len(X))
        target = smooth_function(X_test)
    return X, y, X_test, target


def _normalise(X: np.ndarray, train: np.ndarray) -> np.ndarray:
    """Each column mapped so that its range over `train` becomes [-1, 1] (as the pipeline's train)."""
    lo, hi = train.min(axis=0), train.max(axis=0)
    return (X - (hi + lo) / 2) / np.where(hi > lo, (hi - lo) / 2, 1.0)


@functools.lru_cache(maxsize=1)
def sample_problem():
    """(X, y, X_test, target_test) from sample_data/: rate against (T, dT/dt), 2000 block means."""
    from gyrocomp import recordings
    from gyrocomp.pipeline.rate import model_inputs
    from gyrocomp.pipeline.train import _block_means

    out = []
    for name in ("oven_train", "oven_test"):
        rec = recordings.read_recording(ROOT / "sample_data" / f"{name}.parquet")
        out.append((model_inputs(rec.column("temperature"), rec.fs_hz), rec.column("rate")))
    (X, y), (X_test, y_test) = out
    X, X_test = _normalise(X, X), _normalise(X_test, X)
    Xb, yb = _block_means(X, y, 2000)
    Xtb, ytb = _block_means(X_test, y_test, 2000)
    return Xb, yb, Xtb, ytb


def one(problem: str, seed: int, overrides: tuple = ()) -> dict:
    from threadpoolctl import threadpool_limits

    from gyrocomp.config import load_config
    from gyrocomp.models import ELM, make_model

    data = sample_problem() if problem == "sample" else synthetic(problem, seed)
    X, y, X_test, target = data
    X_test = np.clip(X_test, X.min(axis=0), X.max(axis=0))  # the pipeline's clip_inputs: no extrapolation
    scale = float(np.std(y))  # errors in units of the training target's std
    table = load_config(ROOT / "configs" / "models.toml")["nsga2elm"]

    def error(model):
        return float(np.sqrt(np.mean((model.predict(X_test) - target) ** 2))) / scale

    with threadpool_limits(limits=1, user_api="blas"):
        start = time.perf_counter()
        model = make_model("nsga2elm", {**table, **dict(overrides), "seed": seed}).fit(X, y)
        fit_s = time.perf_counter() - start
        plain = [error(ELM(seed=k).fit(X, y)) for k in range(10)]
        same = error(ELM(seed=model.elm_seed_).fit(X, y))
        pick = error(model)
    kept = model.best_index_ is None
    chosen = model.estimator_.get_params()
    return {
        "problem": problem, "seed": seed, "pick_rmse": pick, "plain_elm_rmse_mean": float(np.mean(plain)),
        "plain_max_over_mean": float(np.max(plain) / np.mean(plain)),
        "ratio": pick / float(np.mean(plain)), "ratio_same_weights": pick / same,
        "picked": {k: chosen[k] for k in ("n_hidden", "activation", "weight_scale")}, "kept_plain_elm": kept,
        "front_size": len(model.front_), "fit_s": fit_s,
    }


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=HERE / "results" / "nsga2elm_pick.json")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a [nsga2elm] setting, e.g. rmse_tolerance=1e9 min_gain=0 (the whole-front knee)")
    args = parser.parse_args(argv)
    overrides = tuple((k, float(v)) for k, v in (item.split("=", 1) for item in args.set))
    jobs = [(p, s, overrides) for p in PROBLEMS for s in range(args.seeds)]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(one, *zip(*jobs)))
    summary = {}
    for p in PROBLEMS:
        mine = [row for row in rows if row["problem"] == p]
        entry = {"n": len(mine), "kept_plain_elm": int(sum(row["kept_plain_elm"] for row in mine))}
        for key in ("ratio", "ratio_same_weights", "plain_max_over_mean"):
            r = np.array([row[key] for row in mine])
            entry[key] = {
                "quantiles_0_5_25_50_75_95_100": np.quantile(r, [0, 0.05, 0.25, 0.5, 0.75, 0.95, 1]).round(4).tolist(),
                "mean": round(float(r.mean()), 4),
                "above_goal": int((r > GOAL).sum()),
            }
        summary[p] = entry
        print(f"{p:7s} kept the plain ELM on {entry['kept_plain_elm']}/{entry['n']}")
        for key in ("ratio", "ratio_same_weights", "plain_max_over_mean"):
            print(f"  {key:20s} quantiles 0/5/25/50/75/95/100 %: {entry[key]['quantiles_0_5_25_50_75_95_100']}; "
                  f"> {GOAL}: {entry[key]['above_goal']}")
    worst = {key: round(max(row[key] for row in rows), 4) for key in ("ratio", "ratio_same_weights")}
    result = {
        "goal": f"pick / plain ELM held-out RMSE <= {GOAL} on every seed",
        "settings": "configs/models.toml [nsga2elm]" + (f" with {dict(overrides)}" if overrides else ""),
        "worst": worst,
        "met": {key: bool(value <= GOAL) for key, value in worst.items()},
        "wall_s": round(time.perf_counter() - start, 1),
        "summary": summary,
        "runs": rows,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=1) + "\n")
    tmp.replace(args.out)
    print(f"worst {worst} (goal <= {GOAL}); {result['wall_s']} s")
    return 0 if all(result["met"].values()) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
