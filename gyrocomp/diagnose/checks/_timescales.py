"""The timescales a noise term explains, and the GLS residual at them: what the ``allan``, ``extreme`` and ``levels`` checks share.

At every octave ``tau = m block_s`` (at least ``min_allan_windows``
windows) where the term carries at least ``explains_share`` of the model's
Allan variance, the checks read the GLS residual ``r = R y``, ``R = I -
X (Xw' Xw)^-1 Xw' L^-1``, whose covariance under the model is ``R Sigma
R'``, through the non-overlapping ``tau`` means.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

__all__ = ["Timescales"]


class Timescales:
    """One run's GLS residual and the block multiples ``m`` at which `term` explains the model's AVAR.

    Attributes
    ----------
    ms : ndarray of int
        The block multiples (empty: the term explains no tested timescale).
    block_s : float
    r, cov_r : ndarray
        The GLS residual and its covariance under the model (only with `ms`).
    sampler : ndarray
        ``R L``, a square root of ``cov_r`` (``L^-1 L = I``: ``R L = L - X Xw^+``).
    lower : ndarray
        ``L``.
    settings
        The checks' settings (:class:`gyrocomp.diagnose.settings.ChecksSettings`).
    """

    def __init__(self, problem, X, cov, lower, Xw, noise, term, s):
        self.settings, self.lower, self.block_s, self.term = s, lower, problem.basis.block_s, term
        tb, n = problem.basis.block_s, problem.y.size
        ms = 2 ** np.arange(int(np.log2(max(n // s.min_allan_windows, 1))) + 1)
        ms = ms[n // ms >= s.min_allan_windows]
        self.ms = ms[noise.term_avar(term, ms * tb) >= s.explains_share * noise.avar(ms * tb)]
        if not self.ms.size:
            return
        pinv = linalg.pinv(Xw)
        # R Sigma R' = (R L)(R L)': one product of n x n matrices, where R and R Sigma R' took three.
        self.sampler = lower - X @ pinv
        self.r = problem.y - X @ (pinv @ linalg.solve_triangular(lower, problem.y, lower=True, check_finite=False))
        self.cov_r = self.sampler @ self.sampler.T
        self._increments = {}

    def means(self, m):
        """The matrix of the non-overlapping means of `m` blocks (``k x n``, the tail dropped)."""
        n = self.r.size
        k = n // m
        return np.hstack([np.kron(np.eye(k), np.full((1, m), 1.0 / m)), np.zeros((k, n - k * m))])

    def increments(self, m):
        """The first differences of the `m`-block means (:meth:`means`, ``(k - 1) x n``) and their covariance under the
        model, computed once per `m` (the ``allan`` and ``extreme`` checks read both)."""
        if m not in self._increments:
            diff = np.diff(self.means(m), axis=0)
            self._increments[m] = (diff, diff @ self.cov_r @ diff.T)
        return self._increments[m]
