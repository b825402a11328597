"""Run every ``benchmarks/bench_*.py`` in turn (``make bench``).

Each benchmark is a script that measures gyrocomp against its reference
library in the same run, prints its figures and writes them to
``benchmarks/results/<name>.json`` with its provenance (``provenance.py``);
``docs/validation.md`` quotes them.
Pass names to run a subset: ``python benchmarks/run.py allan decompose``.
"""

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(names: list[str]) -> int:
    scripts = sorted(HERE.glob("bench_*.py"))
    if names:
        scripts = [s for s in scripts if s.stem.removeprefix("bench_") in names]
    failed = 0
    for script in scripts:
        print(f"== {script.stem}", flush=True)
        failed += subprocess.call([sys.executable, str(script)]) != 0
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
