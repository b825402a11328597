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

__all__ = ["TERMS", "Spec", "kernel", "columns_of"]

TERMS = ("thermal_lag", "temp_rate", "hysteresis", "warmup")
"""The model's optional terms, by their vocabulary names, in the order they are judged."""


@dataclasses.dataclass(frozen=True)
class Spec:
    """Nonlinear parameters of a model: 0 or None means the term is absent."""

    tau_e: float = 0.0
    rate_form: int = 0  # 0 none, 1 one sensitivity, 2 heating and cooling apart
    width: float = 0.0
    tau_w: float = 0.0
    tau_r: float = 0.0  # the dT/dt filter's time constant, with rate_form

    def terms(self) -> list[str]:
        present = (self.tau_e > 0, self.rate_form > 0, self.width > 0, self.tau_w > 0)
        return [t for t, on in zip(TERMS, present) if on]

    def n_nonlinear(self) -> int:
        return int(self.tau_e > 0) + int(self.width > 0) + int(self.tau_w > 0) + int(self.rate_form > 0)


def kernel(time_s, temperature_c, state, spec: Spec) -> np.ndarray:
    """(T_e, dT/dt, play) of each sample; without a dT/dt term the filter runs at 1 s and its output is unused."""
    from gyrocomp.effects._stateful import advance

    out = np.empty((time_s.size, 3))
    advance(time_s, temperature_c, state, float(spec.tau_e), float(spec.tau_r or 1.0), 0.5 * float(spec.width), out)
    return out


def columns_of(raw, time_s, spec: Spec, power_on_s, centre, half, degree) -> dict:
    """The model's design columns of a spec from the kernel's (T_e, dT/dt, play) (no offsets)."""
    z = (raw[:, 0] - centre) / half
    columns = {f"z{k}": z**k for k in range(1, degree + 1)}
    if spec.rate_form:
        columns["rate"] = raw[:, 1]
        if spec.rate_form == 2:
            columns["rate_abs"] = np.abs(raw[:, 1])
    if spec.width:
        columns["play"] = raw[:, 2]
    if spec.tau_w:
        columns["warmup"] = np.exp(-(time_s - power_on_s) / spec.tau_w)
    return columns
