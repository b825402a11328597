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
holdout recording, it lowers the holdout's ``-2 log L`` by more than
`holdout_margin` (:func:`holdout_gain`: a noise term with its fitted value;
a deterministic effect with its fitted shape, scaled on the holdout -- the
check asks that the shape *replicate* in a run it never saw). Otherwise the
next best effect is tried. A deterministic effect that passes both checks
still waits when a noise term of the same step passes the fit check and
explains the holdout better (:func:`_noise_rival`: a sinusoid or a ramp
fitted to one run's slowest flicker wander). When none passes, no swap
(below) helps and a holdout is given, an effect may still enter on the
**joint** likelihood of both runs, which adds the evidence of the two: a deterministic effect with
coefficients shared, offsets and noise realisations per run
(:func:`joint_gain`; a random walk does not repeat between runs, a
deterministic effect does), a noise term with its value shared
(:func:`joint_noise_gain`). It must lower the joint BIC by more than
`bic_margin` and each run must point the same way. Its parameters are
still fitted on the fit run only, so the held-out gap stays a figure of
parameters that never saw the holdout, though the holdout then took part in
the selection. The selection stops when nothing passes. Adding a
deterministic effect refits the nonlinear parameters of those already in
(a warm-up fitted alone stretches its time constant over a ramp); a
backward check drops effects that a newer one made redundant. With no
effect kept the report names none: the baseline explains the recording.

Greedy steps can stop at one noise term standing in for two causes (a
random walk absorbing flicker and a warm-up or hysteresis: neither alone
beats it), or at the look-alike of a deterministic effect. A swap step
(:func:`_swap`) then tries replacing each selected noise term by the other
noise term, a deterministic effect or both (kept when it lowers the BIC,
and the BIC plus the holdout's ``-2 log L``), then each selected
deterministic effect by another (kept when it lowers the joint BIC of both
runs); every new effect must earn `bic_margin`. It returns to
the forward steps; a set already visited ends the search. Swaps come before
the joint criterion: a weak noise term admitted on two runs beside a
stand-in would lock the stand-in in.

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
    KINDS,
    PER_RUN,
    Run,
    TemperatureScale,
    design,
    effect_columns,
    n_params_runs,
    periodic_block_means,
)
from gyrocomp.diagnose.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise, fit_noise_runs, profile_deviance

__all__ = [
    "Fitted",
    "Problem",
    "fit_baseline",
    "extend",
    "holdout_fit",
    "holdout_gain",
    "joint_gain",
    "joint_noise_gain",
    "greedy",
    "sample_arw",
]

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
        self.basis = NoiseBasis(self.y.size, self.run.block_s, self.run.block_start_s)

    def design_blocks(self, spec):
        X, names = design(self.run, spec, self.poly_degree, self.scale)
        return block_means(X, self.run.n_per_block), names

    def bic(self, deviance, n_params):
        return deviance + n_params * np.log(self.y.size)


def fit_baseline(problem: Problem) -> Fitted:
    """The baseline: offset + temperature polynomial + white noise (ARW)."""
    Xb, names = problem.design_blocks({})
    start = NoiseModel(arw=sample_arw(problem.run))
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, start, ("arw",))
    k = Xb.shape[1] + 1
    return Fitted((), {}, noise, beta, names, deviance, k, problem.bic(deviance, k))


