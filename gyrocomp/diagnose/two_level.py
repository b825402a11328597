"""Does a slow noise switch between two levels? Telegraph (popcorn) noise against a Gaussian wander.

A random telegraph signal -- a bias that jumps between two levels at random
times (popcorn noise, a mode hop back and forth) -- has the autocovariance
``(a^2 / 4) rho^|k|`` of a first-order Gauss-Markov process: to second
order (spectrum, Allan variance, Ljung-Box) the two are one process, and a
flicker or Gauss-Markov noise term fits it. What tells them apart is the
*path*: the telegraph sits at one of two levels for a dwell, then jumps.
Under white noise at the block level that is best seen by the likelihood
of a two-state hidden Markov model, which uses the persistence to decide
the level of every block [1]_.

:func:`statistic` is the log-likelihood ratio ``T`` of two models fitted
to the same block means by maximum likelihood:

* **two levels** (five parameters) -- ``y_i = mu_(s_i) + w_i``, ``s_i`` a
  two-state Markov chain (stay probabilities ``p_0``, ``p_1``, started in
  its stationary law), ``w_i ~ N(0, sigma^2)`` white: Baum-Welch (EM) from
  a fixed start for a fixed number of iterations (:func:`two_level_loglik`;
  its forward likelihood is hmmlearn's ``GaussianHMM`` score, tests);
* **Gauss-Markov** (four) -- ``y_i = mu + x_i + w_i``, ``x`` a stationary
  AR(1) (``phi``, variance ``lambda sigma^2``), ``w`` white: the exact
  Kalman likelihood, ``mu`` the series mean and ``sigma^2`` profiled out,
  maximised on a grid of ``phi`` and ``lambda`` (:func:`markov_loglik`).

``T`` has no chi-square law (the models are not nested), and its law under
a Gaussian noise depends on that noise's spectrum; :func:`switching_test` reads it
by a parametric bootstrap: ``n_boot`` Gaussian draws with the covariance
the model gives the residual, each put through the same statistic, and the
observed ``T`` in units of their mean and standard deviation is the
``z``. The null law of ``T`` is short in its upper tail (a Gaussian wander
fits two levels badly), so the normal tail ``1 - Phi(z)`` is conservative
there. Every step is deterministic given the data and the seed.

References
----------
.. [1] L. R. Rabiner, "A tutorial on hidden Markov models and selected
   applications in speech recognition", Proc. IEEE 77(2), 257-286 (1989).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

__all__ = ["two_level_loglik", "markov_loglik", "statistic", "switching_test"]

_LOG_2PI = float(np.log(2.0 * np.pi))


def two_level_loglik(y, n_iter=50):
    """Maximum log-likelihood of two levels under white noise, by Baum-Welch, of each row of `y`.

    Parameters
    ----------
    y : ndarray, shape (m, n)
        ``m`` independent series of ``n`` block means.
    n_iter : int
        EM iterations from the start ``mu_0,1 = mean -+ std``, ``sigma =
        0.6 std``, stay probabilities 0.9 (the likelihood never decreases
        between iterations).

    Returns
    -------
    ndarray, shape (m,)
        The log-likelihood after `n_iter` iterations.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> levels = np.repeat(rng.choice([-1.0, 1.0], 40), 20)
    >>> y = np.vstack([levels, 0.0 * levels]) + 0.5 * rng.standard_normal((2, 800))
    >>> gauss = -0.5 * 800 * (1.0 + np.log(2.0 * np.pi * y.var(axis=1)))  # one level, white
    >>> gain = two_level_loglik(y) - gauss  # two levels: far better; none: no better
    >>> bool(gain[0] > 400.0), bool(abs(gain[1]) < 3.0)
    (True, True)
    """
    from gyrocomp.diagnose import _two_level_passes as passes

    y = np.ascontiguousarray(np.atleast_2d(np.asarray(y, dtype=float)))
    center, spread = y.mean(axis=1), np.maximum(y.std(axis=1), 1e-300)
    mu = np.stack([center - spread, center + spread], axis=1)
    return passes.baum_welch(y, mu, 0.6 * spread, np.full((y.shape[0], 2), 0.9), spread, int(n_iter))


def _forward_loglik(y, mu, sigma, stay):
    """Log-likelihood of each row of `y` under levels `mu` (m, 2), white `sigma` (m,) and stay probabilities `stay` (m, 2),
    the chain started in its stationary law: Rabiner's scaled forward pass (compiled, :mod:`gyrocomp.diagnose._two_level_passes`)."""
    from gyrocomp.diagnose import _two_level_passes as passes

    y = np.ascontiguousarray(np.atleast_2d(np.asarray(y, dtype=float)))
    return passes.loglik(y, np.asarray(mu, dtype=float), np.asarray(sigma, dtype=float), np.asarray(stay, dtype=float))


