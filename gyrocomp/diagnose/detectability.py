"""How strong an effect must be before `gyrocomp diagnose` can see it.

An **ideal detector** knows an effect's exact shape and the true noise
covariance ``Sigma`` of the block means (:mod:`gyrocomp.effects.likelihood`)
and compares the model with the effect to the closest model without it by
the drop ``T`` of ``-2 log L``. The selection
(:mod:`gyrocomp.diagnose.select`) keeps an effect of ``k`` parameters when
that drop exceeds ``threshold = k ln n_blocks + bic_margin``. The
**detection probability** ``P(T > threshold)`` of an effect is the figure
here; the amplitude at which it reaches 0.95 is the **edge of
detectability**: an effect weaker than that is missed by any method often
enough that naming it would be luck. The withheld-effect benchmark draws its
amplitudes from the edge up.

* A deterministic effect whose block means are ``s``, beside nuisance
  columns ``X`` (per-run offset, temperature polynomial, the other
  deterministic effects): ``T`` is a non-central chi-square with one degree
  of freedom and non-centrality (the **evidence**)

  .. math:: \\lambda = \\lVert (I - P_{WX}) W s \\rVert^2, \\quad W = \\Sigma^{-1/2},

  ``P_{WX}`` the projector on the whitened nuisance columns.
* A noise term (``bias_instability``, ``rate_random_walk``), on the
  contrasts orthogonal to ``X`` (the nuisance coefficients are not noise):
  with ``mu_j`` the eigenvalues of ``Sigma_0^{-1} Sigma`` for the closest
  ``Sigma_0`` without the term (the white level and the other noise term
  re-fitted to minimise the Kullback-Leibler divergence),

  .. math:: T = \\sum_j (\\mu_j - 1) z_j^2 - \\ln \\mu_j, \\quad z_j \\sim N(0, 1),

  whose mean, ``2 KL``, is the evidence. A random walk or flicker puts its
  power in a few slow modes, so ``T`` spreads far wider than a non-central
  chi-square of the same mean: a run's slow wander may happen to be small.

Several runs of the same gyro add their ``T``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize, stats

from gyrocomp.diagnose.effects import KINDS, STOCHASTIC, effect_columns, n_params_runs, polynomial_columns
from gyrocomp.effects.likelihood import NoiseModel, block_means

__all__ = [
    "threshold",
    "deterministic_evidence",
    "noise_ratios",
    "Contrasts",
    "noise_evidence",
    "deterministic_detection",
    "noise_detection",
    "edge_evidence",
    "detection_limit",
]


def threshold(n_blocks, effect, bic_margin, n_runs=1):
    """The ``-2 log L`` drop an effect must bring on `n_runs` runs of `n_blocks` blocks in all: ``k ln n_blocks + bic_margin``.

    ``k`` is :func:`gyrocomp.diagnose.effects.n_params_runs`: on two runs a
    sinusoid pays for a phase and an amplitude per run.
    """
    return n_params_runs(effect, n_runs) * np.log(n_blocks) + bic_margin


def deterministic_evidence(problem, contribution_dps, spec, noise: NoiseModel) -> float:
    """Evidence ``lambda`` of a deterministic effect in one run.

    Parameters
    ----------
    problem : gyrocomp.diagnose.select.Problem
        The run (its temperature and block layout; its rate is not used).
    contribution_dps : ndarray, shape (n,)
        The effect's full-rate contribution to the bias [deg/s].
    spec : dict
        The other deterministic effects present, ``{effect: {nonlinear
        parameter: value}}`` (their columns are nuisance, as in
        :func:`gyrocomp.diagnose.effects.design`).
    noise : NoiseModel
        The true noise terms.

    Returns
    -------
    float
        The non-centrality of the ``-2 log L`` drop (dimensionless).
    """
    w = problem.basis.whitener(noise)
    X, _ = problem.design_blocks(spec)
    s = w.whiten(block_means(contribution_dps, problem.run.n_per_block))
    Xw = w.whiten(X)
    beta, *_ = linalg.lstsq(Xw, s, cond=1e-12, lapack_driver="gelsy", check_finite=False)
    r = s - Xw @ beta
    return float(r @ r)


def noise_ratios(problem, spec, noise: NoiseModel, term: str, contrasts=None) -> np.ndarray:
    """Eigenvalues ``mu_j`` of ``Sigma_0^{-1} Sigma`` for the noise `term` in one run.

    Parameters
    ----------
    problem : gyrocomp.diagnose.select.Problem
    spec : dict
        Deterministic effects present (nuisance columns).
    noise : NoiseModel
        The true noise terms, `term` among them.
    term : str
        ``bias_instability`` or ``rate_random_walk``.
    contrasts : Contrasts, optional
        ``Contrasts(problem, spec)``, reused by a search over the term's
        level (its projections and eigendecompositions do not depend on it).

    Returns
    -------
    ndarray, shape (n_blocks - n_columns,)
    """
    if term not in STOCHASTIC or not getattr(noise, term):
        raise ValueError(f"noise_ratios: {term!r} is not a noise term present in {noise}")
    c = contrasts if contrasts is not None else Contrasts(problem, spec)
    block_s = problem.basis.block_s
    other = [t for t in STOCHASTIC if t != term and getattr(noise, t)]
    if not other:
        # Sigma_0 = s^2 I on the contrasts: the divergence is least at s^2 = tr(Sigma) / m.
        true = c.covariance(noise)
        lam = linalg.eigvalsh(true, check_finite=False)
        return lam / (np.sum(lam) / true.shape[0])
    # Sigma_0 = a I + b C shares the eigenvectors V of C (eigenvalues c): with
    # d = diag(V' Sigma V) the divergence is sum(d / (a + b c) + ln(a + b c)) + const,
    # O(m) per trial; V' Sigma V is a sum of the terms' rotated projections.
    lam_other, rotated = c.rotated(noise, other[0], term)
    d = np.diagonal(rotated).copy()
    lam = np.maximum(lam_other, 0.0)

    def divergence(z):
        diag = np.exp(z[0]) / block_s + np.exp(z[1]) * lam
        return float(np.sum(d / diag + np.log(diag)))

    start = np.log([noise.arw**2, getattr(noise, other[0]) ** 2])
    best = optimize.minimize(divergence, start, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-6})
    # The eigenvalues of Sigma_0^-1 Sigma are those of S^-1/2 V' Sigma V S^-1/2, Sigma_0 = V S V'.
    scale = 1.0 / np.sqrt(np.exp(best.x[0]) / block_s + np.exp(best.x[1]) * lam)
    return linalg.eigvalsh(rotated * scale[:, None] * scale[None, :], check_finite=False)


class Contrasts:
    """The unit noise covariances of one run projected on the contrasts orthogonal to a design, computed once.

    ``Q' C Q`` for ``Q`` an orthonormal basis of the complement of the
    design's columns (`problem`'s blocks with the effects of `spec`), for
    ``C`` the flicker (or its Markov form) and the random walk; and, for a
    noise term beside the other one, the eigenvectors ``V`` of the other's
    projection and the term's projection rotated into them, ``V' Q' C Q V``.
    A noise model's projected covariance is then a sum of these scaled by
    its levels (:func:`noise_ratios`).
    """

    def __init__(self, problem, spec):
        X, _ = problem.design_blocks(spec)
        q, _ = np.linalg.qr(X, mode="complete")
        self._q = q[:, X.shape[1] :]
        self._basis = problem.basis
        self._projected, self._eig = {}, {}

    def projected(self, term, noise: NoiseModel):
        """``Q' C Q`` of noise `term` in `noise`'s form (flicker or its Markov form)."""
        key = (term, noise.bias_correlation_s if term == "bias_instability" else 0.0)
        if key not in self._projected:
            unit = self._basis.bias(noise.bias_correlation_s) if term == "bias_instability" else self._basis.random_walk
            self._projected[key] = self._q.T @ unit @ self._q
        return self._projected[key]

    def covariance(self, noise: NoiseModel):
        """``Q' Sigma Q`` of `noise`: ``N^2 / T_b I`` (``Q`` orthonormal) plus each coloured term's projection at its level."""
        out = np.eye(self._q.shape[1]) * (noise.arw**2 / self._basis.block_s)
        for term in STOCHASTIC:
            if getattr(noise, term):
                out += getattr(noise, term) ** 2 * self.projected(term, noise)
        return out

    def rotated(self, noise: NoiseModel, other: str, term: str):
        """The eigenvalues of `other`'s projection and ``V' Q' Sigma Q V`` of `noise` in its eigenvectors ``V``."""
        key = (other, noise.bias_correlation_s)
        if key not in self._eig:
            lam, v = linalg.eigh(self.projected(other, noise), check_finite=False)
            self._eig[key] = (lam, v, v.T @ self.projected(term, noise) @ v)
        lam, _, turned = self._eig[key]
        out = getattr(noise, term) ** 2 * turned
        out[np.diag_indices_from(out)] += noise.arw**2 / self._basis.block_s + getattr(noise, other) ** 2 * lam
        return lam, out


