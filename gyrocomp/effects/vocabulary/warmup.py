"""``warmup``: an exponential transient after power-on, of one time constant or two."""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.effects.vocabulary._base import Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field

TWO = "two_time_constants"
"""The form of two decays, ``A exp(-t / tau) + A2 exp(-t / tau2)`` with ``tau2 > tau``."""


@dataclasses.dataclass(frozen=True)
class Warmup:
    """``warmup``: exponential power-on transient."""

    enabled: bool = True
    amplitude_dps: float = unit_field(0.03, "deg/s")
    tau_s: float = unit_field(900.0, "s")


class _Warmup(Effect):
    """Column: ``exp(-(t - t_0) / tau)``, one decay from power-on; in the form of two, a second column at ``slow_tau_s``.

    A MEMS gyro warms up on more than one time constant where the die
    settles in seconds to minutes and the package and board in an hour or
    more; one exponential then stretches between them, and a power law in
    time (``rate_ramp``) mimics the sum better than either. The second time
    constant is searched on the same grid as the first, at least
    ``warmup_min_ratio`` times it and settling within the run (:meth:`paired`).
    """

    name = "warmup"
    settings = Warmup
    nonlinear = "tau_s"
    grid_setting = "warmup_tau_s"
    n_params = 2
    unit_columns = 1
    forms = ({}, {"form": TWO})

    def n_params_of(self, params):
        """2 (amplitude, time constant); 4 in the form of two decays."""
        return self.n_params * (1 + ((params or {}).get("form") == TWO))

    def paired(self, form: dict, settings, length_s: float):
        """In the form of two decays ``("slow_tau_s", warmup_min_ratio, length_s / warmup_min_decays)``: a second decay
        slower than that does not settle within the run and is a drift there (``rate_ramp``'s); None in the form of one."""
        if form.get("form") != TWO:
            return None
        return "slow_tau_s", settings.warmup_min_ratio, length_s / settings.warmup_min_decays

    def bias(self, time_s, housing_c, gyro):
        return shapes.warmup(time_s, gyro.warmup.amplitude_dps, gyro.warmup.tau_s)

    def columns(self, run, params, poly_degree=3, scale=None):
        fast = shapes.warmup(run.time_s, 1.0, params["tau_s"])
        if params.get("form") != TWO:
            return fast[:, None], [self.name]
        return np.column_stack([fast, shapes.warmup(run.time_s, 1.0, params["slow_tau_s"])]), [self.name, f"{self.name}_slow"]

    def report(self, coef, params, noise):
        out = {
            "amplitude_dps": {"value": coef[self.name], "unit": "deg/s"},
            "tau_s": {"value": params["tau_s"], "unit": "s"},
        }
        if params.get("form") == TWO:
            out["form"] = {"value": TWO, "unit": ""}
            out["slow_amplitude_dps"] = {"value": coef[f"{self.name}_slow"], "unit": "deg/s"}
            out["slow_tau_s"] = {"value": params["slow_tau_s"], "unit": "s"}
        return out


EFFECT = _Warmup()
