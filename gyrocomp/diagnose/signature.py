"""Does a noise term show its own signature? The admissibility of random walk and flicker.

A flexible noise term -- a rate random walk ``K`` or flicker ``B`` -- can
absorb any slow residual: a hidden step, a temperature bump, a ramp. The
likelihood then prefers it, and the gap counts the residual as explained.
:func:`check` lets such a term take the blame only when it behaves like the
noise it claims to be, on every run (issue #16, part 3). It is a room over
the registry of residual checks (:mod:`gyrocomp.diagnose.checks`, where each
test, its statistic and its law under the model are stated):

a. **between runs** -- the runs agree on the term's level (``agreement``),
   nothing of the residual repeats between them as a function of time or
   temperature (``replication``), and no tone repeats at one time since
   power-on in every run (``spectrum``);
b. **innovations** -- on each run, the block-mean residual whitened under
   the model's noise (its levels refitted on that run by restricted
   maximum likelihood; Cholesky, time ordered: for a random walk these
   are, up to the white part, its increments) is white (``ljung_box``),
   without trend (``trend``), without temperature dependence or a step at
   one temperature (``temperature_absorbed``) and without a step in time
   (``step``). Restricted, because the baseline's offset and temperature
   polynomial take the slow part of a random walk or a long Gauss-Markov
   wander: maximum likelihood then reads its level low (``K^2`` at 0.4 of
   the truth beside a cubic over 4 h, ``tests/diagnose/test_likelihood.py``),
   and a true noise term, judged at that level, shows "steps" and an Allan
   variance above its own at long ``tau``;
c. **timescales** -- at every octave ``tau`` where the term carries at least
   ``explains_share`` of the model's Allan variance (the timescales it
   explains), the residual's Allan variance lies within its interval
   (``allan``), no increment of its ``tau`` means is extreme and their
   spread is steady (``extreme``), and a flicker's level is Gaussian, not
   two levels it switches between (``levels``, pooled over the runs).

Every test returns a p-value; all tests of a term (on all runs) share
``refusal_alpha`` by Bonferroni, the family's size counted from what the
registry's checks returned (:func:`gyrocomp.diagnose.checks.family_size`),
so a noise term that *is* what the model says is refused with probability
at most ``refusal_alpha``. The tests of the term's own statistics
(:data:`gyrocomp.diagnose.checks.OWN`, and ``extreme`` when its
stationarity drives it) say whether the noise is of the kind claimed
(``own_ok``); the others may also fail for a structure beside a true noise
term (a drift beside a flicker).
"""

from __future__ import annotations

import dataclasses
import types

import numpy as np

from gyrocomp.diagnose.checks import KINDS, SIGNATURE, as_dict, family_size
from gyrocomp.diagnose.checks import agreement as _agreement
from gyrocomp.diagnose.checks import levels as _levels
from gyrocomp.diagnose.checks import replication as _replication
from gyrocomp.diagnose.checks import spectrum as _spectrum_check
from gyrocomp.diagnose.checks._linear import column_scores, innovations, score_test, temperature_bins, temperature_edges, threshold_scan
from gyrocomp.diagnose.checks._timescales import Timescales
from gyrocomp.diagnose.checks.extreme import bartlett
from gyrocomp.diagnose.checks.levels import level_test
from gyrocomp.diagnose.checks.ljung_box import ljung_box
from gyrocomp.diagnose.checks.spectrum import tone_replication
from gyrocomp.diagnose.checks.step import step_scan
from gyrocomp.diagnose.settings import ChecksSettings, DiagnoseSettings
from gyrocomp.effects.likelihood import block_means, fit_noise

__all__ = ["Signature", "check", "innovations", "score_test", "ljung_box", "column_scores", "threshold_scan", "step_scan", "temperature_bins", "temperature_edges", "level_test", "bartlett", "tone_replication"]

TERMS = ("rate_random_walk", "bias_instability")
"""The noise terms a signature is checked for."""


@dataclasses.dataclass(frozen=True)
class Signature:
    """The verdict of :func:`check`.

    Attributes
    ----------
    ok : bool
        Every test passed at its Bonferroni share of ``refusal_alpha``.
    reasons : tuple of str
        One sentence per failed test (empty when `ok`).
    stats : dict
        ``alpha`` (per test), ``agreement`` (per-run levels, 95 % intervals,
        statistic, p), ``levels`` (the pooled Gaussian-levels test),
        ``replication`` (one per ordered pair of runs and binning),
        ``spectrum`` (:func:`gyrocomp.diagnose.checks.spectrum.tone_replication`, the tone's period and window
        in seconds; None for one run), ``runs`` (per run: each test's
        statistic and p).
    own_ok : bool
        The tests of the term's own statistics passed (level agreement,
        a spectrum that does not repeat between runs, Allan slope, Gaussian
        levels): a failure of the others alone may be a
        structure beside a true noise term.
    tone_repeats : bool
        The spectrum replication refused the term: a tone at the same time
        since power-on in every run.
    """

    ok: bool
    reasons: tuple
    stats: dict
    own_ok: bool = True
    tone_repeats: bool = False