def noise_evidence(ratios) -> float:
    """Evidence of a noise term, ``sum(mu - 1 - ln mu)`` (twice the divergence), from :func:`noise_ratios`."""
    mu = np.asarray(ratios, dtype=float)
    return float(np.sum(mu - 1.0 - np.log(mu)))


def deterministic_detection(evidence, threshold_value) -> float:
    """``P(T > threshold)`` for a non-central chi-square ``T`` of one degree of freedom."""
    return float(stats.ncx2.sf(threshold_value, 1, evidence))


def noise_detection(ratios, threshold_value, draws=4000, seed=0) -> float:
    """``P(T > threshold)`` for ``T = sum((mu - 1) z^2 - ln mu)``, by Monte Carlo.

    Only the modes with ``|mu - 1| > 1e-3`` are drawn; the others add their
    mean (``(mu - 1)^2 / 2`` to second order) and a negligible spread.
    `draws` normal vectors from ``numpy.random.default_rng(seed)``: the
    same ratios give the same probability, so a root finder sees a smooth
    function of the amplitude (common random numbers).
    """
    mu = np.asarray(ratios, dtype=float)
    strong = np.abs(mu - 1.0) > 1e-3
    weak = mu[~strong]
    base = float(np.sum(weak - 1.0 - np.log(weak)))
    z = np.random.default_rng(seed).standard_normal((draws, int(strong.sum())))
    t = (z * z) @ (mu[strong] - 1.0) - np.sum(np.log(mu[strong])) + base
    return float(np.mean(t > threshold_value))


