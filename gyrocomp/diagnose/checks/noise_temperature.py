"""``noise_temperature``: a white noise that depends on temperature.

The paired differences within blocks of ``noise_samples`` grouped by their
block's ``temperature_bins`` bin (bins of at least ``2 min_step_blocks``
pairs), the Brown-Forsythe test of one spread
(:func:`gyrocomp.diagnose.checks.noise_blocks.variance_groups`), with the
``noise_min_ratio`` size rule.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.checks.noise_blocks import noise_change, variance_groups


def test(frame, e, Xw):
    """Brown-Forsythe over the temperature bins; None without temperature, samples or two bins."""
    if frame.pairs is None or frame.temp is None:
        return None
    s = frame.settings
    labels = np.repeat(np.argmax(frame.columns["temperature"], axis=1), frame.pairs_per_block)
    kinds = [k for k in np.unique(labels) if np.sum(labels == k) >= 2 * s.min_step_blocks]
    if len(kinds) < 2:
        return None
    stat, p, std = variance_groups([frame.pairs[labels == k] for k in kinds])
    found = noise_change(stat, p, std * np.sqrt(frame.fs_hz), s.noise_min_ratio)
    cols = frame.columns["temperature"][:, kinds]
    ranges = [[float(frame.temp[c > 0].min()), float(frame.temp[c > 0].max())] for c in cols.T]
    return Result(found.statistic, found.pvalue, found.where | {"temperature_c": ranges})


def shape(frame, rng):
    """Pairs' spread growing from 1 to 2.5 over the temperature range."""
    temp = np.repeat(frame.temp, frame.pairs_per_block)
    return 1.0 + 1.5 * (temp - temp.min()) / max(np.ptp(temp), 1e-9)


CHECK = Check("noise_temperature", test, exact=False, families=("residual",), shape=shape, level="sample")
