"""``power_on``: a settling after power-on.

Indicators of the windows ``poweron_edges_s`` after the first sample (those
shorter than half the run), scored: ``chi^2`` of their rank beyond the
design (exact).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, score_columns


def test(frame, e, Xw):
    """The score of the power-on windows; None when the run is too short for any."""
    return score_columns(frame, e, Xw, "power_on")


def shape(frame, rng):
    """A warm-up of 10 min time constant."""
    return np.exp(-frame.t / 600.0)


CHECK = Check("power_on", test, exact=True, families=("residual",), shape=shape)
