"""``thermal_lag``: the sensing element's temperature lags the measured one (first order)."""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.effects.vocabulary._base import Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class ThermalLag:
    """``thermal_lag``: the bias polynomial is evaluated at the element temperature,
    a first-order lag of the housing temperature (:func:`~gyrocomp.effects.shapes.element_temperature`)."""

    enabled: bool = True
    tau_s: float = unit_field(400.0, "s")


class _ThermalLag(Effect):
    """Columns: the baseline polynomial in the element temperature ``T_e(tau)``, replacing the measured one."""

    name = "thermal_lag"
    settings = ThermalLag
    needs_temperature = True
    nonlinear = "tau_s"
    grid_setting = "thermal_lag_tau_s"
    n_params = 1

    def bias(self, time_s, housing_c, gyro):
        element = shapes.element_temperature(time_s, housing_c, gyro.thermal_lag.tau_s)
        lagged = shapes.bias_polynomial(element, gyro.temperature_coefficients, gyro.reference_c)
        return lagged - shapes.bias_polynomial(housing_c, gyro.temperature_coefficients, gyro.reference_c)

    def columns(self, run, params, poly_degree=3, scale=None):
        return polynomial_columns(run, params["tau_s"], poly_degree, scale)

    def report(self, coef, params, noise):
        return {"tau_s": {"value": params["tau_s"], "unit": "s"}}


def polynomial_columns(run, tau_s, poly_degree, scale):
    """``T~^k``, k = 1..degree, of the measured temperature or (``tau_s``) of the element's.

    ``T~ = (T - centre) / half_range`` with `scale` fixed on the fit run.
    """
    if run.temperature_c is None or poly_degree == 0:
        return np.empty((run.time_s.size, 0)), []
    temperature = run.temperature_c
    if tau_s is not None:
        temperature = shapes.element_temperature(run.time_s, temperature, tau_s)
    z = (temperature - scale.centre_c) / scale.half_range_c
    return np.column_stack([z**k for k in range(1, poly_degree + 1)]), [f"temperature^{k}" for k in range(1, poly_degree + 1)]


EFFECT = _ThermalLag()
