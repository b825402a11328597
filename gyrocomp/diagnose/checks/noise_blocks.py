"""``noise_blocks``: a block-level noise whose spread changes over the run.

The Brown-Forsythe test [1]_ of the spread of the innovations in
``noise_segments`` consecutive segments, ``F_(k-1, n-k)`` (asymptotically
exact). A change counts only when one segment's robust standard deviation
differs from another's by ``noise_min_ratio`` (at 100 Hz a change of 1 % is
significant and of no consequence); this only lowers the false-alarm rate.

References
----------
.. [1] M. B. Brown, A. B. Forsythe, "Robust tests for the equality of
   variances", J. Amer. Statist. Assoc. 69, 364-367 (1974).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose.checks._base import Check, Result

__all__ = ["variance_segments", "variance_groups", "noise_change", "test", "CHECK"]


def variance_segments(x, n_segments):
    """Brown-Forsythe test [1]_ that `x` has one spread in `n_segments` consecutive segments.

    Levene's test on absolute deviations from the segment medians: its
    false-alarm rate holds for heavy tails and a few spikes, where
    Bartlett's test of the variances calls a spike a change of noise.

    Returns
    -------
    stat, p : float
    std : ndarray
        A robust standard deviation of each segment (``1.4826`` times the
        median absolute deviation from its median).
    """
    x = np.asarray(x, dtype=float)
    return variance_groups(np.array_split(x, n_segments))


def variance_groups(groups):
    """Brown-Forsythe test [1]_ that the arrays `groups` share one spread (see :func:`variance_segments`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> stat, p, std = variance_groups([rng.standard_normal(5000), 2.0 * rng.standard_normal(5000)])
    >>> bool(p < 1e-6), bool(1.8 < std[1] / std[0] < 2.2)
    (True, True)
    """
    stat, p = stats.levene(*groups, center="median")
    return float(stat), float(p), np.array([1.4826 * np.median(np.abs(q - np.median(q))) for q in groups])


def noise_change(stat, p, std, min_ratio):
    """A noise-change result: its p counts only when two groups' spreads differ by at least `min_ratio`."""
    ratio = float(std.max() / std.min()) if std.min() > 0 else np.inf
    return Result(stat, p if ratio >= min_ratio else 1.0, {"p_test": p, "ratio": ratio, "std": std})


def test(frame, e, Xw):
    """Brown-Forsythe over the innovations' segments, with the segments' robust spreads."""
    s = frame.settings
    return noise_change(*variance_segments(e, s.noise_segments), s.noise_min_ratio)


def shape(frame, rng):
    """A white block-level noise of twice the innovations' spread in the last third of the run."""
    return 2.0 * rng.standard_normal(frame.t.size) * (np.arange(frame.t.size) >= 2 * frame.t.size // 3)


CHECK = Check("noise_blocks", test, exact=False, families=("residual",), shape=shape, level="noise")
