"""``rate_ramp``: the bias drifts with time since power-on, linearly or as a power of that time.

The simulator draws the straight line ``R (t - t_0)`` (IEEE Std 952's rate
ramp). Real aging and settling drifts bend: the diagnosis also fits the
power law ``c ((t - t_0) / 1 h)^p`` as a richer :attr:`forms` member, the
exponent ``p`` on the ``[diagnose] rate_ramp_power`` log grid; it is kept
only where its extra parameter earns its place by the BIC, and it nests the
line (``p = 1``). Left to the line alone, a bent drift is taken by a rate
random walk, which absorbs any slow curve (issue #16).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.effects.vocabulary._base import HOUR_S, Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class RateRamp:
    """``rate_ramp``: bias linear in time since power-on."""

    enabled: bool = False
    slope_dps_per_s: float = unit_field(2e-7, "deg/s/s")


class _RateRamp(Effect):
    """Column: ``((t - t_0) / 1 h)^p``, ``p = 1`` in the linear form (its coefficient is then deg/s per hour)."""

    name = "rate_ramp"
    settings = RateRamp
    nonlinear = "power"
    grid_setting = "rate_ramp_power"
    n_params = 1
    forms = ({"form": "linear", "power": 1.0}, {"form": "power_law"})

    def n_params_of(self, params):
        """1 for the line, 2 for the power law (its exponent)."""
        return self.n_params + ((params or {}).get("form") == "power_law")

    def bias(self, time_s, housing_c, gyro):
        return shapes.rate_ramp(time_s, gyro.rate_ramp.slope_dps_per_s)

    def columns(self, run, params, poly_degree=3, scale=None):
        hours = shapes.rate_ramp(run.time_s, 1.0 / HOUR_S)
        power = float(params.get("power", 1.0))
        return (hours if power == 1.0 else np.abs(hours) ** power)[:, None], [self.name]

    def report(self, coef, params, noise):
        if params.get("form") != "power_law":
            return self.amplitude(coef[self.name])
        return {
            "drift_dps_at_1h": {"value": coef[self.name], "unit": "deg/s"},
            "power": {"value": params["power"], "unit": "1"},
        }

    def amplitude(self, value):
        return {"slope_dps_per_s": {"value": value / HOUR_S, "unit": "deg/s/s"}}


EFFECT = _RateRamp()
