"""Which selected effects stay listed when the residual tests find something unexplained: named unlisting rules.

After the selection, while the verdict (:func:`gyrocomp.diagnose.unexplained.verdict`)
finds structure the selected model does not predict, :func:`confirm` asks
the rules of :data:`RULES`, in order, whether one selected effect (none of
the start model's) only stands in for that structure. The first rule that
names one unlists it (:class:`Unlisting`), the model is refitted without it
(``search.without``) and the verdict is taken again. Each rule is
``rule(state) -> Unlisting | None`` over one :class:`Round`:

1. :func:`noise_standing_in` -- a noise term that does not show its own
   signature on all runs and takes the place of a structure the tests find;
2. :func:`refuted_on_holdout` -- an effect with per-run columns that the
   holdout does not need at its fitted shape (:func:`replication`),
   although it could have seen it there (:func:`visible`);
3. :func:`unsteady` -- an effect whose per-run amplitude changes between
   parts of the runs (:func:`steadiness`; an effect whose per-run columns
   are a nuisance beside a shared amplitude is not judged here);
4. :func:`stands_in_for_structure` -- an effect that gains at most the
   selection's ``bic_margin`` beside a structure the tests found on the
   fit run (:func:`gain_beside`).

The principle is one: an effect that earned its place in the selection
stays unless something refutes it -- its own statistics, the holdout, or
a description of the fit run's residual beside which it gains nothing.
A holdout that cannot see an effect (its columns there are absorbed by
the per-run offset) does not refute it. The rules only unlist, and only
when the verdict is present, so a recording the model explains is never
touched: the false-alarm rate is the verdict's.

References
----------
.. [1] S. S. Wilks, "The large-sample distribution of the likelihood ratio
   for testing composite hypotheses", Ann. Math. Statist. 9, 60-62 (1938).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

from gyrocomp.diagnose import signature
from gyrocomp.diagnose import unexplained as _unexplained
from gyrocomp.diagnose.effects import KINDS, PER_RUN
from gyrocomp.diagnose.settings import DiagnoseSettings
from gyrocomp.diagnose.signature import TERMS
from gyrocomp.effects.likelihood import fit_noise, profile_deviance

__all__ = ["Unlisting", "Round", "RULES", "confirm", "noise_standing_in", "refuted_on_holdout", "unsteady",
           "stands_in_for_structure", "replication", "visible", "steadiness", "gain_beside"]


@dataclasses.dataclass(frozen=True)
class Unlisting:
    """One effect a rule unlists: its name, the rule, the reason in words, its BIC gain and whether the holdout's evidence took part."""

    effect: str
    rule: str
    reason: str
    gain: float | None = None
    holdout: bool = True

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass
class Round:
    """What the rules read in one round of :func:`confirm`.

    Attributes
    ----------
    search : gyrocomp.diagnose.select.Search
        ``margin`` (the selection's ``bic_margin``) and ``without(model, effect)``.
    runs : list of (str, Problem)
        ``("fit", ...)`` and, when there is one, ``("holdout", ...)``.
    model : Fitted
        The model of this round.
    chosen : tuple of str
        Its effects that may be unlisted (none of the start model's).
    verdict : dict
        :func:`gyrocomp.diagnose.unexplained.verdict` of `model` (present).
    prepared : list
        The runs prepared by the verdict (their tests and structures).
    settings : gyrocomp.diagnose.settings.DiagnoseSettings
    """

    search: object
    runs: list
    model: object
    chosen: tuple
    verdict: dict
    prepared: list
    settings: DiagnoseSettings

    def run(self, label):
        """The Problem labelled `label`, or None."""
        return next((p for name, p in self.runs if name == label), None)

    def per_run(self):
        """The chosen effects with per-run columns (a periodic's phase and amplitude, a hysteresis' power-on branch)."""
        return [e for e in self.chosen if e not in TERMS and KINDS[e].per_run]


def confirm(search, runs, model, settings: DiagnoseSettings = DiagnoseSettings(), baseline_residuals=None):
    """Unlist the selected effects that :data:`RULES` refute while something is unexplained; the final verdict.

    Parameters
    ----------
    search : gyrocomp.diagnose.select.Search
        The finished search: ``baseline`` (its effects are kept), ``margin``,
        ``without(model, effect)``.
    runs : sequence of (str, Problem)
        As :func:`gyrocomp.diagnose.unexplained.verdict`; the run labelled
        ``"fit"`` is the one searched for structures.
    model : gyrocomp.diagnose.select.Fitted
        The selected model.
    settings, baseline_residuals
        As :func:`gyrocomp.diagnose.unexplained.verdict`; the rules' own
        numbers are ``settings.confirm``.

    Returns
    -------
    model : Fitted
        The model with the unlisted effects removed.
    result : dict
        The verdict of that model, with ``unlisted``: one
        :meth:`Unlisting.to_dict` per unlisted effect, in order; the verdict
        is present when any effect was unlisted.
    """
    kept = len(search.baseline.order)
    unlisted = []
    while True:
        result, prepared = _unexplained.assess(runs, model, settings, baseline_residuals)
        chosen = tuple(model.order[kept:])
        if not result["present"] or not chosen:
            break
        state = Round(search, list(runs), model, chosen, result, prepared, settings)
        entry = next((u for rule in RULES if (u := rule(state)) is not None), None)
        if entry is None:
            break
        unlisted.append(entry)
        model = search.without(model, entry.effect)
    if unlisted:
        result["present"] = True
        result["hints"] = [f"{u.effect} is not listed: {u.reason}" for u in unlisted] + result["hints"]
    result["unlisted"] = [u.to_dict() for u in unlisted]
    return model, result