def markov_loglik(y, phi, ratio):
    """Maximum log-likelihood of a stationary AR(1) under white noise, over a grid, of each row of `y`.

    ``y_i = mu + x_i + w_i``, ``x_(i+1) = phi x_i + q_i``, ``Var x = ratio
    sigma^2``, ``Var w = sigma^2``; the exact Kalman likelihood, its
    variances and gains depending on ``(phi, ratio)`` only, ``sigma^2`` and
    ``mu`` profiled out (``mu`` by the row mean).

    Parameters
    ----------
    y : ndarray, shape (m, n)
    phi, ratio : ndarray, shape (g,)
        The grid points (paired).

    Returns
    -------
    ndarray, shape (m,)
        The largest log-likelihood over the grid.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> y = rng.standard_normal((1, 500))
    >>> white = -0.5 * 500 * (1.0 + np.log(2.0 * np.pi * y.var()))
    >>> bool(abs(markov_loglik(y, np.array([0.0]), np.array([1e-9]))[0] - white) < 1e-6)
    True
    """
    from gyrocomp.diagnose import _two_level_passes as passes

    y = np.atleast_2d(np.asarray(y, dtype=float))
    y = y - y.mean(axis=1, keepdims=True)
    n = y.shape[1]
    # The Kalman variances (sigma^2 = 1) do not depend on the data: one recursion for the whole grid (compiled).
    var, ss = passes.kalman_passes(np.ascontiguousarray(y), np.asarray(phi, dtype=float), np.asarray(ratio, dtype=float))
    loglik = -0.5 * n * (np.log(ss / n) + 1.0 + _LOG_2PI) - 0.5 * np.log(var).sum(axis=0)
    return loglik.max(axis=1)


def _grid(n, n_phi=24, n_ratio=17):
    """``phi = exp(-1 / tau)``, ``tau`` from half a block to ``n / 4`` blocks (log spaced), ``ratio`` 1e-2 to 1e2."""
    tau = np.geomspace(0.5, max(n / 4.0, 1.0), n_phi)
    phi, ratio = np.meshgrid(np.exp(-1.0 / tau), np.geomspace(1e-2, 1e2, n_ratio))
    return phi.ravel(), ratio.ravel()


def statistic(y, n_iter=50):
    """``T``: two levels' log-likelihood less the Gauss-Markov's, each row of `y` (module docstring)."""
    y = np.atleast_2d(np.asarray(y, dtype=float))
    return two_level_loglik(y, n_iter) - markov_loglik(y, *_grid(y.shape[1]))


def switching_test(r, sampler, n_boot=100, n_iter=50, seed=0):
    """Whether the residual `r` switches between two levels, against the Gaussian law `sampler` draws from.

    Parameters
    ----------
    r : ndarray, shape (n,)
        Block-level residual.
    sampler : ndarray, shape (n, k)
        ``r`` is ``N(0, sampler sampler')`` when the model holds (a square
        root of its covariance; for a regression residual, the residual
        maker times the Cholesky factor of the noise covariance).
    n_boot : int
        Gaussian draws of the bootstrap.
    n_iter : int
        EM iterations of :func:`two_level_loglik`.
    seed : int or sequence of int
        Seed of the draws.

    Returns
    -------
    dict
        ``stat`` (``T``), ``mean``, ``var`` (of ``T`` over the draws),
        ``z`` (``(T - mean) / sd``), ``p`` (``1 - Phi(z)``).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> sampler = np.eye(300)
    >>> white = switching_test(rng.standard_normal(300), sampler, n_boot=40)
    >>> levels = switching_test(np.repeat(rng.choice([-1.0, 1.0], 15), 20) + rng.standard_normal(300), sampler, n_boot=40)
    >>> bool(white["p"] > 0.01), bool(levels["p"] < 1e-4)
    (True, True)
    """
    r = np.asarray(r, dtype=float)
    draws = (sampler @ np.random.default_rng(seed).standard_normal((sampler.shape[1], n_boot))).T
    t = statistic(np.vstack([r, draws]), n_iter)
    mean, var = float(t[1:].mean()), float(t[1:].var(ddof=1))
    z = float((t[0] - mean) / np.sqrt(var))
    return {"stat": float(t[0]), "mean": mean, "var": var, "z": z, "p": float(stats.norm.sf(z))}
