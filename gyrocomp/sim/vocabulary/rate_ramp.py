"""``rate_ramp``: the bias changes linearly with time since power-on."""

from __future__ import annotations

import dataclasses

from gyrocomp.sim.vocabulary._base import HOUR_S, Effect
from gyrocomp.sim import effects as shapes
from gyrocomp.sim.profile import unit_field


@dataclasses.dataclass(frozen=True)
class RateRamp:
    """``rate_ramp``: bias linear in time since power-on."""

    enabled: bool = False
    slope_dps_per_s: float = unit_field(2e-7, "deg/s/s")


class _RateRamp(Effect):
    """Column: ``t - t_0`` in hours (its coefficient is deg/s per hour, well scaled beside the others)."""

    name = "rate_ramp"
    settings = RateRamp
    n_params = 1

    def bias(self, time_s, housing_c, gyro):
        return shapes.rate_ramp(time_s, gyro.rate_ramp.slope_dps_per_s)

    def columns(self, run, params, poly_degree=3, scale=None):
        return shapes.rate_ramp(run.time_s, 1.0 / HOUR_S)[:, None], [self.name]

    def report(self, coef, params, noise):
        return self.amplitude(coef[self.name])

    def amplitude(self, value):
        return {"slope_dps_per_s": {"value": value / HOUR_S, "unit": "deg/s/s"}}


EFFECT = _RateRamp()
