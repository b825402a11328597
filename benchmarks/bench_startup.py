"""Start-up and whole-process decomposition (issue 38): what a command pays before it computes.

Every figure is measured in this run, each process whole (``python -m
gyrocomp ...``), CPU and peak memory from ``/usr/bin/time -v``:

``process``
    ``gyrocomp decompose --method iceemdan --ensemble 50`` on 10^4 samples
    (Parquet in, ``components.parquet`` out) against a script that reads the
    same file with pyarrow and runs PyEMD ``CEEMDAN(trials=50)`` (serial,
    seeded), alternated `REPEATS` times after one uncounted warm-up of each
    (numba's cache, the page cache). The ratio of median wall times is the
    goal (<= 0.1); the CPU ratio is the one to trust while other jobs share
    the machine.
``kernels``
    The kernel-load timer: for each numba kernel, in a fresh process, the
    import of its module (numba included) and the extra cost of its first
    call over its second (loading the machine code from numba's cache).
``imports``
    ``python -X importtime`` of the decompose command: which heavy packages
    load (pandas must not), their cumulative import time, and ``gyrocomp
    --help``'s wall time.

The 1-minute load average is recorded at the start and end of every part.
Results: ``results/startup.json``, one entry per part with its provenance
(``provenance.py``).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import provenance

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = HERE / "_data"
REPEATS = 3
N_SAMPLES = 10_000
ENSEMBLE = 50

PYEMD = """
import sys
import pyarrow.parquet as pq
from PyEMD import CEEMDAN
rate = pq.read_table(sys.argv[1], columns=["rate"]).column("rate").to_numpy()
ceemdan = CEEMDAN(trials=int(sys.argv[2]), epsilon=0.2, parallel=False)
ceemdan.noise_seed(0)
print(ceemdan(rate).shape)
"""

KERNELS = {
    "sift (decompose)": (
        "from gyrocomp.decompose import emd, _compiled",
        "emd.sift(np.random.default_rng(0).standard_normal((2, 200)))",
    ),
    "pair count (sample entropy)": (
        "from gyrocomp import entropy, _pair_count",
        "entropy.sample_entropy(np.random.default_rng(0).standard_normal(6000))",
    ),
}

KERNEL_TIMER = """
import sys, time
sys.path.insert(0, sys.argv[1])
t0 = time.perf_counter()
import numpy as np
t1 = time.perf_counter()
{imports}
t2 = time.perf_counter()
{call}
t3 = time.perf_counter()
{call}
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, (t3 - t2) - (t4 - t3))
"""


def gyrocomp(*args) -> list[str]:
    """This checkout's gyrocomp, whatever is installed."""
    return [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT)!r}); from gyrocomp.cli import main; main()", *map(str, args)]


def timed(cmd: list[str]) -> tuple[float, float, float]:
    """Wall [s], CPU (user + system) [s] and peak RSS [MB] of one child process."""
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-v", *cmd], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if proc.returncode:
        raise RuntimeError(proc.stderr[-2000:])
    fields = dict(line.strip().split(": ", 1) for line in proc.stderr.splitlines() if ": " in line)
    cpu = float(fields["User time (seconds)"]) + float(fields["System time (seconds)"])
    return wall, cpu, int(fields["Maximum resident set size (kbytes)"]) / 1024.0


def recording(n: int = N_SAMPLES, seed: int = 1) -> Path:
    """An oven-log-like record at 100 Hz (white noise, random-walk drift, slow trend), as in bench_decompose."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = DATA / f"startup_{n}.parquet"
    if not path.exists():
        DATA.mkdir(parents=True, exist_ok=True)
        rng = np.random.default_rng(seed)
        t = np.arange(n) / n
        rate = rng.standard_normal(n) + 0.02 * rng.standard_normal(n).cumsum() + 3 * np.tanh(4 * (t - 0.5))
        pq.write_table(pa.table({"time": np.arange(n) / 100.0, "rate": rate, "temperature": 20.0 + 10.0 * t}), path)
    return path


def part_process() -> dict:
    source = recording()
    cmds = {
        "gyrocomp": gyrocomp("--quiet", "decompose", source, "--method", "iceemdan", "--ensemble", ENSEMBLE, "--seed", 0, "--out", DATA / "startup_components.parquet"),
        "pyemd": [sys.executable, "-c", PYEMD, str(source), str(ENSEMBLE)],
    }
    for cmd in cmds.values():  # warm-up, not counted
        timed(cmd)
    runs = {name: [] for name in cmds}
    for _ in range(REPEATS):
        for name, cmd in cmds.items():
            runs[name].append(timed(cmd))
    med = {name: [statistics.median(r[i] for r in rs) for i in range(3)] for name, rs in runs.items()}
    return {
        "n_samples": N_SAMPLES, "ensemble": ENSEMBLE, "repeats": REPEATS,
        "wall_s": {k: v[0] for k, v in med.items()}, "cpu_s": {k: v[1] for k, v in med.items()},
        "peak_mb": {k: v[2] for k, v in med.items()},
        "wall_ratio": med["gyrocomp"][0] / med["pyemd"][0], "cpu_ratio": med["gyrocomp"][1] / med["pyemd"][1],
        "all_runs": runs,
    }


def part_kernels() -> dict:
    out = {}
    for name, (imports, call) in KERNELS.items():
        script = KERNEL_TIMER.format(imports=imports, call=call)
        rows = []
        for _ in range(REPEATS):
            proc = subprocess.run([sys.executable, "-c", script, str(ROOT)], check=True, capture_output=True, text=True)
            rows.append([float(v) for v in proc.stdout.split()])
        numpy_s, module_s, load_s = (statistics.median(r[i] for r in rows) for i in range(3))
        out[name] = {"numpy_import_s": numpy_s, "module_import_s": module_s, "first_call_load_s": load_s}
    return out


def part_imports() -> dict:
    source = recording()
    cmd = [sys.executable, "-X", "importtime", "-c", gyrocomp()[2], "--quiet", "decompose", source, "--method", "iceemdan",
           "--ensemble", ENSEMBLE, "--out", DATA / "startup_components.parquet"]
    proc = subprocess.run(list(map(str, cmd)), capture_output=True, text=True, check=True)
    cumulative = {}
    for line in proc.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            _, cum, name = (part.strip() for part in line.split("|"))
            if cum.isdigit():
                cumulative.setdefault(name, int(cum) / 1e6)
    heavy = ["numpy", "scipy", "scipy.linalg", "pandas", "pyarrow", "numba", "typer", "rich", "matplotlib",
             "gyrocomp.recordings", "gyrocomp.decompose", "gyrocomp.decompose._compiled"]
    helps = [timed(gyrocomp("--help"))[0] for _ in range(REPEATS)]
    return {
        "decompose_imports_s": {name: cumulative.get(name) for name in heavy},
        "pandas_imported": "pandas" in cumulative,
        "help_wall_s": statistics.median(helps),
    }


def main(parts: list[str]) -> int:
    known = {"process": part_process, "kernels": part_kernels, "imports": part_imports}
    for name in parts or list(known):
        print(f"-- {name}", flush=True)
        start = os.getloadavg()[0]
        found = known[name]()
        found = {"load_average_1min_at_start": start, **found, "load_average_1min_at_end": os.getloadavg()[0]}
        for key, value in found.items():
            print(f"{key}: {value}", flush=True)
        provenance.write("startup", found, key=name)  # one entry per part: parts may run apart
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
