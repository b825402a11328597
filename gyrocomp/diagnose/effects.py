"""The candidate effects as regressors of the block-mean likelihood.

Every deterministic effect of the vocabulary (DESIGN.md, "The simulator and
the sim-to-real gap") enters the model as columns of the design matrix,
built from the simulator's own shapes in :mod:`gyrocomp.sim.effects`, so
that the diagnosis fits exactly the terms the simulator would add:

==============  ==========================================  ======================  ==========
effect          columns                                     nonlinear parameter     signature
==============  ==========================================  ======================  ==========
baseline        1, T~, T~^2, T~^3 (T~ scaled temperature)   --                      --
thermal_lag     the polynomial in the element temperature    ``tau_s`` (grid)        follows a lagged T: transients that decay with tau after a step
temp_rate       dT/dt                                       --                      proportional to dT/dt, zero in a soak
hysteresis      heating/cooling branch (+1/-1)              ``deadband_c`` (grid)   offset by last direction, kept through a soak
warmup          exp(-(t - t0) / tau)                        ``tau_s`` (grid)        one decay from power-on
rate_ramp       t - t0                                      --                      straight line in time
periodic        sin, cos (2 pi t / P)                       ``period_s`` (grid)     fixed period, unrelated to T
==============  ==========================================  ======================  ==========

The stochastic effects (``bias_instability``, ``rate_random_walk``) are
terms of the noise covariance (:mod:`gyrocomp.diagnose.likelihood`), not
columns. The per-run offset and, for ``periodic``, the phase are re-estimated
on every run (a power-on constant and an interference phase are not
properties that carry over from one run to the next); everything else is
fitted on the fit recording only.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.sim import effects as shapes

__all__ = [
    "EFFECTS",
    "DETERMINISTIC",
    "STOCHASTIC",
    "NEEDS_TEMPERATURE",
    "N_PARAMS",
    "Run",
    "design",
    "effect_params",
]

DETERMINISTIC = ("thermal_lag", "temp_rate", "hysteresis", "warmup", "rate_ramp", "periodic")
STOCHASTIC = ("bias_instability", "rate_random_walk")
EFFECTS = DETERMINISTIC + STOCHASTIC
"""The vocabulary of DESIGN.md, in the order of :data:`gyrocomp.sim.model.EFFECTS`."""

NEEDS_TEMPERATURE = ("thermal_lag", "temp_rate", "hysteresis")

N_PARAMS = {
    "thermal_lag": 1,
    "temp_rate": 1,
    "hysteresis": 2,
    "warmup": 2,
    "rate_ramp": 1,
    "periodic": 3,
    "bias_instability": 1,
    "rate_random_walk": 1,
}
"""Free parameters each effect adds (grid-searched ones count as one)."""

PER_RUN = ("offset", "periodic_sin", "periodic_cos")
"""Columns re-estimated on every run."""

_HOUR = 3600.0


@dataclasses.dataclass(frozen=True)
class Run:
    """One recording prepared for the likelihood.

    Attributes
    ----------
    name : str
    time_s, rate_dps : ndarray, shape (n,)
    temperature_c : ndarray or None
    fs_hz : float
    n_per_block : int
        Samples per block of the likelihood.
    """

    name: str
    time_s: np.ndarray
    rate_dps: np.ndarray
    temperature_c: np.ndarray | None
    fs_hz: float
    n_per_block: int

    @property
    def block_s(self) -> float:
        return self.n_per_block / self.fs_hz

    @property
    def n_blocks(self) -> int:
        return self.rate_dps.size // self.n_per_block


@dataclasses.dataclass(frozen=True)
class TemperatureScale:
    """``T~ = (T - centre) / half_range``, fixed on the fit recording and reused on the holdout."""

    centre_c: float
    half_range_c: float

    @classmethod
    def of(cls, temperature_c):
        lo, hi = float(np.min(temperature_c)), float(np.max(temperature_c))
        return cls(0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-3))


def design(run: Run, spec: dict, poly_degree: int, scale: TemperatureScale | None):
    """Full-rate design matrix of the baseline plus the effects in `spec`.

    Parameters
    ----------
    run : Run
    spec : dict
        ``{effect: {nonlinear parameter: value}}`` for deterministic effects.
    poly_degree : int
        Degree of the baseline temperature polynomial (0 without temperature).
    scale : TemperatureScale or None

    Returns
    -------
    X : ndarray, shape (n, p)
    names : list of str
        Column names; ``offset`` first.
    """
    t = run.time_s
    cols = [np.ones_like(t)]
    names = ["offset"]
    if run.temperature_c is not None and poly_degree > 0:
        temperature = run.temperature_c
        if "thermal_lag" in spec:
            temperature = shapes.element_temperature(t, temperature, spec["thermal_lag"]["tau_s"])
        z = (temperature - scale.centre_c) / scale.half_range_c
        for k in range(1, poly_degree + 1):
            cols.append(z**k)
            names.append(f"temperature^{k}")
    for effect in DETERMINISTIC:
        if effect not in spec or effect == "thermal_lag":
            continue
        p = spec[effect]
        if effect == "temp_rate":
            cols.append(shapes.temperature_rate(t, run.temperature_c))
            names.append("temp_rate")
        elif effect == "hysteresis":
            cols.append(shapes.hysteresis_branch(t, run.temperature_c, p["deadband_c"]))
            names.append("hysteresis")
        elif effect == "warmup":
            cols.append(shapes.warmup(t, 1.0, p["tau_s"]))
            names.append("warmup")
        elif effect == "rate_ramp":
            cols.append(shapes.rate_ramp(t, 1.0 / _HOUR))
            names.append("rate_ramp")
        else:
            cols.append(shapes.periodic(t, 1.0, p["period_s"], 0.0))
            cols.append(shapes.periodic(t, 1.0, p["period_s"], 0.5 * np.pi))
            names += ["periodic_sin", "periodic_cos"]
    return np.column_stack(cols), names


def effect_params(effect: str, spec: dict, beta: np.ndarray, names: list, noise) -> dict:
    """Fitted parameters of `effect` with their units, as the simulator's config names them."""
    coef = dict(zip(names, beta))
    if effect == "thermal_lag":
        return {"tau_s": {"value": spec["thermal_lag"]["tau_s"], "unit": "s"}}
    if effect == "temp_rate":
        return {"coefficient_dps_per_c_per_s": {"value": coef["temp_rate"], "unit": "deg/s per degC/s"}}
    if effect == "hysteresis":
        return {
            "amplitude_dps": {"value": coef["hysteresis"], "unit": "deg/s"},
            "deadband_c": {"value": spec["hysteresis"]["deadband_c"], "unit": "degC"},
        }
    if effect == "warmup":
        return {
            "amplitude_dps": {"value": coef["warmup"], "unit": "deg/s"},
            "tau_s": {"value": spec["warmup"]["tau_s"], "unit": "s"},
        }
    if effect == "rate_ramp":
        return {"slope_dps_per_s": {"value": coef["rate_ramp"] / _HOUR, "unit": "deg/s/s"}}
    if effect == "periodic":
        a, b = coef["periodic_sin"], coef["periodic_cos"]
        return {
            "amplitude_dps": {"value": float(np.hypot(a, b)), "unit": "deg/s"},
            "period_s": {"value": spec["periodic"]["period_s"], "unit": "s"},
            "phase_rad": {"value": float(np.arctan2(b, a)), "unit": "rad (fit run)"},
        }
    terms = noise.datasheet_units()
    if effect == "bias_instability":
        return {"b_deg_per_h": terms["bias_instability"]}
    return {"k_deg_per_h_per_sqrt_h": terms["rate_random_walk"]}
