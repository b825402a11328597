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
from gyrocomp.sim.model import EFFECTS  # the vocabulary of DESIGN.md, in report order

__all__ = [
    "EFFECTS",
    "DETERMINISTIC",
    "STOCHASTIC",
    "NEEDS_TEMPERATURE",
    "N_PARAMS",
    "n_params_runs",
    "Run",
    "design",
    "polynomial_columns",
    "effect_columns",
    "periodic_block_means",
    "effect_params",
]

STOCHASTIC = ("bias_instability", "rate_random_walk")
"""Effects that enter the likelihood as covariance terms."""
DETERMINISTIC = tuple(e for e in EFFECTS if e not in STOCHASTIC)
"""Effects that enter as regressors on the rate."""

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


def n_params_runs(effect: str, n_runs: int) -> int:
    """Free parameters `effect` adds when fitted on `n_runs` runs together.

    Its :data:`PER_RUN` columns are fitted once per run: a sinusoid whose
    phase each run re-estimates costs its period plus an amplitude and a
    phase per run (``3 + 2 (n_runs - 1)``); every other effect costs
    :data:`N_PARAMS` whatever the number of runs.

    >>> n_params_runs("periodic", 2), n_params_runs("warmup", 2)
    (5, 2)
    """
    per_run = sum(1 for name in PER_RUN if name.startswith(f"{effect}_"))
    return N_PARAMS[effect] + per_run * (n_runs - 1)

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
    rate_smooth_s : float
        Savitzky-Golay window of dT/dt [s] (:func:`gyrocomp.sim.effects.temperature_rate`):
        a measured temperature is noisy and quantised.
    gapped : bool
        The samples are whole blocks of segments with gaps between them
        (``time_s`` jumps at a gap; no block spans one).
    """

    name: str
    time_s: np.ndarray
    rate_dps: np.ndarray
    temperature_c: np.ndarray | None
    fs_hz: float
    n_per_block: int
    rate_smooth_s: float = 0.0
    gapped: bool = False

    @property
    def block_s(self) -> float:
        return self.n_per_block / self.fs_hz

    @property
    def block_start_s(self) -> np.ndarray | None:
        """Start of each block after the first sample [s] when `gapped`, else None (contiguous blocks)."""
        if not self.gapped:
            return None
        return self.time_s[: self.n_blocks * self.n_per_block : self.n_per_block] - self.time_s[0]

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
    parts = [(np.ones((run.time_s.size, 1)), ["offset"])]
    if "thermal_lag" not in spec:
        parts.append(polynomial_columns(run, None, poly_degree, scale))
    for effect in DETERMINISTIC:
        if effect in spec:
            parts.append(effect_columns(run, effect, spec[effect], poly_degree, scale))
    return np.hstack([p[0] for p in parts]), [n for p in parts for n in p[1]]


def polynomial_columns(run: Run, tau_s, poly_degree, scale):
    """``T~^k``, k = 1..degree, of the measured temperature or (``tau_s``) of the element's."""
    if run.temperature_c is None or poly_degree == 0:
        return np.empty((run.time_s.size, 0)), []
    temperature = run.temperature_c
    if tau_s is not None:
        temperature = shapes.element_temperature(run.time_s, temperature, tau_s)
    z = (temperature - scale.centre_c) / scale.half_range_c
    return np.column_stack([z**k for k in range(1, poly_degree + 1)]), [f"temperature^{k}" for k in range(1, poly_degree + 1)]


def effect_columns(run: Run, effect: str, params: dict, poly_degree=3, scale=None):
    """Full-rate columns of one deterministic effect (``thermal_lag``: the lagged polynomial)."""
    t = run.time_s
    if effect == "thermal_lag":
        return polynomial_columns(run, params["tau_s"], poly_degree, scale)
    if effect == "temp_rate":
        col = shapes.temperature_rate(t, run.temperature_c, smooth_s=run.rate_smooth_s)
    elif effect == "hysteresis":
        col = shapes.hysteresis_branch(t, run.temperature_c, params["deadband_c"])
    elif effect == "warmup":
        col = shapes.warmup(t, 1.0, params["tau_s"])
    elif effect == "rate_ramp":
        col = shapes.rate_ramp(t, 1.0 / _HOUR)
    else:
        sin = shapes.periodic(t, 1.0, params["period_s"], 0.0)
        cos = shapes.periodic(t, 1.0, params["period_s"], 0.5 * np.pi)
        return np.column_stack([sin, cos]), ["periodic_sin", "periodic_cos"]
    return col[:, None], [effect]


def periodic_block_means(run: Run, period_s):
    """Block means of ``sin`` and ``cos(2 pi t / P)``, in closed form.

    For ``m`` samples ``t_c + (k - (m-1)/2) h`` the mean of ``exp(i w t)`` is
    ``exp(i w t_c) sin(m w h / 2) / (m sin(w h / 2))`` (Dirichlet kernel), so
    a period grid costs O(blocks) per period instead of O(samples).
    """
    m = run.n_per_block
    h = 1.0 / run.fs_hz
    centre = run.time_s[: run.n_blocks * m].reshape(run.n_blocks, m).mean(axis=1)
    w = 2.0 * np.pi / period_s
    half = 0.5 * w * h
    kernel = 1.0 if abs(np.sin(half)) < 1e-15 else np.sin(m * half) / (m * np.sin(half))
    return np.column_stack([np.sin(w * centre), np.cos(w * centre)]) * kernel


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
