"""Run the withheld-effect benchmark of `gyrocomp diagnose` (``benchmarks/diagnose_withheld.py``).

Kept under the ``bench_*`` name so that ``benchmarks/run.py`` finds it; the
figures go to ``benchmarks/results/diagnose.json``.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from diagnose_withheld import main  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
