"""``temp_rate``: a bias proportional to dT/dt (thermal-gradient sensitivity, IEEE Std 1431), heating and cooling apart."""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.effects.vocabulary._base import Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class TempRate:
    """``temp_rate``: bias ``g dT/dt + a |dT/dt|`` from thermal gradients (IEEE Std 1431).

    The gradient across the part is not the same heating and cooling (the
    heater and the chamber's air flow differ), so the sensitivity is
    ``g + a`` while heating and ``g - a`` while cooling; ``a = 0`` is the
    symmetric sensitivity.
    """

    enabled: bool = True
    coefficient_dps_per_c_per_s: float = unit_field(1.5, "deg/s per degC/s")
    asymmetry_dps_per_c_per_s: float = unit_field(0.0, "deg/s per degC/s")


class _TempRate(Effect):
    """Columns: dT/dt of the measured temperature (Savitzky-Golay, ``run.rate_smooth_s``), and in the asymmetric form its magnitude; zero in a soak.

    The two columns span every pair of heating and cooling sensitivities:
    ``g_heat max(dT/dt, 0) + g_cool min(dT/dt, 0) = g dT/dt + a |dT/dt|``
    with ``g = (g_heat + g_cool) / 2`` and ``a = (g_heat - g_cool) / 2``.
    The symmetric form (``a = 0``, one parameter) is the plainer of the two
    :attr:`forms`: the asymmetry is fitted only where its column earns its
    place by the BIC. Charged for an unused column, a symmetric sensitivity
    loses to its look-alike, a short thermal lag (one parameter,
    ``P(T - tau dT/dt) ~ P(T) - tau P'(T) dT/dt``). The amplitude of a
    detection limit is that of the first (symmetric) column.
    """

    name = "temp_rate"
    settings = TempRate
    needs_temperature = True
    n_params = 1
    unit_columns = 1
    forms = ({"asymmetric": False}, {"asymmetric": True})

    def n_params_of(self, params):
        """1 symmetric, 2 with heating and cooling apart (``params["asymmetric"]``; without it the plainer, symmetric form)."""
        return self.n_params + bool(params.get("asymmetric", False))

    def bias(self, time_s, housing_c, gyro):
        t = gyro.temp_rate
        rate = shapes.temperature_rate(time_s, housing_c)
        return t.coefficient_dps_per_c_per_s * rate + t.asymmetry_dps_per_c_per_s * np.abs(rate)

    def columns(self, run, params, poly_degree=3, scale=None):
        rate = run.temperature_rate_c_per_s  # a diagnosis run keeps it (gyrocomp.diagnose.effects.Run)
        if not params.get("asymmetric", False):
            return rate[:, None], [self.name]
        return np.column_stack([rate, np.abs(rate)]), [self.name, f"{self.name}_asymmetry"]

    def report(self, coef, params, noise):
        """The sensitivity and its asymmetry (0 in the symmetric form)."""
        return self.amplitude(coef[self.name]) | {
            "asymmetry_dps_per_c_per_s": {"value": coef.get(f"{self.name}_asymmetry", 0.0), "unit": "deg/s per degC/s"}
        }

    def amplitude(self, value):
        return {"coefficient_dps_per_c_per_s": {"value": value, "unit": "deg/s per degC/s"}}


EFFECT = _TempRate()