def extend(problem: Problem, current: Fitted, effect: str) -> Fitted:
    """`current` plus `effect`, its parameters fitted on the fit run."""
    stochastic = [e for e in current.order if e not in DETERMINISTIC]
    spec = dict(current.spec)
    if effect in DETERMINISTIC:
        spec[effect] = _best_nonlinear(problem, current, effect)
        # The earlier effects' nonlinear parameters were fitted without this
        # one (a warm-up fitted alone stretches its tau over a ramp): refit
        # each with the new effect in (one coordinate-descent pass).
        for other in current.spec:
            if KINDS[other].nonlinear:
                trial = dataclasses.replace(current, spec=spec)
                spec[other] = _best_nonlinear(problem, trial, other)
    else:
        stochastic.append(effect)
    Xb, names = problem.design_blocks(spec)
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, current.noise, ("arw",) + tuple(stochastic))
    k = current.n_params + KINDS[effect].n_params
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
    """Forward selection with swaps (see the module docstring), from `start` (default: the baseline).

    Returns
    -------
    selected : Fitted
        The final model.
    first_step : dict
        ``{effect: Fitted}``: each candidate added alone to the baseline.
    steps : list of dict
        Per step: ``tried`` (each tried effect's ``delta_bic`` and
        ``delta_holdout_deviance``, None where the fit check already failed),
        ``accepted`` (or None) and ``dropped`` (by the backward check); a
        swap step has ``swapped`` (``{"out": [...], "in": [...]}``) instead.
    baseline : Fitted
        The model the selection started from.
    """
    s = fit.settings
    baseline = start if start is not None else fit_baseline(fit)
    current = baseline
    first_step, steps = {}, []
    progress = _Progress(callback, len(candidates))
    seen = {_key(current)}
    for _ in range(2 * len(candidates) + 1):
        current = _forward(fit, holdout, baseline, current, candidates, steps, first_step, progress, joint=False)
        swapped = _swap(fit, holdout, baseline, current, candidates, progress)
        if swapped is not None and _key(swapped[0]) not in seen:
            current, step = swapped
            seen.add(_key(current))
            steps.append(step)
            continue
        if holdout is None:
            break
        # Only when neither a forward step nor a swap helps does the joint
        # likelihood of both runs get its say: a weak noise term entering
        # beside a stand-in would otherwise lock the stand-in in.
        joined = _forward(fit, holdout, baseline, current, candidates, steps, first_step, progress, joint=True)
        if _key(joined) in seen:
            break
        current = joined
        seen.add(_key(current))
    progress.finish()
    return current, first_step, steps, baseline


class _Progress:
    """Counts candidate fits for a ``callback(done, total)``."""

    def __init__(self, callback, total):
        self.callback, self.done, self.total = callback, 0, total

    def tick(self, more=0):
        self.done += 1
        self.total = max(self.total, self.done + more)
        if self.callback is not None:
            self.callback(self.done, self.total)

    def finish(self):
        if self.callback is not None:
            self.callback(self.total, self.total)


def _key(model: Fitted):
    return frozenset(model.order)


def _forward(fit, holdout, baseline, current, candidates, steps, first_step, progress, joint):
    """Add effects while one passes both checks (or, with `joint`, the joint criterion); drop those a newer one made redundant."""
    s = fit.settings
    remaining = [e for e in candidates if e not in current.order]
    while remaining and len(current.order) - len(baseline.order) < s.max_effects:
        trials = {}
        for k, effect in enumerate(remaining):
            trials[effect] = extend(fit, current, effect)
            progress.tick(len(remaining) - k - 1)
        if current is baseline:
            first_step.update(trials)
        record = {}
        accepted = None
        for effect in sorted(trials, key=lambda e: trials[e].bic):
            model = trials[effect]
            delta_bic = model.bic - current.bic
            delta_hold = None
            passed = delta_bic < -s.bic_margin
            if passed and holdout is not None:
                delta_hold = holdout_gain(holdout, current, model, effect)
                passed = delta_hold < -s.holdout_margin
            record[effect] = {"delta_bic": delta_bic, "delta_holdout_deviance": delta_hold}
            if passed and holdout is not None and effect in DETERMINISTIC:
                rival = _noise_rival(fit, holdout, current, trials, effect)
                if rival is not None:
                    record[effect]["noise_explains_holdout_better"] = rival
                    passed = False
            if passed:
                accepted = effect
                break
        if accepted is None and joint:
            accepted = _joint_pass(fit, holdout, current, trials, record)
        steps.append({"tried": record, "accepted": accepted, "dropped": []})
        if accepted is None:
            break
        current = trials[accepted]
        remaining.remove(accepted)
        current, dropped = _backward(fit, holdout, baseline, current, accepted, s.bic_margin)
        if dropped:
            steps[-1]["dropped"] = dropped
            remaining += [e for e in dropped if e not in remaining]
    return current


