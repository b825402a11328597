"""``temp_rate``: a bias proportional to dT/dt (thermal-gradient sensitivity, IEEE Std 1431)."""

from __future__ import annotations

import dataclasses

from gyrocomp.sim.vocabulary._base import Effect
from gyrocomp.sim import effects as shapes
from gyrocomp.sim.profile import unit_field


@dataclasses.dataclass(frozen=True)
class TempRate:
    """``temp_rate``: bias ``g dT/dt`` from thermal gradients (IEEE Std 1431)."""

    enabled: bool = True
    coefficient_dps_per_c_per_s: float = unit_field(1.5, "deg/s per degC/s")


class _TempRate(Effect):
    """Column: dT/dt of the measured temperature (Savitzky-Golay, ``run.rate_smooth_s``); zero in a soak."""

    name = "temp_rate"
    settings = TempRate
    needs_temperature = True
    n_params = 1

    def bias(self, time_s, housing_c, gyro):
        return gyro.temp_rate.coefficient_dps_per_c_per_s * shapes.temperature_rate(time_s, housing_c)

    def columns(self, run, params, poly_degree=3, scale=None):
        col = shapes.temperature_rate(run.time_s, run.temperature_c, smooth_s=run.rate_smooth_s)
        return col[:, None], [self.name]

    def report(self, coef, params, noise):
        return self.amplitude(coef[self.name])

    def amplitude(self, value):
        return {"coefficient_dps_per_c_per_s": {"value": value, "unit": "deg/s per degC/s"}}


EFFECT = _TempRate()
