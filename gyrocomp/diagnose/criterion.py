r"""The criterion of the selection: a model of effects, fitted on a run, and its BIC.

Every model is the baseline (per-run offset, temperature polynomial, white
noise) plus a set of effects (:class:`Fitted`); it is scored by the
block-mean likelihood of :mod:`gyrocomp.effects.likelihood`, in which
deterministic effects are regressors and ``bias_instability`` /
``rate_random_walk`` are noise terms, on one run (:class:`Problem`):

.. math:: \mathrm{BIC} = -2 \log L + k \ln n

with ``k`` counting each effect's parameters in its fitted form
(:func:`_n_params`) [1]_. :meth:`gyrocomp.diagnose.search.Search.score`
sums it over the selection runs. A model applies to another run with its
per-run columns refitted and the rest frozen (:func:`holdout_fit`).

References
----------
.. [1] G. Schwarz, "Estimating the dimension of a model", Ann. Stat. 6(2), 461-464 (1978).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.diagnose.effects import DETERMINISTIC, KINDS, PER_RUN, Run, TemperatureScale, design, effect_columns
from gyrocomp.effects.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise, profile_deviance

__all__ = ["Fitted", "Problem", "fit_baseline", "holdout_fit", "residual_of", "sample_arw"]


@dataclasses.dataclass(frozen=True)
class Fitted:
    """A model fitted on the fit recording.

    Attributes
    ----------
    order : tuple of str
        Effects in the order they were added.
    spec : dict
        ``{deterministic effect: {nonlinear parameter: value}}``.
    noise : NoiseModel
    beta : ndarray
        Coefficients of the design columns `names`.
    names : list of str
    deviance : float
        ``-2 log L`` on the fit blocks.
    n_params : int
    bic : float
    """

    order: tuple
    spec: dict
    noise: NoiseModel
    beta: np.ndarray
    names: list
    deviance: float
    n_params: int
    bic: float

    @property
    def key(self) -> tuple:
        """A hashable key of the model's shape: its effects in order and their nonlinear parameters."""
        return (self.order, _spec_key(self.spec))


@dataclasses.dataclass
class Problem:
    """A run with its block means, covariance basis and temperature scaling.

    The block means of a design (:meth:`design_blocks`) and of one effect's
    columns (:meth:`effect_blocks`) are computed once per shape and kept
    read-only: the searches ask for the same grid points at every step.
    """

    run: Run
    settings: object
    scale: TemperatureScale | None
    poly_degree: int

    def __post_init__(self):
        self.y = block_means(self.run.rate_dps, self.run.n_per_block)
        self.basis = NoiseBasis(self.y.size, self.run.block_s, self.run.block_start_s)
        self._blocks = {}

    def design_blocks(self, spec):
        """Block means of the full-rate design of the baseline plus `spec` (:func:`~gyrocomp.diagnose.effects.design`), and its column names."""
        key = ("design", _spec_key(spec))
        if key not in self._blocks:
            X, names = design(self.run, spec, self.poly_degree, self.scale)
            self._blocks[key] = (_read_only(block_means(X, self.run.n_per_block)), tuple(names))
        X, names = self._blocks[key]
        return X, list(names)

    def effect_blocks(self, effect, params):
        """Block means of `effect`'s full-rate columns at `params` (:func:`~gyrocomp.diagnose.effects.effect_columns`), and their names."""
        key = (effect, tuple(sorted(params.items())))
        if key not in self._blocks:
            full, names = effect_columns(self.run, effect, params, self.poly_degree, self.scale)
            self._blocks[key] = (_read_only(block_means(full, self.run.n_per_block)), tuple(names))
        X, names = self._blocks[key]
        return X, list(names)

    def whitened(self, whitener, key, blocks):
        """Block-mean columns `blocks` (a callable returning them, called once per `key`) whitened by `whitener`.

        The eigenbasis rotation that every noise model of one family shares
        (:meth:`~gyrocomp.effects.likelihood.NoiseBasis.whitener`) is kept per
        family and `key`, so the searches, which whiten the same grid
        columns at each model's noise, only rescale them (the same products,
        byte for byte); other factorisations whiten the kept block means.
        """
        if ("blocks", key) not in self._blocks:
            self._blocks["blocks", key] = _read_only(blocks())
        raw = self._blocks["blocks", key]
        if whitener.family is None:
            return whitener.whiten(raw)
        if ("rotated", whitener.family, key) not in self._blocks:
            self._blocks["rotated", whitener.family, key] = _read_only(whitener.rotated(raw))
        return whitener.scaled(self._blocks["rotated", whitener.family, key])

    def own_columns(self, spec, effect) -> np.ndarray:
        """Mask of the columns of :meth:`design_blocks` at `spec` that `effect` adds (absent from the design without it)."""
        others = self.design_blocks({k: v for k, v in spec.items() if k != effect})[1]
        return np.array([n not in others for n in self.design_blocks(spec)[1]])

    def bic(self, deviance, n_params):
        return deviance + n_params * np.log(self.y.size)