def _noise_rival(fit, holdout, current, trials, effect):
    """The noise term of this step that explains the holdout better than deterministic `effect`, or None.

    Flicker or a random walk puts power at every slow frequency; within one
    run, a sinusoid, a warm-up or a ramp fitted to the slowest wander can
    beat it by BIC, and its shape (the phase of a sinusoid is re-estimated
    per run) replicates on the holdout's own wander. On the holdout, though,
    the noise term explains the new wander at every frequency while the
    shape explains one: a noise trial that passes the fit run's BIC check
    and gives the holdout a lower ``-2 log L`` (both models frozen, per-run
    columns refitted) is preferred, and the shape waits for a later step,
    where it is judged beside that noise term.
    """
    s = fit.settings
    hold_effect = holdout_fit(holdout, trials[effect])[0]
    best = None
    for name, model in trials.items():
        if name in DETERMINISTIC or model.bic - current.bic >= -s.bic_margin:
            continue
        dev = holdout_fit(holdout, model)[0]
        if dev < hold_effect and (best is None or dev < best[1]):
            best = (name, dev)
    return None if best is None else best[0]


def _joint_pass(fit, holdout, current, trials, record):
    """The effect that the joint criterion of both runs accepts, or None.

    Tried after no effect passes the fit-run BIC and holdout checks: an
    effect qualifies when its joint BIC change (:func:`joint_gain` for a
    deterministic effect, :func:`joint_noise_gain` for a noise term) is
    below ``-bic_margin`` and each run on its own points the same way: at
    the joint estimate, both runs' ``-2 log L`` drop (the holdout's with its
    own noise: a random walk that one run's realisation barely shows must
    not count against a ramp that both runs carry); the lowest joint BIC
    wins.
    """
    s = fit.settings
    best, best_gain = None, -s.bic_margin
    for effect, model in trials.items():
        if effect in DETERMINISTIC:
            if model.deviance >= current.deviance:
                continue
            gain, per_run = joint_gain(fit, holdout, current, effect)
        else:
            gain, per_run = joint_noise_gain(fit, holdout, current, model, effect)
        agrees = max(per_run) < 0.0
        record[effect]["delta_joint_bic"] = gain
        if gain < best_gain and agrees:
            best, best_gain = effect, gain
    return best


def joint_noise_gain(fit: Problem, holdout: Problem, current: Fitted, model: Fitted, effect: str):
    """Change of the joint BIC of fit and holdout from `current` to `model` (= `current` + noise `effect`).

    The noise terms are properties of the gyro, shared by both runs and
    fitted on the sum of their ``-2 log L`` (:func:`gyrocomp.diagnose.likelihood.fit_noise_runs`);
    each run keeps its own regression coefficients (the nonlinear parameters
    are the fit run's). Flicker or a random walk too weak to pass on one run
    adds its evidence over two, as a deterministic effect does in
    :func:`joint_gain`.

    Returns
    -------
    gain : float
        ``Delta(-2 log L) + k ln(n_fit + n_holdout)``.
    per_run : tuple of float
        Each run's ``-2 log L`` change at the jointly fitted terms; both
        must be negative for the runs to agree.
    """
    runs = [(p.y, p.design_blocks(current.spec)[0], p.basis) for p in (fit, holdout)]
    before = ("arw",) + tuple(e for e in current.order if e not in DETERMINISTIC)
    noise0, dev0, _ = fit_noise_runs(runs, current.noise, before)
    noise1, dev1, _ = fit_noise_runs(runs, model.noise, before + (effect,))
    per_run = tuple(
        profile_deviance(y, X, basis.whitener(noise1))[0] - profile_deviance(y, X, basis.whitener(noise0))[0]
        for y, X, basis in runs
    )
    return dev1 - dev0 + KINDS[effect].n_params * np.log(fit.y.size + holdout.y.size), per_run


