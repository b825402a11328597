r"""Stepwise selection of effects by one criterion: BIC on the selection runs.

A model's score is its BIC on the *selection runs* (the fit run, plus the
holdouts that take part in the selection; never the run the held-out gap is
reported on), the deterministic coefficients shared by the runs, the
per-run columns (offset, a sinusoid's phase) and the noise levels fitted on
each run, ``k`` counting each of those once per run (:meth:`Search.score`;
the criterion of one run is :mod:`gyrocomp.diagnose.criterion`). The moves
(forward, backward, swap) and their false-alarm rate are those of
:mod:`gyrocomp.diagnose.select`; the effect added is fitted by
:func:`gyrocomp.diagnose.nonlinear.extend`.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.criterion import Fitted, _refit, _with_own_noise, fit_baseline
from gyrocomp.diagnose.effects import DETERMINISTIC, PER_RUN, STOCHASTIC
from gyrocomp.diagnose.nonlinear import _descend, _joint_deviance, _JointPart, extend

__all__ = ["Search"]


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
        key = model.key
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