def edge_evidence(threshold_value, power=0.95) -> float:
    """The evidence a deterministic effect needs to be detected with probability `power`.

    For one parameter, 720 blocks and a margin of 10 (threshold 16.6) it is 32.7.
    """
    return float(optimize.brentq(lambda lam: deterministic_detection(lam, threshold_value) - power, 0.0, 1e4 + 10 * threshold_value))


def detection_limit(runs, model, effect, shape, bic_margin, power=0.95):
    """The weakest `effect` an ideal detector finds with probability `power` beside `model`.

    The upper limit a diagnosis that did not select `effect` puts on it: the
    amplitude (thermal lag: the element time constant; noise terms: ``B``,
    ``K``) at which, with `model`'s noise terms and deterministic effects as
    they were fitted, the effect would cross the selection threshold with
    probability `power` on the recordings `runs` together.

    Parameters
    ----------
    runs : sequence of gyrocomp.diagnose.select.Problem
        The fit run, then the holdout if any (its evidence is taken equal to
        the fit run's: same gyro, same profile).
    model : gyrocomp.diagnose.select.Fitted
        The selected model.
    effect : str
    shape : dict
        The effect's nonlinear parameter (``deadband_c``, ``tau_s`` of a
        warm-up, ``period_s``), as fitted when the effect was tried.
    bic_margin : float
    power : float, default=0.95

    Returns
    -------
    dict or None
        ``{parameter: {"value", "unit"}}`` in the simulator's names, or None
        when even the end of the search range would not be found.
    """
    fit = runs[0]
    thr = threshold(len(runs) * fit.y.size, effect, bic_margin, len(runs))
    spec = {k: v for k, v in model.spec.items() if k != effect}
    noise = model.noise
    if effect in STOCHASTIC:
        unit = {"bias_instability": np.sqrt(fit.run.block_s), "rate_random_walk": fit.run.block_s}[effect]

        contrasts = Contrasts(fit, spec)

        def shortfall(z):
            trial = dataclasses.replace(noise, **{effect: noise.arw / unit * np.exp(z)})
            return noise_detection(np.tile(noise_ratios(fit, spec, trial, effect, contrasts), len(runs)), thr) - power

        if shortfall(np.log(1e3)) < 0:
            return None
        value = noise.arw / unit * np.exp(optimize.brentq(shortfall, np.log(1e-3), np.log(1e3), xtol=0.01))
        return KINDS[effect].report({}, {}, dataclasses.replace(noise, **{effect: value}))
    target = edge_evidence(thr, power) / len(runs)
    if effect == "thermal_lag":
        plain, names = polynomial_columns(fit.run, None, fit.poly_degree, fit.scale)
        beta = dict(zip(model.names, model.beta))
        coefficients = np.array([beta[n] for n in names])

        def lag_evidence(z):
            lagged, _ = polynomial_columns(fit.run, float(np.exp(z)), fit.poly_degree, fit.scale)
            return deterministic_evidence(fit, (lagged - plain) @ coefficients, spec, noise)

        # Not monotonic: a very slow element barely moves, and a constant
        # element temperature is absorbed by the offset. The limit is the
        # first crossing on a log grid, refined.
        # The range the selection searches (the registry's grid, configs/diagnose.toml).
        grid = np.log(KINDS[effect].grid(fit.settings, fit.run.n_blocks * fit.run.block_s, fit.run.block_s))
        hits = np.flatnonzero(np.array([lag_evidence(z) for z in grid]) >= target)
        if hits.size == 0:
            return None
        k = int(hits[0])
        z = grid[0] if k == 0 else optimize.brentq(lambda z: np.log(lag_evidence(z) / target), grid[k - 1], grid[k], xtol=0.01)
        return {"tau_s": {"value": float(np.exp(z)), "unit": "s"}}
    columns, _ = effect_columns(fit.run, effect, shape, fit.poly_degree, fit.scale)
    # A sinusoid's evidence depends on its phase: the mean over phases is that of sin and cos averaged.
    unit = np.mean([deterministic_evidence(fit, c, spec, noise) for c in columns.T[: KINDS[effect].unit_columns]])
    return KINDS[effect].amplitude(float(np.sqrt(target / unit)))
