"""The grey-box model against the autopilots' cubic on held-out runs (issue 34).

Four parts, each scored by the held-out residual drift: the standard
deviation of the 100 s means of ``rate - model`` after its mean is removed
(a turn-on offset is no temperature effect), in deg/h.

* ``sample``: ``sample_data`` (train on ``oven_train``, hold out
  ``oven_test``); the floor is the same statistic of the simulator's
  stochastic truth columns of ``oven_test`` (white + flicker + random walk,
  what no temperature model removes), rerun from ``configs/sample``.
* ``independent``: pairs of :mod:`benchmarks.independent_gen` (its own
  shapes, profiles and noise; it imports nothing of gyrocomp) for the
  thermal-lag, dT/dt, hysteresis and warm-up forms and four effect-free
  pairs per seed, on check seeds the model was never tuned on
  (:data:`CHECK_SEEDS`); the floor is the expectation of the statistic for
  the pair's white noise alone. A hysteresis pair also gets the **oracle**:
  what a compensator that knows the form exactly but not the branch the
  part powered on in leaves (the generator's ``power_on_unknown_dps``,
  beside the floor). Where the cubic leaves under 3 times the oracle, "3x
  better than the cubic" is out of reach of any feed-forward model.
* ``heating_cooling``: one gyro (lag, asymmetric dT/dt, play, warm-up;
  written here with NumPy loops) trained on a heating run and held out on a
  cooling run, and the other way round.
* ``tvac``: the LSM6DSM thermal-vacuum log (``../shared/real-data``), fitted
  on the even bursts and held out on the odd ones; the statistic is the
  standard deviation of the burst means (5 s each).

Usage: ``python benchmarks/greybox.py [--part sample|independent|strong|heating_cooling|tvac|all] [--seeds 3007 3008] [--key NAME]``
(``strong``: the independent pairs with effects of visibility 200 to 400);
writes each part under ``runs`` of ``benchmarks/results/greybox.json`` with its provenance (:mod:`provenance`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
CHECK_SEEDS = (3011, 3012)
"""Seeds of the independent generator never looked at while the grey-box model was built. 3001 and 3002 were the
first version's; their misses (relay and Preisach hysteresis, two heat paths, two-exponential warm-ups) shaped the
second, and a relay case of 3001 the width grid of the third. 3003 and 3004 checked the second version, 3005 and
3006 the third; their saturating dT/dt pairs, and a play pair of 3006 whose selection hung on the noise fit's start,
shaped the fourth. 3007 and 3008 checked the fourth; their Preisach pair led to the second play of the fifth, and a
play pair that took the second play in place of a lag to the hysteresis on the element temperature. 3009 and 3010
checked the fifth; a Preisach miss there, and the spent seeds' plays at 2-5x the oracle, led to the sixth's columns
of the play's unknown power-on state. All ten are spent: ``--seeds 3001 ... 3010 --key strong_spent`` reruns them."""
KEYS = [
    "thermal_lag/first_order", "thermal_lag/two_parallel_lags", "thermal_lag/two_lags_in_series",
    "temp_rate/linear", "temp_rate/heating_cooling_asymmetric", "temp_rate/saturating",
    "hysteresis/two_branch_relay", "hysteresis/preisach_width_spread", "hysteresis/play_operator",
    "warmup/single_exponential", "warmup/two_time_constants", "warmup/stretched_exponential",
]
STRONG_Z = (200.0, 400.0)
"""Visibility of the ``strong`` pairs: the cubic leaves 12 to 24 times the floor, as on the pairs issue 34 quotes."""
BLOCK_S = 100.0
TVAC = ROOT.parent / "shared" / "real-data" / "pan-lsm6dsm-tvac" / "pan_lsm6dsm_tvac_cold_2020-03-07.csv"


def block_std_deg_h(t, x, block_s=BLOCK_S):
    """Std of the means of `block_s` blocks of `x` (gaps: blocks never span one), mean removed [deg/h]."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    index = np.floor((t - t[0]) / block_s).astype(int)
    counts = np.bincount(index)
    sums = np.bincount(index, weights=x)
    means = sums[counts > 0] / counts[counts > 0]
    return float(np.std(means - means.mean()) * 3600.0)


def cubic_fit(T, y, T_new):
    """The autopilots' calibration: least squares cubic in the measured temperature (about 25 degC)."""
    A = lambda u: np.column_stack([np.ones_like(u), u - 25, (u - 25) ** 2, (u - 25) ** 3])  # noqa: E731
    return A(T_new) @ np.linalg.lstsq(A(T), y, rcond=None)[0]


