"""The candidate effects as regressors of the block-mean likelihood.

Every deterministic effect of the vocabulary (DESIGN.md, "The simulator and
the sim-to-real gap") enters the model as columns of the design matrix,
built by its object in the registry :data:`gyrocomp.effects.vocabulary.KINDS`
that the simulator also draws its bias from, so that the diagnosis fits
exactly the terms the simulator would add:

==============  ==========================================  ======================  ==========
effect          columns                                     nonlinear parameter     signature
==============  ==========================================  ======================  ==========
baseline        1, T~, T~^2, T~^3 (T~ scaled temperature)   --                      --
thermal_lag     the polynomial in the element temperature    ``tau_s`` (grid)        follows a lagged T: transients that decay with tau after a step
temp_rate       dT/dt [and |dT/dt|: heat, cool apart]     form (lowest BIC)       proportional to dT/dt, zero in a soak
hysteresis      heating/cooling branch (+1/-1), power-on    ``deadband_c`` (grid)   offset by last direction, kept through a soak
warmup          exp(-(t - t0) / tau)                        ``tau_s`` (grid)        one decay from power-on
rate_ramp       ((t - t0) / 1 h)^p, p = 1 the line          form; ``power`` (grid)  a drift in time, straight or bent
periodic        sin, cos (2 pi k t / P), k = 1..H           ``period_s`` (grid), H  fixed period, unrelated to T
==============  ==========================================  ======================  ==========

The stochastic effects (``bias_instability``, ``rate_random_walk``) are
terms of the noise covariance (:mod:`gyrocomp.effects.likelihood`), not
columns; ``bias_instability`` is flicker or, where the BIC pays for its
correlation time, its Markov form (:func:`gyrocomp.diagnose.select.extend`). The per-run offset, for ``periodic`` the phase (every harmonic's) and for ``hysteresis``
the level before the first excursion beyond the deadband (the branch the part
was left in before power-on) are re-estimated
on every run (a power-on constant and an interference phase are not
properties that carry over from one run to the next); everything else is
fitted on the fit recording only.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from gyrocomp.effects import shapes
from gyrocomp.effects.vocabulary import DETERMINISTIC, EFFECTS, KINDS, NEEDS_TEMPERATURE, PER_RUN, STOCHASTIC
from gyrocomp.effects.vocabulary.thermal_lag import polynomial_columns

__all__ = [
    "EFFECTS",
    "KINDS",
    "DETERMINISTIC",
    "STOCHASTIC",
    "NEEDS_TEMPERATURE",
    "PER_RUN",
    "n_params_runs",
    "Run",
    "TemperatureScale",
    "design",
    "polynomial_columns",
    "effect_columns",
    "periodic_block_means",
    "effect_params",
]


def n_params_runs(effect: str, n_runs: int, params=None) -> int:
    """Free parameters `effect` adds at nonlinear parameters `params` when fitted on `n_runs` runs together
    (:meth:`gyrocomp.effects.vocabulary.Effect.n_params_runs`).

    >>> n_params_runs("periodic", 2), n_params_runs("warmup", 2)
    (5, 2)
    """
    return KINDS[effect].n_params_runs(n_runs, params)




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
        Savitzky-Golay window of dT/dt [s] (:func:`gyrocomp.effects.shapes.temperature_rate`):
        a measured temperature is noisy and quantised.
    gapped : bool
        The samples are whole blocks of segments with gaps between them
        (``time_s`` jumps at a gap; no block spans one).
    arw_sample : float or None
        White level ``N`` [deg/s/sqrt(Hz)] of the recording at its own
        sample rate, before any reduction (:func:`gyrocomp.diagnose.select.sample_arw`).
    """

    name: str
    time_s: np.ndarray
    rate_dps: np.ndarray
    temperature_c: np.ndarray | None
    fs_hz: float
    n_per_block: int
    rate_smooth_s: float = 0.0
    gapped: bool = False
    arw_sample: float | None = None

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

    @functools.cached_property
    def temperature_rate_c_per_s(self) -> np.ndarray:
        """dT/dt of the measured temperature [degC/s] (:func:`gyrocomp.effects.shapes.temperature_rate` over
        `rate_smooth_s`), computed once: every design with ``temp_rate`` takes it."""
        rate = shapes.temperature_rate(self.time_s, self.temperature_c, smooth_s=self.rate_smooth_s)
        rate.setflags(write=False)
        return rate

    @functools.cached_property
    def block_centre_s(self) -> np.ndarray:
        """Mean time of each block's samples [s] (computed once: a period grid asks for it at every period)."""
        m = self.n_per_block
        return self.time_s[: self.n_blocks * m].reshape(self.n_blocks, m).mean(axis=1)


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


def effect_columns(run: Run, effect: str, params: dict, poly_degree=3, scale=None):
    """Full-rate columns of one deterministic effect (``thermal_lag``: the lagged polynomial)."""
    return KINDS[effect].columns(run, params, poly_degree, scale)


def periodic_block_means(run: Run, period_s, harmonics: int = 1):
    """Block means of ``sin`` and ``cos(2 pi k t / P)``, ``k = 1..harmonics``, in closed form.

    For ``m`` samples ``t_c + (j - (m-1)/2) h`` the mean of ``exp(i w t)`` is
    ``exp(i w t_c) sin(m w h / 2) / (m sin(w h / 2))`` (Dirichlet kernel), so
    a period grid costs O(blocks) per period instead of O(samples).

    Returns
    -------
    ndarray, shape (n_blocks, 2 harmonics)
        Columns in the order of :func:`gyrocomp.effects.vocabulary.periodic.harmonic_names`.
    """
    m = run.n_per_block
    h = 1.0 / run.fs_hz
    centre = run.block_centre_s
    cols = []
    for k in range(1, int(harmonics) + 1):
        w = 2.0 * np.pi * k / period_s
        half = 0.5 * w * h
        kernel = 1.0 if abs(np.sin(half)) < 1e-15 else np.sin(m * half) / (m * np.sin(half))
        cols += [np.sin(w * centre) * kernel, np.cos(w * centre) * kernel]
    return np.column_stack(cols)


def effect_params(effect: str, spec: dict, beta: np.ndarray, names: list, noise) -> dict:
    """Fitted parameters of `effect` with their units, as the simulator's config names them."""
    return KINDS[effect].report(dict(zip(names, beta)), spec.get(effect, {}), noise)