def check(term, runs, model, settings: DiagnoseSettings = DiagnoseSettings(), extra=None) -> Signature:
    """Whether noise `term` of `model` shows its own signature on `runs`.

    Parameters
    ----------
    term : {"rate_random_walk", "bias_instability"}
    runs : sequence of gyrocomp.diagnose.select.Problem
        The runs the term should explain (fit, holdout); each provides ``y``
        (block means), ``basis`` (:class:`NoiseBasis`), ``run``
        (:class:`gyrocomp.diagnose.effects.Run`) and ``design_blocks(spec)``.
    model : gyrocomp.diagnose.select.Fitted
        A model with `term` in its noise (selected, or proposed: the trial
        model); its ``spec`` (deterministic shapes, coefficients refitted on
        each run) and ``noise`` are used.
    settings : gyrocomp.diagnose.settings.DiagnoseSettings
        Its ``signature.refusal_alpha`` and the checks' ``checks``.
    extra : sequence of ndarray, optional
        Block-level columns added to each run's design (one array of shape
        ``(n_blocks, q)`` per run): the term judged beside structures found
        in the residual (:func:`gyrocomp.diagnose.confirm.confirm`).

    Returns
    -------
    Signature
        ``ok`` False with the reasons when a test fails (module docstring).
    """
    if term not in TERMS:
        raise ValueError(f"{term!r}: a signature is checked for {TERMS}")
    s = settings.checks
    if not getattr(model.noise, term) > 0.0:
        return Signature(False, (f"{term} has level 0 in the model",), {}, False)
    designs = [p.design_blocks(model.spec)[0] for p in runs]
    if extra is not None:
        designs = [np.hstack([X, G]) for X, G in zip(designs, extra)]
    free = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    per_run, whitened, levels = [], [], []
    for p, X in zip(runs, designs):
        # Each run is judged at its own (restricted) maximum-likelihood levels: whether they agree is test (a).
        own = fit_noise(p.y, X, p.basis, model.noise, free, restricted=True)[0]
        cov = p.basis.covariance(own)
        whitened.append(innovations(p.y, X, cov))
        out, level = _run_tests(p, X, own, cov, whitened[-1], term, s)
        per_run.append({"noise": own.datasheet_units(), **out})
        levels += [level] if level is not None else []
    between = {"agreement": None, "replication": [], "spectrum": None, "levels": _levels.pooled(levels)}
    if len(runs) > 1:
        between["agreement"] = _agreement.test(runs, designs, model.noise, term, s)
        between["replication"] = _replication.test(runs, designs, whitened, s)
        between["spectrum"] = _spectrum_check.test(runs, [e for e, *_ in whitened], s)
    between = {k: ([as_dict(r) for r in v] if isinstance(v, list) else (as_dict(v) if v is not None else None))
               for k, v in between.items()}
    n_tests = sum(family_size({k: v for k, v in out.items() if k != "noise"}) for out in per_run) + family_size(between)
    alpha = settings.signature.refusal_alpha / max(n_tests, 1)
    reasons, own_failed, tone_repeats = _reasons(runs, per_run, between, term, alpha)
    stats_out = {"alpha": alpha, "n_tests": n_tests, "agreement": between["agreement"], "levels": between["levels"],
                 "replication": between["replication"], "spectrum": between["spectrum"], "runs": per_run}
    return Signature(not reasons, tuple(reasons), stats_out, not own_failed, tone_repeats)


def _run_tests(problem, X, noise, cov, whitened, term, s: ChecksSettings):
    """Tests (b) and (c) of the module docstring on one run: the registry's per-run and timescale checks.

    `cov` is the block means' covariance under `noise`, and `whitened` the
    :func:`innovations` under it (computed once per run, shared with the
    replication tests). Returns the results by name and the run's levels
    statistics (None unless the term is flicker), which pool over the runs.
    """
    e, Xw, lower = whitened
    n = problem.y.size
    temp = None
    if problem.run.temperature_c is not None:
        temp = block_means(problem.run.temperature_c, problem.run.n_per_block)[:n]
    frame = types.SimpleNamespace(lower=lower, temp=temp, block_s=problem.basis.block_s, settings=s)
    out = {}
    for name in SIGNATURE:
        found = KINDS[name].test(frame, e, Xw)
        if found is not None:
            out[name] = as_dict(found)
    ts = Timescales(problem, X, cov, lower, Xw, noise, term, s)
    out["allan"] = [as_dict(r) for r in KINDS["allan"].test(ts)] if ts.ms.size else []
    out["extreme"] = as_dict(KINDS["extreme"].test(ts))
    return out, _levels.run_levels(ts)


