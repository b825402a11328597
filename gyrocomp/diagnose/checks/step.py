"""``step``: a step at an unknown time.

A step at every block ``j`` (at least ``min_step_blocks`` from either end):
the columns ``1[i >= j]`` scored one at a time
(:func:`gyrocomp.diagnose.checks._linear.threshold_scan`), the union bound
``n 2 Phi(-max |z|)`` over the times (conservative). The verdict's test of
a step in the residual, and a noise term's signature test of a step it absorbed.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result, log10
from gyrocomp.diagnose.checks._linear import threshold_scan

__all__ = ["step_positions", "step_scan", "test", "CHECK"]


def step_positions(n, min_blocks):
    """The first blocks after a step that the scan tries: every one at least `min_blocks` from either end of `n`.

    Examples
    --------
    >>> step_positions(10, 4).tolist()
    [4, 5, 6]
    """
    return np.arange(min_blocks, n - min_blocks + 1)


def step_scan(e, Xw, lower, min_blocks=4):
    """The most likely step in the residual and its p-value, for innovations `e` of the design `Xw`.

    A step at every block ``j`` (at least `min_blocks` from either end):
    :func:`gyrocomp.diagnose.checks._linear.threshold_scan` of the block index.

    Returns
    -------
    dict
        ``stat`` (max ``|z|``), ``block`` (first block after the step),
        ``size`` (the step's GLS size in the residual's unit), ``p``,
        ``log_p`` (natural log of the bound).
    """
    n = e.size
    pos = step_positions(n, min_blocks)
    if not pos.size:
        return {"stat": 0.0, "block": 0, "size": 0.0, "p": 1.0, "log_p": 0.0}
    found = threshold_scan(e, Xw, lower, np.arange(n), pos)
    return {k: found[k] for k in ("stat", "size", "p", "log_p")} | {"block": int(pos[found["index"]])}


def test(frame, e, Xw):
    """The step of largest score, its time [s] and size (module docstring)."""
    found = step_scan(e, Xw, frame.lower, frame.settings.min_step_blocks)
    return Result(found["stat"], found["p"], {"size": found["size"], "log10_p": log10(found["log_p"]),
                                             "block": found["block"], "time_s": found["block"] * frame.block_s})


def shape(frame, rng):
    """A step at 37 % of the run."""
    return (np.arange(frame.t.size) >= int(0.37 * frame.t.size)).astype(float)


CHECK = Check("step", test, exact=False, families=("residual", "signature"), shape=shape)