def holdout_gain(problem: Problem, current: Fitted, model: Fitted, effect: str) -> float:
    """Change of the holdout's ``-2 log L`` from `current` to `model` (= `current` + `effect`).

    A noise term is checked with its fitted value frozen. A deterministic
    effect is checked for **replication**: the change ``d`` of the frozen
    prediction that the fit run's estimate brings is scaled by ``alpha >= 0``
    fitted on the holdout (with the per-run columns), so the check asks
    whether the shape found on the fit run is also in the held-out run,
    without charging it the fit run's amplitude error. Under no effect,
    ``d`` is independent of the holdout's noise and the drop is a one-sided
    ``chi^2_1`` (P(drop > 6) = 0.007); a shape that merely absorbed the fit
    run's noise wander (a warm-up fitted to a random walk) has
    ``alpha ~ 0`` on an independent run.
    """
    base_dev = holdout_fit(problem, current)[0]
    if effect not in DETERMINISTIC:
        return holdout_fit(problem, model)[0] - base_dev
    run = problem.run
    fixed_c, _, _ = _holdout_parts(problem, current)
    fixed_m, X_free, _ = _holdout_parts(problem, model)
    y = problem.y - block_means(fixed_c, run.n_per_block)
    free_b = block_means(X_free, run.n_per_block)
    d = block_means(fixed_m - fixed_c, run.n_per_block)
    w = problem.basis.whitener(model.noise)
    dev0, _ = profile_deviance(y, free_b, w)
    dev1, beta = profile_deviance(y, np.column_stack([free_b, d]), w)
    return (dev1 if beta[-1] > 0 else dev0) - base_dev


def _holdout_parts(problem: Problem, model: Fitted):
    """Frozen full-rate prediction of `model` on a run, its per-run columns and their mask."""
    X, names = design(problem.run, model.spec, problem.poly_degree, problem.scale)
    if names != model.names:
        raise ValueError(f"holdout design {names} differs from the fit design {model.names}")
    free = np.array([n in PER_RUN for n in names])
    return X[:, ~free] @ model.beta[~free], X[:, free], free


def _swap(fit, holdout, baseline, current, candidates, progress):
    """Replace a selected effect by a look-alike: a noise term by the other one and/or a deterministic effect, a deterministic effect by another.

    Greedy selection can stop at a noise term that stands in for two
    causes (one random walk absorbing flicker and a warm-up): neither true
    cause alone beats it, both together do. Each selected noise term is
    replaced by the other noise term, by one unselected deterministic effect,
    or by both; the best replacement by BIC is taken when it lowers the BIC,
    and the BIC plus the holdout's ``-2 log L`` (frozen parameters), below
    the current model's, and every effect it brings in earns `bic_margin`
    on its own. The sum lets the fit run's evidence outweigh a holdout that
    is nearly indifferent (a slow thermal lag against the random walk it
    replaces), while a shape that merely absorbed the fit run's wander
    leaves the holdout's wander unexplained and costs far more there.

    Failing that, each selected deterministic effect is replaced by one
    unselected deterministic effect (near the edge a thermal lag of a few
    seconds is, on one run, a temperature-rate term to first order); with a
    holdout the replacement is judged on the joint BIC of both runs
    (:func:`_joint_bic`: shapes shared, each run's noise its own, so a noise
    level that one run's realisation sets low does not decide between two
    shapes), without one on the BIC.

    Returns
    -------
    (Fitted, dict) or None
        The new model and its step record, or None when no swap improves.
    """
    s = fit.settings
    chosen = current.order[len(baseline.order) :]
    current_hold = holdout_fit(holdout, current)[0] if holdout is not None else 0.0
    spare = [e for e in candidates if e in DETERMINISTIC and e not in current.order]
    best = None
    for out in (e for e in chosen if e not in DETERMINISTIC):
        reduced = _refit(fit, baseline, tuple(e for e in current.order if e != out), current.spec, current.noise)
        others = [e for e in candidates if e not in DETERMINISTIC and e not in current.order]
        bases = [(reduced, ())] + [(extend(fit, reduced, o), (o,)) for o in others]
        for model, added in bases:
            options = [(model, added)] if added else []
            for d in spare:
                options.append((extend(fit, model, d), added + (d,)))
                progress.tick()
            for option, brought in options:
                if option.bic >= current.bic or (best is not None and option.bic >= best[0].bic):
                    continue
                if not all(_earns(fit, baseline, option, e, s.bic_margin) for e in brought):
                    continue
                hold = holdout_fit(holdout, option)[0] if holdout is not None else 0.0
                if option.bic + hold < current.bic + current_hold:
                    best = (option, {"out": [out], "in": list(brought), "delta_bic": option.bic - current.bic,
                                     "delta_holdout_deviance": hold - current_hold if holdout is not None else None})
    if best is None:
        score = (lambda m: _joint_bic(fit, holdout, m)) if holdout is not None else (lambda m: m.bic)
        current_score = score(current) if any(e in DETERMINISTIC for e in chosen) else None
        best_gain = 0.0
        for out in (e for e in chosen if e in DETERMINISTIC):
            order = tuple(e for e in current.order if e != out)
            reduced = _refit(fit, baseline, order, {k: v for k, v in current.spec.items() if k != out}, current.noise)
            for d in spare:
                option = extend(fit, reduced, d)
                progress.tick()
                gain = score(option) - current_score
                if gain < best_gain and _earns(fit, baseline, option, d, s.bic_margin):
                    best_gain = gain
                    best = (option, {"out": [out], "in": [d], "delta_bic": option.bic - current.bic})
                    if holdout is not None:
                        best[1]["delta_joint_bic"] = gain
    if best is None:
        return None
    model, record = best
    return model, {"tried": {}, "accepted": None, "dropped": [], "swapped": record}


