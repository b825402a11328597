"""Decomposition speed against PyEMD, measured in the same run (ratios, not absolute times).

0. Start-up of the numba kernel in this process (import + cached machine
   code; the first run after a source change also compiles, ~30 s).
1. EMD on 10^5 samples: gyrocomp defaults (10 fixed siftings) vs PyEMD
   ``EMD()`` defaults; matched: PyEMD ``EMD(FIXE=10)`` (same work per IMF);
   and gyrocomp with ``emd.m``'s Rilling stop and bound 2000.
2. ICEEMDAN with 50 realisations on 10^4 samples (1 worker, defaults) vs
   PyEMD ``CEEMDAN(trials=50)`` (serial, defaults), and ICEEMDAN-50 with
   Rilling / 2000 (the paper's sifting) for reference.
3. ICEEMDAN with 100 realisations on 10^5 samples, 2 workers: wall time.

The signal is an oven-log-like record: white noise, a random-walk drift and a
slow thermal trend. Writes ``benchmarks/results/decompose.json``. Pass
``--quick`` for 10x smaller sizes. Timings are noisy on a shared machine.
"""

import sys
import time
from pathlib import Path

import provenance

import numpy as np

from gyrocomp.decompose import DecomposeSettings, decompose
from gyrocomp.decompose.emd import Sifting, emd



def signal(n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / n
    return rng.standard_normal(n) + 0.02 * rng.standard_normal(n).cumsum() + 3 * np.tanh(4 * (t - 0.5))


def timed(fn):
    t0 = time.perf_counter()
    value = fn()
    return time.perf_counter() - t0, value


def main(quick=False):
    from PyEMD import CEEMDAN, EMD

    scale = 10 if quick else 1
    figures = {"quick": quick}
    startup, _ = timed(lambda: emd(signal(100)))
    figures["kernel_startup_s"] = startup
    print(f"kernel start-up (numba import + cache load): {startup:.2f} s", flush=True)
    n = 100_000 // scale
    x = signal(n)
    ours, (imfs, _) = timed(lambda: emd(x))
    ref, ref_imfs = timed(lambda: EMD()(x))
    figures["emd"] = {"n": n, "gyrocomp_s": ours, "pyemd_s": ref, "ratio": ours / ref,
                      "imfs": [int(imfs.shape[0]), int(ref_imfs.shape[0] - 1)]}
    ref_f, _ = timed(lambda: EMD(FIXE=10)(x))
    figures["emd_fixed10"] = {"n": n, "gyrocomp_s": ours, "pyemd_s": ref_f, "ratio": ours / ref_f}
    paper = Sifting(stop="rilling", max_sift=2000)
    ours_r, _ = timed(lambda: emd(x, paper))
    figures["emd_rilling2000"] = {"n": n, "gyrocomp_s": ours_r, "pyemd_default_s": ref, "ratio": ours_r / ref}
    print(f"EMD n={n}: gyrocomp {ours:.2f} s, PyEMD {ref:.2f} s, ratio {ours / ref:.3f}; "
          f"matched 10 fixed sifts: PyEMD {ref_f:.2f} s, ratio {ours / ref_f:.3f}; "
          f"gyrocomp Rilling/2000 {ours_r:.2f} s, ratio {ours_r / ref:.3f}", flush=True)

    n = 10_000 // scale
    x = signal(n, 1)
    settings = DecomposeSettings(method="iceemdan", ensemble=50)
    ours, _ = timed(lambda: decompose(x, settings, seed=0))
    ref, _ = timed(lambda: CEEMDAN(trials=50, epsilon=0.2, parallel=False)(x))
    figures["iceemdan50_vs_pyemd_ceemdan50"] = {"n": n, "gyrocomp_s": ours, "pyemd_s": ref, "ratio": ours / ref}
    rill = DecomposeSettings(method="iceemdan", ensemble=50, stop="rilling", max_sift=2000)
    ours_r, _ = timed(lambda: decompose(x, rill, seed=0))
    figures["iceemdan50_rilling2000_vs_pyemd_ceemdan50"] = {"n": n, "gyrocomp_s": ours_r, "pyemd_s": ref,
                                                             "ratio": ours_r / ref}
    print(f"ICEEMDAN-50 n={n}: {ours:.2f} s; PyEMD CEEMDAN-50 {ref:.2f} s; ratio {ours / ref:.3f}; "
          f"ICEEMDAN-50 Rilling/2000 {ours_r:.2f} s, ratio {ours_r / ref:.3f}", flush=True)

    n = 100_000 // scale
    x = signal(n, 2)
    wall, d = timed(lambda: decompose(x, DecomposeSettings(method="iceemdan", ensemble=100), seed=0, workers=2))
    figures["iceemdan100_2workers"] = {"n": n, "wall_s": wall, "modes": len(d.names)}
    print(f"ICEEMDAN-100 n={n}, 2 workers: {wall:.1f} s, {len(d.names)} components", flush=True)
    provenance.write("decompose", figures)


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
