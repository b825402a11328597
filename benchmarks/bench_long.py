"""Long, fast logs (issue 19): causal compensation against `allan`, memory at 1x and 10x, streaming, Allan past memory.

Every figure is a ratio of two measurements taken in the same run, each the
whole process (``python -m gyrocomp ...``), peak resident memory from
``/usr/bin/time -v``. Parts, run one at a time (``python benchmarks/bench_long.py PART``):

``compensate``
    2 h at 1 kHz (7.2e6 samples, Parquet): ``compensate --mode causal`` with
    the polynomial model and with PE-LCD-ANFIS (both trained on
    ``sample_data``) over ``allan`` on the same file; one uncounted warm-up
    run of each, then the median of `REPEATS` rounds of the three in turn.
``memory``
    Peak memory of causal compensation on 12 min and on 2 h at 1 kHz (1x and
    10x), and the size of the extra input columns.
``stream``
    ``compensate -`` reading CSV from standard input: peak memory on the 1x
    and the 10x stream, and the wall time against the one-shot file.
``allantools``
    ``allan`` on 10^8 samples (Parquet) against ``allantools.oadev`` on the
    same samples in memory.
``big``
    ``allan`` on 3e8 samples (1 kHz, 83 h, Parquet) under 1 GB, against
    :func:`gyrocomp.allan.analyse` of the whole array in memory (relative
    difference of every deviation). The file is deleted afterwards.
``train``
    Peak memory of ``train`` (polynomial, ELM, and PE-LCD-ANFIS, which
    decomposes the recording) on the 1x and the 10x recording, and the size
    of the extra input columns.
``train_anfis``
    Peak memory of ``train --config pe-lcd-anfis`` on 12 min and 2 h at
    1 kHz (issue 38: under 1.2 GB on 2 h, and the 10x longer log at most
    1.3x the shorter one's peak plus its extra input columns), with the load.
``train_anfis_20h``
    The same on 2 h and 20 h (7.2e7 samples); the 20 h log (1.5 GB of
    Parquet, about 10 GB of components on disk while training) is deleted
    afterwards.
``plot``
    Peak memory of ``compensate --mode causal`` (polynomial and
    PE-LCD-ANFIS models) and of ``train --config polynomial`` and
    ``train --config pe-lcd-anfis`` on 2 h at 1 kHz, without and with
    ``--plot`` (issue 35 item 9, issue 38: ``--plot`` adds at most 100 MB).
``rate``
    The O(1) dT/dt against the direct FIR (``np.convolve``) on 10 min at
    1 kHz, and its rounding after 10^8 samples of a stream against the exact
    window slope there.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import provenance

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = HERE / "_data"
FS_HZ = 1000.0
REPEATS = 3
SEED = 19


def gyrocomp(*args) -> list[str]:
    """This checkout's gyrocomp, whatever is installed."""
    return [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT)!r}); from gyrocomp.cli import main; main()", "--quiet", *map(str, args)]


