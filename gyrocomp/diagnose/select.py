r"""Stepwise selection of effects by one criterion: BIC on the selection runs.

Every model is the baseline (per-run offset, temperature polynomial, white
noise) plus a set of effects; it is scored by the block-mean likelihood of
:mod:`gyrocomp.effects.likelihood`, in which deterministic effects are
regressors and ``bias_instability`` / ``rate_random_walk`` are noise terms.

**The criterion.** A model's score is its BIC on the *selection runs* (the
fit run, plus the holdouts that take part in the selection; never the run
the held-out gap is reported on):

.. math:: \mathrm{BIC} = \sum_r -2 \log L_r + k \ln \sum_r n_r

with the deterministic coefficients shared by the runs, the per-run columns
(offset, a sinusoid's phase) and the noise levels fitted on each run, ``k``
counting each of those once per run (:meth:`Search.score`). An effect
**earns its place** in a model when removing it raises the score by more
than ``bic_margin`` (:meth:`Search.earns`), and a noise term must in
addition pass the admissibility check given to the search (its own
signature on the runs). Every move uses that one rule:

* **forward** adds the candidate that lowers the score most, if it earns
  its place;
* **backward** drops, after each addition, an effect that no longer earns
  its place (a random walk that stood in for a warm-up before the warm-up
  was in), when the model left still passes the admissibility check;
* **swap** replaces one selected effect by one or (for a noise term, which
  can stand in for two causes) two others, when the new model scores lower
  and every effect it brings earns its place.

For one deterministic parameter on 720 blocks the margin of 10 asks for a
``-2 log L`` drop of ``ln 720 + 10 = 16.6``: a false-alarm rate of
``P(chi^2_1 > 16.6) = 4.7e-5`` per tried effect and move, at most about
``4e-4`` over the eight candidates of a forward step (Bonferroni). For a
noise term at the boundary of its range the null distribution is half a
``chi^2_1`` (Self & Liang 1987), so the rate is halved.

Adding a deterministic effect refits the nonlinear parameters of those
already in (a warm-up fitted alone stretches its time constant over a
ramp), and an accepted model is settled at its own noise before the next
step (:meth:`Search.settle`), so that a later step is not credited with
the refit of an earlier effect's parameters. Look-alikes are told apart by
the likelihood of their shapes, not by a rule: thermal lag must reproduce
the decaying transient after every step, temperature-rate sensitivity the
square pulses of dT/dt that vanish in a soak, hysteresis an offset that
holds through a soak; a rate ramp is a line in time while a random walk
only widens the covariance.

References
----------
.. [1] G. Schwarz, "Estimating the dimension of a model", Ann. Stat. 6(2), 461-464 (1978).
.. [2] R. E. Kass, A. E. Raftery, "Bayes factors", JASA 90(430), 773-795 (1995).
.. [3] S. G. Self, K.-Y. Liang, "Asymptotic properties of maximum likelihood
   estimators and likelihood ratio tests under nonstandard conditions", JASA 82(398), 605-610 (1987).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize

from gyrocomp.diagnose.effects import DETERMINISTIC, KINDS, PER_RUN, STOCHASTIC, Run, TemperatureScale, design, effect_columns, periodic_block_means
from gyrocomp.effects.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise, merge_blocks, profile_deviance
from gyrocomp.effects.vocabulary.periodic import harmonic_names

__all__ = ["Fitted", "Problem", "Search", "fit_baseline", "extend", "holdout_fit", "residual_of", "sample_arw"]


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
    """`current` plus `effect`, its parameters fitted on the fit run.

    ``bias_instability`` takes the form of lowest BIC: flicker, or its
    Markov form at each correlation time of its grid (one parameter more;
    :class:`~gyrocomp.effects.likelihood.NoiseModel`).
    """
    stochastic = [e for e in current.order if e not in DETERMINISTIC]
    spec = dict(current.spec)
    starts = [current.noise]
    if effect in DETERMINISTIC:
        spec[effect] = _best_nonlinear(problem, current, effect)
        # The earlier effects' nonlinear parameters were fitted without this
        # one (a warm-up fitted alone stretches its tau over a ramp): refit
        # each with the new effect in.
        spec = _descend(problem, current, spec, current.spec)
    else:
        stochastic.append(effect)
    Xb, names = problem.design_blocks(spec)
    free = ("arw",) + tuple(stochastic)
    if effect == "bias_instability":
        starts = _bias_forms(problem, current.noise, Xb, free)
    order = current.order + (effect,)
    best = None
    for start in starts:
        noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, start, free)
        k = current.n_params + _n_params(order, spec, noise) - _n_params(current.order, current.spec, current.noise)
        trial = Fitted(order, spec, noise, beta, names, deviance, k, problem.bic(deviance, k))
        if best is None or trial.bic < best.bic:
            best = trial
    return best


def _bias_forms(problem: Problem, noise: NoiseModel, Xb, free) -> list:
    """Noise models to fit ``bias_instability`` from: flicker, and its Markov form at each correlation time of the grid.

    Beside a random walk every likelihood evaluation factorises the whole
    covariance (:meth:`NoiseBasis.whitener`), so the correlation time is
    chosen on the block means merged to ``bias_correlation_search_blocks``
    (:func:`~gyrocomp.effects.likelihood.merge_blocks`; the Markov forms
    have one parameter count, so their deviances rank them) and only that
    form is fitted beside flicker on the full blocks.
    """
    run, s = problem.run, problem.settings
    grid = KINDS["bias_instability"].grid(s, run.n_blocks * run.block_s, run.block_s)
    markov = [dataclasses.replace(noise, bias_correlation_s=float(tc)) for tc in grid]
    flicker = dataclasses.replace(noise, bias_correlation_s=0.0)
    if not noise.rate_random_walk or not markov or problem.y.size <= s.bias_correlation_search_blocks:
        return [flicker] + markov
    y, X, basis = merge_blocks(problem.y, Xb, problem.basis, s.bias_correlation_search_blocks)
    deviance = [fit_noise(y, X, basis, start, free)[1] for start in markov]
    return [flicker, markov[int(np.argmin(deviance))]]


def _descend(problem: Problem, model: Fitted, spec: dict, effects) -> dict:
    """One coordinate-descent pass: `spec` with each of `effects` that has a nonlinear parameter or forms
    refitted in turn (:func:`_best_nonlinear`) at `model`'s noise, beside the others' parameters as they stand."""
    spec = dict(spec)
    for effect in effects:
        if KINDS[effect].nonlinear or KINDS[effect].forms:
            spec[effect] = _best_nonlinear(problem, dataclasses.replace(model, spec=spec), effect)
    return spec


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


class Search:
    """Stepwise selection over the vocabulary, every move judged by one criterion (module docstring).

    Parameters
    ----------
    runs : sequence of Problem
        The selection runs: the fit run first (the parameters are fitted on
        it), then any holdouts that take part in the selection.
    candidates : sequence of str
        Effects that may be added.
    start : Fitted, optional
        The model to start from (default: the baseline of the fit run); its
        effects are never dropped.
    admissible : callable(runs, model, effect) -> bool, optional
        The noise-signature check a noise term must pass to take the blame
        (the level agrees between runs, the increments look like that
        noise, its Allan slope holds); without one every noise term is
        admissible.
    callback : callable(done, total), optional
        Progress over candidate fits.

    Attributes
    ----------
    model : Fitted
        The current model (the selected one after :meth:`run`).
    baseline : Fitted
    first_step : dict
        ``{effect: Fitted}``: each candidate added alone to the start model.
    steps : list of dict
        One record per move: ``move`` (forward, backward, swap), ``delta``
        (each tried effect's score change, forward), ``accepted``,
        ``dropped``, ``swapped`` (``{"out", "in", "delta"}``).
    """

    def __init__(self, runs, candidates, start: Fitted | None = None, admissible=None, callback=None):
        self.runs = list(runs)
        self.fit = self.runs[0]
        s = self.fit.settings
        self.margin = s.bic_margin
        self.max_effects = s.max_effects
        self.candidates = list(candidates)
        self.baseline = start if start is not None else fit_baseline(self.fit)
        self.model = self.baseline
        self.admissible = admissible
        self.first_step, self.steps = {}, []
        self._progress = _Progress(callback, len(self.candidates))
        self._scores = {}

    # -- the criterion -------------------------------------------------------------------------

    def score(self, model: Fitted) -> float:
        """BIC of `model` on the selection runs.

        One run: ``model.bic``. Several: ``-2 log L`` summed over the runs at
        deterministic coefficients shared by them (each run's per-run columns
        and noise levels its own, :func:`_with_own_noise`), plus
        ``k ln(total blocks)`` with ``k`` the model's parameters, the per-run
        columns and noise levels counted once per run.
        """
        key = _key(model)
        if key not in self._scores:
            if len(self.runs) == 1:
                value = model.bic
            else:
                parts = [_JointPart(self.fit, model, None)]
                parts += [_JointPart(p, _with_own_noise(p, model), None) for p in self.runs[1:]]
                deviance = float(_joint_deviance(parts, None, None).sum())
                n_noise = 1 + sum(e in STOCHASTIC for e in model.order)
                per_run = sum(n in PER_RUN for n in model.names)
                k = model.n_params + (len(self.runs) - 1) * (n_noise + per_run)
                value = deviance + k * np.log(sum(p.y.size for p in self.runs))
            self._scores[key] = (model, value)
        return self._scores[key][1]

    def earns(self, model: Fitted, effect: str) -> bool:
        """Whether `effect` earns its place in `model`: removing it raises the score by more than the margin,
        and a noise term passes the admissibility check."""
        if not self._admissible(model, effect):
            return False
        return self.score(self.without(model, effect)) - self.score(model) > self.margin

    def without(self, model: Fitted, effect: str) -> Fitted:
        """`model` refitted without `effect` (the others' nonlinear parameters kept)."""
        order = tuple(e for e in model.order if e != effect)
        spec = {k: v for k, v in model.spec.items() if k != effect}
        return _refit(self.fit, self.baseline, order, spec, model.noise)

    # -- the moves ----------------------------------------------------------------------------

    def forward(self) -> bool:
        """Add the candidate that lowers the score most, if it earns its place; then :meth:`backward`."""
        remaining = [e for e in self.candidates if e not in self.model.order]
        if not remaining or len(self.model.order) - len(self.baseline.order) >= self.max_effects:
            return False
        trials = {}
        for k, effect in enumerate(remaining):
            trials[effect] = extend(self.fit, self.model, effect)
            self._progress.tick(len(remaining) - k - 1)
        if self.model is self.baseline:
            self.first_step.update(trials)
        current = self.score(self.model)
        delta = {e: self.score(m) - current for e, m in trials.items()}
        accepted = None
        for effect in sorted(delta, key=delta.get):
            # Adding `effect` earns its place iff the model without it scores
            # more than the margin higher: the inequality of `earns`.
            if delta[effect] >= -self.margin:
                break
            if self._admissible(trials[effect], effect):
                accepted = effect
                break
        self.steps.append({"move": "forward", "delta": delta, "accepted": accepted, "dropped": []})
        if accepted is None:
            return False
        self.model = self.settle(trials[accepted])
        self.backward(accepted)
        return True

    def settle(self, model: Fitted) -> Fitted:
        """`model` with its nonlinear parameters refitted at its own noise, while that lowers the score.

        An effect's nonlinear parameters are searched at the noise of the
        model it joins, which still holds the effect's own signal as noise:
        a sawtooth searched at the baseline's white level keeps 4 harmonics
        where its fitted noise supports 8. Left so, the next forward step
        credits whichever effect it tries with the refit that
        :func:`extend` gives the earlier effects, and a spurious effect
        earns its place. Each pass refits every nonlinear parameter in turn
        (coordinate descent at the current noise, then the noise refitted);
        it stops when a pass no longer lowers the score, after at most one
        pass per deterministic effect.
        """
        for _ in range(len(model.spec)):
            spec = _descend(self.fit, model, model.spec, model.spec)
            trial = _refit(self.fit, self.baseline, model.order, spec, model.noise)
            if self.score(trial) >= self.score(model):
                break
            model = trial
        return model

    def backward(self, added: str | None = None) -> list:
        """Drop, one at a time, the effects (other than `added` and the start model's) that no longer earn their place.

        Like every move, a drop must leave a model whose noise terms pass the
        admissibility check: a short-correlation noise term beside a warm-up
        can take the warm-up's decay at a small loss of score, but alone it
        does not show its own signature, and forward would never have
        accepted it so.
        """
        dropped = []
        changed = True
        while changed:
            changed = False
            for effect in self.model.order[len(self.baseline.order) :]:
                if effect == added or self.earns(self.model, effect):
                    continue
                reduced = self.without(self.model, effect)
                if all(self._admissible(reduced, e) for e in reduced.order[len(self.baseline.order) :]):
                    self.model = reduced
                    dropped.append(effect)
                    changed = True
                    break
        if dropped:
            self.steps.append({"move": "backward", "accepted": None, "dropped": dropped})
        return dropped

    def swap(self, seen=frozenset()) -> bool:
        """Replace one selected effect by one other, or a noise term by a noise term and a deterministic effect.

        Greedy steps can stop at one effect standing in for another (a random
        walk absorbing a warm-up and flicker: neither true cause alone beats
        it, both together do; a short thermal lag that is, on one run, a
        temperature-rate term to first order). The replacement with the
        lowest score is taken when it scores below the current model, every
        effect it brings earns its place, and its set of effects is not in
        `seen`.
        """
        chosen = self.model.order[len(self.baseline.order) :]
        spare = [e for e in self.candidates if e not in self.model.order]
        best, best_score = None, self.score(self.model)
        for out in chosen:
            reduced = self.without(self.model, out)
            options = []
            for d in spare:
                single = extend(self.fit, reduced, d)
                self._progress.tick()
                options.append((single, (d,)))
                if out in STOCHASTIC and d in STOCHASTIC:
                    for d2 in (e for e in spare if e in DETERMINISTIC):
                        options.append((extend(self.fit, single, d2), (d, d2)))
                        self._progress.tick()
            for option, brought in options:
                if frozenset(option.order) in seen or self.score(option) >= best_score:
                    continue
                if all(self.earns(option, e) for e in brought):
                    best, best_score = (option, out, brought), self.score(option)
        if best is None:
            return False
        option, out, brought = best
        self.steps.append(
            {
                "move": "swap",
                "accepted": None,
                "dropped": [],
                "swapped": {"out": [out], "in": list(brought), "delta": best_score - self.score(self.model)},
            }
        )
        self.model = option
        self.backward()
        return True

    def run(self) -> Fitted:
        """Forward steps until none earns its place, then a swap, and again; a set of effects seen before ends it."""
        seen = {frozenset(self.model.order)}
        for _ in range(2 * len(self.candidates) + 1):
            while self.forward():
                seen.add(frozenset(self.model.order))
            if not self.swap(seen):
                break
            seen.add(frozenset(self.model.order))
        self._progress.finish()
        return self.model

    def _admissible(self, model, effect):
        return effect not in STOCHASTIC or self.admissible is None or bool(self.admissible(self.runs, model, effect))


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
    return (model.order, tuple(sorted((e, tuple(sorted(p.items()))) for e, p in model.spec.items())))


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


def _best_nonlinear(problem: Problem, current: Fitted, effect: str, others_problems=()) -> dict:
    """Grid search (then bounded refinement in log scale) of the effect's nonlinear parameter, in its best form.

    An effect with :attr:`~gyrocomp.effects.vocabulary.Effect.forms` takes the
    form of lowest BIC, ``-2 log L + k ln n`` with ``k`` the form's
    parameter count and ``n`` the blocks of the runs, each form at its own
    best nonlinear parameter: a richer form's extra columns earn their
    place like an effect's (a temperature-rate asymmetry that is not there
    must not charge a symmetric sensitivity a parameter its look-alike, a
    short thermal lag, does not pay), and between forms with as many
    parameters the likelihood decides (a hysteresis relay or play).

    Every parameter is refined between the grid's neighbours of the best
    point, the hysteresis deadband too: a relay's switching width is
    anything from half a degree to 15 degC, and a width between two grid
    points moves every switch by tens of seconds on a 1 degC/min ramp,
    which a strong hysteresis shows (and a noise term would absorb).

    The noise is held at the current model's; the other columns are
    block-averaged once. With `others_problems` (``(problem, model)`` pairs:
    the holdout with its own noise, in the joint criterion of
    :func:`joint_gain`) the deviance is summed over the runs, the per-run
    columns separate and the rest shared.
    """
    kind = KINDS[effect]
    if not kind.nonlinear and not kind.forms:
        return {}
    parts = [_JointPart(problem, current, effect)] + [_JointPart(p, m, effect) for p, m in others_problems]
    log_n = np.log(sum(part.y_w.size for part in parts))
    fitted = [_best_in_form(problem, parts, effect, dict(form)) for form in kind.forms or ({},)]
    bic = [value + kind.n_params_of(params) * log_n for params, value in fitted]
    return fitted[int(np.argmin(bic))][0]


def _best_in_form(problem: Problem, parts, effect: str, form: dict):
    """The nonlinear parameter of `effect` in one of its forms (:func:`_best_nonlinear`): ``(params, -2 log L)``."""
    kind = KINDS[effect]
    key = kind.nonlinear

    def deviance(params):
        return float(_joint_deviance(parts, params, effect).sum())

    if not key or key in form:
        return form, deviance(form)
    run = problem.run
    length_s = run.n_blocks * run.block_s
    grid = kind.grid(problem.settings, length_s, run.block_s)
    if effect == "periodic":
        return _periodic_waveform(parts, grid, problem.settings, length_s, run.block_s, lambda p: deviance(form | p))
    values = np.array([deviance(form | {key: float(v)}) for v in grid])
    value, best = _refine(grid, values, lambda v: deviance(form | {key: v}))
    return form | {key: value}, best


def _refine(grid, values, deviance):
    """The grid point of least deviance refined (bounded, in log scale) between its neighbours: ``(value, deviance)``."""
    i = int(np.argmin(values))
    a, b = sorted((np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, grid.size - 1)])))
    if b > a:
        best = optimize.minimize_scalar(
            lambda z: deviance(float(np.exp(z))), bounds=(a, b), method="bounded", options={"xatol": 1e-3}
        )
        if best.fun < values[i]:
            return float(np.exp(best.x)), float(best.fun)
    return float(grid[i]), float(values[i])