def _joint_bic(fit: Problem, holdout: Problem, model: Fitted) -> float:
    """BIC of `model` on both runs: shared coefficients (per-run :data:`PER_RUN` columns, counted once per run), each run's noise fitted on it."""
    parts = [_JointPart(fit, model, None), _JointPart(holdout, _with_own_noise(holdout, model), None)]
    k = model.n_params + sum(n in PER_RUN for n in model.names)
    return float(_joint_deviance(parts, None, None).sum()) + k * np.log(fit.y.size + holdout.y.size)


def _with_own_noise(problem: Problem, model: Fitted) -> Fitted:
    """`model` with its noise terms refitted on another run (one realisation of a random walk can read larger)."""
    stochastic = ("arw",) + tuple(e for e in model.order if e not in DETERMINISTIC)
    Xb, _ = problem.design_blocks(model.spec)
    noise, _, _ = fit_noise(problem.y, Xb, problem.basis, model.noise, stochastic)
    return dataclasses.replace(model, noise=noise)


def _earns(problem, baseline, model, effect, margin):
    """Whether removing `effect` from `model` raises the BIC by more than `margin`."""
    order = tuple(e for e in model.order if e != effect)
    spec = {k: v for k, v in model.spec.items() if k != effect}
    return _refit(problem, baseline, order, spec, model.noise).bic > model.bic + margin