def noise_standing_in(state: Round) -> Unlisting | None:
    """Rule 1: a noise term without its own signature on all runs, that stands in for a structure or is refused by its own statistics.

    A term that fails its signature (:func:`gyrocomp.diagnose.signature.check`)
    and gains at most ``bic_margin`` beside the deterministic structures the
    tests find on the fit run in its place (the model without it;
    :func:`gain_beside`) absorbs what the vocabulary does not explain. One
    whose own statistics (level agreement, Allan slope, Gaussian levels)
    refuse it -- with nothing found in its place, or still beside what was
    found (a tone that repeats in every run is not judged again: the test
    reads the smallest power over the runs) -- is not that noise. A failure
    of the other tests alone (a trend beside a true flicker) keeps it.
    """
    signatures = state.verdict["signatures"]
    failing = [t for t in state.chosen if t in signatures and not signatures[t]["ok"]]
    fit_p = state.run("fit")
    problems = [p for _, p in state.runs]
    standing_in, in_place = {}, {}
    for term in failing:
        in_place[term] = gain, G = _in_place(state.search, fit_p, state.model, term, state.settings)
        sig = signatures[term]
        if gain is not None and gain <= state.search.margin:
            standing_in[term] = gain
        elif not sig["own_ok"] and (
            G is None or sig["tone_repeats"]
            or not signature.check(term, problems, state.model, state.settings,
                                   [G if p is fit_p else np.empty((p.y.size, 0)) for p in problems]).own_ok
        ):
            standing_in[term] = -np.inf
    if not standing_in:
        return None
    effect = min(standing_in, key=standing_in.get)
    why = "; ".join(signatures[effect]["reasons"][:2])
    gain, G = in_place[effect]
    if gain is not None and gain <= state.search.margin:
        return Unlisting(effect, "noise_standing_in", f"it does not show its own signature ({why}) and gains {gain:.1f} in BIC "
                         f"(<= {state.search.margin:g}) beside the structure the tests find on the fit run in its place", float(gain))
    where = ("nor beside the structure the tests find on the fit run in its place" if G is not None
             else "and the tests find no structure on the fit run in its place")
    return Unlisting(effect, "noise_standing_in", f"its own statistics are not those of {effect.replace('_', ' ')} ({why}), {where}: "
                     "it stands in for a residual the vocabulary does not explain", None if gain is None else float(gain))


def refuted_on_holdout(state: Round) -> Unlisting | None:
    """Rule 2: an effect with per-run columns that the holdout, which could see it, does not need at its fitted shape.

    The holdout must need the effect's columns -- all of them, the ones
    that carry its amplitude (a hysteresis' branch, a periodic
    disturbance's sine and cosine) and its per-run nuisances (the branch
    a hysteresis was left in at power-on) -- at the effect's fitted
    nonlinear parameters (:func:`replication`, p at most
    ``replication_alpha``). A holdout on which the effect, at the fit
    run's run-independent coefficients, would not be detected
    (:func:`visible`: a hysteresis whose branch never changes there) cannot
    refute it. Of several, the one the holdout needs least goes first.
    Effects without per-run columns are re-estimated whole on every run of
    the selection and are not judged here.
    """
    held = state.run("holdout")
    if held is None:
        return None
    alpha = state.settings.confirm.replication_alpha
    p = {e: replication(held, state.model, e) for e in state.per_run()}
    lost = {e: v for e, v in p.items() if v > alpha and visible(held, state.model, e, alpha)}
    if not lost:
        return None
    effect = max(lost, key=lost.get)
    return Unlisting(effect, "refuted_on_holdout", f"at its fitted {', '.join(state.model.spec.get(effect, {}))} it is not "
                     f"found again on the holdout (p = {lost[effect]:.2g} > {alpha:g})")