def fit_baseline(problem: Problem) -> Fitted:
    """The baseline: offset + temperature polynomial + white noise (ARW)."""
    Xb, names = problem.design_blocks({})
    start = NoiseModel(arw=sample_arw(problem.run))
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, start, ("arw",))
    k = Xb.shape[1] + 1
    return Fitted((), {}, noise, beta, names, deviance, k, problem.bic(deviance, k))


def holdout_fit(problem: Problem, model: Fitted):
    """Apply `model` to another run: per-run columns refitted, the rest frozen.

    Returns
    -------
    deviance : float
        ``-2 log L`` of the holdout blocks.
    residual : ndarray, shape (n,)
        Full-rate rate minus the model [deg/s].
    n_fitted : int
        Coefficients re-estimated on this run.
    """
    X, names = design(problem.run, model.spec, problem.poly_degree, problem.scale)
    if names != model.names:
        raise ValueError(f"holdout design {names} differs from the fit design {model.names}")
    free = np.array([n in PER_RUN for n in names])
    fixed_part = X[:, ~free] @ model.beta[~free]
    Xb = block_means(X[:, free], problem.run.n_per_block)
    y = problem.y - block_means(fixed_part, problem.run.n_per_block)
    deviance, beta_free = profile_deviance(y, Xb, problem.basis.whitener(model.noise))
    residual = problem.run.rate_dps - fixed_part - X[:, free] @ beta_free
    return deviance, residual, int(free.sum())


def residual_of(problem: Problem, model: Fitted):
    """Full-rate residual of the fit run under `model` [deg/s]."""
    X, _ = design(problem.run, model.spec, problem.poly_degree, problem.scale)
    return problem.run.rate_dps - X @ model.beta


def _spec_key(spec: dict):
    return tuple(sorted((e, tuple(sorted(p.items()))) for e, p in spec.items()))


def _read_only(a):
    a.setflags(write=False)
    return a


def _with_own_noise(problem: Problem, model: Fitted) -> Fitted:
    """`model` with its noise terms refitted on another run (one realisation of a random walk can read larger)."""
    stochastic = ("arw",) + tuple(e for e in model.order if e not in DETERMINISTIC)
    Xb, _ = problem.design_blocks(model.spec)
    noise, _, _ = fit_noise(problem.y, Xb, problem.basis, model.noise, stochastic)
    return dataclasses.replace(model, noise=noise)


def _refit(problem: Problem, baseline: Fitted, order: tuple, spec: dict, noise: NoiseModel) -> Fitted:
    """Refit coefficients and noise of a model with given effects and nonlinear parameters."""
    stochastic = tuple(e for e in order if e not in DETERMINISTIC)
    values = dataclasses.asdict(noise)
    for e in ("bias_instability", "rate_random_walk"):
        if e not in stochastic:
            values[e] = 0.0
    if "bias_instability" not in stochastic:
        values["bias_correlation_s"] = 0.0
    Xb, names = problem.design_blocks(spec)
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, NoiseModel(**values), ("arw",) + stochastic)
    k = baseline.n_params + _n_params(order[len(baseline.order) :], spec, noise)
    return Fitted(order, spec, noise, beta, names, deviance, k, problem.bic(deviance, k))


def _n_params(effects, spec: dict, noise: NoiseModel) -> int:
    """Free parameters of `effects` on one run, each in its fitted form (:meth:`~gyrocomp.effects.vocabulary.Effect.n_params_of`;
    ``bias_instability``'s form is in `noise`)."""
    return sum(KINDS[e].n_params_of(_form(e, spec, noise)) for e in effects)


def _form(effect: str, spec: dict, noise: NoiseModel) -> dict:
    """The fitted nonlinear parameters of `effect`: its `spec` entry, or for ``bias_instability`` the Markov form's correlation time."""
    if effect == "bias_instability":
        return {"correlation_s": noise.bias_correlation_s} if noise.bias_correlation_s else {}
    return spec.get(effect, {})


def sample_arw(run: Run) -> float:
    """White level from first differences: ``var(diff) / 2`` per sample, ``N = sigma / sqrt(fs)``.

    Half the variance of first differences is the Allan variance at the
    sample interval, ``N^2 fs`` plus terms of order ``1 / fs`` smaller
    (IEEE Std 952): the white level the shortest timescales show, which
    slow drift cannot inflate.
    """
    if run.gapped:  # differences within blocks only: none across a gap
        d = np.diff(run.rate_dps[: run.n_blocks * run.n_per_block].reshape(run.n_blocks, -1), axis=1)
    else:
        d = np.diff(run.rate_dps)
    return float(np.sqrt(max(np.var(d) / 2.0, 1e-300) / run.fs_hz))