def _backward(problem: Problem, holdout: Problem | None, baseline: Fitted, current: Fitted, added: str, margin: float):
    """Drop earlier effects that the newly `added` one made redundant.

    An effect selected early as a stand-in (a random walk absorbing a
    warm-up and an interference before either was modelled) no longer earns
    its BIC margin once the real cause is in; it is removed (stepwise
    selection) and may be chosen again later. With a holdout, an effect that
    still earns the margin on the joint BIC of both runs (:func:`joint_gain`,
    :func:`joint_noise_gain`) stays.
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
            if smaller.bic < current.bic + margin and not (holdout is not None and _joint_earns(problem, holdout, smaller, current, effect, margin)):
                current, changed = smaller, True
                dropped.append(effect)
                break
    return current, dropped


def _joint_earns(fit: Problem, holdout: Problem, smaller: Fitted, model: Fitted, effect: str, margin: float) -> bool:
    """Whether `effect` (in `model`, not in `smaller`) lowers the joint BIC of both runs by more than `margin`."""
    if effect in DETERMINISTIC:
        return joint_gain(fit, holdout, smaller, effect)[0] < -margin
    return joint_noise_gain(fit, holdout, smaller, model, effect)[0] < -margin


def _refit(problem: Problem, baseline: Fitted, order: tuple, spec: dict, noise: NoiseModel) -> Fitted:
    """Refit coefficients and noise of a model with given effects and nonlinear parameters."""
    stochastic = tuple(e for e in order if e not in DETERMINISTIC)
    values = dataclasses.asdict(noise)
    for e in ("bias_instability", "rate_random_walk"):
        if e not in stochastic:
            values[e] = 0.0
    Xb, names = problem.design_blocks(spec)
    noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, NoiseModel(**values), ("arw",) + stochastic)
    k = baseline.n_params + sum(KINDS[e].n_params for e in order[len(baseline.order) :])
    return Fitted(order, spec, noise, beta, names, deviance, k, problem.bic(deviance, k))


def _best_nonlinear(problem: Problem, current: Fitted, effect: str, others_problems=()) -> dict:
    """Grid search (then bounded refinement in log scale) of the effect's nonlinear parameter.

    The noise is held at the current model's; the other columns are
    block-averaged once. With `others_problems` (``(problem, model)`` pairs:
    the holdout with its own noise, in the joint criterion of
    :func:`joint_gain`) the deviance is summed over the runs, the per-run
    columns separate and the rest shared.
    """
    s = problem.settings
    run = problem.run
    key = KINDS[effect].nonlinear
    if not key:
        return {}
    length_s = run.n_blocks * run.block_s
    parts = [_JointPart(problem, current, effect)] + [_JointPart(p, m, effect) for p, m in others_problems]

    def deviance(params):
        return float(_joint_deviance(parts, params, effect).sum())

    grid = KINDS[effect].grid(s, length_s, run.block_s)
    if effect == "hysteresis":
        values = [deviance({key: float(v)}) for v in grid]
        return {key: float(grid[int(np.argmin(values))])}
    if effect == "periodic":
        values = _periodic_grid_deviances(parts, grid)
    else:
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


class _JointPart:
    """One run's whitened block means and fixed columns for a candidate `effect`."""

    def __init__(self, problem: Problem, current: Fitted, effect: str):
        run = problem.run
        self.problem = problem
        self.whitener = problem.basis.whitener(current.noise)
        others = {k: v for k, v in current.spec.items() if k != effect}
        X, names = design(run, others, problem.poly_degree, problem.scale)
        if effect == "thermal_lag":
            keep = [i for i, n in enumerate(names) if not n.startswith("temperature^")]
            X, names = X[:, keep], [names[i] for i in keep]
        # Whitening is linear: whiten the fixed columns and y once, then only the candidate's.
        self.base_w = self.whitener.whiten(block_means(X, run.n_per_block))
        self.base_names = names
        self.y_w = self.whitener.whiten(problem.y)
        self.constant = self.whitener.logdet + problem.y.size * np.log(2.0 * np.pi)

    def candidate(self, effect, params):
        run, p = self.problem.run, self.problem
        if effect is None:
            return np.empty((self.y_w.size, 0)), []
        if effect == "periodic":
            return self.whitener.whiten(periodic_block_means(run, params["period_s"])), ["periodic_sin", "periodic_cos"]
        full, names = effect_columns(run, effect, params, p.poly_degree, p.scale)
        return self.whitener.whiten(block_means(full, run.n_per_block)), names


def _periodic_grid_deviances(parts, periods):
    """:func:`_joint_deviance` of ``periodic`` at every period of a grid, in a few matrix products.

    The base columns do not change along the grid: with ``U`` an orthonormal
    basis of the (stacked, whitened) base design, ``y_perp = y - U U' y``
    and the sin/cos columns ``C`` of one period (per run), the deviance is
    ``constant + |y_perp|^2 - b' A^+ b`` with ``b = C' y_perp`` and
    ``A = C'C - (U'C)'(U'C)``; all periods' ``C`` are whitened at once.
    """
    free = [np.array([n in PER_RUN for n in part.base_names]) for part in parts]
    shared = np.vstack([part.base_w[:, ~f] for part, f in zip(parts, free)])
    per_run = linalg.block_diag(*[part.base_w[:, f] for part, f in zip(parts, free)])
    u, sv, _ = linalg.svd(np.hstack([shared, per_run]), full_matrices=False, check_finite=False)
    u = u[:, sv > sv[0] * 1e-12]
    y = np.concatenate([part.y_w for part in parts])
    y_perp = y - u @ (u.T @ y)
    n_g = len(periods)
    gram = np.zeros((n_g, 2 * len(parts), 2 * len(parts)))
    b = np.zeros((n_g, 2 * len(parts)))
    ucs = np.zeros((n_g, u.shape[1], 2 * len(parts)))
    row = 0
    for j, part in enumerate(parts):
        k = part.y_w.size
        cols = np.hstack([periodic_block_means(part.problem.run, p) for p in periods])  # (k, 2 G)
        cw = part.whitener.whiten(cols).reshape(k, n_g, 2).transpose(1, 0, 2)  # (G, k, 2)
        gram[:, 2 * j : 2 * j + 2, 2 * j : 2 * j + 2] = np.einsum("gki,gkj->gij", cw, cw)
        b[:, 2 * j : 2 * j + 2] = np.einsum("gki,k->gi", cw, y_perp[row : row + k])
        ucs[:, :, 2 * j : 2 * j + 2] = np.einsum("kp,gki->gpi", u[row : row + k], cw)
        row += k
    a = gram - np.einsum("gpi,gpj->gij", ucs, ucs)
    explained = np.einsum("gi,gij,gj->g", b, np.linalg.pinv(a, rcond=1e-12, hermitian=True), b)
    constant = sum(part.constant for part in parts)
    return constant + float(y_perp @ y_perp) - explained