def oven(path: Path, seconds: float, *, seed: int = SEED, rows: int = 1 << 20) -> Path:
    """A 1 kHz oven log, written row group by row group: a 1 degC/min ramp and soaks, white rate noise."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if path.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    n = int(seconds * FS_HZ)
    with pq.ParquetWriter(path, pa.schema([("time", pa.float64()), ("rate", pa.float64()), ("temperature", pa.float64())])) as writer:
        for start in range(0, n, rows):
            i = np.arange(start, min(start + rows, n))
            t = i / FS_HZ
            temperature = 25.0 + 20.0 * np.sin(2 * np.pi * t / 7200.0) + rng.normal(0, 0.02, len(i))
            rate = 0.1 + 0.002 * (temperature - 25.0) + rng.normal(0, 0.05, len(i))
            writer.write_table(pa.table({"time": t, "rate": rate, "temperature": temperature}))
    return path


def timed(cmd: list[str], stdin: Path | None = None) -> tuple[float, float, float]:
    """Wall [s], CPU (user + system) [s] and peak RSS [MB] of one child process."""
    start = time.perf_counter()
    with open(stdin, "rb") if stdin else open("/dev/null", "rb") as source:
        proc = subprocess.run(["/usr/bin/time", "-v", *cmd], stdin=source, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if proc.returncode:
        raise RuntimeError(proc.stderr[-2000:])
    fields = dict(line.strip().split(": ", 1) for line in proc.stderr.splitlines() if ": " in line)
    cpu = float(fields["User time (seconds)"]) + float(fields["System time (seconds)"])
    return wall, cpu, int(fields["Maximum resident set size (kbytes)"]) / 1024.0


def models() -> dict:
    """The polynomial and PE-LCD-ANFIS models, trained on sample_data (1 Hz; the rate window is 60 s at any rate)."""
    train = ROOT / "sample_data" / "oven_train.parquet"
    polynomial, anfis = DATA / "model_polynomial.json", DATA / "model_pe-lcd-anfis.json"
    if not polynomial.exists():
        subprocess.run(gyrocomp("train", train, "-c", "polynomial", "--out", polynomial), check=True)
    if not anfis.exists():
        components, classes = DATA / "components.parquet", DATA / "classes.json"
        subprocess.run(gyrocomp("decompose", train, "--config", "pe-lcd-anfis", "--out", components), check=True)
        subprocess.run(gyrocomp("classify", components, "--config", "pe-lcd-anfis", "--out", classes), check=True)
        subprocess.run(gyrocomp("train", components, classes, "--config", "pe-lcd-anfis", "--out", anfis), check=True)
    return {"polynomial": polynomial, "pe-lcd-anfis": anfis}


def part_compensate() -> dict:
    source = oven(DATA / "oven_2h_1khz.parquet", 7200.0)
    runs = {"allan": [], "polynomial": [], "pe-lcd-anfis": []}
    cmds = {"allan": gyrocomp("allan", source, "--out", DATA / "a.json")}
    for name, model in models().items():
        cmds[name] = gyrocomp("compensate", source, model, "--mode", "causal", "--out", DATA / f"c_{name}.parquet")
    for cmd in cmds.values():  # warm-up, not counted: numba's cache of the ANFIS kernel, the page cache
        timed(cmd)
    for _ in range(REPEATS):
        for name, cmd in cmds.items():
            runs[name].append(timed(cmd))
    med = {name: (statistics.median(r[0] for r in rs), statistics.median(r[1] for r in rs)) for name, rs in runs.items()}
    return {
        "n_samples": 7_200_000,
        "repeats": REPEATS,
        "load_average_1min_at_end": os.getloadavg()[0],
        "threads": {k: os.environ.get(k) for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")},
        "anfis_kernel_threads": 1,  # the NumPy forward pass (issue 38; a numba njit kernel before): one thread
        "wall_s": {k: v[0] for k, v in med.items()},
        "cpu_s": {k: v[1] for k, v in med.items()},
        "polynomial_over_allan_wall": med["polynomial"][0] / med["allan"][0],
        "anfis_over_allan_wall": med["pe-lcd-anfis"][0] / med["allan"][0],
        "polynomial_over_allan_cpu": med["polynomial"][1] / med["allan"][1],
        "anfis_over_allan_cpu": med["pe-lcd-anfis"][1] / med["allan"][1],
    }


def part_memory() -> dict:
    short, long = oven(DATA / "oven_12min_1khz.parquet", 720.0), oven(DATA / "oven_2h_1khz.parquet", 7200.0)
    model = models()["pe-lcd-anfis"]
    peaks = [timed(gyrocomp("compensate", f, model, "--mode", "causal", "--out", DATA / "m.parquet"))[2] for f in (short, long)]
    extra_mb = 3 * 8 * (7_200_000 - 720_000) / 2**20  # time, rate, temperature
    return {
        "peak_1x_mb": peaks[0],
        "peak_10x_mb": peaks[1],
        "ratio_10x_1x": peaks[1] / peaks[0],
        "extra_input_columns_mb": extra_mb,
        "bound_mb": 1.3 * peaks[0] + extra_mb,
    }


def part_plot() -> dict:
    source = oven(DATA / "oven_2h_1khz.parquet", 7200.0)
    model = models()
    runs = {
        "compensate": gyrocomp("compensate", source, model["polynomial"], "--mode", "causal", "--out", DATA / "p.parquet"),
        "train": gyrocomp("train", source, "--config", "polynomial", "--out", DATA / "p.json"),
        "compensate_anfis": gyrocomp("compensate", source, model["pe-lcd-anfis"], "--mode", "causal", "--out", DATA / "p.parquet"),
        "train_anfis": gyrocomp("train", source, "--config", "pe-lcd-anfis", "--out", DATA / "p.json"),
    }
    found = {}
    for name, cmd in runs.items():
        without = timed(cmd)
        with_plot = timed([*cmd, "--plot", DATA / f"{name}.png"])
        found |= {
            f"{name}_peak_mb": without[2],
            f"{name}_plot_peak_mb": with_plot[2],
            f"{name}_plot_adds_mb": with_plot[2] - without[2],
            f"{name}_plot_wall_ratio": with_plot[0] / without[0],
        }
    found["plot_adds_at_most_100_mb"] = all(found[f"{name}_plot_adds_mb"] <= 100.0 for name in runs)
    return found


def part_stream() -> dict:
    import pyarrow.parquet as pq

    model = models()["pe-lcd-anfis"]
    csvs = []
    for seconds, label in ((720.0, "12min"), (7200.0, "2h")):
        csv = DATA / f"oven_{label}_1khz.csv"
        if not csv.exists():
            pq.read_table(oven(DATA / f"oven_{label}_1khz.parquet", seconds)).to_pandas().to_csv(csv, index=False)
        csvs.append(csv)
    stream = [timed(gyrocomp("compensate", "-", model, "--mode", "causal", "--out", "-"), stdin=csv) for csv in csvs]
    one_shot = timed(gyrocomp("compensate", csvs[1], model, "--mode", "causal", "--resample", "--out", DATA / "oneshot.csv"))
    return {
        "stream_peak_1x_mb": stream[0][2],
        "stream_peak_10x_mb": stream[1][2],
        "stream_ratio_10x_1x": stream[1][2] / stream[0][2],
        "stream_10x_wall_s": stream[1][0],
        "one_shot_10x_wall_s": one_shot[0],
        "one_shot_10x_peak_mb": one_shot[2],
        "stream_over_one_shot_wall": stream[1][0] / one_shot[0],
    }


ALLANTOOLS = """
import sys, allantools, pyarrow.parquet as pq
rate = pq.read_table(sys.argv[1], columns=["rate"]).column("rate").to_numpy()
tau, adev, err, n = allantools.oadev(rate, rate=1000.0, data_type="freq", taus="octave")
"""


def part_allantools() -> dict:
    source = allan_log(DATA / "allan_1e8.parquet", 10**8)
    ours = timed(gyrocomp("allan", source, "--out", DATA / "a8.json"))
    theirs = timed([sys.executable, "-c", ALLANTOOLS, str(source)])
    return {
        "n_samples": 10**8,
        "gyrocomp_wall_s": ours[0], "allantools_wall_s": theirs[0], "wall_ratio": ours[0] / theirs[0],
        "gyrocomp_cpu_s": ours[1], "allantools_cpu_s": theirs[1], "cpu_ratio": ours[1] / theirs[1],
        "gyrocomp_peak_mb": ours[2], "allantools_peak_mb": theirs[2], "memory_ratio": ours[2] / theirs[2],
    }


def allan_log(path: Path, n: int, rows: int = 1 << 20) -> Path:
    """Time and rate at 1 kHz: white noise, a random walk and a slow drift, row group by row group."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if path.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    walk = 0.0
    with pq.ParquetWriter(path, pa.schema([("time", pa.float64()), ("rate", pa.float64())])) as writer:
        for start in range(0, n, rows):
            i = np.arange(start, min(start + rows, n))
            steps = np.cumsum(rng.normal(0, 1e-5, len(i))) + walk
            walk = float(steps[-1])
            rate = 0.2 + rng.normal(0, 0.05, len(i)) + steps
            writer.write_table(pa.table({"time": i / FS_HZ, "rate": rate}))
    return path


