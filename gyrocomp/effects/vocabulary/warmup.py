"""``warmup``: an exponential transient after power-on."""

from __future__ import annotations

import dataclasses

from gyrocomp.effects.vocabulary._base import Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class Warmup:
    """``warmup``: exponential power-on transient."""

    enabled: bool = True
    amplitude_dps: float = unit_field(0.03, "deg/s")
    tau_s: float = unit_field(900.0, "s")


class _Warmup(Effect):
    """Column: ``exp(-(t - t_0) / tau)``, one decay from power-on."""

    name = "warmup"
    settings = Warmup
    nonlinear = "tau_s"
    grid_setting = "warmup_tau_s"
    n_params = 2

    def bias(self, time_s, housing_c, gyro):
        return shapes.warmup(time_s, gyro.warmup.amplitude_dps, gyro.warmup.tau_s)

    def columns(self, run, params, poly_degree=3, scale=None):
        return shapes.warmup(run.time_s, 1.0, params["tau_s"])[:, None], [self.name]

    def report(self, coef, params, noise):
        return {
            "amplitude_dps": {"value": coef[self.name], "unit": "deg/s"},
            "tau_s": {"value": params["tau_s"], "unit": "s"},
        }


EFFECT = _Warmup()
