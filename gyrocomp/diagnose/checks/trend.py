"""``trend``: a ramp or a curve in time that a noise term absorbed (its signature).

The score statistic of ``[1, t]`` in innovation space, ``chi^2`` of the
rank beyond the design (exact).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.checks._linear import score_test


def test(frame, e, Xw):
    """The score of a constant and a line in the (whitened) block index."""
    n = e.size
    t = np.linspace(-1.0, 1.0, n)
    stat, dof, p, *_ = score_test(e, Xw, np.column_stack([np.ones(n), t]))
    return Result(stat, p, {"dof": dof})


def shape(frame, rng):
    """A ramp over the run (in the innovations: whitened columns)."""
    return np.linspace(-1.0, 1.0, frame.t.size)


CHECK = Check("trend", test, exact=True, families=("signature",), shape=shape)
