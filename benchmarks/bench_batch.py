"""gyrocomp batch: speed-up of 2 workers over 1, and the scheduling overhead per input.

Sixteen simulated static logs (2 h at 2 Hz, 14,400 samples each) through
``batch allan``. The reference is the stage itself: the same allan job
called directly in a loop (read, analyse, allan.json, allan.png), with no
hashing, manifest, temporary folder, rename or pool. Figures:

* speed-up = wall time with 1 worker / wall time with 2 workers (goal >= 1.7
  on 2 cores), both warm: the one-off start of the forkserver (imports) is
  timed apart, as the first 2-worker batch of 2 inputs;
* overhead per input = (batch with 1 worker - direct loop) / 16 (goal < 50 ms);
* machinery per input = what a batch adds around the stage (input hash,
  up-to-date check, temporary folder, manifest, rename), timed alone, / 16;
* up-to-date re-run per input = a second batch that skips every input / 16.

Timings are noisy when other jobs share the CPU: the results file records
the load average beside them.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

import provenance

N_LOGS = 16
HERE = Path(__file__).resolve().parent


def main() -> dict:
    from gyrocomp import artefacts, sim
    from gyrocomp.batch import run_batch
    from gyrocomp.batch.jobs import JOBS

    work = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    try:
        cfg = sim.load_sim_config(None, profile="soak-25")
        logs = work / "logs"
        logs.mkdir()
        for seed in range(N_LOGS):
            frame, _ = sim.simulate(cfg.gyro, cfg.profile, fs_hz=2.0, seed=seed, duration_s=7200.0)
            artefacts.write_table(logs / f"log{seed:02d}.parquet", frame[["time", "rate", "temperature"]], {})
        paths = sorted(str(p) for p in logs.glob("*.parquet"))
        job = JOBS["allan"]
        settings = job.resolve(dict(job.options), {})

        run_batch("allan", paths[:2], work / "warm1", workers=1)  # imports, matplotlib font cache
        t0 = time.perf_counter()
        run_batch("allan", paths[:2], work / "warm2", workers=2)  # starts the forkserver (once per process)
        cold_pool = time.perf_counter() - t0
        t0 = time.perf_counter()
        for i, p in enumerate(paths):
            folder = work / "direct" / str(i)
            folder.mkdir(parents=True)
            job.execute(Path(p), folder, settings, {})
        direct = time.perf_counter() - t0

        timings = {}
        for workers in (1, 2):
            t0 = time.perf_counter()
            result = run_batch("allan", paths, work / f"w{workers}", workers=workers)
            timings[workers] = time.perf_counter() - t0
            assert result.count("ok") == N_LOGS, result.rows
        same = all(
            (work / "w1" / name).read_bytes() == (work / "w2" / name).read_bytes() for name in ("summary.csv", "summary.parquet")
        )
        t0 = time.perf_counter()
        again = run_batch("allan", paths, work / "w1", workers=1)
        rerun = time.perf_counter() - t0
        assert again.count("skipped") == N_LOGS
        machinery = _machinery(paths, work / "direct", settings)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    figures = {
        "n_logs": N_LOGS,
        "samples_per_log": 14400,
        "cores": len(os.sched_getaffinity(0)),
        "load_average_1min": os.getloadavg()[0],
        "direct_loop_s": direct,
        "batch_1_worker_s": timings[1],
        "batch_2_workers_s": timings[2],
        "speedup_2_vs_1": timings[1] / timings[2],
        "first_pool_2_inputs_s": cold_pool,
        "overhead_per_input_ms": 1000 * (timings[1] - direct) / N_LOGS,
        "machinery_per_input_ms": 1000 * machinery / N_LOGS,
        "up_to_date_rerun_per_input_ms": 1000 * rerun / N_LOGS,
        "summaries_identical_1_vs_2_workers": same,
        "goals": {"speedup_2_vs_1": ">= 1.7", "overhead_per_input_ms": "< 50"},
    }
    return figures


def _machinery(paths, direct: Path, settings: dict) -> float:
    """Seconds of what a batch adds around the stage, timed alone: hash, check, manifest, rename."""
    from gyrocomp import artefacts
    from gyrocomp.batch import manifest as mf

    t0 = time.perf_counter()
    for i, p in enumerate(paths):
        sha = artefacts.file_sha256(p)
        mf.is_up_to_date(direct / f"m{i}", "allan", sha, settings)
        tmp = mf.new_folder(direct, f"m{i}")
        for name in ("allan.json", "allan.png"):
            os.link(direct / str(i) / name, tmp / name)
        mf.write_manifest(tmp, command="allan", input_name=Path(p).name, input_sha256=sha, settings=settings, figures={}, threshold="")
        mf.commit_folder(tmp, direct / f"m{i}")
    return time.perf_counter() - t0


if __name__ == "__main__":
    result = main()
    for key, value in result.items():
        print(f"{key:36s} {value:.4g}" if isinstance(value, float) else f"{key:36s} {value}")
    provenance.write("batch", result)
