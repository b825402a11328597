"""``heating_cooling``: a different offset or slope in temperature when heating and when cooling.

Heating and cooling are ``|dT/dt|`` above ``soak_rate_c_per_min``; the
columns are the two regimes' indicators and their slopes in (scaled)
temperature, scored: ``chi^2`` of their rank beyond the design (exact).
"""

from __future__ import annotations

from gyrocomp.diagnose.checks._base import Check, score_columns


def test(frame, e, Xw):
    """The score of the heating and cooling columns; None when the run does not both heat and cool."""
    return score_columns(frame, e, Xw, "heating_cooling")


def shape(frame, rng):
    """An offset of one sign while heating and of the other while cooling (a relay hysteresis)."""
    return (frame.regime == "heating").astype(float) - (frame.regime == "cooling").astype(float)


CHECK = Check("heating_cooling", test, exact=True, families=("residual",), shape=shape)