def _reasons(runs, per_run, between, term, alpha):
    """One sentence per failed test; whether a test of the term's own statistics failed; whether a tone repeats."""
    reasons, own_failed = [], False
    for p, out in zip(runs, per_run):
        for point in out["allan"]:
            if point["p"] < alpha:
                own_failed = True
                reasons.append(
                    f"{p.run.name}: Allan variance at tau {point['tau_s']:.0f} s is {point['ratio']:.2f} times the "
                    f"{term} model's (p = {point['p']:.2g}): the slope it claims does not hold"
                )
        steady = out["extreme"]["stationary"]
        for name, what in _WHAT.items():
            if name in out and out[name]["p"] < alpha and not (name == "extreme" and out[name]["by"] == "stationary"):
                reasons.append(f"{p.run.name}: {what} (p = {out[name]['p']:.2g})")
        if out["extreme"]["p"] < alpha and out["extreme"]["by"] == "stationary":
            own_failed = True
            spread = ", ".join(f"{v:.2g}" for v in steady["spread"])
            reasons.append(
                f"{p.run.name}: the residual's {steady['tau_s']:.0f} s increments change their spread over the run "
                f"({spread} times the {term} model's variance in {len(steady['spread'])} parts; p = {out['extreme']['p']:.2g}): "
                "not the stationary increments of that noise"
            )
    agreement, levels, spectrum = between["agreement"], between["levels"], between["spectrum"]
    if agreement is not None and agreement["p"] < alpha:
        own_failed = True
        values = ", ".join(f"{v:.3g}" for v in agreement["level"])
        reasons.append(f"the runs disagree on the {term} level ({values} {agreement['unit']}; p = {agreement['p']:.2g})")
    if levels is not None and levels["p"] < alpha:
        own_failed = True
        reasons.append(_levels_reason(levels))
    tone_repeats = spectrum is not None and spectrum["p"] < alpha
    if tone_repeats:
        own_failed = True
        start, end = spectrum["window_s"]
        power = ", ".join(f"{v:.1f}" for v in spectrum["power"])
        reasons.append(
            f"a tone of period {spectrum['period_s']:.0f} s repeats in every run {start:.0f}-{end:.0f} s after power-on "
            f"(whitened periodogram {power} times the model's; p = {spectrum['p']:.2g}): a disturbance tied to the "
            f"time since power-on, where the wander of {term} does not repeat"
        )
    for rep in between["replication"]:
        if rep["p"] < alpha:
            reasons.append(
                f"the {rep['of']} residual of {rep['source']} repeats in {rep['target']} (p = {rep['p']:.2g}): "
                "a deterministic effect, where a random wander would not repeat"
            )
    return reasons, own_failed, tone_repeats


def _levels_reason(levels):
    """The sentence of a failed levels test."""
    if levels["by"] == "two_levels":
        return (
            f"the residual switches between two levels, not the Gaussian wander of flicker (two levels gain "
            f"{levels['two_levels']['gain']:.1f} in log-likelihood over a Gauss-Markov wander, z = "
            f"{levels['two_levels']['z']:.1f} against Gaussian draws; p = {levels['p']:.2g}): telegraph or popcorn noise"
        )
    kurt = ", ".join(f"{k:+.2f}" for k in levels["kurtosis"])
    return (
        f"the residual's {levels['tau_s'][0]:.0f} s level is bimodal, not the Gaussian level of flicker (excess kurtosis "
        f"{kurt} on the model's scale; p = {levels['p']:.2g}): a noise switching between a few levels (telegraph, popcorn)"
    )


_WHAT = {
    "ljung_box": "the innovations are autocorrelated (Ljung-Box): the residual is not the claimed noise",
    "trend": "the innovations carry a trend in time: a deterministic drift is absorbed as noise",
    "temperature_absorbed": "the innovations follow the temperature changes (bins, or a step at one temperature): a temperature effect is absorbed as noise",
    "step": "the residual holds a step that the noise absorbed",
    "extreme": "one increment of the residual is far beyond the noise's spread: a step is absorbed as noise",
}