def greybox_fit(runs, **params):
    from gyrocomp.models.greybox import GreyBoxDrift, TrainingRun

    return GreyBoxDrift(**params).fit([TrainingRun(t, T, y, segs, float(t[0]), name) for t, T, y, segs, name in runs])


def _whole(t):
    return [slice(0, len(t))]


def sample():
    """The sample pair, with the floor from the simulator's truth columns."""
    import pandas as pd

    from gyrocomp.sim.model import load_sim_config
    from gyrocomp.sim.simulate import run

    train = pd.read_parquet(ROOT / "sample_data" / "oven_train.parquet")
    test = pd.read_parquet(ROOT / "sample_data" / "oven_test.parquet")
    frame, _ = run(load_sim_config(ROOT / "configs" / "sample" / "oven_test.toml", truth_columns=True))
    assert np.array_equal(frame["rate"].to_numpy(), test["rate"].to_numpy()), "sample_data/oven_test.parquet is not configs/sample/oven_test.toml"
    stochastic = sum(frame[c].to_numpy() for c in frame.columns if c in ("truth_noise", "truth_bias_instability", "truth_rate_random_walk"))
    t, T, y = (train[c].to_numpy() for c in ("time", "temperature", "rate"))
    tt, TT, yy = (test[c].to_numpy() for c in ("time", "temperature", "rate"))
    start = time.process_time()
    model = greybox_fit([(t, T, y, _whole(t), "oven_train")])
    fit_cpu = time.process_time() - start
    floor = block_std_deg_h(tt, stochastic)
    greybox = block_std_deg_h(tt, yy - model.predict(tt, TT))
    cubic = block_std_deg_h(tt, yy - cubic_fit(T, y, TT))
    return {
        "floor_deg_h": floor, "greybox_deg_h": greybox, "cubic_deg_h": cubic,
        "greybox_over_floor": greybox / floor, "cubic_over_floor": cubic / floor,
        "spec": model.spec_, "selection": model.selection_, "not_fitted": model.not_fitted_, "fit_cpu_s": fit_cpu,
    }


def independent(seeds=CHECK_SEEDS, z=None):
    """Each effect form and four effect-free pairs per seed: greybox and cubic against the white-noise floor.

    `z` replaces the generator's visibility range ``[amplitude] z`` (8 to 40,
    the edge of detectability): there the cubic leaves about ``z / 17`` times
    the floor of 100 s means on 8 h runs, so "3x better than the cubic" can
    only be asked of stronger effects (``z`` 200 to 400: 12 to 24 times).
    """
    import independent_gen as gen

    cfg = gen.load_config()
    if z is not None:
        cfg["amplitude"]["z"] = list(z)
    rows = []
    for seed in seeds:
        for index, key in enumerate(KEYS + [gen.NONE] * 4):
            case = gen.draw_case(seed, index, key, cfg=cfg)
            runs, realised = gen.generate_pair(case, cfg, power_on_oracle=True)
            fit, hold = runs["fit"], runs["holdout"]
            n_block = int(round(BLOCK_S * case["fs_hz"]))
            floor = realised["sigma_per_sample_dps"] / np.sqrt(n_block) * 3600.0
            start = time.process_time()
            model = greybox_fit([(fit["time"], fit["temperature"], fit["rate"], _whole(fit["time"]), "fit")])
            cpu = time.process_time() - start
            greybox = block_std_deg_h(hold["time"], hold["rate"] - model.predict(hold["time"], hold["temperature"]))
            cubic = block_std_deg_h(hold["time"], hold["rate"] - cubic_fit(fit["temperature"], fit["rate"], hold["temperature"]))
            unknown = realised.get("power_on_unknown_dps")
            oracle = math.hypot(floor, block_std_deg_h(hold["time"], unknown)) if unknown is not None else floor
            rows.append({
                "seed": seed, "index": index, "key": key, "category": case["category"], "fs_hz": case["fs_hz"],
                "floor_deg_h": floor, "greybox_deg_h": greybox, "cubic_deg_h": cubic,
                "greybox_over_floor": greybox / floor, "cubic_over_greybox": cubic / greybox,
                "oracle_over_floor": oracle / floor, "cubic_over_oracle": cubic / oracle,
                "terms": [s["term"] for s in model.selection_], "not_fitted": [r["term"] for r in model.not_fitted_], "fit_cpu_s": cpu,
            })
            print(f"{seed} {key:40s} floor {floor:7.2f}  greybox {greybox:8.2f}  cubic {cubic:8.2f}  {rows[-1]['terms']}", flush=True)
    effects = [r for r in rows if r["category"] != "none"]
    free = [r for r in rows if r["category"] == "none"]
    return {
        "seeds": list(seeds),
        "z": cfg["amplitude"]["z"],
        "rows": rows,
        "effects_median_greybox_over_floor": float(np.median([r["greybox_over_floor"] for r in effects])),
        "effects_min_cubic_over_greybox": float(min(r["cubic_over_greybox"] for r in effects)),
        "effects_at_least_3x_better": sum(r["cubic_over_greybox"] >= 3 for r in effects),
        "n_effects": len(effects),
        "effects_3x_attainable": int(sum(r["cubic_over_oracle"] >= 3 for r in effects)),
        "effects_3x_better_where_attainable": int(sum(r["cubic_over_greybox"] >= 3 for r in effects if r["cubic_over_oracle"] >= 3)),
        "effect_free_max_greybox_over_cubic": float(max(1 / r["cubic_over_greybox"] for r in free)),
    }


