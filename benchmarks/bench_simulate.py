"""Benchmark `gyrocomp.sim.simulate`: throughput and linear scaling, and noise generation vs allantools.

1. Eight hours at 100 Hz (2.88 million samples) with every effect of the
   vocabulary switched on (and a turntable reference, quantisation, sensor
   noise): samples per second, best of 3.
2. Linear scaling: the same run at 2, 4 and 8 hours; the time per sample
   should stay flat (ratios 4h/2h and 8h/4h near 2).
3. The three rate-noise generators (white, flicker, random walk) against
   allantools.noise (white, pink, brown) at the same length, as a ratio
   (allantools' pink is a Voss-McCartney sum of `depth` random series).

Timings are noisy on a shared machine; compare ratios measured in one run.
Writes benchmarks/results/simulate.json.
"""

import time
from pathlib import Path

import provenance

import allantools.noise as an
import numpy as np

from gyrocomp import sim
from gyrocomp.effects import noise
from gyrocomp.sim import model

HERE = Path(__file__).resolve().parent
FS_HZ = 100.0
HOURS = (2.0, 4.0, 8.0)
NOISE_N = 2**18


def _best(fn, repeat=3):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    gyro = sim.GyroSettings(
        hysteresis=model.Hysteresis(enabled=True),
        rate_ramp=model.RateRamp(enabled=True),
        periodic=model.Periodic(enabled=True),
    )
    profile = sim.ProfileSettings()
    reference = sim.ReferenceSettings(kind="steps")
    assert gyro.active_effects() == list(model.EFFECTS)
    scaling = {}
    for hours in HOURS:
        n = int(hours * 3600 * FS_HZ) + 1
        seconds = _best(lambda: sim.simulate(gyro, profile, fs_hz=FS_HZ, seed=0, reference=reference, duration_s=hours * 3600))
        scaling[hours] = {"n_samples": n, "seconds": seconds, "samples_per_s": n / seconds}
        print(f"simulate {hours:.0f} h at {FS_HZ:g} Hz ({n} samples, all effects): {seconds:.3f} s, {n / seconds / 1e6:.2f} M samples/s")
    ratio_2x = scaling[4.0]["seconds"] / scaling[2.0]["seconds"]
    ratio_4x = scaling[8.0]["seconds"] / scaling[4.0]["seconds"]
    print(f"scaling: time(4 h)/time(2 h) = {ratio_2x:.2f}, time(8 h)/time(4 h) = {ratio_4x:.2f} (linear: 2)")

    rng = np.random.default_rng(0)
    ours = _best(lambda: (noise.white(NOISE_N, FS_HZ, 1.0, rng), noise.flicker(NOISE_N, FS_HZ, 10.0, rng),
                          noise.random_walk(NOISE_N, FS_HZ, 5.0, rng)))
    theirs = _best(lambda: (an.white(NOISE_N, fs=FS_HZ), an.pink(NOISE_N), an.brown(NOISE_N, fs=FS_HZ)))
    print(f"noise, {NOISE_N} samples: gyrocomp {ours * 1e3:.1f} ms, allantools.noise {theirs * 1e3:.1f} ms, "
          f"speed-up x{theirs / ours:.1f}")
    results = {
        "fs_hz": FS_HZ,
        "effects": list(model.EFFECTS),
        "simulate": {f"{h:g}h": v for h, v in scaling.items()},
        "samples_per_s_8h": scaling[8.0]["samples_per_s"],
        "scaling_ratio_4h_over_2h": ratio_2x,
        "scaling_ratio_8h_over_4h": ratio_4x,
        "noise_n": NOISE_N,
        "noise_seconds_gyrocomp": ours,
        "noise_seconds_allantools": theirs,
        "noise_speedup_vs_allantools": theirs / ours,
        "note": "best of 3 on a machine shared with other jobs; compare the ratios",
    }
    provenance.write("simulate", results)


if __name__ == "__main__":
    main()
