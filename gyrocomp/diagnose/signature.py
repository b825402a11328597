"""Does a noise term show its own signature? The admissibility of random walk and flicker.

A flexible noise term -- a rate random walk ``K`` or flicker ``B`` -- can
absorb any slow residual: a hidden step, a temperature bump, a ramp. The
likelihood then prefers it, and the gap counts the residual as explained.
:func:`check` lets such a term take the blame only when it behaves like the
noise it claims to be, on every run (issue #16, part 3):

a. **agreement** -- its level is a property of the gyro, so the runs must
   agree on it: the likelihood-ratio statistic of one shared level against
   one level per run (each run's white level profiled out) is ``chi^2`` with
   ``n_runs - 1`` degrees of freedom under that hypothesis (Wilks). Each
   run's 95 % profile-likelihood interval is reported.
a'. **replication** -- its wander is drawn afresh in every run, so nothing
   of it repeats between runs: one run's residual, averaged in bins of the
   time since power-on (of temperature), is one column of a score test on
   another run (``chi^2_1``, every ordered pair); and the power of the
   innovations at one time since power-on and one period is not high in
   every run at once: cut from power-on into halves, quarters and eighths
   (``spectrum_parts``), each run's periodogram ordinates are independent
   ``Exp(1)`` under the model, so their minimum over the ``R`` runs is
   ``Exp(R)`` and the largest such minimum over the ``M`` cells has an
   exact tail (:func:`tone_replication`). A tone or chirp tied to the time
   since power-on repeats there whatever its phase in each run; a flicker
   or random walk fitted to it does not.
b. **innovations** -- the block-mean residual whitened under the model's
   noise (its levels refitted on each run by maximum likelihood) (Cholesky, time ordered: for a random walk these are, up to the
   white part, its increments) are white, Gaussian, without trend and without
   temperature dependence:

   * Ljung-Box ``Q = n (n + 2) sum_k rho_k^2 / (n - k)`` over ``h`` lags,
     ``chi^2_h`` [1]_;
   * trend: the score statistic of ``[1, t]`` in innovation space (a ramp
     or a curve in time that the noise absorbed), ``chi^2_2``;
   * temperature: the score statistic of ``temperature_bins`` equal-width
     temperature-bin indicators, whitened (a function of temperature beyond
     the model's that the noise absorbed), ``chi^2`` of their rank beyond the
     design, and a step at one temperature, the largest score of ``1[T >= c]`` at
     the inner edges of ``temperature_step_bins`` equal-width bins (a bias
     discontinuity the noise absorbed) with the union bound over the edges
     (:func:`threshold_scan`); the two make one test, ``p = 2 min`` of
     theirs, so that the family keeps its number of tests;
   * extreme and stationary: at the timescales the term explains (c), the
     largest increment of the residual's ``tau`` means in units of its
     standard deviation under the model (a step is one large increment where
     a random walk spreads its wander over all of them), with the union bound
     ``n 2 Phi(-z)``, times the number of taus; and whether those increments
     keep one spread over the run (a random walk's and a flicker's increments
     are stationary, where a transient -- a wander that starts late, a burst
     -- puts its spread in one part): at each of those taus with at least
     ``stationarity_segments * min_segment_increments`` increments, Bartlett's
     test of equal variance of the standardised increments in
     ``stationarity_segments`` consecutive parts, each part's degrees of
     freedom the exact (Satterthwaite) ones of its sum of squares under the
     model (:func:`bartlett`), ``chi^2`` with ``parts - 1``, times the
     number of taus. The two make one test, ``p = 2 min(p_extreme,
     p_stationary)``, so that the family keeps its number of tests; it is of
     the term's own statistics when the stationarity drives it;
   * levels (flicker only): a flicker's level is Gaussian, where a noise that
     switches between a few levels (random telegraph or popcorn noise, mode
     hops) has a bimodal, light-tailed level. At the shortest ``tau`` the
     term explains (the most nearly independent means, where the term first
     dominates the white noise) the residual's ``tau`` means ``u_i``, each
     in units of its standard deviation under the model (``z_i``), give
     ``Q = mean He_4(z_i)``, ``He_4(z) = z^4 - 6 z^2 + 3``. Under the model
     ``E Q = 0`` and ``Var Q = 24 sum_ij rho_ij^4 / k^2`` exactly (Mehler:
     ``Cov(He_4(z_i), He_4(z_j)) = 4! rho_ij^4``), and a wrong scale moves
     ``E Q`` only to second order (``3 delta^2``). The lower tail is tested,
     ``Phi(Q / sd)``: conservative, since ``He_4 >= -6`` makes ``Q``
     right-skewed. The runs are independent, so their ``Q`` pool into one
     test, ``sum Q_r / sqrt(sum Var Q_r)``. (A random walk's levels are its
     own sum; its increments may be heavy-tailed -- jumps -- and are left to
     the extreme test.) Under the white noise of the block means that
     bimodality is diluted; the persistence of the levels shows it better:
     the log-likelihood ratio ``T_r`` of two levels under white noise (a
     two-state hidden Markov model) to a Gauss-Markov wander under white
     noise, the two of the same spectrum, on the block-level residual, read
     against ``two_level_draws`` Gaussian draws with the residual's
     covariance under the model (:mod:`gyrocomp.diagnose.two_level`); the
     runs pool as ``sum (T_r - m_r) / sqrt(sum v_r)`` (``m_r``, ``v_r`` the
     draws' mean and variance), upper tail. The two make one test, ``p = 2
     min`` of theirs, so that the family keeps its number of tests.

   The score statistics project the whitened columns onto the complement of
   the whitened design, so with the noise known they are exactly
   ``chi^2`` with the rank of what is left.
c. **Allan slope** -- at every octave ``tau`` where the term carries at least
   ``explains_share`` of the model's Allan variance (the timescales it
   explains: ``+1/2`` ADEV slope for a random walk, ``0`` for flicker), the
   non-overlapping Allan variance of the residual lies within its interval:
   ``avar`` is a quadratic form ``r' A r`` in the residual, whose mean and
   Satterthwaite degrees of freedom under the model (regression removed)
   are exact moments [2]_; two-sided ``chi^2_nu`` test.

Every test returns a p-value; all tests of a term (on all runs) share
``family_alpha`` by Bonferroni, so a noise term that *is* what the model
says is refused with probability at most ``family_alpha``. The tests of the
term's own statistics -- its level (a), the independence of its spectrum
between runs (a'), its Allan slope (c), its Gaussian levels -- say whether
the noise is of the kind claimed (``own_ok``); the others may also fail for
a structure beside a true noise term (a drift beside a flicker).

References
----------
.. [1] G. M. Ljung, G. E. P. Box, "On a measure of lack of fit in time
   series models", Biometrika 65(2), 297-303 (1978).
.. [2] F. E. Satterthwaite, "An approximate distribution of estimates of
   variance components", Biometrics Bulletin 2(6), 110-114 (1946).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize, stats

from gyrocomp.config import bind, load_config
from gyrocomp.diagnose import two_level
from gyrocomp.diagnose.gap import effective_dof
from gyrocomp.effects.likelihood import NoiseModel, block_means, fit_noise, merge_blocks, profile_deviance

__all__ = ["SignatureSettings", "Signature", "get_config", "check", "innovations", "score_test", "ljung_box", "column_scores", "threshold_scan", "step_scan", "temperature_bins", "temperature_edges", "level_test", "bartlett", "tone_replication"]

TERMS = ("rate_random_walk", "bias_instability")
"""The noise terms a signature is checked for."""


@dataclasses.dataclass(frozen=True)
class SignatureSettings:
    """The ``[signature]`` table; defaults equal ``configs/unexplained.toml`` (reasons there)."""

    family_alpha: float = 0.01
    ljung_box_lags: int = 10
    max_blocks: int = 240
    profile_span: tuple = (-10.0, 6.0)
    profile_points: int = 33
    explains_share: float = 0.5
    min_allan_windows: int = 4
    temperature_bins: int = 8
    time_bins: int = 16
    min_step_blocks: int = 4
    temperature_step_bins: int = 64
    stationarity_segments: int = 4
    min_segment_increments: int = 4
    two_level_draws: int = 100
    two_level_iterations: int = 40
    two_level_seed: int = 0
    spectrum_parts: tuple = (2, 4, 8)


def get_config(path="unexplained") -> SignatureSettings:
    """Bind the ``[signature]`` table of a TOML file (default: the shipped ``configs/unexplained.toml``)."""
    return bind(SignatureSettings, load_config(path).get("signature", {}), f"{path} [signature]")


@dataclasses.dataclass(frozen=True)
class Signature:
    """The verdict of :func:`check`.

    Attributes
    ----------
    ok : bool
        Every test passed at its Bonferroni share of ``family_alpha``.
    reasons : tuple of str
        One sentence per failed test (empty when `ok`).
    stats : dict
        ``alpha`` (per test), ``agreement`` (per-run levels, 95 % intervals,
        statistic, p), ``levels`` (the pooled Gaussian-levels test),
        ``replication`` (one per ordered pair of runs and binning),
        ``spectrum`` (:func:`tone_replication`, the tone's period and window
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


def check(term, runs, model, settings: SignatureSettings = SignatureSettings(), extra=None) -> Signature:
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
    settings : SignatureSettings
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
    s = settings
    level = getattr(model.noise, term)
    if not level > 0.0:
        return Signature(False, (f"{term} has level 0 in the model",), {}, False)
    designs = [p.design_blocks(model.spec)[0] for p in runs]
    if extra is not None:
        designs = [np.hstack([X, G]) for X, G in zip(designs, extra)]
    free = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
    per_run, own, whitened = [], [], []
    for p, X in zip(runs, designs):
        # Each run is judged at its own maximum-likelihood levels: whether they agree is test (a).
        own.append(fit_noise(p.y, X, p.basis, model.noise, free)[0])
        cov = p.basis.covariance(own[-1])
        whitened.append(innovations(p.y, X, cov))
        per_run.append({"noise": own[-1].datasheet_units(), **_run_tests(p, X, own[-1], cov, whitened[-1], term, s)})
    agreement = _agreement(runs, designs, model.noise, term, s) if len(runs) > 1 else None
    replication, spectrum = [], None
    if len(runs) > 1:
        replication = _replication(runs, designs, whitened, s)
        spectrum = _spectrum(runs, [e for e, *_ in whitened], s)
    levels = _pooled_levels([out.pop("levels") for out in per_run if "levels" in out])
    n_tests = sum(len([k for k in out if k not in ("noise", "allan")]) + len(out["allan"]) for out in per_run)
    n_tests += len(replication) + (agreement is not None) + (levels is not None) + (spectrum is not None)
    alpha = s.family_alpha / max(n_tests, 1)
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
    if agreement is not None and agreement["p"] < alpha:
        own_failed = True
        values = ", ".join(f"{v:.3g}" for v in agreement["level"])
        reasons.append(f"the runs disagree on the {term} level ({values} {agreement['unit']}; p = {agreement['p']:.2g})")
    if levels is not None and levels["p"] < alpha:
        own_failed = True
        if levels["by"] == "two_levels":
            reasons.append(
                f"the residual switches between two levels, not the Gaussian wander of flicker (two levels gain "
                f"{levels['two_levels']['gain']:.1f} in log-likelihood over a Gauss-Markov wander, z = "
                f"{levels['two_levels']['z']:.1f} against Gaussian draws; p = {levels['p']:.2g}): telegraph or popcorn noise"
            )
        else:
            kurt = ", ".join(f"{k:+.2f}" for k in levels["kurtosis"])
            reasons.append(
                f"the residual's {levels['tau_s'][0]:.0f} s level is bimodal, not the Gaussian level of flicker (excess kurtosis "
                f"{kurt} on the model's scale; p = {levels['p']:.2g}): a noise switching between a few levels (telegraph, popcorn)"
            )
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
    for rep in replication:
        if rep["p"] < alpha:
            reasons.append(
                f"the {rep['of']} residual of {rep['source']} repeats in {rep['target']} (p = {rep['p']:.2g}): "
                "a deterministic effect, where a random wander would not repeat"
            )
    stats_out = {"alpha": alpha, "n_tests": n_tests, "agreement": agreement, "levels": levels, "replication": replication,
                 "spectrum": spectrum, "runs": per_run}
    return Signature(not reasons, tuple(reasons), stats_out, not own_failed, tone_repeats)


def _pooled_levels(tests):
    """One Gaussian-levels test of independent runs (None without any).

    The kurtosis ``sum Q_r / sqrt(sum Var Q_r)``, lower tail, and the two
    levels ``sum (T_r - m_r) / sqrt(sum v_r)``, upper tail; ``2 min`` of the
    two p-values (module docstring, levels).
    """
    if not tests:
        return None
    q = [t["kurtosis"] for t in tests]
    var = [t["var"] for t in tests]
    stat = float(np.sum(q) / np.sqrt(np.sum(var)))
    p_kurtosis = float(stats.norm.cdf(stat))
    two = [t["two_levels"] for t in tests]
    z = float(sum(t["stat"] - t["mean"] for t in two) / np.sqrt(sum(t["var"] for t in two)))
    p_two = float(stats.norm.sf(z))
    return {
        "stat": stat,
        "p": float(min(1.0, 2.0 * min(p_kurtosis, p_two))),
        "by": "kurtosis" if p_kurtosis <= p_two else "two_levels",
        "p_kurtosis": p_kurtosis,
        "kurtosis": q,
        "tau_s": [t["tau_s"] for t in tests],
        "two_levels": {"z": z, "p": p_two, "gain": float(sum(t["stat"] for t in two)), "runs": two},
    }


_WHAT = {
    "ljung_box": "the innovations are autocorrelated (Ljung-Box): the residual is not the claimed noise",
    "trend": "the innovations carry a trend in time: a deterministic drift is absorbed as noise",
    "temperature": "the innovations follow the temperature changes (bins, or a step at one temperature): a temperature effect is absorbed as noise",
    "step": "the residual holds a step that the noise absorbed",
    "extreme": "one increment of the residual is far beyond the noise's spread: a step is absorbed as noise",
}


def innovations(y, X, covariance):
    """The residual of ``y ~ N(X beta, covariance)`` whitened by the Cholesky factor, time ordered.

    Parameters
    ----------
    y : ndarray, shape (n,)
    X : ndarray, shape (n, p)
    covariance : ndarray, shape (n, n)

    Returns
    -------
    e : ndarray, shape (n,)
        ``L^-1 (y - X beta)`` with ``beta`` the GLS estimate and ``L L' =
        covariance``: one-step prediction errors in units of their standard
        deviation; ``N(0, I - P)`` when the model holds (``P`` the projector
        on the whitened design).
    Xw : ndarray, shape (n, p)
        ``L^-1 X``.
    lower : ndarray, shape (n, n)
        ``L``.
    """
    lower = linalg.cholesky(covariance, lower=True, check_finite=False)
    yw = linalg.solve_triangular(lower, y, lower=True, check_finite=False)
    Xw = linalg.solve_triangular(lower, X, lower=True, check_finite=False)
    beta, *_ = linalg.lstsq(Xw, yw, cond=1e-12, lapack_driver="gelsy", check_finite=False)
    return yw - Xw @ beta, Xw, lower


def score_test(e, Xw, Gw):
    """Score statistic of extra whitened columns `Gw` for innovations `e` of the design `Xw`.

    ``||U' e||^2`` with ``U`` an orthonormal basis of the part of ``Gw``
    orthogonal to ``Xw``; ``chi^2`` with ``rank(U)`` degrees of freedom when
    ``e ~ N(0, I - P_X)``.

    Returns
    -------
    stat : float
    dof : int
    p : float
    coef : ndarray
        ``U' e`` (the size of each direction found).
    u : ndarray, shape (n, dof)

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> e = rng.standard_normal(400)
    >>> round(score_test(e - e.mean(), np.ones((400, 1)), np.ones((400, 1)))[1], 1)  # nothing left beyond X
    0
    """
    qx, _ = linalg.qr(Xw, mode="economic")
    rest = Gw - qx @ (qx.T @ Gw)
    u, sv, _ = linalg.svd(rest, full_matrices=False)
    scale = np.linalg.norm(Gw, axis=0).max() if Gw.size else 0.0
    u = u[:, sv > 1e-8 * max(scale, 1e-300)]
    coef = u.T @ e
    stat = float(coef @ coef)
    dof = u.shape[1]
    return stat, dof, float(stats.chi2.sf(stat, dof)) if dof else 1.0, coef, u


def ljung_box(e, lags):
    """Ljung-Box ``Q`` of `e` over `lags` lags and its ``chi^2_lags`` p-value [1]_.

    Examples
    --------
    >>> q, p = ljung_box(np.random.default_rng(1).standard_normal(500), 10)
    >>> bool(p > 0.01)
    True
    """
    e = np.asarray(e, dtype=float) - np.mean(e)
    n = e.size
    denom = float(e @ e)
    k = np.arange(1, lags + 1)
    rho = np.array([float(e[j:] @ e[:-j]) for j in k]) / denom
    q = float(n * (n + 2) * np.sum(rho**2 / (n - k)))
    return q, float(stats.chi2.sf(q, lags))


def _run_tests(problem, X, noise: NoiseModel, cov, whitened, term, s: SignatureSettings):
    """Tests (b) and (c) of the module docstring on one run.

    `cov` is the block means' covariance under `noise`, and `whitened` the
    :func:`innovations` under it (computed once per run, shared with the
    replication tests).
    """
    y = problem.y
    e, Xw, lower = whitened
    n = y.size
    out = {}
    q, p = ljung_box(e, min(s.ljung_box_lags, n // 4))
    out["ljung_box"] = {"stat": q, "p": p}
    t = np.linspace(-1.0, 1.0, n)
    stat, dof, p, *_ = score_test(e, Xw, np.column_stack([np.ones(n), t]))
    out["trend"] = {"stat": stat, "dof": dof, "p": p}
    if problem.run.temperature_c is not None:
        temp = block_means(problem.run.temperature_c, problem.run.n_per_block)[:n]
        bins = temperature_bins(temp, s.temperature_bins)
        stat, dof, p, *_ = score_test(e, Xw, linalg.solve_triangular(lower, bins, lower=True, check_finite=False))
        out["temperature"] = {"stat": stat, "dof": dof, "p": p, "by": "bins"}
        edges = temperature_edges(temp, s.temperature_step_bins, s.min_step_blocks)
        if edges.size:
            # The bins and the step at one temperature make one test (2 min p): the family keeps its number of tests.
            found = threshold_scan(e, Xw, lower, temp, edges)
            out["temperature"] = out["temperature"] | {
                "p": float(min(1.0, 2.0 * min(p, found["p"]))),
                "by": "bins" if p <= found["p"] else "step",
                "step": {"stat": found["stat"], "temperature_c": float(edges[found["index"]]), "p": found["p"]},
            }
    out["step"] = step_scan(e, Xw, lower, s.min_step_blocks)
    out["step"]["time_s"] = out["step"]["block"] * problem.basis.block_s
    out["allan"], out["extreme"], levels = _timescales(problem, X, cov, lower, Xw, noise, term, s)
    if levels is not None:
        out["levels"] = levels
    return out


def column_scores(e, Xw, lower, G):
    """Whitened scores of the columns `G` against the innovations `e` of the design `Xw`.

    Each column is whitened by ``L`` and made orthogonal to the design;
    ``z_j`` is the score of its unit direction, ``N(0, 1)`` when the model
    holds. A column inside the design (no part orthogonal to it) scores 0.

    Returns
    -------
    z : ndarray
    live : ndarray of bool
        The columns with a part outside the design.
    norm : ndarray
        The norm of that part (``z_j / norm_j`` is the column's GLS size).
    """
    g = linalg.solve_triangular(lower, G, lower=True, check_finite=False)
    qx, _ = linalg.qr(Xw, mode="economic")
    g -= qx @ (qx.T @ g)
    norm = np.linalg.norm(g, axis=0)
    live = norm > 1e-9 * max(float(norm.max(initial=0.0)), 1e-300)
    z = np.where(live, (g.T @ e) / np.maximum(norm, 1e-300), 0.0)
    return z, live, norm


def threshold_scan(e, Xw, lower, x, edges):
    """The most likely step of the residual where the block-level variable `x` crosses one of `edges`, and its p-value.

    The columns ``1[x >= c]``, one per edge ``c`` (time since power-on: a
    step at one time; temperature: a step at one temperature, the same
    heating and cooling), scored by :func:`column_scores`. The p-value of
    ``max |z_j|`` is the union bound ``min(1, n_j 2 Phi(-max |z|))`` over the
    ``n_j`` columns outside the design, valid whatever their correlation.

    Returns
    -------
    dict
        ``stat`` (max ``|z|``), ``index`` (of that edge), ``size`` (the
        step's GLS size in the residual's unit), ``p``, ``log_p`` (natural
        log of the bound, for p-values below floating point).
    """
    z, live, norm = column_scores(e, Xw, lower, (np.asarray(x)[:, None] >= np.asarray(edges)[None, :]).astype(float))
    if not live.any():
        return {"stat": 0.0, "index": 0, "size": 0.0, "p": 1.0, "log_p": 0.0}
    j = int(np.argmax(np.abs(z)))
    log_p = min(0.0, float(np.log(2.0 * live.sum()) + stats.norm.logsf(abs(z[j]))))
    return {"stat": float(abs(z[j])), "index": j, "size": float(z[j] / norm[j]), "p": float(np.exp(log_p)), "log_p": log_p}


def step_scan(e, Xw, lower, min_blocks=4):
    """The most likely step in the residual and its p-value, for innovations `e` of the design `Xw`.

    A step at every block ``j`` (at least `min_blocks` from either end):
    :func:`threshold_scan` of the block index.

    Returns
    -------
    dict
        ``stat`` (max ``|z|``), ``block`` (first block after the step),
        ``size`` (the step's GLS size in the residual's unit), ``p``,
        ``log_p`` (as :func:`threshold_scan`).
    """
    n = e.size
    pos = np.arange(min_blocks, n - min_blocks + 1)
    if not pos.size:
        return {"stat": 0.0, "block": 0, "size": 0.0, "p": 1.0, "log_p": 0.0}
    found = threshold_scan(e, Xw, lower, np.arange(n), pos)
    return {k: found[k] for k in ("stat", "size", "p", "log_p")} | {"block": int(pos[found["index"]])}


def temperature_edges(temperature_c, n_bins, min_blocks):
    """The inner edges of `n_bins` equal-width bins of the block temperatures with at least `min_blocks` blocks on either side [degC].

    Examples
    --------
    >>> temperature_edges(np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]), 4, 2).tolist()
    [1.75, 3.5, 5.25]
    """
    t = np.asarray(temperature_c, dtype=float)
    edges = np.linspace(t.min(), t.max(), n_bins + 1)[1:-1]
    above = (t[:, None] >= edges[None, :]).sum(axis=0)
    return edges[(above >= min_blocks) & (t.size - above >= min_blocks)]


def temperature_bins(temperature_c, n_bins):
    """Indicator columns of `n_bins` equal-width temperature bins over the range (empty ones dropped).

    Equal widths, not equal counts: a soak holds many samples at one
    temperature and would take several bins of its own.

    Examples
    --------
    >>> temperature_bins(np.array([0.0, 0.5, 1.0, 3.9, 4.0]), 4).sum(axis=0).tolist()
    [2.0, 1.0, 2.0]
    """
    t = np.asarray(temperature_c, dtype=float)
    edges = np.linspace(t.min(), t.max(), n_bins + 1)[1:-1]
    idx = np.searchsorted(edges, t, side="right")
    cols = (idx[:, None] == np.arange(n_bins)[None, :]).astype(float)
    return cols[:, cols.sum(axis=0) > 0]


def _allan_taus(problem, noise: NoiseModel, term, s: SignatureSettings):
    """Octave block multiples ``m`` at which `term` carries ``explains_share`` of the model's AVAR."""
    tb, n = problem.basis.block_s, problem.y.size
    ms = 2 ** np.arange(int(np.log2(max(n // s.min_allan_windows, 1))) + 1)
    ms = ms[n // ms >= s.min_allan_windows]
    tau = ms * tb
    return ms[noise.term_avar(term, tau) >= s.explains_share * noise.avar(tau)]


def _timescales(problem, X, cov, lower, Xw, noise, term, s):
    """Tests (c), (b, extreme and stationary) and (b, levels) at the taus `term` explains.

    The residual's non-overlapping AVAR against its exact moments; the
    largest increment of the ``tau`` means in units of its standard
    deviation under the model (union bound over the increments: valid
    whatever their correlation); and the spread of those increments in
    consecutive parts of the run (:func:`bartlett`). Each of the last two
    is Bonferroni over the taus tried, and they make one test, ``2 min``
    of the two.
    """
    ms = _allan_taus(problem, noise, term, s)
    quiet = {"stat": 0.0, "p": 1.0, "by": "extreme", "stationary": None}
    if not ms.size:
        return [], quiet, None
    y = problem.y
    n = y.size
    tb = problem.basis.block_s
    # r = R y with R = I - X (Xw' Xw)^-1 Xw' L^-1: the GLS residual; under the model Cov(r) = R Sigma R'.
    pinv = linalg.pinv(Xw)
    resid_maker = np.eye(n) - X @ pinv @ linalg.solve_triangular(lower, np.eye(n), lower=True, check_finite=False)
    r = resid_maker @ y
    cov_r = resid_maker @ cov @ resid_maker.T
    allan, levels, extreme, steady = [], None, {"p": 1.0}, {"p": 1.0}
    n_steady = int(np.sum(n // ms - 1 >= s.stationarity_segments * s.min_segment_increments))
    for m in ms:
        k = n // m
        agg = np.hstack([np.kron(np.eye(k), np.full((1, m), 1.0 / m)), np.zeros((k, n - k * m))])
        if term == "bias_instability" and levels is None:
            # The shortest tau flicker explains: its Gaussian level; the block-level residual: two levels or a
            # Gaussian wander (module docstring, levels).
            levels = level_test(agg @ r, agg @ cov_r @ agg.T) | {"tau_s": float(m * tb)}
            levels["two_levels"] = two_level.switching_test(
                r, resid_maker @ lower, s.two_level_draws, s.two_level_iterations, s.two_level_seed)
        diff = np.diff(agg, axis=0)
        form = diff / np.sqrt(2.0 * (k - 1))
        avar = float(np.sum((form @ r) ** 2))
        cov_d = diff @ cov_r @ diff.T
        var_d = np.diag(cov_d)
        mean = float(np.sum(var_d) / (2.0 * (k - 1)))
        nu = effective_dof(form, cov_r)
        x = nu * avar / mean
        p = float(min(1.0, 2.0 * min(stats.chi2.cdf(x, nu), stats.chi2.sf(x, nu))))
        allan.append({"tau_s": float(m * tb), "ratio": avar / mean, "dof": nu, "p": p})
        d = diff @ r
        z = np.abs(d) / np.sqrt(var_d)
        p_max = float(min(1.0, z.size * 2.0 * stats.norm.sf(z.max())))
        if p_max * ms.size < extreme["p"]:
            j = int(np.argmax(z))
            extreme = {"stat": float(z.max()), "tau_s": float(m * tb), "time_s": float((j + 1) * m * tb), "p": p_max * ms.size}
        if k - 1 >= s.stationarity_segments * s.min_segment_increments:
            test = bartlett(d, cov_d, s.stationarity_segments)
            if test["p"] * n_steady < steady["p"]:
                steady = test | {"tau_s": float(m * tb), "p": float(min(1.0, test["p"] * n_steady))}
    if steady["p"] < extreme["p"]:
        by, p = "stationary", steady["p"]
    else:
        by, p = "extreme", extreme["p"]
    out = {k: v for k, v in extreme.items() if k != "p"} | {
        "p": float(min(1.0, 2.0 * p)), "by": by, "stationary": steady if "tau_s" in steady else None}
    return allan, out, levels


def bartlett(d, cov, n_parts):
    """Bartlett's test that the increments `d` (covariance `cov` under the model) keep one spread over `n_parts` consecutive parts.

    Each part ``j`` gives ``v_j = mean(d_i^2 / cov_ii)`` (1 in expectation
    under the model) with Satterthwaite's degrees of freedom ``nu_j`` of
    that quadratic form (:func:`gyrocomp.diagnose.gap.effective_dof`: the
    increments of a random walk's means are correlated). With ``N = sum
    nu_j`` and ``v = sum nu_j v_j / N``, Bartlett's ``M = N ln v - sum nu_j
    ln v_j`` over ``C = 1 + (sum 1 / nu_j - 1 / N) / (3 (k - 1))`` is
    ``chi^2_(k-1)`` when the spread is one; a scale common to all parts
    (a level the model has wrong) cancels.

    Returns
    -------
    dict
        ``stat`` (``M / C``), ``spread`` (``v_j``), ``dof`` (``nu_j``), ``p``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> steady = bartlett(rng.standard_normal(200), np.eye(200), 4)
    >>> late = bartlett(rng.standard_normal(200) * np.repeat([1.0, 1.0, 1.0, 3.0], 50), np.eye(200), 4)
    >>> bool(steady["p"] > 0.01), bool(late["p"] < 1e-6)
    (True, True)
    """
    sd = np.sqrt(np.diag(cov))
    parts = np.array_split(np.arange(d.size), n_parts)
    v = np.array([np.mean((d[i] / sd[i]) ** 2) for i in parts])
    nu = np.array([effective_dof(np.diag(1.0 / sd[i]) / np.sqrt(i.size), cov[np.ix_(i, i)]) for i in parts])
    total = nu.sum()
    pooled = float(nu @ v / total)
    m = total * np.log(pooled) - float(nu @ np.log(v))
    c = 1.0 + (np.sum(1.0 / nu) - 1.0 / total) / (3.0 * (n_parts - 1))
    stat = float(m / c)
    return {"stat": stat, "spread": v.tolist(), "dof": nu.tolist(), "p": float(stats.chi2.sf(stat, n_parts - 1))}


def level_test(u, cov):
    """Whether the Gaussian levels `u` with covariance `cov` are bimodal (light-tailed): the lower tail of ``mean He_4(z)``.

    ``z_i = u_i / sqrt(cov_ii)``; ``Q = mean(z^4 - 6 z^2 + 3)`` has mean 0
    and variance ``24 sum_ij rho_ij^4 / k^2`` when ``u ~ N(0, cov)``
    (module docstring, levels). A noise switching between two levels has
    ``He_4`` near ``-2`` at every level, a Gaussian one 0 on average.

    Returns
    -------
    dict
        ``stat`` (``Q`` over its standard deviation), ``kurtosis`` (``Q``,
        the levels' excess kurtosis on the model's scale), ``var``
        (``Var Q``), ``p`` (``Phi(stat)``).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> gaussian = level_test(rng.standard_normal(400), np.eye(400))
    >>> two_levels = level_test(rng.choice([-1.0, 1.0], 400) + 0.3 * rng.standard_normal(400), 1.09 * np.eye(400))
    >>> bool(gaussian["p"] > 0.01), bool(two_levels["p"] < 1e-6)
    (True, True)
    """
    sd = np.sqrt(np.diag(cov))
    z = u / sd
    rho = cov / np.outer(sd, sd)
    q = float(np.mean(z**4 - 6.0 * z**2 + 3.0))
    var = float(24.0 * np.sum(rho**4) / z.size**2)
    stat = q / np.sqrt(var)
    return {"stat": stat, "kurtosis": q, "var": var, "p": float(stats.norm.cdf(stat))}


def _replication(runs, designs, whitened, s: SignatureSettings):
    """Test (a'): does one run's slow residual, as a function of time or of temperature, repeat in another run?

    For every ordered pair of runs the source run's GLS residual is averaged
    in ``time_bins`` equal bins of time since power-on (and in
    ``temperature_bins`` equal-width temperature bins); that step function,
    read at the target run's times (temperatures), is one whitened column
    of a score test on the target run. The source's noise is independent of
    the target's, so the statistic is ``chi^2_1`` when the model holds.
    """
    prepared = []
    for p, X, (e, Xw, lower) in zip(runs, designs, whitened):
        beta, *_ = linalg.lstsq(Xw, linalg.solve_triangular(lower, p.y, lower=True, check_finite=False), cond=1e-12)
        t = np.arange(p.y.size) * p.basis.block_s
        temp = None
        if p.run.temperature_c is not None:
            temp = block_means(p.run.temperature_c, p.run.n_per_block)[: p.y.size]
        prepared.append((p, e, Xw, lower, p.y - X @ beta, t, temp))
    out = []
    for a, (pa, _, _, _, ra, ta, Ta) in enumerate(prepared):
        for b, (pb, eb, Xwb, lowb, _, tb, Tb) in enumerate(prepared):
            if a == b:
                continue
            shapes = {"time": _binned(ta, ra, tb, np.linspace(0.0, min(ta[-1], tb[-1]), s.time_bins + 1)[1:-1])}
            if Ta is not None and Tb is not None:
                edges = np.linspace(Ta.min(), Ta.max(), s.temperature_bins + 1)[1:-1]
                shapes["temperature"] = _binned(Ta, ra, Tb, edges)
            for of, g in shapes.items():
                gw = linalg.solve_triangular(lowb, g[:, None], lower=True, check_finite=False)
                stat, dof, p, *_ = score_test(eb, Xwb, gw)
                out.append({"of": of, "source": pa.run.name, "target": pb.run.name, "stat": stat, "p": p})
    return out


def _binned(x_source, r_source, x_target, edges):
    """The bin means of `r_source` over `x_source` (bins cut at `edges`), read at `x_target`."""
    k = edges.size + 1
    src = np.searchsorted(edges, x_source, side="right")
    means = np.bincount(src, weights=r_source, minlength=k) / np.maximum(np.bincount(src, minlength=k), 1)
    return means[np.searchsorted(edges, x_target, side="right")]


def tone_replication(innovations, parts):
    """Whether a tone repeats in every run at the same time since power-on: the largest run-wise minimum of the periodograms.

    Each run's innovations are cut from power-on into segments of ``L =
    n_min // parts`` blocks (``n_min`` the shortest run); segment ``j`` of
    run ``r`` gives the periodogram ``I_rjk = |sum_t e_t exp(-2 pi i k t /
    L)|^2 / L`` at the inner Fourier frequencies ``k = 1 .. ceil(L/2) - 1``.
    When the model holds the innovations are white with unit variance, so
    the ``I_rjk`` are independent ``Exp(1)`` and their minimum over the
    ``R`` runs, ``m_jk``, is ``Exp(R)``: a wander, however large, does not
    put its power at the same time and frequency in independent runs, where
    a disturbance tied to the time since power-on (a tone, a chirp) does,
    whatever its phase. Over the ``M`` cells ``P(max m >= x) = 1 - (1 -
    exp(-R x))^M``; Bonferroni over the segment lengths.

    Parameters
    ----------
    innovations : sequence of ndarray
        One run's whitened residual each (:func:`innovations`), of blocks of one length.
    parts : sequence of int
        The shortest run is cut into this many segments, one segment length each.

    Returns
    -------
    dict or None
        ``p``, the strongest cell's ``segment`` and ``bin`` (``k``),
        ``blocks`` (``L``), ``power`` (its ``I`` in each run), ``cells``
        (``M``); None with fewer than two runs or no length giving a bin.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(720)
    >>> noise = [rng.standard_normal(720) for _ in range(2)]
    >>> tone = [e + 0.5 * np.sin(2 * np.pi * t / 30.0 + phase) for e, phase in zip(noise, (0.3, 2.0))]
    >>> bool(tone_replication(noise, (2, 4))["p"] > 0.01), bool(tone_replication(tone, (2, 4))["p"] < 1e-6)
    (True, True)
    """
    if len(innovations) < 2:
        return None
    n = min(e.size for e in innovations)
    best = None
    for k in parts:
        length = n // k
        if length < 4:
            continue
        power = np.array([np.abs(np.fft.rfft(e[: k * length].reshape(k, length), axis=1)[:, 1:(length + 1) // 2]) ** 2 / length
                          for e in innovations])
        low = power.min(axis=0)
        j, b = np.unravel_index(np.argmax(low), low.shape)
        p = float(-np.expm1(low.size * np.log1p(-np.exp(-len(innovations) * low[j, b]))))
        if best is None or p < best["p"]:
            best = {"p": p, "segment": int(j), "bin": int(b) + 1, "blocks": int(length), "power": power[:, j, b].tolist(), "cells": int(low.size)}
    if best is not None:
        best["p"] = float(min(1.0, best["p"] * len(parts)))
    return best


def _spectrum(runs, es, s: SignatureSettings):
    """Test (a', spectrum): :func:`tone_replication` of the runs' innovations, with the tone's period and window in seconds.

    Runs whose blocks differ in length (runs of different durations), or
    with gaps between their blocks (a recording in segments: its block
    index is not its time), are not compared (None).
    """
    block_s = {p.basis.block_s for p in runs}
    if len(block_s) != 1 or not all(p.basis.contiguous for p in runs):
        return None
    found = tone_replication(es, s.spectrum_parts)
    if found is None:
        return None
    tb = block_s.pop()
    span = found["blocks"] * tb
    return found | {"period_s": span / found["bin"], "window_s": [found["segment"] * span, (found["segment"] + 1) * span]}


def _agreement(runs, designs, noise: NoiseModel, term, s: SignatureSettings):
    """Test (a): profile ``-2 log L`` of each run over the term's log-variance, white level profiled out."""
    grid = np.log(getattr(noise, term) ** 2) + np.linspace(*s.profile_span, s.profile_points)
    curves = []
    for p, X in zip(runs, designs):
        y, Xm, basis = merge_blocks(p.y, X, p.basis, s.max_blocks)
        curves.append(np.array([_profile_white(y, Xm, basis, noise, term, g) for g in grid]))
    curves = np.array(curves)
    lows = curves.min(axis=1)
    stat = float(max(0.0, curves.sum(axis=0).min() - lows.sum()))
    p = float(stats.chi2.sf(stat, len(runs) - 1))
    crit = stats.chi2.ppf(0.95, 1)
    scale = 3600.0 * 60.0 if term == "rate_random_walk" else 3600.0
    unit = "deg/h/sqrt(h)" if term == "rate_random_walk" else "deg/h"
    level, interval = [], []
    for c, low in zip(curves, lows):
        inside = grid[c - low <= crit]
        level.append(float(np.exp(0.5 * grid[np.argmin(c)]) * scale))
        interval.append([float(np.exp(0.5 * inside.min()) * scale), float(np.exp(0.5 * inside.max()) * scale)])
    return {"stat": stat, "p": p, "level": level, "interval_95": interval, "unit": unit}


def _profile_white(y, X, basis, noise: NoiseModel, term, log_var):
    """``min`` over the white level of ``-2 log L`` with `term`'s variance ``exp(log_var)``."""
    start = np.log(noise.arw**2)

    def dev(z):
        trial = dataclasses.replace(noise, arw=float(np.exp(0.5 * z)), **{term: float(np.exp(0.5 * log_var))})
        return profile_deviance(y, X, basis.whitener(trial))[0]

    best = optimize.minimize_scalar(dev, bounds=(start - 4.0, start + 4.0), method="bounded", options={"xatol": 1e-3})
    return float(best.fun)