IN_MEMORY = """
import json, sys, numpy as np, pyarrow.parquet as pq
sys.path.insert(0, sys.argv[3])
from gyrocomp import allan
rate = pq.read_table(sys.argv[1], columns=["rate"]).column("rate").to_numpy()
s = allan.analyse(rate, 1000.0)
# an independent plain-NumPy overlapping ADEV on the same samples (IEEE 1139 eq. for phase data)
x = np.cumsum((rate - rate.mean()) / 1000.0)
del rate
x = np.concatenate([[0.0], x])
plain = []
for tau in s.tau_s:
    m = int(round(tau * 1000.0))
    d = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
    plain.append(float(np.sqrt(np.dot(d, d) / (2.0 * tau**2 * len(d)))))
    del d
json.dump({"adev": s.adev.tolist(), "edf": s.edf.tolist(), "alpha": s.alpha.tolist(), "plain_adev": plain}, open(sys.argv[2], "w"))
"""


def part_big() -> dict:
    n = 3 * 10**8
    source = allan_log(DATA / "allan_3e8.parquet", n)
    try:
        ours = timed(gyrocomp("allan", source, "--out", DATA / "a_big.json"))
        reference = timed([sys.executable, "-c", IN_MEMORY, str(source), str(DATA / "a_big_memory.json"), str(ROOT)])
    finally:
        source.unlink()
    streamed = json.loads((DATA / "a_big.json").read_text())["series"][0]
    memory = json.loads((DATA / "a_big_memory.json").read_text())
    adev, ref = np.array(streamed["adev"]), np.array(memory["adev"])
    return {
        "n_samples": n,
        "wall_s": ours[0], "cpu_s": ours[1], "peak_mb": ours[2],
        "in_memory_wall_s": reference[0], "in_memory_peak_mb": reference[2],
        "n_taus": len(adev),
        "max_relative_difference": float(np.max(np.abs(adev - ref) / ref)),
        "edf_max_relative_difference": float(np.max(np.abs(np.array(streamed["edf"]) - memory["edf"]) / np.array(memory["edf"]))),
        "alpha_equal": streamed["alpha"] == memory["alpha"],
        "plain_numpy_max_relative_difference": float(np.max(np.abs(adev - memory["plain_adev"]) / ref)),
    }