def _periodic_waveform(parts, periods, settings, length_s, block_s, deviance):
    """The multiharmonic periodogram: the period and the number of harmonics ``H`` of least BIC.

    For every ``H`` from 1 to ``periodic_harmonics`` the deviance of a
    Fourier series of ``H`` harmonics is scanned over the periods that may
    carry ``H`` (:meth:`gyrocomp.effects.vocabulary.periodic._Periodic.max_harmonics`)
    and its best period refined (harmonic ``k`` moves ``k`` times faster
    with the period than the fundamental, so each ``H`` is refined apart);
    the ``H`` of least ``deviance + 2 H R ln n`` wins (``2 H`` per-run
    coefficients on each of the ``R`` runs, ``n`` their blocks: the
    selection's parameter count). The harmonics summed, a pulse train's
    fundamental scores its whole power, not the fundamental's share
    (Schwarzenberg-Czerny 1996).

    Returns
    -------
    params : dict
        ``{"period_s": P, "harmonics": H}``.
    deviance : float
        Its ``-2 log L``.
    """
    effect = KINDS["periodic"]
    h_max = np.array([effect.max_harmonics(settings, p, length_s, block_s) for p in periods])
    log_n = np.log(sum(part.y_w.size for part in parts))
    best_score, best = np.inf, None
    for h in range(1, int(h_max.max()) + 1):
        ok = h_max >= h
        values = np.full(len(periods), np.inf)
        values[ok] = _periodic_grid_deviances(parts, periods[ok], h)
        period, dev = _refine(periods, values, lambda p: deviance({"period_s": p, "harmonics": h}))
        score = dev + 2 * h * len(parts) * log_n
        if score < best_score:
            best_score, best = score, ({"period_s": period, "harmonics": h}, dev)
    return best


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
            harmonics = int(params.get("harmonics", 1))
            return self.whitener.whiten(periodic_block_means(run, params["period_s"], harmonics)), harmonic_names(harmonics)
        full, names = effect_columns(run, effect, params, p.poly_degree, p.scale)
        return self.whitener.whiten(block_means(full, run.n_per_block)), names