def _chamber(t, knots_t, knots_c, tau_s=300.0):
    T = np.interp(t, knots_t, knots_c)
    out = np.empty_like(T)
    out[0] = T[0]
    a = np.exp(-(t[1] - t[0]) / tau_s)
    for i in range(1, T.size):
        out[i] = a * out[i - 1] + (1 - a) * T[i]
    return out


def _gyro(t, T, seed):
    """Lag 400 s, dT/dt 1.5 (+0.5 heating, -0.5 cooling) deg/s per degC/s, a 4 degC play of 0.01 deg/s, warm-up 0.03 deg/s / 900 s."""
    rng = np.random.default_rng(seed)
    Te = np.empty_like(T)
    Te[0] = T[0]
    for i in range(1, T.size):
        Te[i] = Te[i - 1] + (T[i] - Te[i - 1]) * (1 - np.exp(-(t[i] - t[i - 1]) / 400.0))
    d = Te - 25.0
    r = np.gradient(T, t)
    p, play = T[0], np.empty_like(T)
    for i in range(T.size):
        p = min(max(p, T[i] - 2.0), T[i] + 2.0)
        play[i] = (T[i] - p) / 2.0
    bias = 0.05 + 2e-3 * d - 3e-5 * d**2 + 4e-7 * d**3 + 1.5 * r + 0.5 * np.abs(r) + 0.01 * play + 0.03 * np.exp(-(t - t[0]) / 900.0)
    noise = 0.003 * rng.normal(size=t.size) + np.cumsum(2e-6 * rng.normal(size=t.size))
    return bias + noise, noise


def heating_cooling():
    """Train on heating, hold out cooling, and the other way round (cubic and greybox)."""
    t = np.arange(0.0, 6 * 3600.0)
    profiles = {
        "heating": ([0, 1800, 5400, 7200, 10800, 12600, 16200, 21600], [-10, -10, 15, 15, 40, 40, 60, 60]),
        "cooling": ([0, 1800, 5400, 7200, 10800, 12600, 16200, 21600], [60, 60, 35, 35, 10, 10, -10, -10]),
    }
    runs = {name: (_chamber(t, *knots),) for name, knots in profiles.items()}
    runs = {name: (T, *_gyro(t, T, seed)) for (name, (T,)), seed in zip(runs.items(), (11, 12))}
    rows = []
    for train, test in (("heating", "cooling"), ("cooling", "heating")):
        T, y, _ = runs[train]
        TT, yy, noise = runs[test]
        model = greybox_fit([(t, T, y, _whole(t), train)])
        rows.append({
            "train": train, "test": test, "floor_deg_h": block_std_deg_h(t, noise),
            "cubic_deg_h": block_std_deg_h(t, yy - cubic_fit(T, y, TT)),
            "greybox_deg_h": block_std_deg_h(t, yy - model.predict(t, TT)),
            "terms": [s["term"] for s in model.selection_], "not_fitted": [r["term"] for r in model.not_fitted_],
        })
    return rows