def part_train() -> dict:
    """Peak memory of ``train`` (polynomial, ELM, PE-LCD-ANFIS) on 12 min and on 2 h at 1 kHz, against the extra input columns."""
    short, long = oven(DATA / "oven_12min_1khz.parquet", 720.0), oven(DATA / "oven_2h_1khz.parquet", 7200.0)
    extra_mb = 3 * 8 * (7_200_000 - 720_000) / 2**20  # time, rate, temperature
    out = {"extra_input_columns_mb": extra_mb}
    for config in ("polynomial", "elm", "pe-lcd-anfis"):
        runs = [timed(gyrocomp("train", f, "-c", config, "--out", DATA / f"t_{config}.json")) for f in (short, long)]
        out[config] = {
            "peak_1x_mb": runs[0][2], "peak_10x_mb": runs[1][2], "ratio_10x_1x": runs[1][2] / runs[0][2],
            "bound_mb": 1.3 * runs[0][2] + extra_mb, "wall_1x_s": runs[0][0], "wall_10x_s": runs[1][0],
        }
    return out


ANFIS_LOGS = {"12min": 720.0, "2h": 7200.0, "20h": 72000.0}


def part_train_anfis(labels=("12min", "2h")) -> dict:
    """PE-LCD-ANFIS ``train`` on two 1 kHz logs 10x apart: peak RSS of each, the longer's against 1.3x the shorter's plus the extra columns."""
    out = {}
    for label in labels:
        path = DATA / f"oven_{label}_1khz.parquet"
        try:
            load = os.getloadavg()[0]
            wall, cpu, peak = timed(gyrocomp("train", oven(path, ANFIS_LOGS[label]), "-c", "pe-lcd-anfis", "--out", DATA / f"t_anfis_{label}.json"))
        finally:
            if label == "20h":
                path.unlink(missing_ok=True)
        out[label] = {"n_samples": int(ANFIS_LOGS[label] * FS_HZ), "peak_mb": peak, "wall_s": wall, "cpu_s": cpu, "load_1min_before": load}
    short, long = labels
    extra = 3 * 8 * (out[long]["n_samples"] - out[short]["n_samples"]) / 2**20  # time, rate, temperature
    out["ratio"] = out[long]["peak_mb"] / out[short]["peak_mb"]
    out["extra_input_columns_mb"] = extra
    out["bound_mb"] = 1.3 * out[short]["peak_mb"] + extra
    out["bound_met"] = out[long]["peak_mb"] <= out["bound_mb"]
    out["2h_under_1200_mb"] = out["2h"]["peak_mb"] < 1200.0
    return out


