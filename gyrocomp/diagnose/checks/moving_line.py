"""``moving_line``: a line whose frequency moves (a chirp, a tone drifting with temperature or age) or that comes and goes.

Fisher's ``g`` (:func:`gyrocomp.diagnose.checks.spectral_line.fisher_g`) in
each of ``line_segments`` consecutive segments of the innovations (at least
``line_min_cycles`` cycles in a segment), Bonferroni over the segments,
``P = min(1, K min_k P_k)`` (conservative). A drifting line spreads its
power over many Fourier frequencies of the whole run, where the
``spectral_line`` check does not see it, and a flicker or random walk
absorbs it: a stationary noise has the same spectrum in every segment.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.checks.spectral_line import fisher_g


def test(frame, e, Xw):
    """Fisher's ``g`` in each segment; the smallest p times the number of segments."""
    k, cycles = frame.settings.line_segments, frame.settings.line_min_cycles
    parts = np.array_split(np.arange(e.size), k)
    if (parts[-1].size - 1) // 2 - cycles + 1 < 2:
        # Segments too short to hold two Fourier frequencies of at least `cycles` cycles (a run in bursts).
        return Result(0.0, 1.0, {"p_segments": [], "segments": [], "period_s": [], "power": []})
    found = [fisher_g(e[idx], cycles) for idx in parts]
    p = [f[1] for f in found]
    return Result(float(max(f[0] for f in found)), float(min(1.0, k * min(p))), {
        "p_segments": p,
        "segments": [[int(idx[0]), int(idx[-1]) + 1] for idx in parts],
        "period_s": [idx.size * frame.block_s / f[2] for idx, f in zip(parts, found)],
        "power": [float(f[0] * e[idx] @ e[idx]) for idx, f in zip(parts, found)],
    })


def shape(frame, rng):
    """A chirp: a tone whose frequency sweeps from 20 to 30 cycles per run."""
    x = np.arange(frame.t.size) / frame.t.size
    return np.sin(2.0 * np.pi * (20.0 * x + 5.0 * x**2))


CHECK = Check("moving_line", test, exact=False, families=("residual",), shape=shape)
