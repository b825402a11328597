"""How strong an effect must be before `gyrocomp diagnose` can see it.

The **evidence** of an effect in a run is the expected drop of ``-2 log L``
of the block means (:mod:`gyrocomp.diagnose.likelihood`) when the effect is
added to the model that lacks it, for an ideal detector that knows the
effect's exact shape and the true noise covariance ``Sigma``:

* a deterministic effect whose block means are ``s``, beside nuisance
  columns ``X`` (per-run offset, temperature polynomial, the other
  deterministic effects): the non-centrality of the likelihood-ratio
  statistic,

  .. math:: \\lambda = \\lVert (I - P_{WX}) W s \\rVert^2, \\quad W = \\Sigma^{-1/2},

  with ``P_{WX}`` the projector on the whitened nuisance columns;
* a noise term (``bias_instability``, ``rate_random_walk``): twice the
  Kullback-Leibler divergence of the true block-mean distribution from the
  closest one without that term (the other noise terms re-fitted), on the
  contrasts orthogonal to ``X`` (the nuisance coefficients are not noise),

  .. math:: \\lambda = \\min_{\\Sigma_0} \\operatorname{tr}(\\Sigma_0^{-1}\\Sigma)
            - m - \\ln\\det(\\Sigma_0^{-1}\\Sigma).

The selection (:mod:`gyrocomp.diagnose.select`) keeps an effect of ``k``
parameters when ``-2 log L`` drops by more than
``threshold = k ln n_blocks + bic_margin``. With a statistic
``(Z + sqrt(lambda))^2``, ``Z ~ N(0, 1)``, an ideal detector crosses it with
probability ``Phi(sqrt(lambda) - sqrt(threshold))``;
:func:`edge_evidence` is the evidence it needs to do so with probability
``power``. That is the **edge of detectability** the withheld-effect
benchmark draws its amplitudes from: an effect weaker than it is missed by
any method often enough that naming it would be luck.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg, optimize, stats

from gyrocomp.diagnose.effects import N_PARAMS, STOCHASTIC
from gyrocomp.diagnose.likelihood import NoiseModel, block_means

__all__ = ["threshold", "edge_evidence", "deterministic_evidence", "noise_evidence"]


def threshold(n_blocks, effect, bic_margin):
    """The ``-2 log L`` drop an effect must bring: ``k ln n_blocks + bic_margin``."""
    return N_PARAMS[effect] * np.log(n_blocks) + bic_margin


def edge_evidence(n_blocks, effect, bic_margin, power=0.95):
    """Evidence an ideal detector needs to cross :func:`threshold` with probability `power`.

    ``(sqrt(threshold) + z_power)^2``; for one parameter, 720 blocks and a
    margin of 10 this is 32.7 (``z_0.95 = 1.645``).
    """
    return float((np.sqrt(threshold(n_blocks, effect, bic_margin)) + stats.norm.ppf(power)) ** 2)


def deterministic_evidence(problem, contribution_dps, spec, noise: NoiseModel) -> float:
    """Evidence of a deterministic effect in one run.

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
        ``lambda`` (dimensionless; the ``-2 log L`` drop is ``lambda`` plus a
        chi-square of the effect's parameters).
    """
    w = problem.basis.whitener(noise)
    X, _ = problem.design_blocks(spec)
    s = w.whiten(block_means(contribution_dps, problem.run.n_per_block))
    Xw = w.whiten(X)
    beta, *_ = linalg.lstsq(Xw, s, cond=1e-12, lapack_driver="gelsy", check_finite=False)
    r = s - Xw @ beta
    return float(r @ r)


def noise_evidence(problem, spec, noise: NoiseModel, term: str) -> float:
    """Evidence of the noise `term` (``bias_instability`` or ``rate_random_walk``) in one run.

    The alternative keeps the white level and the other noise term of
    `noise` (when present) free and is fitted to minimise the divergence.

    Parameters
    ----------
    problem : gyrocomp.diagnose.select.Problem
    spec : dict
        Deterministic effects present (nuisance columns).
    noise : NoiseModel
        The true noise terms, `term` among them.
    term : str

    Returns
    -------
    float
    """
    if term not in STOCHASTIC or not getattr(noise, term):
        raise ValueError(f"noise_evidence: {term!r} is not a noise term present in {noise}")
    X, _ = problem.design_blocks(spec)
    q, _ = np.linalg.qr(X, mode="complete")
    contrasts = q[:, X.shape[1] :]
    basis = problem.basis

    def project(c):
        return contrasts.T @ c @ contrasts

    true = project(basis.covariance(noise))
    chol_true = linalg.cholesky(true, lower=True, check_finite=False)
    logdet_true = 2.0 * float(np.sum(np.log(np.diag(chol_true))))
    m = true.shape[0]
    other = [t for t in STOCHASTIC if t != term and getattr(noise, t)]
    if not other:
        # Sigma_0 = s^2 I on the contrasts: the divergence is least at s^2 = tr(Sigma) / m.
        s2 = float(np.trace(true)) / m
        return float(m * np.log(s2) - logdet_true)
    name = other[0]
    colored = project(basis.flicker if name == "bias_instability" else basis.random_walk)
    white = float(np.mean(np.diag(project(basis.white))))

    def divergence(z):
        sigma0 = np.exp(z[0]) * white * np.eye(m) + np.exp(z[1]) * colored
        try:
            chol0 = linalg.cholesky(sigma0, lower=True, check_finite=False)
        except linalg.LinAlgError:
            return np.inf
        a = linalg.solve_triangular(chol0, chol_true, lower=True, check_finite=False)
        return float(np.sum(a * a) - m - logdet_true + 2.0 * np.sum(np.log(np.diag(chol0))))

    start = np.log([noise.arw**2, getattr(noise, name) ** 2])
    best = optimize.minimize(divergence, start, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-3})
    return float(best.fun)