def part_rate() -> dict:
    sys.path.insert(0, str(ROOT))
    from gyrocomp.pipeline.rate import CausalRate, causal_coefficients, temperature_rate
    from gyrocomp.pipeline.settings import RateSettings

    settings = RateSettings()
    rng = np.random.default_rng(SEED)
    n = 600_000
    temperature = 25.0 + 20.0 * np.sin(np.arange(n) / FS_HZ / 1000.0) + rng.normal(0, 0.02, n)
    start = time.perf_counter()
    ours = temperature_rate(temperature, FS_HZ, settings, causal=True)
    t_ours = time.perf_counter() - start
    taps = causal_coefficients(settings, FS_HZ)
    start = time.perf_counter()
    primed = np.concatenate([np.full(len(taps) - 1, temperature[0]), temperature])
    fir = np.convolve(primed, taps[::-1], mode="valid")
    t_fir = time.perf_counter() - start
    # 10^8 samples as a stream, then the last outputs against the exact slope of their windows
    estimator = CausalRate(settings, FS_HZ)
    w = len(taps)
    total, chunk, last = 10**8, 1 << 20, None
    tail = np.empty(0)
    for begin in range(0, total, chunk):
        i = np.arange(begin, min(begin + chunk, total))
        block = 25.0 + 20.0 * np.sin(i / FS_HZ / 3000.0) + rng.normal(0, 0.02, len(i))
        last = estimator(block)
        tail = np.concatenate([tail, block])[-(w + 99) :]
    k = np.arange(w, dtype=np.longdouble)
    exact_taps = 12 * np.longdouble(FS_HZ) / (w * (np.longdouble(w) ** 2 - 1)) * (k - (w - 1) / 2)
    exact = np.array([float(np.dot(exact_taps, tail[j : j + w].astype(np.longdouble))) for j in range(100)])
    return {
        "window_samples": w,
        "n_samples": n,
        "moment_s": t_ours,
        "fir_s": t_fir,
        "fir_over_moment": t_fir / t_ours,
        "max_relative_difference_to_fir": float(np.max(np.abs(ours - fir)) / np.max(np.abs(fir))),
        "after_1e8_max_relative_error": float(np.max(np.abs(last[-100:] - exact)) / np.max(np.abs(exact))),
    }


def main(parts: list[str]) -> int:
    known = {
        "rate": part_rate, "compensate": part_compensate, "memory": part_memory, "stream": part_stream,
        "allantools": part_allantools, "big": part_big, "train": part_train, "plot": part_plot,
        "train_anfis": part_train_anfis, "train_anfis_20h": lambda: part_train_anfis(("2h", "20h")),
    }
    for name in parts or ["rate", "compensate", "memory", "stream"]:
        print(f"-- {name}", flush=True)
        found = {"load_average_1min_at_start": os.getloadavg()[0], **known[name]()}
        for key, value in found.items():
            print(f"{key}: {value}", flush=True)
        provenance.write("long", found, key=name)  # one entry per part: parts may run side by side
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