def _joint_deviance(parts, params, effect):
    """``-2 log L`` of each run: shared coefficients, per-run :data:`PER_RUN` columns.

    Returns an array, one deviance per run (their sum is the joint one).
    """
    blocks, ys, constants = [], [], []
    for part in parts:
        cols, names = part.candidate(effect, params)
        X = np.hstack([part.base_w, cols])
        names = part.base_names + names
        blocks.append((X, np.array([n in PER_RUN for n in names])))
        ys.append(part.y_w)
        constants.append(part.constant)
    if len(parts) == 1:
        X = blocks[0][0]
    else:
        free = blocks[0][1]
        shared = np.vstack([X[:, ~free] for X, _ in blocks])
        per_run = linalg.block_diag(*[X[:, free] for X, _ in blocks])
        X = np.hstack([shared, per_run])
    y = np.concatenate(ys)
    beta, *_ = linalg.lstsq(X, y, cond=1e-12, lapack_driver="gelsy", check_finite=False)
    r = y - X @ beta
    ends = np.cumsum([part.y_w.size for part in parts])[:-1]
    return np.array([c + float(rk @ rk) for c, rk in zip(constants, np.split(r, ends))])


def joint_gain(fit: Problem, holdout: Problem, current: Fitted, effect: str):
    """Change of the joint BIC of fit and holdout from `current` to `current` + deterministic `effect`.

    The two runs are one gyro with two noise realisations: their
    log-likelihoods add, with the deterministic coefficients (temperature
    polynomial, effects) shared, the per-run columns (:data:`PER_RUN`)
    separate and each run's noise terms those of `current` fitted on that
    run (one realisation of a random walk can read larger). A random walk
    does not repeat between runs, a deterministic effect does, so the sum
    detects an effect that one run's wander hides. The effect's nonlinear
    parameter is fitted on the sum, then those of the effects already in
    (one coordinate-descent pass, as in :func:`extend`: a warm-up fitted
    alone stretches its time constant over a ramp); the change is
    ``Delta(-2 log L) + k ln(n_fit + n_holdout)``, with ``k`` from
    :func:`gyrocomp.diagnose.effects.n_params_runs` (a sinusoid's amplitude
    and phase, fitted per run, count twice).

    The held-out gap of a model selected this way is no longer independent
    of the selection (its parameters are still fitted on the fit run only).

    Returns
    -------
    gain : float
    per_run : tuple of float
        Each run's ``-2 log L`` change at the joint coefficients; both must
        be negative for the runs to agree.
    """
    on_holdout = _with_own_noise(holdout, current)

    def runs_deviance(spec):
        models = (dataclasses.replace(current, spec=spec), dataclasses.replace(on_holdout, spec=spec))
        return _joint_deviance([_JointPart(fit, models[0], None), _JointPart(holdout, models[1], None)], None, None)

    before = runs_deviance(current.spec)
    spec = {**current.spec, effect: _best_nonlinear(fit, current, effect, ((holdout, on_holdout),))}
    for other in current.spec:
        if KINDS[other].nonlinear:
            trial = dataclasses.replace(current, spec=spec)
            spec[other] = _best_nonlinear(fit, trial, other, ((holdout, dataclasses.replace(on_holdout, spec=spec)),))
    change = runs_deviance(spec) - before
    n = fit.y.size + holdout.y.size
    return float(change.sum() + n_params_runs(effect, 2) * np.log(n)), tuple(float(c) for c in change)


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