def _periodic_grid_deviances(parts, periods, harmonics=1):
    """:func:`_joint_deviance` of ``periodic`` of `harmonics` harmonics at every period of a grid, in a few matrix products.

    The base columns do not change along the grid: with ``U`` an orthonormal
    basis of the (stacked, whitened) base design, ``y_perp = y - U U' y``
    and the sin/cos columns ``C`` of one period (per run), the deviance is
    ``constant + |y_perp|^2 - b' A^+ b`` with ``b = C' y_perp`` and
    ``A = C'C - (U'C)'(U'C)``; all periods' ``C`` are whitened at once.
    """
    c = 2 * int(harmonics)
    free = [np.array([n in PER_RUN for n in part.base_names]) for part in parts]
    shared = np.vstack([part.base_w[:, ~f] for part, f in zip(parts, free)])
    per_run = linalg.block_diag(*[part.base_w[:, f] for part, f in zip(parts, free)])
    u, sv, _ = linalg.svd(np.hstack([shared, per_run]), full_matrices=False, check_finite=False)
    u = u[:, sv > sv[0] * 1e-12]
    y = np.concatenate([part.y_w for part in parts])
    y_perp = y - u @ (u.T @ y)
    n_g = len(periods)
    gram = np.zeros((n_g, c * len(parts), c * len(parts)))
    b = np.zeros((n_g, c * len(parts)))
    ucs = np.zeros((n_g, u.shape[1], c * len(parts)))
    row = 0
    for j, part in enumerate(parts):
        k = part.y_w.size
        cols = np.hstack([periodic_block_means(part.problem.run, p, harmonics) for p in periods])  # (k, c G)
        cw = part.whitener.whiten(cols).reshape(k, n_g, c).transpose(1, 0, 2)  # (G, k, c)
        gram[:, c * j : c * j + c, c * j : c * j + c] = np.einsum("gki,gkj->gij", cw, cw)
        b[:, c * j : c * j + c] = np.einsum("gki,k->gi", cw, y_perp[row : row + k])
        ucs[:, :, c * j : c * j + c] = np.einsum("kp,gki->gpi", u[row : row + k], cw)
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
