"""``time``: a drift in time.

Indicators of ``time_segments`` equal segments of the run, scored:
``chi^2`` of their rank beyond the design (exact).
"""

from __future__ import annotations

from gyrocomp.diagnose.checks._base import Check, score_columns


def test(frame, e, Xw):
    """The score of the run's time segments."""
    return score_columns(frame, e, Xw, "time")


def shape(frame, rng):
    """A bump in time: a raised level over the third eighth of the run."""
    end = frame.duration_s
    return ((frame.t >= 0.25 * end) & (frame.t < 0.375 * end)).astype(float)


CHECK = Check("time", test, exact=True, families=("residual",), shape=shape)
