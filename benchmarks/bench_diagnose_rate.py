"""Benchmark `gyrocomp diagnose`: its time does not grow with the sample rate.

One gyro (the default gyro's baseline with a warm-up and flicker; no other
effect) on the papers' oven profile, eight hours, a fit run and a holdout,
simulated at 2 Hz and at 100 Hz (2.88 million samples a run). Each pair is
diagnosed once (``diagnose(fit, holdout)``, one BLAS thread) and timed;
the figure is the ratio 100 Hz / 2 Hz measured in the same run (goal: at
most 2), beside the 2 Hz pair's own time (goal: under a minute on two
cores; timings on a shared machine are noisy, the ratio less so; the
process CPU time of each pair and the load average are recorded beside the
wall time, since a loaded machine inflates wall time only). The
recordings are averaged to ``max_rate_hz`` at entry, so both pairs run the
same likelihood on the same number of blocks.

Writes ``benchmarks/results/diagnose_rate.json``.
"""

import os
import time
from pathlib import Path

import provenance

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from gyrocomp.diagnose import diagnose  # noqa: E402
from gyrocomp.recordings import recording_from_frame  # noqa: E402
from gyrocomp.sim.model import GyroSettings, RateRandomWalk, TempRate, ThermalLag  # noqa: E402
from gyrocomp.sim.profile import ProfileSettings  # noqa: E402
from gyrocomp.sim.simulate import simulate  # noqa: E402

HERE = Path(__file__).resolve().parent
HOURS = 8.0
RATES_HZ = (2.0, 100.0)


def _pair(fs_hz):
    gyro = GyroSettings(
        thermal_lag=ThermalLag(enabled=False), temp_rate=TempRate(enabled=False), rate_random_walk=RateRandomWalk(enabled=False)
    )
    recs = []
    for seed in (1, 2):
        frame, _ = simulate(gyro, ProfileSettings(), fs_hz=fs_hz, seed=seed, duration_s=HOURS * 3600.0)
        recs.append(recording_from_frame(frame[["time", "rate", "temperature"]], name=f"run{seed}"))
    return recs


def main():
    out = {}
    for fs in RATES_HZ:
        fit, hold = _pair(fs)
        start, cpu = time.perf_counter(), time.process_time()
        report = diagnose(fit, hold)
        out[f"{fs:g}"] = {
            "seconds": time.perf_counter() - start,
            "cpu_seconds": time.process_time() - cpu,
            "selected": report["selected_effects"],
            "samples_per_run": fit.time_s.size,
        }
        print(f"{fs:g} Hz: {out[f'{fs:g}']['seconds']:.1f} s ({out[f'{fs:g}']['cpu_seconds']:.1f} s CPU), selected {report['selected_effects']}", flush=True)
    out["ratio_100_over_2"] = out["100"]["seconds"] / out["2"]["seconds"]
    out["cpu_ratio_100_over_2"] = out["100"]["cpu_seconds"] / out["2"]["cpu_seconds"]
    out["load_average"] = os.getloadavg()
    print(f"ratio 100 Hz / 2 Hz: {out['ratio_100_over_2']:.2f} wall, {out['cpu_ratio_100_over_2']:.2f} CPU (goal <= 2)")
    provenance.write("diagnose_rate", out)
    return 0 if out["ratio_100_over_2"] <= 2.0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
