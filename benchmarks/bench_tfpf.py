"""Time-frequency peak filtering on 10^5 samples, beside scipy's Savitzky-Golay as a yardstick.

No library implements TFPF, so the reference is the cost of the SG filter
the other pipeline uses on the same data. Writes ``results/tfpf.json``;
timings on a shared machine are noisy.
"""

import json
import time
from pathlib import Path

import numpy as np

from gyrocomp.denoise import savgol, tfpf

OUT = Path(__file__).resolve().parent / "results" / "tfpf.json"


def main():
    rng = np.random.default_rng(0)
    n = 100_000
    t = np.arange(n, dtype=float)
    clean = np.sin(2 * np.pi * t / 2000)
    x = clean + 0.3 * rng.standard_normal(n)
    rows = []
    for window in (21, 101, 301):
        t0 = time.perf_counter()
        y = tfpf(x, window)
        seconds = time.perf_counter() - t0
        rms = float(np.sqrt(np.mean((y - clean) ** 2)))
        rows.append(dict(n=n, window=window, seconds=seconds, rms_error=rms))
        print(f"TFPF n=1e5 window {window}: {seconds:.2f} s, rms error {rms:.4f} (input 0.3)", flush=True)
    t0 = time.perf_counter()
    y = savgol(x, 51, 3)
    sg = dict(n=n, window=51, seconds=time.perf_counter() - t0, rms_error=float(np.sqrt(np.mean((y - clean) ** 2))))
    print(f"scipy savgol n=1e5 window 51: {sg['seconds']:.3f} s, rms error {sg['rms_error']:.4f}")
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps({"tfpf": rows, "savgol": sg}, indent=2) + "\n")


if __name__ == "__main__":
    main()
