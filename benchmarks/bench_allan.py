"""Whole-process `gyrocomp allan` against a script calling allantools.oadev.

Both read the same 10^7-sample Parquet recording (100 Hz, white + random-walk
rate) and compute the octave overlapping Allan deviation; gyrocomp also
identifies the noise, computes confidence intervals, fits the IEEE terms and
writes allan.json. The two commands alternate `REPEATS` times (5: other agents share the 2 cores); the figures
are the ratios of median wall times, of median CPU times (user + system of
the child, less sensitive to other load) and of peak resident memory
(``/usr/bin/time -v``). Timings are noisy while other jobs share the CPU.
gyrocomp's modules are byte-compiled first, as those of an installed copy are.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import provenance

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
DATA = HERE / "_data" / "allan_1e7.parquet"
N_SAMPLES = 10**7
FS_HZ = 100.0
REPEATS = 5
SEED = 20240601

ALLANTOOLS_SCRIPT = """
import sys, allantools, pyarrow.parquet as pq
frame = pq.read_table(sys.argv[1]).to_pandas()
tau, adev, err, n = allantools.oadev(frame["rate"].to_numpy(), rate=1.0 / (frame["time"].iloc[1] - frame["time"].iloc[0]), data_type="freq", taus="octave")
print(len(tau))
"""


def make_data() -> None:
    if DATA.exists():
        return
    DATA.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    rate = 0.2 + 0.05 * rng.normal(size=N_SAMPLES) + 1e-5 * np.cumsum(rng.normal(size=N_SAMPLES))
    pd.DataFrame({"time": np.arange(N_SAMPLES) / FS_HZ, "rate": rate}).to_parquet(DATA)


def run(cmd: list[str]) -> tuple[float, float]:
    """Wall time and CPU time (user + system) [s] of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def peak_rss(cmd: list[str]) -> float:
    """Peak RSS [MB] of `cmd` alone, from /usr/bin/time -v when present."""
    if Path("/usr/bin/time").exists():
        proc = subprocess.run(["/usr/bin/time", "-v", *cmd], check=True, capture_output=True, text=True)
        for line in proc.stderr.splitlines():
            if "Maximum resident set size" in line:
                return int(line.split(":")[1]) / 1024.0
    # fall back: a fresh interpreter that runs the command as its only child
    probe = "import resource,subprocess,sys; subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL); print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    out = subprocess.run([sys.executable, "-c", probe, *cmd], check=True, capture_output=True, text=True)
    return int(out.stdout.strip()) / 1024.0


def main() -> int:
    make_data()
    load_at_start = os.getloadavg()
    # gyrocomp as pip installs it, its modules byte-compiled: a checkout run with PYTHONDONTWRITEBYTECODE
    # compiles every module it imports from source in every run, which no installed copy does (allantools'
    # modules are compiled in site-packages)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(HERE.parent / "gyrocomp")], check=True)
    out = HERE / "_data" / "allan_bench.json"
    ours = [sys.executable, "-m", "gyrocomp", "--quiet", "allan", str(DATA), "--out", str(out)]
    theirs = [sys.executable, "-c", ALLANTOOLS_SCRIPT, str(DATA)]
    t_ours, t_theirs, cpu_ours, cpu_theirs = [], [], [], []
    for _ in range(REPEATS):
        wall, cpu = run(ours)
        t_ours.append(wall)
        cpu_ours.append(cpu)
        wall, cpu = run(theirs)
        t_theirs.append(wall)
        cpu_theirs.append(cpu)
    mem_ours, mem_theirs = peak_rss(ours), peak_rss(theirs)
    figures = {
        "n_samples": N_SAMPLES,
        "load_average_at_start": [round(x, 2) for x in load_at_start],
        "repeats": REPEATS,
        "gyrocomp_s": statistics.median(t_ours),
        "allantools_s": statistics.median(t_theirs),
        "time_ratio": statistics.median(t_ours) / statistics.median(t_theirs),
        "cpu_ratio": statistics.median(cpu_ours) / statistics.median(cpu_theirs),
        "gyrocomp_peak_mb": mem_ours,
        "allantools_peak_mb": mem_theirs,
        "memory_ratio": mem_ours / mem_theirs,
        "all_runs_s": {"gyrocomp": t_ours, "allantools": t_theirs},
        "all_cpu_s": {"gyrocomp": cpu_ours, "allantools": cpu_theirs},
    }
    for key, value in figures.items():
        print(f"{key}: {value}")
    provenance.write("allan", figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
