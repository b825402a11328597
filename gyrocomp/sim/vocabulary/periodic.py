"""``periodic``: a sinusoidal bias interference of fixed period, unrelated to temperature."""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.sim.vocabulary._base import Effect
from gyrocomp.sim import effects as shapes
from gyrocomp.sim.profile import unit_field


@dataclasses.dataclass(frozen=True)
class Periodic:
    """``periodic``: sinusoidal interference of fixed period."""

    enabled: bool = False
    amplitude_dps: float = unit_field(0.005, "deg/s")
    period_s: float = unit_field(1800.0, "s")
    phase_rad: float = unit_field(0.0, "rad")


class _Periodic(Effect):
    """Columns: ``sin`` and ``cos(2 pi t / P)``; amplitude and phase are re-estimated on every run."""

    name = "periodic"
    settings = Periodic
    nonlinear = "period_s"
    grid_setting = None  # periodic_min_blocks and periodic_oversample: see grid()
    n_params = 3
    per_run = ("periodic_sin", "periodic_cos")

    def bias(self, time_s, housing_c, gyro):
        p = gyro.periodic
        return shapes.periodic(time_s, p.amplitude_dps, p.period_s, p.phase_rad)

    def columns(self, run, params, poly_degree=3, scale=None):
        sin = shapes.periodic(run.time_s, 1.0, params["period_s"], 0.0)
        cos = shapes.periodic(run.time_s, 1.0, params["period_s"], 0.5 * np.pi)
        return np.column_stack([sin, cos]), list(self.per_run)

    def grid(self, settings, length_s, block_s):
        """Periods from half the run down to ``periodic_min_blocks`` blocks, frequency step ``1 / (periodic_oversample L)``."""
        f_lo = 2.0 / length_s
        f_hi = 1.0 / (settings.periodic_min_blocks * block_s)
        return 1.0 / np.arange(f_lo, f_hi, 1.0 / (settings.periodic_oversample * length_s))

    def report(self, coef, params, noise):
        a, b = coef["periodic_sin"], coef["periodic_cos"]
        return {
            "amplitude_dps": {"value": float(np.hypot(a, b)), "unit": "deg/s"},
            "period_s": {"value": params["period_s"], "unit": "s"},
            "phase_rad": {"value": float(np.arctan2(b, a)), "unit": "rad (fit run)"},
        }


EFFECT = _Periodic()
