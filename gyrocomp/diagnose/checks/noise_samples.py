"""``noise_samples``: a sample-level (white) noise whose spread changes over the run.

The Brown-Forsythe test (:func:`gyrocomp.diagnose.checks.noise_blocks.variance_segments`)
on the paired differences ``(x_(2j+1) - x_(2j)) / sqrt(2)`` within blocks
(independent under white noise: every slow term cancels) in
``noise_segments`` segments, with the ``noise_min_ratio`` size rule; the
spreads in deg/s/sqrt(Hz).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check
from gyrocomp.diagnose.checks.noise_blocks import noise_change, variance_segments


def test(frame, e, Xw):
    """Brown-Forsythe over the pairs' segments; None without the full-rate samples."""
    if frame.pairs is None:
        return None
    s = frame.settings
    stat, p, std = variance_segments(frame.pairs, s.noise_segments)
    return noise_change(stat, p, std * np.sqrt(frame.fs_hz), s.noise_min_ratio)


def shape(frame, rng):
    """Pairs' spread doubled in the last quarter of the run."""
    k = frame.pairs.size
    return np.where(np.arange(k) >= 3 * k // 4, 2.0, 1.0)


CHECK = Check("noise_samples", test, exact=False, families=("residual",), shape=shape, level="sample")
