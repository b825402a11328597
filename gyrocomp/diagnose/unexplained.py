"""What the selected model does not explain: tests of the residual for structure it does not predict.

After the selection (:mod:`gyrocomp.diagnose.select`) the residual of every
run is tested for structure that the selected model -- its deterministic
shapes and its noise -- does not predict (issue #16, part 2). On each run
the block means ``y`` are regressed on the model's design ``X`` by GLS under
the model's noise ``Sigma`` (the levels of its noise terms refitted on that
run by maximum likelihood), and whitened by the Cholesky factor ``L``:
``e = L^-1 (y - X beta)`` is ``N(0, I - P)`` when the model holds. The
verdict is a room over the registry of residual checks
(:mod:`gyrocomp.diagnose.checks`, :data:`~gyrocomp.diagnose.checks.RESIDUAL`),
each exact or conservative with a known false-alarm rate, each stated in
its module: ``temperature`` (a function of temperature beyond the
model's), ``heating_cooling``, ``power_on``, ``time`` (a drift in time),
``step``, ``temperature_step`` (a bias discontinuity), ``spectral_line``,
``moving_line`` (a chirp), and the noise checks ``noise_blocks``,
``noise_correlation``, ``noise_samples``, ``noise_temperature``.

All tests on all runs form one family: Holm's step-down procedure [3]_
keeps the probability that a recording the model *does* explain is called
unexplained at most ``family_alpha``. A selected noise term must also show
its own signature (:func:`gyrocomp.diagnose.signature.check`): one that
does not stands in for a residual the vocabulary does not explain, and the
verdict is present with its reasons (each term adds its own family rate,
``[diagnose.signature] refusal_alpha``, by Bonferroni).

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
.. [3] S. Holm, "A simple sequentially rejective multiple test procedure",
   Scand. J. Statist. 6, 65-70 (1979).
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

from gyrocomp.diagnose import signature
from gyrocomp.diagnose.checks import DETERMINISTIC, KINDS, RESIDUAL, Frame, as_dict
from gyrocomp.diagnose.checks._linear import column_scores
from gyrocomp.diagnose.checks.noise_blocks import variance_groups, variance_segments
from gyrocomp.diagnose.checks.spectral_line import fisher_g
from gyrocomp.diagnose.signature import TERMS
from gyrocomp.diagnose.settings import DiagnoseSettings
from gyrocomp.effects.likelihood import NoiseBasis, NoiseModel, block_means, fit_noise

__all__ = ["verdict", "assess", "structure_found", "Prepared", "holm", "fisher_g", "variance_segments", "variance_groups"]

_DEG_H = 3600.0
"""deg/h per deg/s."""


def verdict(
    runs,
    model,
    settings: DiagnoseSettings = DiagnoseSettings(),
    baseline_residuals=None,
) -> dict:
    """Test the residual of `model` on `runs` for structure it does not predict.

    Parameters
    ----------
    runs : sequence of (str, gyrocomp.diagnose.select.Problem)
        ``(label, problem)``: the runs (``"fit"``, ``"holdout"``), each
        providing ``y``, ``basis``, ``run`` and ``design_blocks(spec)``.
    model : gyrocomp.diagnose.select.Fitted
        The selected model (``spec`` and ``noise`` are used).
    settings : gyrocomp.diagnose.settings.DiagnoseSettings
        ``unexplained.family_alpha``, the checks' ``checks``, ``gap_block_s``
        (the share of the gap), and the signature's: a selected
        ``rate_random_walk`` or ``bias_instability`` that does not show its
        own signature (:func:`gyrocomp.diagnose.signature.check`, its own
        false-refusal rate ``signature.refusal_alpha``) absorbs something the
        vocabulary does not explain: the verdict is then present, with its
        reasons.
    baseline_residuals : sequence of ndarray, optional
        Full-rate residual of the baseline on each run [deg/s], for the share
        of the gap.

    Returns
    -------
    dict
        ``present`` (bool), ``family_alpha``, ``where`` (one entry per
        rejected test: run, test, p and its location), ``hints`` (sentences),
        ``size`` (per run: ``rms_deg_h`` of the unexplained part of the block
        means and its ``share_of_gap``, None without `baseline_residuals`),
        ``tests`` (every test's statistic and p).
    """
    return assess(runs, model, settings, baseline_residuals)[0]


def structure_found(problem, model, s: DiagnoseSettings = DiagnoseSettings()):
    """Block-level columns of the deterministic structures the tests find on `problem` under `model`, or None.

    The deterministic tests of the run (Holm at ``family_alpha`` over that
    run's tests), the findings that say the same thing reported once
    (:meth:`Prepared.explain`).
    """
    pr = Prepared("fit", problem, model, s)
    names = list(pr.tests)
    alpha = s.unexplained.family_alpha
    rejected = holm([pr.tests[k]["p"] for k in names], alpha)
    found = [k for k, r in zip(names, rejected) if r and not k.startswith("noise_")]
    kept = [k for k in pr.explain(found, alpha / max(len(names), 1)) if not k.startswith("noise_")]
    return pr.structure(kept) if kept else None


def assess(runs, model, settings, baseline_residuals):
    """:func:`verdict` and the prepared runs (their structures, for :func:`gyrocomp.diagnose.confirm.confirm`)."""
    s = settings
    prepared = [Prepared(label, p, model, s) for label, p in runs]
    tests = [(pr, name, result) for pr in prepared for name, result in pr.tests.items()]
    rejected = holm([t[2]["p"] for t in tests], s.unexplained.family_alpha)
    alpha = s.unexplained.family_alpha / max(len(tests), 1)
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
            sig = signature.check(term, [p for _, p in runs], model, s)
            signatures[term] = {"ok": sig.ok, "own_ok": sig.own_ok, "tone_repeats": sig.tone_repeats, "reasons": list(sig.reasons),
                                "alpha": sig.stats.get("alpha"), "levels": _levels_evidence(sig.stats.get("levels"))}
            if not sig.ok:
                where.append({"run": "all", "test": f"signature:{term}", "p": sig.stats.get("alpha")})
                hints.append(f"the selected {term} does not show its own signature: " + "; ".join(sig.reasons[:3]))
    size = {}
    for k, pr in enumerate(prepared):
        base = baseline_residuals[k] if baseline_residuals is not None else None
        size[pr.label] = pr.size(base, s)
    return {
        "present": bool(any(rejected) or any(not v["ok"] for v in signatures.values())),
        "family_alpha": s.unexplained.family_alpha,
        "signatures": signatures,
        "signature_alpha": s.signature.refusal_alpha if signatures else None,
        "where": where,
        "hints": hints,
        "size": size,
        "tests": {pr.label: {name: _public(r) for name, r in pr.tests.items()} for pr in prepared},
        "unlisted": [],
    }, prepared


def _levels_evidence(levels):
    """A flicker's Gaussian-levels test for the report (:mod:`gyrocomp.diagnose.checks.levels`): its p and the two-level statistic; None for a random walk."""
    if levels is None:
        return None
    two = levels["two_levels"]
    return {"p": levels["p"], "by": levels["by"], "two_levels_z": two["z"], "two_levels_gain": two["gain"]}


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


class Prepared(Frame):
    """One run: its innovations under the model, its structure columns and the registry's checks on it."""

    def __init__(self, label, problem, model, s: DiagnoseSettings):
        self.label, self.problem = label, problem
        y, basis, run = problem.y, problem.basis, problem.run
        self.X = problem.design_blocks(model.spec)[0]
        free = ("arw",) + tuple(t for t in TERMS if getattr(model.noise, t) > 0.0)
        self.noise: NoiseModel = fit_noise(y, self.X, basis, model.noise, free)[0]
        n = y.size
        # Block centres after the first sample [s]: the true times, gaps included.
        t = block_means(run.time_s, run.n_per_block)[:n] - run.time_s[0]
        temp = block_means(run.temperature_c, run.n_per_block)[:n] if run.temperature_c is not None else None
        lower = linalg.cholesky(basis.covariance(self.noise), lower=True, check_finite=False)
        super().__init__(lower, t, temp, basis.block_s, s.checks, samples=(run.rate_dps, run.n_per_block, run.fs_hz))
        self.tests = self._deterministic_tests(np.empty((n, 0)))
        e, Xw, _ = self._innovations(np.empty((n, 0)))
        for name in RESIDUAL:
            if name not in DETERMINISTIC and (found := KINDS[name].test(self, e, Xw)) is not None:
                self.tests[name] = as_dict(found)
        self.kept = []

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
        """The registry's checks of a deterministic structure with the columns `extra` in the design."""
        e, Xw, _ = self._innovations(extra)
        found = {name: KINDS[name].test(self, e, Xw) for name in DETERMINISTIC}
        return {name: as_dict(r) for name, r in found.items() if r is not None}

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
            e, Xw, _ = self._innovations(self.structure(kept))
            if KINDS["noise_blocks"].test(self, e, Xw).pvalue < alpha:
                kept.append("noise_blocks")
        if "noise_correlation" in names and KINDS["noise_correlation"].test(self, *self._innovations(self.structure(kept))[:2]).pvalue < alpha:
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
        if name.startswith("noise_"):
            return self._describe_noise(name, result)
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

    def _describe_noise(self, name, result):
        """:meth:`describe` of a noise check (``noise_temperature``, ``noise_correlation``, ``noise_blocks``, ``noise_samples``)."""
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

    def _strongest(self, G):
        """Index of the column of `G` whose whitened score ``|g' e| / |g|`` (orthogonal to the design) is largest."""
        e, Xw, _ = self._innovations(np.empty((self.t.size, 0)))
        return int(np.argmax(np.abs(column_scores(e, Xw, self.lower, G)[0])))

    def size(self, baseline_residual, s: DiagnoseSettings):
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


def _public(result):
    """A test's result with arrays as lists (for JSON)."""
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in result.items()}