def tvac():
    """The LSM6DSM thermal-vacuum log: even bursts train, odd bursts hold out (each axis)."""
    import pandas as pd

    if not TVAC.is_file():
        return {"skipped": f"{TVAC} absent"}
    frame = pd.read_csv(TVAC).drop_duplicates("time", keep="first")
    t, T = frame["time"].to_numpy(), frame["temperature"].to_numpy()
    burst = np.concatenate([[0], np.cumsum(np.diff(t) > 10.0)])
    out = {}
    for axis in ("rate_x", "rate_y", "rate_z"):
        y = frame[axis].to_numpy()
        parts = {}
        for role, parity in (("fit", 0), ("holdout", 1)):
            keep = burst % 2 == parity
            tk, Tk, yk, bk = t[keep], T[keep], y[keep], burst[keep]
            edges = np.flatnonzero(np.diff(bk)) + 1
            segs = [slice(a, b) for a, b in zip(np.r_[0, edges], np.r_[edges, tk.size])]
            parts[role] = (tk, Tk, yk, segs, bk)
        tf, Tf, yf, sf, _ = parts["fit"]
        th, Th, yh, sh, bh = parts["holdout"]
        model = greybox_fit([(tf, Tf, yf, sf, "even bursts")], block_s=1.0, max_blocks=200)
        means = lambda x: np.array([x[bh == b].mean() for b in np.unique(bh)]) * 3600.0  # noqa: E731
        raw = means(yh)
        cubic = means(yh - cubic_fit(Tf, yf, Th))
        greybox = means(yh - model.predict(th, Th, segments=sh))
        out[axis] = {
            "raw_deg_h": float(np.std(raw - raw.mean())), "cubic_deg_h": float(np.std(cubic - cubic.mean())),
            "greybox_deg_h": float(np.std(greybox - greybox.mean())), "terms": [s["term"] for s in model.selection_],
            "not_fitted": model.not_fitted_,
        }
    return out


def speed(workdir=None):
    """Whole-process causal compensation of 2 h at 1 kHz, greybox against the cubic (same run), and training on 14 h at 1 Hz.

    Each command is timed three times after one warm-up and the median of
    wall and CPU time kept; memory is the peak resident set of the process
    (``ru_maxrss`` of the child), so a ratio of 1 means the state costs
    nothing beyond what the cubic's pipeline holds.
    """
    import resource
    import tempfile

    import pandas as pd

    work = Path(workdir or tempfile.mkdtemp(prefix="greybox-speed-"))
    exe = str(Path(sys.executable).with_name("gyrocomp"))
    t = np.arange(0, 2 * 3600.0, 1e-3)
    T = _chamber(t[::1000], [0, 1200, 3600, 4800, 7200], [20, 20, 45, 45, 30])
    T = np.interp(t, t[::1000], T)
    rng = np.random.default_rng(0)
    y = 0.05 + 2e-3 * (T - 25) + 0.01 * rng.normal(size=t.size)
    pd.DataFrame({"time": t, "rate": y, "temperature": T}).to_parquet(work / "long.parquet")
    t14 = np.arange(0, 14 * 3600.0)
    T14 = _chamber(t14, [0, 3600, 18000, 25200, 43200, 50400], [20, 20, 60, 60, -10, -10])
    y14, _ = _gyro(t14, T14, 3)
    pd.DataFrame({"time": t14, "rate": y14, "temperature": T14}).to_parquet(work / "day.parquet")

    def timed(args):
        runs = []
        for _ in range(4):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run([exe, "-q", *args], check=True, capture_output=True)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            runs.append((time.perf_counter() - start, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime))
        runs = runs[1:]
        return {"wall_s": float(np.median([r[0] for r in runs])), "cpu_s": float(np.median([r[1] for r in runs]))}

    out = {"load_1min_before": os.getloadavg()[0]}
    for config in ("firmware", "greybox"):
        subprocess.run([exe, "-q", "train", str(work / "long.parquet"), "--config", config, "--out", str(work / f"{config}.json")], check=True)
        out[f"compensate_{config}"] = timed(["compensate", str(work / "long.parquet"), str(work / f"{config}.json"), "--out", str(work / "c.parquet")])
    out["compensate_greybox_over_cubic_wall"] = out["compensate_greybox"]["wall_s"] / out["compensate_firmware"]["wall_s"]
    out["compensate_greybox_over_cubic_cpu"] = out["compensate_greybox"]["cpu_s"] / out["compensate_firmware"]["cpu_s"]
    out["train_greybox_14h_1hz"] = timed(["train", str(work / "day.parquet"), "--config", "greybox", "--out", str(work / "day.json")])
    out["peak_rss_mb_children"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    out["load_1min_after"] = os.getloadavg()[0]
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", default="all", choices=["sample", "independent", "strong", "heating_cooling", "tvac", "speed", "all"])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(CHECK_SEEDS))
    parser.add_argument("--key", help="results key of a single part (default: the part's name)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from provenance import write

    parts = ["sample", "independent", "strong", "heating_cooling", "tvac", "speed"] if args.part == "all" else [args.part]
    for part in parts:
        if part in ("independent", "strong"):
            figures = independent(args.seeds, None if part == "independent" else STRONG_Z)
        else:
            figures = globals()[part]()
        figures = figures if isinstance(figures, dict) else {"rows": figures}
        write("greybox", figures, key=args.key if args.key and len(parts) == 1 else part)
        print(part, json.dumps({k: v for k, v in figures.items() if k != "rows"}, indent=1, default=float))


if __name__ == "__main__":
    main()
