"""Compiled Baum-Welch (numba) of the two-level hidden Markov model of :mod:`gyrocomp.diagnose.two_level`.

The forward and backward passes are recursions over the blocks, a few
products per step: in numpy each step is a dozen array operations on
vectors of the series, and the Python loop over the blocks, with the
strided arrays of the re-estimation, cost most of the signature's
``levels`` check (101 series of some 700 blocks, 50 EM iterations). Here
one series at a time runs all its iterations in contiguous buffers, with
the scaled forward-backward recursions and Baum-Welch re-estimation of
Rabiner [1] (one variance tied between the levels). The sums over the
blocks run in order, where numpy sums pairwise, and ``exp``/``log`` are
libm's: the log-likelihood agrees with the numpy formulation to rounding
(4e-15 relative on 101 series of 720 blocks, measured). Imported lazily by
:mod:`gyrocomp.diagnose.two_level` (numba compiles on first use and caches
the machine code beside this file).

References
----------
.. [1] L. R. Rabiner, Proc. IEEE 77(2), 257-286 (1989).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)


@numba.njit(cache=True)
def loglik(y, mu, sigma, stay):
    """Log-likelihood of each row of `y` (shape (m, n)) under two levels `mu` (m, 2), white `sigma` (m,) and stay probabilities `stay` (m, 2),
    the chain started in its stationary law."""
    m, n = y.shape
    em0, em1, top = np.empty(n), np.empty(n), np.empty(n)
    a0, a1, scale = np.empty(n), np.empty(n), np.empty(n)
    out = np.empty(m)
    for j in range(m):
        out[j] = _forward(y[j], mu[j, 0], mu[j, 1], sigma[j], stay[j, 0], stay[j, 1], em0, em1, top, a0, a1, scale)
    return out


@numba.njit(cache=True)
def baum_welch(y, mu, sigma, stay, spread, n_iter):
    """`n_iter` EM iterations on each row of `y` from `mu`, `sigma`, `stay`; the log-likelihood after them (:func:`loglik`).

    `spread` (m,) floors the variance at ``1e-30 spread^2``; the stay
    probabilities are clipped to ``[1e-4, 1 - 1e-4]``.
    """
    m, n = y.shape
    em0, em1, top = np.empty(n), np.empty(n), np.empty(n)
    a0, a1, scale = np.empty(n), np.empty(n), np.empty(n)
    b0, b1 = np.empty(n), np.empty(n)
    out = np.empty(m)
    for j in range(m):
        row = y[j]
        mu0, mu1, sig, st0, st1 = mu[j, 0], mu[j, 1], sigma[j], stay[j, 0], stay[j, 1]
        for _ in range(n_iter):
            _forward(row, mu0, mu1, sig, st0, st1, em0, em1, top, a0, a1, scale)
            go0, go1 = 1.0 - st0, 1.0 - st1
            b0[n - 1], b1[n - 1] = 1.0, 1.0
            for i in range(n - 2, -1, -1):
                d0 = b0[i + 1] * (em0[i + 1] / scale[i + 1])
                d1 = b1[i + 1] * (em1[i + 1] / scale[i + 1])
                b0[i] = st0 * d0 + go0 * d1
                b1[i] = go1 * d0 + st1 * d1
            kept0 = kept1 = occ0 = occ1 = tot0 = tot1 = wy0 = wy1 = 0.0
            for i in range(n):
                g0, g1 = a0[i] * b0[i], a1[i] * b1[i]
                s = g0 + g1
                g0, g1 = g0 / s, g1 / s
                tot0 += g0
                tot1 += g1
                wy0 += g0 * row[i]
                wy1 += g1 * row[i]
                if i < n - 1:
                    occ0 += g0
                    occ1 += g1
                    kept0 += a0[i] * st0 * (b0[i + 1] * em0[i + 1] / scale[i + 1])
                    kept1 += a1[i] * st1 * (b1[i + 1] * em1[i + 1] / scale[i + 1])
                # block i's backward variables are not needed again: keep its occupation probabilities there
                b0[i], b1[i] = g0, g1
            st0 = min(max(kept0 / max(occ0, 1e-300), 1e-4), 1.0 - 1e-4)
            st1 = min(max(kept1 / max(occ1, 1e-300), 1e-4), 1.0 - 1e-4)
            mu0 = wy0 / max(tot0, 1e-300)
            mu1 = wy1 / max(tot1, 1e-300)
            var = 0.0
            for i in range(n):
                var += b0[i] * (row[i] - mu0) ** 2 + b1[i] * (row[i] - mu1) ** 2
            sig = math.sqrt(max(var / n, 1e-30 * spread[j] ** 2))
        out[j] = _forward(row, mu0, mu1, sig, st0, st1, em0, em1, top, a0, a1, scale)
    return out


@numba.njit(cache=True)
def _forward(row, mu0, mu1, sig, st0, st1, em0, em1, top, a0, a1, scale):
    """The scaled forward pass of one series into the buffers: emissions (each block over its larger one), filtered
    probabilities and scale factors; returns the log-likelihood."""
    n = row.size
    log_sig = math.log(sig)
    total = 0.0
    for i in range(n):
        l0 = -0.5 * ((row[i] - mu0) / sig) ** 2 - log_sig - _HALF_LOG_2PI
        l1 = -0.5 * ((row[i] - mu1) / sig) ** 2 - log_sig - _HALF_LOG_2PI
        top[i] = max(l0, l1)
        em0[i] = math.exp(l0 - top[i])
        em1[i] = math.exp(l1 - top[i])
    go0, go1 = 1.0 - st0, 1.0 - st1
    f0 = go1 / max(go0 + go1, 1e-300) * em0[0]
    f1 = go0 / max(go0 + go1, 1e-300) * em1[0]
    for i in range(n):
        if i:
            f0 = (a0[i - 1] * st0 + a1[i - 1] * go1) * em0[i]
            f1 = (a0[i - 1] * go0 + a1[i - 1] * st1) * em1[i]
        scale[i] = f0 + f1
        a0[i] = f0 / scale[i]
        a1[i] = f1 / scale[i]
        total += math.log(scale[i]) + top[i]
    return total


@numba.njit(cache=True)
def kalman_passes(y, phi, ratio):
    """The Kalman recursions of :func:`gyrocomp.diagnose.two_level.markov_loglik` for every row of `y` (m, n) (its
    mean removed) and grid point ``(phi, ratio)`` (g,): innovation variances (n, g) at ``sigma^2 = 1`` and each row's
    sum of squared standardised innovations (m, g); the same products, in the same order, as the numpy recursion
    (the rows, independent, in the innermost loop)."""
    m, n = y.shape
    g = phi.size
    var, gain = np.empty((n, g)), np.empty((n, g))
    p = ratio.copy()
    for i in range(n):
        for k in range(g):
            var[i, k] = p[k] + 1.0
            gain[i, k] = p[k] / var[i, k]
            square = phi[k] * phi[k]
            p[k] = square * p[k] * (1.0 - gain[i, k]) + ratio[k] * (1.0 - square)
    columns = np.ascontiguousarray(y.T)
    ss = np.zeros((g, m))
    state = np.empty(m)
    for k in range(g):
        state[:] = 0.0
        total = ss[k]
        for i in range(n):
            v, a, f, row = var[i, k], gain[i, k], phi[k], columns[i]
            for j in range(m):
                r = row[j] - state[j]
                total[j] += r * r / v
                state[j] = f * (state[j] + a * r)
    return var, np.ascontiguousarray(ss.T)
