"""Sample and permutation entropy: gyrocomp against antropy, same run, same data.

Prints the figures and writes ``benchmarks/results/entropy.json``. Timings
on a shared machine are noisy; the ratios matter, not the seconds.
Peak memory of gyrocomp's sample entropy is measured with tracemalloc
(numpy allocations are traced; numba's are not, but its kernels allocate
only O(N) arrays). The smooth case (a slow sine plus small noise, like a
low-frequency decomposition component) is where match-enumerating methods
slow down: nearly every template pair matches. Sample entropy's compiled
kernels are loaded (or, on a fresh checkout, compiled) before timing; that
one-off cost is reported separately.
"""

import time
import tracemalloc
from pathlib import Path

import provenance

import numpy as np

from gyrocomp.entropy import permutation_entropy, sample_entropy



def timed(fn, *args, repeat=1, **kwargs):
    """Value and the best wall time of `repeat` calls."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        value = fn(*args, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return value, best


def main():
    rng = np.random.default_rng(0)
    _, kernel_load_s = timed(sample_entropy, rng.standard_normal(1000), 2)  # before numba is warmed by antropy
    t0 = time.perf_counter()
    import antropy

    results = {"antropy_import_s": time.perf_counter() - t0, "gyrocomp_kernel_load_s": kernel_load_s,
               "sample_entropy": [], "permutation_entropy": []}
    print(f"kernel load (compile on a fresh checkout): gyrocomp {results['gyrocomp_kernel_load_s']:.2f} s, "
          f"antropy import {results['antropy_import_s']:.2f} s", flush=True)
    for n in (10_000, 100_000):
        x = rng.standard_normal(n)
        ours, t_ours = timed(sample_entropy, x, 2)
        theirs, t_theirs = timed(antropy.sample_entropy, x, order=2)
        tracemalloc.start()
        sample_entropy(x, 2)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        row = dict(n=n, gyrocomp=ours, antropy=theirs, gyrocomp_s=t_ours, antropy_s=t_theirs,
                   ratio=t_ours / t_theirs, gyrocomp_peak_mb=peak / 2**20)
        results["sample_entropy"].append(row)
        print(f"SampEn n={n}: gyrocomp {t_ours:.2f} s ({ours:.4f}), antropy {t_theirs:.2f} s ({theirs:.4f}), "
              f"ratio {row['ratio']:.2f}, peak {row['gyrocomp_peak_mb']:.0f} MB", flush=True)
    t = np.arange(50_000)
    x = np.sin(2 * np.pi * t / 5000) + 0.01 * rng.standard_normal(t.size)
    ours, t_ours = timed(sample_entropy, x, 2)
    theirs, t_theirs = timed(antropy.sample_entropy, x, order=2)
    results["sample_entropy_smooth"] = dict(n=x.size, signal="sin(2 pi t / 5000) + 0.01 N(0, 1)", gyrocomp=ours,
                                            antropy=theirs, gyrocomp_s=t_ours, antropy_s=t_theirs,
                                            ratio=t_ours / t_theirs)
    print(f"SampEn smooth n=5e4: gyrocomp {t_ours:.2f} s ({ours:.4f}), antropy {t_theirs:.2f} s ({theirs:.4f}), "
          f"ratio {t_ours / t_theirs:.3f}", flush=True)
    x = rng.standard_normal(1_000_000)
    ours, t_ours = timed(sample_entropy, x, 2)
    results["sample_entropy_1e6"] = dict(n=x.size, gyrocomp=ours, gyrocomp_s=t_ours, target_s=10.0)
    print(f"SampEn n=1e6: gyrocomp {t_ours:.1f} s ({ours:.4f}); target 10 s; antropy not run (KD-tree ~N^1.75)", flush=True)
    for order in (3, 4, 5, 6):
        ours, t_ours = timed(permutation_entropy, x, order, repeat=3)
        theirs, t_theirs = timed(antropy.perm_entropy, x, order=order, normalize=True, repeat=3)
        row = dict(n=x.size, order=order, gyrocomp=ours, antropy=theirs, gyrocomp_s=t_ours, antropy_s=t_theirs,
                   ratio=t_ours / t_theirs)
        results["permutation_entropy"].append(row)
        print(f"PE n=1e6 order {order}: gyrocomp {t_ours:.3f} s, antropy {t_theirs:.3f} s, ratio {row['ratio']:.2f}, "
              f"|diff| {abs(ours - theirs):.1e}", flush=True)
    provenance.write("entropy", results)


if __name__ == "__main__":
    main()