def unsteady(state: Round) -> Unlisting | None:
    """Rule 3: an effect with a per-run amplitude whose per-run columns differ between parts of the runs (:func:`steadiness`).

    An interference keeps its amplitude and phase, where a sinusoid fitted
    to a transient or to a wander that comes late does not. Only effects
    whose amplitude is per run (:attr:`~gyrocomp.effects.vocabulary.Effect.amplitude_per_run`)
    are judged: a hysteresis' per-run columns are its state at power-on,
    constant on a run that never leaves the play (a soak), where splitting
    them in parts tests the steadiness of the offset, not of the hysteresis.
    """
    s = state.settings.confirm
    problems = [q for _, q in state.runs]
    judged = [e for e in state.per_run() if KINDS[e].amplitude_per_run]
    p = {e: steadiness(problems, state.model, e, s.steady_segments, s.steady_min_cycles) for e in judged}
    p = {e: v for e, v in p.items() if v < s.replication_alpha}
    if not p:
        return None
    effect = min(p, key=p.get)
    return Unlisting(effect, "unsteady", f"its amplitude and phase differ between {s.steady_segments} parts of the runs "
                     f"(p = {p[effect]:.2g} < {s.replication_alpha:g}): not a steady interference")


def stands_in_for_structure(state: Round) -> Unlisting | None:
    """Rule 4: the effect that gains least beside the structure the tests found on the fit run, when that is at most ``bic_margin``.

    The structures are those kept together
    (:meth:`gyrocomp.diagnose.unexplained.Prepared.explain`), or any one
    found that those make redundant: the same residual described another
    way. The gain is ``Delta(-2 log L) - k ln n`` of removing the effect
    from the fit run's model with those columns in the design
    (:func:`gain_beside`). An effect that earns its place against the
    vocabulary but not beside a step at one time described the step; a
    hysteresis fitted to a bias that steps at one temperature leaves one
    crossing as a step in time and gains nothing beside the step in
    temperature.
    """
    fit = next((pr for pr in state.prepared if pr.label == "fit"), None)
    names = [k for k in (fit.kept if fit is not None else []) if not k.startswith("noise_")]
    if not names:
        return None
    others = [k for k, t in fit.tests.items() if t.get("rejected") and not k.startswith("noise_") and k not in names]
    gains = {e: min((gain_beside(fit.problem, state.model, e, fit.structure(G)), G) for G in [names] + [[k] for k in others])
             for e in state.chosen}
    effect = min(gains, key=lambda e: gains[e][0])
    gain, beside = gains[effect]
    if gain > state.search.margin:
        return None
    return Unlisting(effect, "stands_in_for_structure",
                     f"beside the {', '.join(n.replace('_', ' ') for n in beside)} the tests found on the fit run it gains "
                     f"{gain:.1f} in BIC (<= {state.search.margin:g}): it stands in for that structure", float(gain), False)


RULES = (noise_standing_in, refuted_on_holdout, unsteady, stands_in_for_structure)
"""The unlisting rules in the order :func:`confirm` asks them."""


def replication(problem, model, effect):
    """p-value that `effect`'s columns explain nothing on another run (`problem`), at `model`'s shape.

    The model's nonlinear parameters and the other effects' shared
    coefficients are frozen at their fit-run values; the effect's columns
    (shared and per-run) and every per-run column are refitted, the noise
    levels refitted on that run. The likelihood-ratio statistic of the
    effect's columns is ``chi^2`` (their rank beside the per-run columns)
    when the effect is absent there (Wilks [1]_). A shape the effect has
    on the gyro is found again; one fitted to something else on one run
    (a sinusoid fitted to a bias jump at one temperature) is not.
    """
    Xb, free, own, y = _frozen(problem, model, effect)
    terms = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    noise, with_it, _ = fit_noise(y, Xb[:, free | own], problem.basis, model.noise, terms)
    without = profile_deviance(y, Xb[:, free & ~own], problem.basis.whitener(noise))[0]
    dof = np.linalg.matrix_rank(Xb[:, free | own]) - np.linalg.matrix_rank(Xb[:, free & ~own])
    return float(stats.chi2.sf(max(without - with_it, 0.0), dof)) if dof > 0 else 1.0


def visible(problem, model, effect, alpha):
    """Whether `effect`, at the fit run's run-independent coefficients, would be found on `problem` more often than not.

    The non-centrality ``lambda = |P W X_s beta_s|^2`` of the effect's
    shared columns ``X_s`` at their fit-run values ``beta_s``, whitened
    (``W``) under the model's noise and projected (``P``) off the run's
    per-run columns other than the effect's, against the median of the
    ``chi^2`` test of :func:`replication` at level `alpha`: about
    ``chi^2_(1-alpha)``. An effect whose amplitude is per run only (a
    periodic disturbance) has no such values and counts as visible.
    """
    Xb, free, own, y = _frozen(problem, model, effect)
    shared = own & ~free
    if not shared.any():
        return True
    terms = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    W = problem.basis.whitener(fit_noise(y, Xb[:, free | own], problem.basis, model.noise, terms)[0])
    signal = W.whiten(Xb[:, shared] @ model.beta[shared])
    nuisance = W.whiten(Xb[:, free & ~own])
    coef = np.linalg.lstsq(nuisance, signal, rcond=None)[0]
    lam = float(np.sum((signal - nuisance @ coef) ** 2))
    dof = np.linalg.matrix_rank(Xb[:, free | own]) - np.linalg.matrix_rank(Xb[:, free & ~own])
    return lam >= stats.chi2.isf(alpha, max(dof, 1))


