"""The grey-box model's nonlinear specification, its states and its design columns.

:class:`Spec` names the nonlinear parameters of a model (0: the term is
absent); :func:`kernel` runs the states (:mod:`gyrocomp.effects._stateful`)
over a chunk; :func:`columns_of` turns them into the design columns whose
coefficients the model fits. Shared by the estimator's stream
(:mod:`gyrocomp.models.greybox`) and its term search
(:mod:`gyrocomp.models._greybox_search`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["TERMS", "JOINS", "Spec", "kernel", "columns_of", "element_column"]

TERMS = ("thermal_lag", "temp_rate", "hysteresis", "warmup", "second_lag", "second_warmup", "rate_saturation", "second_hysteresis")
"""The model's optional terms, in the order they are judged: the vocabulary's names, then a second time constant
of the element lag and of the warm-up, a saturation of the dT/dt sensitivity and a second play of another width,
each tried only once the term it joins is in."""

JOINS = {"second_lag": "thermal_lag", "second_warmup": "warmup", "rate_saturation": "temp_rate", "second_hysteresis": "hysteresis"}
"""Each term that refines another and the term it joins: it is tried only once that term is in."""


@dataclasses.dataclass(frozen=True)
class Spec:
    """Nonlinear parameters of a model: 0 means the term is absent."""

    tau_e: float = 0.0
    rate_form: int = 0  # 0 none, 1 one sensitivity, 2 heating and cooling apart
    width: float = 0.0
    tau_w: float = 0.0
    tau_r: float = 0.0  # the dT/dt filter's time constant, with rate_form
    relay: bool = False  # the hysteresis is a direction relay, not a play (with width)
    tau_e2: float = 0.0  # a second element time constant (with tau_e)
    tau_w2: float = 0.0  # a second warm-up time constant (with tau_w)
    rate_sat: float = 0.0  # the dT/dt sensitivity saturates: s tanh(dT/dt / s), s in degC/s (with rate_form)
    series: bool = False  # the second element lag is in series with the first (the cubic at its output), not in parallel
    width2: float = 0.0  # a second play's width, degC (with width): a spread of widths, Prandtl-Ishlinskii's sum of plays
    on_element: bool = False  # the hysteresis switches on T_e (with tau_e and width), not on the measured T

    def terms(self) -> list[str]:
        present = (self.tau_e > 0, self.rate_form > 0, self.width > 0, self.tau_w > 0, self.tau_e2 > 0, self.tau_w2 > 0, self.rate_sat > 0,
                   self.width2 > 0)
        return [t for t, on in zip(TERMS, present) if on]

    def n_nonlinear(self) -> int:
        """Nonlinear parameters fitted: each time constant and width (the relay/play choice counts as none)."""
        return len(self.terms())


def kernel(time_s, temperature_c, state, spec: Spec) -> np.ndarray:
    """(T_e, dT/dt, hysteresis output, second T_e, second play output) of each sample; without a dT/dt term the filter
    runs at 1 s, unused."""
    from gyrocomp.effects._stateful import advance

    out = np.empty((time_s.size, 5))
    advance(time_s, temperature_c, state, float(spec.tau_e), float(spec.tau_r or 1.0), 0.5 * float(spec.width), bool(spec.relay),
            float(spec.tau_e2), bool(spec.series), 0.5 * float(spec.width2), bool(spec.on_element and spec.tau_e), out)
    return out


def element_column(spec: Spec) -> int:
    """The kernel's column the cubic is evaluated at: the second stage's temperature for two lags in series, else T_e."""
    return 3 if spec.series and spec.tau_e and spec.tau_e2 else 0


def columns_of(raw, time_s, spec: Spec, power_on_s, centre, half, degree) -> dict:
    """The model's design columns of a spec from the kernel's output (no offsets).

    ``z1..z3`` (powers of the scaled element temperature), ``rate`` and
    ``rate_abs`` (dT/dt, or its saturation
    :func:`~gyrocomp.effects.shapes.saturating_rate`; heating and cooling apart), ``play`` or ``relay``
    (the hysteresis operator's output), ``play2`` (a second play's), ``warmup`` and ``warmup2``
    (``exp(-t_on / tau)``) and ``lag2`` (the second element temperature
    less the first, scaled as z: the second path's share of the drift).
    Two lags in series have no ``lag2``: the powers are of the second
    stage's temperature.
    """
    z = (raw[:, element_column(spec)] - centre) / half
    columns = {f"z{k}": z**k for k in range(1, degree + 1)}
    if spec.rate_form:
        from gyrocomp.effects.shapes import saturating_rate  # scipy.signal: only a fit needs it, compensation evaluates in numba

        rate = saturating_rate(raw[:, 1], spec.rate_sat) if spec.rate_sat else raw[:, 1]
        columns["rate"] = rate
        if spec.rate_form == 2:
            columns["rate_abs"] = np.abs(rate)
    if spec.width:
        columns["relay" if spec.relay else "play"] = raw[:, 2]
    if spec.width and spec.width2:
        columns["play2"] = raw[:, 4]
    if spec.tau_w:
        columns["warmup"] = np.exp(-(time_s - power_on_s) / spec.tau_w)
    if spec.tau_w and spec.tau_w2:
        columns["warmup2"] = np.exp(-(time_s - power_on_s) / spec.tau_w2)
    if spec.tau_e and spec.tau_e2 and not spec.series:
        columns["lag2"] = (raw[:, 3] - raw[:, 0]) / half
    return columns
