"""Where a benchmark's figures came from, and the one place results are written.

Every benchmark keeps one file, ``benchmarks/results/<name>.json``, holding its
latest figures and a ``provenance`` record: the commit, the machine (CPU
model, cores, OS, Python, NumPy) and the load average when the run started.
Timings from the shared development machine are only comparable as ratios
taken in one run; the load says how inflated the absolute ones are.
Per-case detail (every pair of a seed, every fit of a search) goes to
``benchmarks/_data/`` (ignored by git); the history of results is git's.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
DATA = HERE / "_data"


def stamp() -> dict:
    """Commit, machine and load of this run, to store beside its figures."""
    import numpy as np

    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    if not commit and (ROOT / ".commit").exists():  # a `git archive` snapshot of the tree
        commit = (ROOT / ".commit").read_text().strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return {
        "commit": commit + ("+changes" if dirty else ""),
        "date_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        "machine": f"{_cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.machine()}",
        "python": platform.python_version(),
        "numpy": np.__version__,
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }


def write(name: str, figures: dict, *, key: str | None = None) -> Path:
    """Write `figures` with this run's provenance to ``results/<name>.json``.

    With `key` (a seed, a part) only that entry of the file's ``runs`` is
    replaced, each with its own provenance; the file is read just before
    writing, so parts run side by side keep each other's entries.
    """
    path = RESULTS / f"{name}.json"
    RESULTS.mkdir(exist_ok=True)
    entry = {"provenance": stamp()} | figures
    if key is None:
        content = entry
    else:
        content = json.loads(path.read_text()) if path.exists() else {}
        content.setdefault("runs", {})[str(key)] = entry
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(content, indent=1, default=float) + "\n")
    tmp.replace(path)
    return path


def detail_path(name: str) -> Path:
    """A file under ``benchmarks/_data/`` for a run's per-case detail (not kept in git)."""
    path = DATA / name
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"
