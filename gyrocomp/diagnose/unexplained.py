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
from gyrocomp.effects.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise
from gyrocomp.diagnose import signature
from gyrocomp.diagnose.signature import TERMS, score_test, step_scan, temperature_bins, temperature_edges

__all__ = ["UnexplainedSettings", "get_config", "verdict", "assess", "structure_found", "Prepared", "holm", "fisher_g", "variance_segments", "variance_groups"]

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
    return assess(runs, model, settings, baseline_residuals, signature_settings)[0]


def structure_found(problem, model, s: UnexplainedSettings = UnexplainedSettings()):
    """Block-level columns of the deterministic structures the tests find on `problem` under `model`, or None.

    The deterministic tests of the run (Holm at ``family_alpha`` over that
    run's tests), the findings that say the same thing reported once
    (:meth:`Prepared.explain`).
    """
    pr = Prepared("fit", problem, model, s)
    names = list(pr.tests)
    rejected = holm([pr.tests[k]["p"] for k in names], s.family_alpha)
    found = [k for k, r in zip(names, rejected) if r and not k.startswith("noise_")]
    kept = [k for k in pr.explain(found, s.family_alpha / max(len(names), 1)) if not k.startswith("noise_")]
    return pr.structure(kept) if kept else None


def assess(runs, model, settings, baseline_residuals, signature_settings):
    """:func:`verdict` and the prepared runs (their structures, for :func:`gyrocomp.diagnose.confirm.confirm`)."""
    s = settings
    prepared = [Prepared(label, p, model, s) for label, p in runs]
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


class Prepared:
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
