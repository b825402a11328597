"""What the selected model does not explain: tests of the residual for structure it does not predict.

After the selection (:mod:`gyrocomp.diagnose.select`) the residual of every
run is tested for structure that the selected model -- its deterministic
shapes and its noise -- does not predict (issue #16, part 2). On each run
the block means ``y`` are regressed on the model's design ``X`` by GLS under
the model's noise ``Sigma`` (the levels of its noise terms refitted on that
run by maximum likelihood), and whitened by the Cholesky factor ``L``:
``e = L^-1 (y - X beta)`` is ``N(0, I - P)`` when the model holds. Each
test below is then exact (or conservative) with a known false-alarm rate:

* ``temperature`` -- a function of temperature beyond the model's:
  indicators of ``temperature_bins`` equal-width temperature bins; score,
  ``chi^2_q``; and, for a structure narrower than a bin (a dip over a few
  degC), a scan of the single bins of ``temperature_scan_bins`` equal-width
  binnings (bins of fewer than ``min_step_blocks`` blocks left out), each
  bin's whitened score ``z`` ``N(0, 1)`` under the model, the union bound
  ``n 2 Phi(-max |z|)``; the two make one test, ``p = 2 min`` of theirs;
* ``heating_cooling`` -- a different offset or slope in temperature when
  heating and when cooling (``|dT/dt|`` above ``soak_rate_c_per_min``);
  score, ``chi^2_q``;
* ``power_on`` -- a settling after power-on: indicators of the windows
  ``poweron_edges_s``; score, ``chi^2_q``;
* ``time`` -- a drift in time: indicators of ``time_segments`` equal
  segments of the run; score, ``chi^2_q``;
* ``step`` -- a step at an unknown time
  (:func:`gyrocomp.diagnose.signature.step_scan`); union bound over times;
* ``temperature_step`` -- a step at an unknown temperature, the same when
  heating and when cooling (a bias discontinuity: a mode that switches at
  one temperature, a solder or package transition): the column
  ``1[T >= c]`` at each inner edge ``c`` of ``temperature_step_bins``
  equal-width bins (at least ``min_step_blocks`` blocks on either side),
  its whitened score ``z`` ``N(0, 1)`` under the model, the union bound
  ``n 2 Phi(-max |z|)``. A run that crosses ``c`` several times shows it
  as several steps in time, and a hysteresis (which switches with the
  direction of the temperature change, wherever that is) takes part of it;
* ``spectral_line`` -- a sinusoid at an unknown frequency (at least
  ``line_min_cycles`` cycles in the run): Fisher's ``g`` of the periodogram
  of ``e``, ``P = m (1 - g)^(m-1)`` [1]_;
* ``moving_line`` -- a line whose frequency moves (a tone that drifts with
  temperature or age, a chirp) or that comes and goes: Fisher's ``g`` in
  each of ``line_segments`` consecutive segments of ``e`` (at least
  ``line_min_cycles`` cycles in a segment), Bonferroni over the segments,
  ``P = min(1, K min_k P_k)``. A drifting line spreads its power over many
  Fourier frequencies of the whole run, where the ``spectral_line`` test
  does not see it, and a flicker or random walk absorbs it: a stationary
  noise has the same spectrum in every segment;
* ``noise_correlation`` -- a correlated noise the model's noise terms do
  not take (a telegraph noise under white noise, a wander the noise
  terms' signature refused): Ljung-Box ``Q`` of ``e`` over
  ``whiteness_lags`` lags, ``chi^2_h`` (:func:`gyrocomp.diagnose.signature.ljung_box`);
* ``noise_blocks`` -- a block-level noise that changes over the run: the
  Brown-Forsythe test of the spread of ``e`` in ``noise_segments``
  segments, ``F_(k-1, n-k)`` [2]_;
* ``noise_samples`` -- a sample-level (white) noise that changes: the same
  test on the paired differences ``x_(2j+1) - x_(2j)`` within blocks
  (independent under white noise; every slow term cancels), in the same
  segments;
* ``noise_temperature`` -- a white noise that depends on temperature: the
  same pairs grouped by the temperature bins.

The score statistic of whitened columns ``G`` is ``|U' e|^2`` with ``U`` an
orthonormal basis of the part of ``L^-1 G`` orthogonal to ``L^-1 X``
(:func:`gyrocomp.diagnose.signature.score_test`). The three noise tests also
ask for a size: one group's (robust) standard deviation differs from another's by
the factor ``noise_min_ratio`` (at 100 Hz a change of 1 % is significant
and of no consequence); this only lowers their false-alarm rate.

All tests on all runs form one family: Holm's step-down procedure [3]_
keeps the probability that a recording the model *does* explain is called
unexplained at most ``family_alpha``. A selected noise term must also show
its own signature (:func:`gyrocomp.diagnose.signature.check`): one that
does not stands in for a residual the vocabulary does not explain, and the
verdict is present with its reasons (each term adds its own family rate,
``[signature] family_alpha``, by Bonferroni).

For every test that rejects, :func:`verdict` says *where* (time window,
temperature range, regime, timescale), gives a *hint* in words, and
measures the *size* of what remains: the rejected structures' columns are
fitted jointly with the model's by GLS, and their part ``f`` of the block
means is reported as an RMS in deg/h, and, with the baseline's residual,
as a share of the baseline's gap: ``var(f_100) / (s_b^2 - E s^2)``, the
variance of the 100 s means of ``f`` over the baseline residual's 100 s
spread in excess of what the selected model's noise gives it.

References
----------
.. [1] R. A. Fisher, "Tests of significance in harmonic analysis",
   Proc. R. Soc. Lond. A 125, 54-59 (1929).
.. [2] M. B. Brown, A. B. Forsythe, "Robust tests for the equality of
   variances", J. Amer. Statist. Assoc. 69, 364-367 (1974).
.. [3] S. Holm, "A simple sequentially rejective multiple test procedure",
   Scand. J. Statist. 6, 65-70 (1979).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, stats

from gyrocomp.config import bind, load_config
from gyrocomp.diagnose.effects import KINDS, PER_RUN
from gyrocomp.effects.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise, profile_deviance
from gyrocomp.diagnose import signature
from gyrocomp.diagnose.signature import TERMS, score_test, step_scan, temperature_bins, temperature_edges

__all__ = ["UnexplainedSettings", "get_config", "verdict", "confirm", "gain_beside", "replication", "steadiness", "holm", "fisher_g", "variance_segments", "variance_groups"]

_DEG_H = 3600.0
"""deg/h per deg/s."""


@dataclasses.dataclass(frozen=True)
class UnexplainedSettings:
    """The ``[unexplained]`` table; defaults equal ``configs/unexplained.toml`` (reasons there)."""

    family_alpha: float = 0.01
    temperature_bins: int = 8
    temperature_scan_bins: tuple = (8, 16, 32, 64)
    poweron_edges_s: tuple = (300.0, 900.0, 2700.0, 7200.0)
    min_step_blocks: int = 4
    temperature_step_bins: int = 64
    noise_segments: int = 8
    noise_min_ratio: float = 1.25
    soak_rate_c_per_min: float = 0.05
    time_segments: int = 8
    line_min_cycles: int = 3
    line_segments: int = 4
    whiteness_lags: int = 10
    replication_alpha: float = 0.01
    steady_segments: int = 4
    steady_min_cycles: float = 1.0
    gap_block_s: float = 100.0


def get_config(path="unexplained") -> UnexplainedSettings:
    """Bind the ``[unexplained]`` table of a TOML file (default: the shipped ``configs/unexplained.toml``)."""
    return bind(UnexplainedSettings, load_config(path).get("unexplained", {}), f"{path} [unexplained]")


def verdict(
    runs,
    model,
    settings: UnexplainedSettings = UnexplainedSettings(),
    baseline_residuals=None,
    signature_settings: signature.SignatureSettings = signature.SignatureSettings(),
) -> dict:
    """Test the residual of `model` on `runs` for structure it does not predict.

    Parameters
    ----------
    runs : sequence of (str, gyrocomp.diagnose.select.Problem)
        ``(label, problem)``: the runs (``"fit"``, ``"holdout"``), each
        providing ``y``, ``basis``, ``run`` and ``design_blocks(spec)``.
    model : gyrocomp.diagnose.select.Fitted
        The selected model (``spec`` and ``noise`` are used).
    settings : UnexplainedSettings
    baseline_residuals : sequence of ndarray, optional
        Full-rate residual of the baseline on each run [deg/s], for the share
        of the gap.
    signature_settings : gyrocomp.diagnose.signature.SignatureSettings
        A selected ``rate_random_walk`` or ``bias_instability`` that does not
        show its own signature (:func:`gyrocomp.diagnose.signature.check`,
        its own family false-refusal rate) absorbs something the vocabulary
        does not explain: the verdict is then present, with its reasons.

    Returns
    -------
    dict
        ``present`` (bool), ``family_alpha``, ``where`` (one entry per
        rejected test: run, test, p and its location), ``hints`` (sentences),
        ``size`` (per run: ``rms_deg_h`` of the unexplained part of the block
        means and its ``share_of_gap``, None without `baseline_residuals`),
        ``tests`` (every test's statistic and p).
    """
    return _verdict(runs, model, settings, baseline_residuals, signature_settings)[0]


def confirm(search, runs, model, settings: UnexplainedSettings = UnexplainedSettings(), baseline_residuals=None,
            signature_settings: signature.SignatureSettings = signature.SignatureSettings()):
    """Unlist the selected effects that only stand in for structure the residual tests flag; the final verdict.

    An effect is listed only when its shape is that effect's. After the
    selection, while :func:`verdict` finds something unexplained, one
    selected effect (none of the start model's) is unlisted and the model
    refitted without it (``search.without``):

    1. a noise term that does not show its own signature on all runs
       (:func:`gyrocomp.diagnose.signature.check`: its level agrees between
       the runs, its innovations are white without trend or temperature
       dependence, its Allan slope holds, a flicker's level is Gaussian) and
       that, beside the deterministic structures the tests find on the fit
       run in its place (the model without it), gains at most
       ``bic_margin`` (:func:`gain_beside`): it absorbs what the vocabulary
       does not explain. A true flicker beside a drift keeps its place (the
       drift is reported) -- unless the tests of its own statistics (level
       agreement, Allan slope, Gaussian levels) refuse it, and still refuse
       it with that structure in the fit run's design: then the wander is
       not that noise. A tone that repeats in every run at the same time
       since power-on (the signature's spectrum replication) is not judged
       again beside that structure: the test reads the smallest power over
       the runs, which a structure taken out of the fit run alone can only
       lower, whatever the runs share. When the tests find nothing in its place,
       the term goes if its own statistics refused it (at the signature's
       false-refusal rate) and stays if only the other tests did (a trend
       beside it);
    2. otherwise an effect with per-run columns (a periodic disturbance's
       phase and amplitude) that the holdout does not need at the effect's
       fitted shape (:func:`replication`, p above ``replication_alpha``), or
       whose per-run columns differ between parts of the runs (:func:`steadiness`,
       p below ``replication_alpha``): an interference keeps its amplitude
       and phase, where a sinusoid fitted to a transient or to a wander
       that comes late does not;
    3. otherwise the effect that, beside the deterministic structures the
       tests found on the fit run (a step, a step at one temperature, a
       spectral line, temperature bins, windows after power-on, segments of
       time, a heating/cooling offset: :meth:`_Prepared.structure`), gains
       least: ``Delta(-2 log L) - k ln n`` of removing it from the fit
       run's model with those columns in the design (its nonlinear
       parameters kept, the noise refitted), when that gain is at most the
       selection's ``bic_margin``. The structures are those kept together
       (:meth:`_Prepared.explain`), or any one found that those make
       redundant: the same residual described another way. An effect that
       earns its place against the vocabulary but not beside a step at one
       time, say, described the step; a hysteresis fitted to a bias that
       steps at one temperature leaves one crossing as a step in time, and
       does not earn its place beside the step in temperature.

    The rules only unlist, and only when the verdict is present, so a
    recording the model explains is never touched (its false-alarm rate is
    the verdict's). The structures are looked for on the fit run only;
    rules 1 and 2 also read the holdout (the signature's agreement between
    runs, the replication), which then took part in what is listed (never
    in what was added): the report's protocol says so.

    Parameters
    ----------
    search : gyrocomp.diagnose.select.Search
        The finished search: ``fit`` (the fit run's Problem), ``baseline``
        (its effects are kept), ``margin``, ``without(model, effect)``.
    runs : sequence of (str, Problem)
        As :func:`verdict`; the run labelled ``"fit"`` is the one searched
        for structures.
    model : gyrocomp.diagnose.select.Fitted
        The selected model.
    settings, baseline_residuals, signature_settings
        As :func:`verdict`.

    Returns
    -------
    model : Fitted
        The model with the unlisted effects removed.
    result : dict
        The verdict of that model (:func:`verdict`), with ``unlisted``: one
        ``{"effect", "reason", "gain", "holdout"}`` per unlisted effect (``holdout``: the
        holdout's evidence took part), in order; the
        verdict is present when any effect was unlisted.
    """
    s = settings
    kept = len(search.baseline.order)
    unlisted = []
    while True:
        result, prepared = _verdict(runs, model, settings, baseline_residuals, signature_settings)
        chosen = list(model.order[kept:])
        if not result["present"] or not chosen:
            break
        failing = [t for t in chosen if t in result["signatures"] and not result["signatures"][t]["ok"]]
        held = next((p for label, p in runs if label == "holdout"), None)
        lost = {e: replication(held, model, e) for e in chosen if KINDS[e].per_run and held is not None}
        lost = {e: p for e, p in lost.items() if p > s.replication_alpha}
        unsteady = {e: steadiness([p for _, p in runs], model, e, s.steady_segments, s.steady_min_cycles)
                    for e in chosen if KINDS[e].per_run and e not in lost}
        unsteady = {e: p for e, p in unsteady.items() if p < s.replication_alpha}
        fit_p = next((p for label, p in runs if label == "fit"), None)
        in_place = {t: _in_place(search, fit_p, model, t, s) for t in failing}
        # A term that gains little beside the structure found in its place stands in for it; one whose own
        # statistics (level, slope, distribution) refuse it, with nothing found in its place or still beside
        # what was found, is not that noise. A failure of the other tests alone may be a structure beside it.
        standing_in = {}
        for t, (g, G) in in_place.items():
            if g is not None and g <= search.margin:
                standing_in[t] = g
            elif not result["signatures"][t]["own_ok"] and (
                G is None or result["signatures"][t]["tone_repeats"]
                or not signature.check(t, [p for _, p in runs], model, signature_settings,
                                       [G if p is fit_p else np.empty((p.y.size, 0)) for _, p in runs]).own_ok
            ):
                standing_in[t] = -np.inf
        if standing_in:
            effect = min(standing_in, key=standing_in.get)
            why = "; ".join(result["signatures"][effect]["reasons"][:2])
            gain, G = in_place[effect]
            if gain is None or gain > search.margin:
                where = "nor beside the structure the tests find on the fit run in its place" if G is not None else (
                    "and the tests find no structure on the fit run in its place")
                entry = {"effect": effect, "gain": None if gain is None else float(gain), "holdout": True, "reason":
                         f"its own statistics are not those of {effect.replace('_', ' ')} ({why}), {where}: "
                         "it stands in for a residual the vocabulary does not explain"}
            else:
                entry = {"effect": effect, "gain": float(gain), "holdout": True, "reason":
                         f"it does not show its own signature ({why}) and gains {gain:.1f} in BIC "
                         f"(<= {search.margin:g}) beside the structure the tests find on the fit run in its place"}
        elif lost:
            effect = max(lost, key=lost.get)
            entry = {"effect": effect, "gain": None, "holdout": True, "reason":
                     f"at its fitted {', '.join(model.spec.get(effect, {}))} it is not found again on the holdout "
                     f"(p = {lost[effect]:.2g} > {s.replication_alpha:g})"}
        elif unsteady:
            effect = min(unsteady, key=unsteady.get)
            entry = {"effect": effect, "gain": None, "holdout": True, "reason":
                     f"its amplitude and phase differ between {s.steady_segments} parts of the runs "
                     f"(p = {unsteady[effect]:.2g} < {s.replication_alpha:g}): not a steady interference"}
        else:
            fit = next((pr for pr in prepared if pr.label == "fit"), None)
            names = [k for k in (fit.kept if fit is not None else []) if not k.startswith("noise_")]
            if not names:
                break
            # The structures kept together, and each one the tests found that those make redundant on its own: the
            # same residual described another way (a step at one temperature, of which a step in time is one crossing).
            others = [k for k, t in fit.tests.items() if t.get("rejected") and not k.startswith("noise_") and k not in names]
            gains = {}
            for e in chosen:
                gains[e] = min((gain_beside(fit.problem, model, e, fit.structure(G)), G) for G in [names] + [[k] for k in others])
            effect = min(gains, key=lambda e: gains[e][0])
            gain, beside = gains[effect]
            if gain > search.margin:
                break
            entry = {"effect": effect, "gain": float(gain), "holdout": False, "reason":
                     f"beside the {', '.join(n.replace('_', ' ') for n in beside)} the tests found on the fit run it gains "
                     f"{gain:.1f} in BIC (<= {search.margin:g}): it stands in for that structure"}
        unlisted.append(entry)
        model = search.without(model, effect)
    if unlisted:
        result["present"] = True
        result["hints"] = [f"{u['effect']} is not listed: {u['reason']}" for u in unlisted] + result["hints"]
    result["unlisted"] = unlisted
    return model, result


def replication(problem, model, effect):
    """p-value that `effect`'s per-run columns explain nothing on another run (`problem`), at `model`'s shape.

    The model's nonlinear parameters and shared coefficients are frozen at
    their fit-run values, the per-run columns refitted, the noise levels
    refitted on that run; the likelihood-ratio statistic of the effect's own
    per-run columns (a periodic disturbance's sine and cosine at its fitted
    period) is ``chi^2_k`` when the effect is absent there (Wilks). A shape
    the effect has on the gyro is found again; one fitted to something else
    on one run (a sinusoid fitted to a bias jump at one temperature) is not.
    """
    Xb, names = problem.design_blocks(model.spec)
    if names != model.names:
        raise ValueError(f"design {names} differs from the model's {model.names}")
    free = np.array([n in PER_RUN for n in names])
    own = np.array([n in KINDS[effect].per_run for n in names])
    y = problem.y - Xb[:, ~free] @ model.beta[~free]
    terms = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    noise, with_it, _ = fit_noise(y, Xb[:, free], problem.basis, model.noise, terms)
    without = profile_deviance(y, Xb[:, free & ~own], problem.basis.whitener(noise))[0]
    return float(stats.chi2.sf(max(without - with_it, 0.0), int(own.sum())))


def steadiness(problems, model, effect, segments, min_cycles):
    """p-value that `effect`'s per-run columns keep their coefficients over each run of `problems`.

    On each run the model's shared coefficients are frozen at their fit-run
    values and the noise levels refitted; the effect's per-run columns (a
    periodic disturbance's sines and cosines) get one set of coefficients in
    each of `segments` consecutive parts of the run instead of one for the
    run (fewer parts where a part would hold less than `min_cycles` of the
    effect's ``period_s``; none below two). The likelihood-ratio statistics
    of the runs are independent and add: ``chi^2`` with the columns gained,
    when the effect keeps one amplitude and phase (Wilks).
    """
    stat, dof = 0.0, 0
    for problem in problems:
        Xb, names = problem.design_blocks(model.spec)
        if names != model.names:
            raise ValueError(f"design {names} differs from the model's {model.names}")
        n = problem.y.size
        period = model.spec.get(effect, {}).get("period_s")
        k = segments if period is None else min(segments, int(n * problem.basis.block_s // (min_cycles * period)))
        if k < 2:
            continue
        free = np.array([c in PER_RUN for c in names])
        own = np.array([c in KINDS[effect].per_run for c in names])
        y = problem.y - Xb[:, ~free] @ model.beta[~free]
        part = np.arange(n) * k // n
        split = np.hstack([Xb[:, free & ~own]] + [Xb[:, own] * (part == j)[:, None] for j in range(k)])
        terms = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
        noise, with_parts, _ = fit_noise(y, split, problem.basis, model.noise, terms)
        whole = profile_deviance(y, Xb[:, free], problem.basis.whitener(noise))[0]
        stat += max(whole - with_parts, 0.0)
        dof += np.linalg.matrix_rank(split) - np.linalg.matrix_rank(Xb[:, free])
    return float(stats.chi2.sf(stat, dof)) if dof > 0 else 1.0


def _in_place(search, problem, model, term, s: UnexplainedSettings):
    """:func:`gain_beside` of noise `term` beside the structures the tests find on the fit run without it, and their columns.

    The deterministic tests of the fit run under the model without `term`
    (Holm at ``family_alpha`` over that run's tests), the findings that say
    the same thing reported once (:meth:`_Prepared.explain`); with none,
    ``(None, None)`` (no structure a test describes takes its place).
    """
    if problem is None:
        return None, None
    pr = _Prepared("fit", problem, search.without(model, term), s)
    names = list(pr.tests)
    rejected = holm([pr.tests[k]["p"] for k in names], s.family_alpha)
    found = [k for k, r in zip(names, rejected) if r and not k.startswith("noise_")]
    kept = [k for k in pr.explain(found, s.family_alpha / max(len(names), 1)) if not k.startswith("noise_")]
    if not kept:
        return None, None
    G = pr.structure(kept)
    return gain_beside(problem, model, term, G), G


def gain_beside(problem, model, effect, G):
    """``Delta(-2 log L) - k ln n`` of removing `effect` from `model` on `problem`, the columns `G` in the design.

    The effect's nonlinear parameters and the others' are kept; the noise
    levels of the model's terms (without `effect` when it is one) are
    refitted by maximum likelihood; ``k`` is the effect's parameter count
    and ``n`` the number of block means (the selection's BIC, eq. of
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


def _verdict(runs, model, settings, baseline_residuals, signature_settings):
    """:func:`verdict` and the prepared runs (their structures, for :func:`confirm`)."""
    s = settings
    prepared = [_Prepared(label, p, model, s) for label, p in runs]
    tests = [(pr, name, result) for pr in prepared for name, result in pr.tests.items()]
    rejected = holm([t[2]["p"] for t in tests], s.family_alpha)
    alpha = s.family_alpha / max(len(tests), 1)
    where, hints = [], []
    for pr in prepared:
        names = [name for (q, name, _), r in zip(tests, rejected) if r and q is pr]
        for name in pr.tests:
            pr.tests[name]["rejected"] = name in names
        for name in pr.explain(names, alpha):
            entry, hint = pr.describe(name)
            where.append({"run": pr.label, "test": name, "p": pr.tests[name]["p"], **entry})
            hints.append(f"{pr.label}: {hint}")
    signatures = {}
    for term in TERMS:
        if term in getattr(model, "order", ()) and getattr(model.noise, term) > 0.0:
            sig = signature.check(term, [p for _, p in runs], model, signature_settings)
            signatures[term] = {"ok": sig.ok, "own_ok": sig.own_ok, "tone_repeats": sig.tone_repeats, "reasons": list(sig.reasons)}
            if not sig.ok:
                where.append({"run": "all", "test": f"signature:{term}", "p": sig.stats.get("alpha")})
                hints.append(f"the selected {term} does not show its own signature: " + "; ".join(sig.reasons[:3]))
    size = {}
    for k, pr in enumerate(prepared):
        base = baseline_residuals[k] if baseline_residuals is not None else None
        size[pr.label] = pr.size(base, s)
    return {
        "present": bool(any(rejected) or any(not v["ok"] for v in signatures.values())),
        "family_alpha": s.family_alpha,
        "signatures": signatures,
        "signature_alpha": signature_settings.family_alpha if signatures else None,
        "where": where,
        "hints": hints,
        "size": size,
        "tests": {pr.label: {name: _public(r) for name, r in pr.tests.items()} for pr in prepared},
        "unlisted": [],
    }, prepared


def holm(p_values, alpha):
    """Holm's step-down rejections at family-wise error `alpha` [3]_.

    Examples
    --------
    >>> holm([0.001, 0.04, 0.03, 0.2], 0.05).tolist()
    [True, False, False, False]
    """
    p = np.asarray(p_values, dtype=float)
    out = np.zeros(p.size, dtype=bool)
    for rank, j in enumerate(np.argsort(p)):
        if p[j] > alpha / (p.size - rank):
            break
        out[j] = True
    return out


def fisher_g(e, min_cycles=1):
    """Fisher's ``g`` (largest periodogram ordinate over their sum) of `e` and its p-value [1]_.

    The Fourier frequencies ``j / n``, ``min_cycles <= j < n / 2`` (slower
    ones are drifts, not lines: the ``time`` test looks for them); the p-value is the
    first (upper-bound) term ``m (1 - g)^(m - 1)`` of Fisher's exact series,
    accurate in the tail where a decision is made.

    Returns
    -------
    g : float
    p : float
    index : int
        ``j`` of the largest ordinate (period ``n / j`` samples).

    Examples
    --------
    >>> t = np.arange(256)
    >>> g, p, j = fisher_g(np.sin(2 * np.pi * 10 * t / 256) + np.random.default_rng(0).standard_normal(256))
    >>> j, bool(p < 1e-6)
    (10, True)
    """
    e = np.asarray(e, dtype=float)
    n = e.size
    power = np.abs(np.fft.rfft(e - e.mean())) ** 2
    power = power[min_cycles : (n - 1) // 2 + 1]
    m = power.size
    j = int(np.argmax(power))
    g = float(power[j] / power.sum())
    return g, float(min(1.0, m * (1.0 - g) ** (m - 1))), j + min_cycles


def variance_segments(x, n_segments):
    """Brown-Forsythe test [2]_ that `x` has one spread in `n_segments` consecutive segments.

    Levene's test on absolute deviations from the segment medians: its
    false-alarm rate holds for heavy tails and a few spikes, where
    Bartlett's test of the variances calls a spike a change of noise.

    Returns
    -------
    stat, p : float
    std : ndarray
        A robust standard deviation of each segment (``1.4826`` times the
        median absolute deviation from its median).
    """
    x = np.asarray(x, dtype=float)
    return variance_groups(np.array_split(x, n_segments))


def variance_groups(groups):
    """Brown-Forsythe test [2]_ that the arrays `groups` share one spread (see :func:`variance_segments`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> stat, p, std = variance_groups([rng.standard_normal(5000), 2.0 * rng.standard_normal(5000)])
    >>> bool(p < 1e-6), bool(1.8 < std[1] / std[0] < 2.2)
    (True, True)
    """
    stat, p = stats.levene(*groups, center="median")
    return float(stat), float(p), np.array([1.4826 * np.median(np.abs(q - np.median(q))) for q in groups])


class _Prepared:
    """One run: its innovations under the model, its structure columns and its tests."""

    def __init__(self, label, problem, model, s: UnexplainedSettings):
        self.label, self.problem, self.settings = label, problem, s
        y, basis, run = problem.y, problem.basis, problem.run
        self.X = problem.design_blocks(model.spec)[0]
        free = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
        self.noise: NoiseModel = fit_noise(y, self.X, basis, model.noise, free)[0]
        self.lower = linalg.cholesky(basis.covariance(self.noise), lower=True, check_finite=False)
        n = y.size
        self.block_s = basis.block_s
        # Block centres after the first sample [s]: the true times, gaps included.
        self.t = block_means(run.time_s, run.n_per_block)[:n] - run.time_s[0]
        self.columns = {}
        if run.temperature_c is not None:
            temp = block_means(run.temperature_c, run.n_per_block)[:n]
            self.temp = temp
            self.columns["temperature"] = temperature_bins(temp, s.temperature_bins)
            self.bands, self.band_c = _bands(temp, s.temperature_scan_bins, s.min_step_blocks)
            self.threshold_c = temperature_edges(temp, s.temperature_step_bins, s.min_step_blocks)
            rate = np.gradient(temp, self.block_s) * 60.0
            heating, cooling = rate > s.soak_rate_c_per_min, rate < -s.soak_rate_c_per_min
            z = (temp - temp.mean()) / max(np.ptp(temp) / 2.0, 1e-9)
            self.regime = np.where(heating, "heating", np.where(cooling, "cooling", "soak"))
            if heating.sum() >= 2 and cooling.sum() >= 2:
                self.columns["heating_cooling"] = np.column_stack([heating, cooling, heating * z, cooling * z]).astype(float)
        edges = [e for e in s.poweron_edges_s if e < self.t[-1] / 2.0]
        end = float(self.t[-1] + 0.5 * self.block_s)
        self.edges = {"power_on": [0.0] + edges + [end]}
        if edges:
            self.columns["power_on"] = _indicators(self.t, self.edges["power_on"])
        self.edges["time"] = np.linspace(0.0, end, s.time_segments + 1).tolist()
        self.columns["time"] = _indicators(self.t, self.edges["time"])
        self.tests = self._deterministic_tests(np.empty((n, 0)))
        e = self._innovations(np.empty((n, 0)))[0]
        self.tests["noise_blocks"] = _noise_test(*variance_segments(e, s.noise_segments), s)
        self.tests["noise_correlation"] = self._correlation(e)
        # Pairs within blocks (no block spans a gap), block after block in time.
        x = np.asarray(run.rate_dps, dtype=float)[: n * run.n_per_block].reshape(n, run.n_per_block)
        even = run.n_per_block - run.n_per_block % 2
        pairs = ((x[:, 1:even:2] - x[:, 0:even:2]) / np.sqrt(2.0)).ravel()
        stat, p, std = variance_segments(pairs, s.noise_segments)
        self.tests["noise_samples"] = _noise_test(stat, p, std * np.sqrt(run.fs_hz), s)
        if run.temperature_c is not None:
            # The same pairs grouped by their block's temperature bin: a white noise that grows with temperature.
            labels = np.repeat(np.argmax(self.columns["temperature"], axis=1), even // 2)
            kinds = [k for k in np.unique(labels) if np.sum(labels == k) >= 2 * s.min_step_blocks]
            if len(kinds) >= 2:
                groups = [pairs[labels == k] for k in kinds]
                stat, p, std = variance_groups(groups)
                test = _noise_test(stat, p, std * np.sqrt(run.fs_hz), s)
                cols = self.columns["temperature"][:, kinds]
                test["temperature_c"] = [[float(self.temp[c > 0].min()), float(self.temp[c > 0].max())] for c in cols.T]
                self.tests["noise_temperature"] = test
        self.duration_s = end
        self.kept = []

    def _correlation(self, e):
        """Ljung-Box test of the innovations `e` (white under the model)."""
        lags = min(self.settings.whiteness_lags, e.size // 4)
        q, p = signature.ljung_box(e, lags)
        x = e - e.mean()
        rho = [float(x[k:] @ x[:-k] / (x @ x)) for k in range(1, lags + 1)]
        return {"stat": q, "p": p, "lags": lags, "rho": rho}

    def _whiten(self, G):
        return linalg.solve_triangular(self.lower, G, lower=True, check_finite=False)

    def _innovations(self, extra):
        """Innovations and whitened design with the columns `extra` added to the model's."""
        X = np.hstack([self.X, extra])
        Xw = self._whiten(X)
        yw = self._whiten(self.problem.y)
        coef, *_ = linalg.lstsq(Xw, yw, cond=1e-12, lapack_driver="gelsy", check_finite=False)
        return yw - Xw @ coef, Xw, coef

    def _deterministic_tests(self, extra):
        """The score, step and spectral-line tests with the columns `extra` in the design."""
        e, Xw, _ = self._innovations(extra)
        out = {}
        for name, G in self.columns.items():
            stat, dof, p, *_ = score_test(e, Xw, self._whiten(G))
            out[name] = {"stat": stat, "dof": dof, "p": p, "log10_p": _log10(stats.chi2.logsf(stat, dof)) if dof else 0.0}
        if "temperature" in out and self.bands.shape[1]:
            out["temperature"] = self._band_scan(e, Xw, out["temperature"])
        step = step_scan(e, Xw, self.lower, self.settings.min_step_blocks)
        step["log10_p"] = _log10(step.pop("log_p"))
        step["time_s"] = step["block"] * self.block_s
        out["step"] = step
        if self.problem.run.temperature_c is not None and self.threshold_c.size:
            out["temperature_step"] = self._threshold_scan(e, Xw)
        g, p, j = fisher_g(e, self.settings.line_min_cycles)
        m = (e.size - 1) // 2 - self.settings.line_min_cycles + 1
        out["spectral_line"] = {
            "stat": g,
            "p": p,
            "period_s": e.size * self.block_s / j,
            "log10_p": min(0.0, _log10(np.log(m) + (m - 1) * np.log1p(-min(g, 1.0 - 1e-16)))),
        }
        out["moving_line"] = self._moving_line(e)
        return out

    def _band_scan(self, e, Xw, bins):
        """The temperature test (module docstring): the bins' score `bins` and the scan of narrow bands, ``2 min`` of the two."""
        z, live, _ = signature.column_scores(e, Xw, self.lower, self.bands)
        j = int(np.argmax(np.abs(z)))
        log_scan = np.log(2.0 * live.sum()) + stats.norm.logsf(abs(z[j]))
        scan_p = float(min(1.0, np.exp(log_scan)))
        by = "band" if scan_p < bins["p"] else "bins"
        log_p = min(0.0, np.log(2.0) + (log_scan if by == "band" else stats.chi2.logsf(bins["stat"], bins["dof"])))
        return bins | {
            "p": float(min(1.0, 2.0 * min(scan_p, bins["p"]))),
            "log10_p": _log10(log_p),
            "by": by,
            "band": {"stat": float(abs(z[j])), "column": j, "temperature_c": self.band_c[j], "p": scan_p},
        }

    def _threshold_scan(self, e, Xw):
        """The temperature-step test (module docstring): the edge of largest ``|z|`` and its union-bound p."""
        found = signature.threshold_scan(e, Xw, self.lower, self.temp, self.threshold_c)
        return {
            "stat": found["stat"],
            "temperature_c": float(self.threshold_c[found["index"]]),
            "size": found["size"],
            "p": found["p"],
            "log10_p": _log10(found["log_p"]),
        }

    def _moving_line(self, e):
        """Fisher's ``g`` in each of ``line_segments`` segments of `e`; Bonferroni over them."""
        k, cycles = self.settings.line_segments, self.settings.line_min_cycles
        parts = np.array_split(np.arange(e.size), k)
        if (parts[-1].size - 1) // 2 - cycles + 1 < 2:
            # Segments too short to hold two Fourier frequencies of at least `cycles` cycles (a run in bursts).
            return {"stat": 0.0, "p": 1.0, "p_segments": [], "segments": [], "period_s": [], "power": []}
        found = [fisher_g(e[idx], cycles) for idx in parts]
        p = [f[1] for f in found]
        return {
            "stat": float(max(f[0] for f in found)),
            "p": float(min(1.0, k * min(p))),
            "p_segments": p,
            "segments": [[int(idx[0]), int(idx[-1]) + 1] for idx in parts],
            "period_s": [idx.size * self.block_s / f[2] for idx, f in zip(parts, found)],
            "power": [float(f[0] * e[idx] @ e[idx]) for idx, f in zip(parts, found)],
        }

    def explain(self, names, alpha):
        """The rejected deterministic structures that remain significant given the stronger ones.

        From the best description down -- the largest score statistic less
        ``ln n`` per free parameter (BIC; a step's time and a line's
        frequency count as one each) -- each rejected structure is re-tested with the columns of those already kept in the
        design, and kept when its p stays below `alpha` (the family's
        Bonferroni share): a step is also a change between heating and
        cooling on a triangular profile, and is reported once, as a step.
        The block-level noise test is repeated on the innovations with the
        kept structures in the design (a bump raises the variance of the
        segment it lies in); the sample-level one is kept as rejected.
        """
        n = self.t.size
        order = sorted((k for k in names if not k.startswith("noise_")), key=lambda k: -self._evidence(k, n))
        kept = []
        for name in order:
            if not kept or self._deterministic_tests(self.structure(kept))[name]["p"] < alpha:
                kept.append(name)
        if "noise_blocks" in names:
            e = self._innovations(self.structure(kept))[0]
            if _noise_test(*variance_segments(e, self.settings.noise_segments), self.settings)["p"] < alpha:
                kept.append("noise_blocks")
        if "noise_correlation" in names and self._correlation(self._innovations(self.structure(kept))[0])["p"] < alpha:
            # Still correlated with the kept structures in the design (a step alone makes the innovations correlated).
            kept.append("noise_correlation")
        kept += [k for k in ("noise_samples", "noise_temperature") if k in names]
        self.kept = kept
        return kept

    def _evidence(self, name, n):
        """Score statistic minus its BIC penalty (``chi^2`` = ``z^2`` for a step; ``g`` times the total power for a line)."""
        t = self.tests[name]
        if name in ("step", "temperature_step"):
            return t["stat"] ** 2 - 2.0 * np.log(n)
        if name == "spectral_line":
            e = self._innovations(np.empty((n, 0)))[0]
            return t["stat"] * float(e @ e) * 2.0 - 3.0 * np.log(n)
        if name == "moving_line":
            return float(np.sum(2.0 * np.asarray(t["power"]) - 3.0 * np.log(n)))
        if t.get("by") == "band":
            return t["band"]["stat"] ** 2 - np.log(n)
        return t["stat"] - t["dof"] * np.log(n)

    def structure(self, names):
        """Block-level columns of the deterministic structures `names` (a step its indicator, a line sin / cos)."""
        cols = [self.columns[n] for n in names if n in self.columns]
        if "temperature" in names and self.tests["temperature"].get("by") == "band":
            cols.append(self.bands[:, [self.tests["temperature"]["band"]["column"]]])
        if "step" in names:
            cols.append((np.arange(self.t.size) >= self.tests["step"]["block"]).astype(float)[:, None])
        if "temperature_step" in names:
            cols.append((self.temp >= self.tests["temperature_step"]["temperature_c"]).astype(float)[:, None])
        if "spectral_line" in names:
            w = 2.0 * np.pi / self.tests["spectral_line"]["period_s"]
            cols.append(np.column_stack([np.sin(w * self.t), np.cos(w * self.t)]))
        if "moving_line" in names:
            # In each segment a sinusoid at that segment's own line: the drifting tone piecewise.
            line = self.tests["moving_line"]
            for (a, b), period in zip(line["segments"], line["period_s"]):
                inside = (np.arange(self.t.size) >= a) & (np.arange(self.t.size) < b)
                w = 2.0 * np.pi / period
                cols.append(np.column_stack([np.sin(w * self.t) * inside, np.cos(w * self.t) * inside]))
        return np.hstack(cols) if cols else np.empty((self.t.size, 0))

    def _part(self, names):
        """The fitted block-level part [deg/s] of the structures `names`, mean removed."""
        G = self.structure(names)
        if not G.shape[1]:
            return np.zeros(self.t.size), np.empty(0)
        coef = self._innovations(G)[2][self.X.shape[1] :]
        f = G @ coef
        return f - f.mean(), coef

    def describe(self, name):
        """Where the structure `name` lies and a sentence about its shape."""
        result = self.tests[name]
        if name == "noise_temperature":
            std = np.asarray(result["std"])
            hi, lo = result["temperature_c"][int(np.argmax(std))], result["temperature_c"][int(np.argmin(std))]
            return (
                {"temperature_c": hi, "ratio": result["ratio"]},
                f"the sample (white) noise depends on temperature: {result['ratio']:.2f} times larger at "
                f"{hi[0]:.1f}-{hi[1]:.1f} degC than at {lo[0]:.1f}-{lo[1]:.1f} degC",
            )
        if name == "noise_correlation":
            rho = result["rho"]
            return (
                {"timescale_s": [self.block_s, result["lags"] * self.block_s]},
                f"the residual is correlated beyond the model's noise (Ljung-Box over {result['lags']} lags of "
                f"{self.block_s:.0f} s; lag-1 correlation {rho[0]:+.2f}): a correlated noise (telegraph, Markov) "
                "or a slow structure that no vocabulary noise term takes with its own signature",
            )
        if name.startswith("noise_"):
            std = np.asarray(result["std"])
            k_hi, k_lo = int(np.argmax(std)), int(np.argmin(std))
            seg = self.duration_s / std.size
            level = "block-mean (slow)" if name == "noise_blocks" else "sample (white)"
            return (
                {"time_s": [k_hi * seg, (k_hi + 1) * seg], "ratio": result["ratio"]},
                f"the {level} noise changes over the run: {result['ratio']:.2f} times larger in "
                f"{k_hi * seg / 3600:.1f}-{(k_hi + 1) * seg / 3600:.1f} h than in "
                f"{k_lo * seg / 3600:.1f}-{(k_lo + 1) * seg / 3600:.1f} h",
            )
        f, coef = self._part([name])
        f_dh = f * _DEG_H
        amp = float(np.sqrt(np.mean(f_dh**2)))
        if name in self.columns:
            # The column with the largest score on its own: where the residual departs most from the model.
            k = self._strongest(self.columns[name])
            mean_in = float(f_dh[self.columns[name][:, k] > 0].mean())
        if name == "temperature":
            if result.get("by") == "band":
                lo, hi = result["band"]["temperature_c"]
                mean_in = float(f_dh[self.bands[:, result["band"]["column"]] > 0].mean())
            else:
                inside = self.temp[self.columns[name][:, k] > 0]
                lo, hi = float(inside.min()), float(inside.max())
            return (
                {"temperature_c": [lo, hi]},
                f"the residual depends on temperature beyond the model (rms {amp:.3g} deg/h), most between "
                f"{lo:.1f} and {hi:.1f} degC ({mean_in:+.3g} deg/h)",
            )
        if name == "heating_cooling":
            heat = float(f_dh[self.regime == "heating"].mean())
            cool = float(f_dh[self.regime == "cooling"].mean())
            return (
                {"regime": "heating" if abs(heat) > abs(cool) else "cooling"},
                f"the residual differs between heating and cooling (mean {heat:+.3g} deg/h heating, {cool:+.3g} deg/h "
                "cooling): a hysteresis or rate sensitivity of a form the vocabulary does not hold",
            )
        if name in ("power_on", "time"):
            edges = self.edges[name]
            lo, hi = edges[k], edges[k + 1]
            what = "after power-on" if name == "power_on" else "in time"
            return (
                {"time_s": [lo, hi]},
                f"the residual drifts {what} (rms {amp:.3g} deg/h), most between {lo / 3600:.2f} and {hi / 3600:.2f} h "
                f"({mean_in:+.3g} deg/h)",
            )
        if name == "step":
            t0 = result["time_s"]
            return (
                {"time_s": [t0 - self.block_s, t0 + self.block_s]},
                f"a step of {float(coef[-1]) * _DEG_H:+.3g} deg/h at {t0 / 3600:.2f} h",
            )
        if name == "temperature_step":
            c = result["temperature_c"]
            return (
                {"temperature_c": [c, c]},
                f"a step of {float(coef[-1]) * _DEG_H:+.3g} deg/h at {c:.1f} degC, the same heating and cooling: "
                "a bias discontinuity in temperature (a hysteresis switches with the direction of the change, not at one temperature)",
            )
        if name == "moving_line":
            periods = result["period_s"]
            spans = ", ".join(
                f"{p:.0f} s in {a * self.block_s / 3600:.1f}-{b * self.block_s / 3600:.1f} h"
                for (a, b), p in zip(result["segments"], periods)
            )
            return (
                {"timescale_s": [float(min(periods)), float(max(periods))]},
                f"a periodic component whose period moves over the run (rms {amp:.3g} deg/h): {spans}",
            )
        period = result["period_s"]
        return (
            {"timescale_s": period},
            f"a periodic component of period {period:.0f} s (amplitude {amp * np.sqrt(2.0):.3g} deg/h)",
        )

    def _strongest(self, G):
        """Index of the column of `G` whose whitened score ``|g' e| / |g|`` (orthogonal to the design) is largest."""
        e, Xw, _ = self._innovations(np.empty((self.t.size, 0)))
        return int(np.argmax(np.abs(signature.column_scores(e, Xw, self.lower, G)[0])))

    def size(self, baseline_residual, s: UnexplainedSettings):
        """RMS [deg/h] of the kept deterministic structures (fitted jointly) and their share of the baseline's gap."""
        f = self._part([k for k in self.kept if not k.startswith("noise_")])[0]
        out = {"rms_deg_h": float(np.sqrt(np.mean(f * f)) * _DEG_H), "share_of_gap": None}
        if baseline_residual is None:
            return out
        m = max(1, int(round(s.gap_block_s / self.block_s)))
        f100 = block_means(f, m)
        r100 = block_means(baseline_residual, m * self.problem.run.n_per_block)
        k = min(r100.size, f100.size)
        if k >= 3:
            centre = np.eye(k) - 1.0 / k
            expected = float(np.trace(centre @ NoiseBasis(k, m * self.block_s).covariance(self.noise))) / (k - 1)
            excess = float(np.var(r100[:k], ddof=1)) - expected
            share = float(np.var(f100[:k], ddof=1)) / excess if excess > 0 else 1.0
            out["share_of_gap"] = float(min(1.0, max(0.0, share)))
        return out


def _bands(temp, binnings, min_blocks):
    """Indicators of the bins of each equal-width binning of `temp` in `binnings` holding at least `min_blocks` blocks, and their ranges [degC]."""
    cols, ranges = [], []
    for n_bins in binnings:
        for col in temperature_bins(temp, n_bins).T:
            if col.sum() >= min_blocks:
                inside = temp[col > 0]
                cols.append(col)
                ranges.append([float(inside.min()), float(inside.max())])
    return (np.column_stack(cols) if cols else np.empty((temp.size, 0))), ranges


def _indicators(t, edges):
    """Indicator columns of the intervals between consecutive `edges` (the last one closed)."""
    k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(edges) - 2)
    return (k[:, None] == np.arange(len(edges) - 1)[None, :]).astype(float)


def _log10(log_p):
    return float(log_p / np.log(10.0))


def _noise_test(stat, p, std, s):
    """A noise-change test: significant and at least `noise_min_ratio` between two segments."""
    ratio = float(std.max() / std.min()) if std.min() > 0 else np.inf
    p_eff = p if ratio >= s.noise_min_ratio else 1.0
    return {"stat": stat, "p": p_eff, "p_test": p, "ratio": ratio, "std": std}


def _public(result):
    """A test's result with arrays as lists (for JSON)."""
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in result.items()}
