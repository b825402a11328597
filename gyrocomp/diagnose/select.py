"""Greedy forward selection of effects by BIC, with a held-out check.

Every model is the baseline (per-run offset, temperature polynomial, white
noise) plus a set of effects; it is scored by the block-mean likelihood of
:mod:`gyrocomp.diagnose.likelihood`, in which deterministic effects are
regressors and ``bias_instability`` / ``rate_random_walk`` are noise terms.
One step adds, for each remaining effect, that effect to the current model,
fits its nonlinear parameter on a log grid (then a bounded refinement) with
the noise held, and refits the noise terms by maximum likelihood. The effect
with the lowest

.. math:: \\mathrm{BIC} = -2 \\log L + k \\ln n_\\mathrm{blocks}

is kept when it lowers the BIC by more than `bic_margin` **and**, with a
holdout recording, its fitted parameters (offset and periodic phase
re-estimated on the holdout, everything else frozen) lower the holdout's
``-2 log L`` by more than `holdout_margin`. Otherwise the next best effect is
tried; the selection stops when none passes. With no effect kept the report
names none: the baseline explains the recording.

Look-alikes are told apart by the likelihood of their shapes, not by a
rule: thermal lag must reproduce the decaying transient after every step,
temperature-rate sensitivity the square pulses of dT/dt that vanish in a
soak, hysteresis an offset that holds through a soak; a rate ramp is a line
in time while a random walk only widens the covariance, and flicker adds
covariance at every lag while a random walk adds it mostly at long lags.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize

from gyrocomp.diagnose.effects import (
    DETERMINISTIC,
    N_PARAMS,
    PER_RUN,
    Run,
    TemperatureScale,
    design,
    effect_columns,
    periodic_block_means,
)
from gyrocomp.diagnose.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise, profile_deviance

__all__ = ["Fitted", "Problem", "fit_baseline", "extend", "holdout_fit", "greedy"]


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


@dataclasses.dataclass
class Problem:
    """A run with its block means, covariance basis and temperature scaling."""

    run: Run
    settings: object
    scale: TemperatureScale | None
    poly_degree: int

    def __post_init__(self):
        self.y = block_means(self.run.rate_dps, self.run.n_per_block)
        self.basis = NoiseBasis(self.y.size, self.run.block_s)

    def design_blocks(self, spec):
        X, names = design(self.run, spec, self.poly_degree, self.scale)
        return block_means(X, self.run.n_per_block), names

    def bic(self, deviance, n_params):
        return deviance + n_params * np.log(self.y.size)


def fit_baseline(problem: Problem) -> Fitted:
    """The baseline: offset + temperature polynomial + white noise (ARW)."""
    Xb, names = problem.design_blocks({})
    start = NoiseModel(arw=_arw_guess(problem.run))
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, start, ("arw",))
    k = Xb.shape[1] + 1
    return Fitted((), {}, noise, beta, names, deviance, k, problem.bic(deviance, k))


def extend(problem: Problem, current: Fitted, effect: str) -> Fitted:
    """`current` plus `effect`, its parameters fitted on the fit run."""
    stochastic = [e for e in current.order if e not in DETERMINISTIC]
    spec = dict(current.spec)
    if effect in DETERMINISTIC:
        spec[effect] = _best_nonlinear(problem, current, effect)
    else:
        stochastic.append(effect)
    start_values = dataclasses.asdict(current.noise)
    for e in stochastic:
        if not start_values[e]:
            # Start the new term where it matches the white level at T_b.
            scale = {"bias_instability": 1.0, "rate_random_walk": 1.0 / np.sqrt(problem.run.block_s)}[e]
            start_values[e] = 0.3 * current.noise.arw / np.sqrt(problem.run.block_s) * scale
    Xb, names = problem.design_blocks(spec)
    noise, deviance, beta = fit_noise(
        problem.y, Xb, problem.basis, NoiseModel(**start_values), ("arw",) + tuple(stochastic)
    )
    k = current.n_params + N_PARAMS[effect]
    return Fitted(current.order + (effect,), spec, noise, beta, names, deviance, k, problem.bic(deviance, k))


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


def greedy(fit: Problem, holdout: Problem | None, candidates, callback=None, start: Fitted | None = None):
    """Forward selection (see the module docstring), from `start` (default: the baseline).

    Returns
    -------
    selected : Fitted
        The final model.
    first_step : dict
        ``{effect: Fitted}``: each candidate added alone to the baseline.
    steps : list of dict
        Per step: ``tried`` (each tried effect's ``delta_bic`` and
        ``delta_holdout_deviance``, None where the fit check already failed),
        ``accepted`` (or None) and ``dropped`` (by the backward check).
    baseline : Fitted
        The model the selection started from.
    """
    s = fit.settings
    baseline = start if start is not None else fit_baseline(fit)
    current = baseline
    current_hold = holdout_fit(holdout, current)[0] if holdout is not None else None
    remaining = list(candidates)
    first_step, steps = {}, []
    rounds = 0
    total = len(remaining)
    done = 0
    while remaining and len(current.order) - len(baseline.order) < s.max_effects:
        trials = {}
        for effect in remaining:
            trials[effect] = extend(fit, current, effect)
            done += 1
            if callback is not None:
                callback(done, total)
        if current is baseline:
            first_step = dict(trials)
        record = {}
        accepted = None
        for effect in sorted(trials, key=lambda e: trials[e].bic):
            model = trials[effect]
            delta_bic = model.bic - current.bic
            delta_hold = None
            passed = delta_bic < -s.bic_margin
            if passed and holdout is not None:
                hold_dev = holdout_fit(holdout, model)[0]
                delta_hold = hold_dev - current_hold
                passed = delta_hold < -s.holdout_margin
            record[effect] = {"delta_bic": delta_bic, "delta_holdout_deviance": delta_hold}
            if passed:
                accepted = effect
                if holdout is not None:
                    current_hold = hold_dev
                break
        steps.append({"tried": record, "accepted": accepted, "dropped": []})
        if accepted is None:
            break
        current = trials[accepted]
        remaining.remove(accepted)
        current, dropped = _backward(fit, baseline, current, accepted, s.bic_margin)
        if dropped:
            steps[-1]["dropped"] = dropped
            remaining += [e for e in dropped if e not in remaining]
            if holdout is not None:
                current_hold = holdout_fit(holdout, current)[0]
        rounds += 1
        if rounds > 2 * len(candidates):
            break
        total = done + len(remaining)
    if callback is not None:
        callback(total, total)
    return current, first_step, steps, baseline


def _backward(problem: Problem, baseline: Fitted, current: Fitted, added: str, margin: float):
    """Drop earlier effects that the newly `added` one made redundant.

    An effect selected early as a stand-in (a random walk absorbing a
    warm-up and an interference before either was modelled) no longer earns
    its BIC margin once the real cause is in; it is removed (stepwise
    selection) and may be chosen again later.
    """
    dropped = []
    changed = True
    while changed:
        changed = False
        for effect in current.order[len(baseline.order) :]:
            if effect == added:
                continue
            order = tuple(e for e in current.order if e != effect)
            spec = {k: v for k, v in current.spec.items() if k != effect}
            smaller = _refit(problem, baseline, order, spec, current.noise)
            if smaller.bic < current.bic + margin:
                current, changed = smaller, True
                dropped.append(effect)
                break
    return current, dropped


def _refit(problem: Problem, baseline: Fitted, order: tuple, spec: dict, noise: NoiseModel) -> Fitted:
    """Refit coefficients and noise of a model with given effects and nonlinear parameters."""
    stochastic = tuple(e for e in order if e not in DETERMINISTIC)
    values = dataclasses.asdict(noise)
    for e in ("bias_instability", "rate_random_walk"):
        if e not in stochastic:
            values[e] = 0.0
    Xb, names = problem.design_blocks(spec)
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, NoiseModel(**values), ("arw",) + stochastic)
    k = baseline.n_params + sum(N_PARAMS[e] for e in order[len(baseline.order) :])
    return Fitted(order, spec, noise, beta, names, deviance, k, problem.bic(deviance, k))


def _best_nonlinear(problem: Problem, current: Fitted, effect: str) -> dict:
    """Grid search (then bounded refinement in log scale) of the effect's nonlinear parameter.

    The noise is held at the current model's; the other columns are block-averaged once.
    """
    s = problem.settings
    run = problem.run
    if effect in ("temp_rate", "rate_ramp"):
        return {}
    w = problem.basis.whitener(current.noise)
    length_s = run.n_blocks * run.block_s
    X, names = design(run, current.spec, problem.poly_degree, problem.scale)
    if effect == "thermal_lag":
        keep = [i for i, n in enumerate(names) if not n.startswith("temperature^")]
        X = X[:, keep]
    # Whitening is linear: whiten the fixed columns and y once, then only the candidate's.
    base_w = w.whiten(block_means(X, run.n_per_block))
    y_w = w.whiten(problem.y)
    constant = w.logdet + problem.y.size * np.log(2.0 * np.pi)

    def deviance(params):
        if effect == "periodic":
            cols = periodic_block_means(run, params["period_s"])
        else:
            full, _ = effect_columns(run, effect, params, problem.poly_degree, problem.scale)
            cols = block_means(full, run.n_per_block)
        Xw = np.hstack([base_w, w.whiten(cols)])
        beta, *_ = linalg.lstsq(Xw, y_w, cond=1e-12, lapack_driver="gelsy", check_finite=False)
        r = y_w - Xw @ beta
        return constant + float(r @ r)

    if effect == "hysteresis":
        grid = [float(v) for v in s.hysteresis_deadband_c]
        values = [deviance({"deadband_c": v}) for v in grid]
        return {"deadband_c": grid[int(np.argmin(values))]}
    if effect == "periodic":
        f_lo = 2.0 / length_s
        f_hi = 1.0 / (s.periodic_min_blocks * run.block_s)
        grid = 1.0 / np.arange(f_lo, f_hi, 1.0 / (s.periodic_oversample * length_s))
        key = "period_s"
    else:
        lo, hi = s.thermal_lag_tau_s if effect == "thermal_lag" else s.warmup_tau_s
        grid = np.geomspace(lo, hi, s.tau_grid_points)
        key = "tau_s"
    values = np.array([deviance({key: float(v)}) for v in grid])
    i = int(np.argmin(values))
    a, b = sorted((np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, grid.size - 1)])))
    if b > a:
        best = optimize.minimize_scalar(
            lambda z: deviance({key: float(np.exp(z))}), bounds=(a, b), method="bounded", options={"xatol": 1e-3}
        )
        if best.fun < values[i]:
            return {key: float(np.exp(best.x))}
    return {key: float(grid[i])}


def _arw_guess(run: Run) -> float:
    """White level from first differences: ``var(diff) / 2`` per sample, ``N = sigma / sqrt(fs)``."""
    d = np.diff(run.rate_dps)
    return float(np.sqrt(max(np.var(d) / 2.0, 1e-300) / run.fs_hz))