def steadiness(problems, model, effect, segments, min_cycles):
    """p-value that `effect`'s per-run columns keep their coefficients over each run of `problems`.

    On each run the model's shared coefficients are frozen at their fit-run
    values and the noise levels refitted; the effect's per-run columns (a
    periodic disturbance's sines and cosines) get one set of coefficients in
    each of `segments` consecutive parts of the run instead of one for the
    run (fewer parts where a part would hold less than `min_cycles` of the
    effect's ``period_s``; none below two). The likelihood-ratio statistics
    of the runs are independent and add: ``chi^2`` with the columns gained,
    when the effect keeps one amplitude and phase (Wilks [1]_).
    """
    stat, dof = 0.0, 0
    for problem in problems:
        n = problem.y.size
        period = model.spec.get(effect, {}).get("period_s")
        k = segments if period is None else min(segments, int(n * problem.basis.block_s // (min_cycles * period)))
        if k < 2:
            continue
        Xb, free, own, y = _frozen(problem, model, effect)
        own &= free
        part = np.arange(n) * k // n
        split = np.hstack([Xb[:, free & ~own]] + [Xb[:, own] * (part == j)[:, None] for j in range(k)])
        terms = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
        noise, with_parts, _ = fit_noise(y, split, problem.basis, model.noise, terms)
        whole = profile_deviance(y, Xb[:, free], problem.basis.whitener(noise))[0]
        stat += max(whole - with_parts, 0.0)
        dof += np.linalg.matrix_rank(split) - np.linalg.matrix_rank(Xb[:, free])
    return float(stats.chi2.sf(stat, dof)) if dof > 0 else 1.0


def gain_beside(problem, model, effect, G):
    """``Delta(-2 log L) - k ln n`` of removing `effect` from `model` on `problem`, the columns `G` in the design.

    The effect's nonlinear parameters and the others' are kept; the noise
    levels of the model's terms (without `effect` when it is one) are
    refitted by maximum likelihood; ``k`` is the effect's parameter count
    and ``n`` the number of block means (the selection's BIC,
    :meth:`gyrocomp.diagnose.select.Problem.bic`).
    """
    y, basis = problem.y, problem.basis
    X = problem.design_blocks(model.spec)[0]
    free = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    full = fit_noise(y, np.hstack([X, G]), basis, model.noise, free)[1]
    if effect in TERMS:
        reduced = dataclasses.replace(model.noise, **{effect: 0.0})
        less = fit_noise(y, np.hstack([X, G]), basis, reduced, tuple(t for t in free if t != effect))[1]
    else:
        Xm = problem.design_blocks({k: v for k, v in model.spec.items() if k != effect})[0]
        less = fit_noise(y, np.hstack([Xm, G]), basis, model.noise, free)[1]
    return float(less - full - KINDS[effect].n_params_of(model.spec.get(effect, {})) * np.log(y.size))


def _frozen(problem, model, effect):
    """`problem`'s block design at `model`'s shape, the masks of per-run and of `effect`'s columns, and ``y`` less the others' shared columns.

    The shared columns of the other effects are fixed at their fit-run
    coefficients; `effect`'s own columns and every per-run column are left
    to be refitted.
    """
    Xb, names = problem.design_blocks(model.spec)
    if names != model.names:
        raise ValueError(f"design {names} differs from the model's {model.names}")
    free = np.array([n in PER_RUN for n in names])
    own = problem.own_columns(model.spec, effect)
    fixed = ~free & ~own
    return Xb, free, own, problem.y - Xb[:, fixed] @ model.beta[fixed]


def _in_place(search, problem, model, term, s):
    """:func:`gain_beside` of noise `term` beside the structures the tests find on the fit run without it, and their columns.

    The deterministic tests of the fit run under the model without `term`
    (Holm at ``family_alpha`` over that run's tests), the findings that say
    the same thing reported once; with none, ``(None, None)`` (no structure
    a test describes takes its place).
    """
    if problem is None:
        return None, None
    G = _unexplained.structure_found(problem, search.without(model, term), s)
    if G is None:
        return None, None
    return gain_beside(problem, model, term, G), G
