"""The linear algebra every check shares: innovations, score statistics and max-statistic scans.

A run's block means ``y ~ N(X beta, Sigma)`` under the model; ``L L' =
Sigma``; the innovations ``e = L^-1 (y - X beta)`` are ``N(0, I - P)``
with ``P`` the projector on the whitened design ``Xw = L^-1 X``. A set of
extra columns ``G`` is scored by the part of ``L^-1 G`` orthogonal to
``Xw``: exactly ``chi^2`` with its rank (:func:`score_test`), or one
column at a time, each score ``N(0, 1)`` (:func:`column_scores`), whose
largest absolute value has the union bound ``n 2 Phi(-max |z|)``
(:func:`threshold_scan`).
"""

from __future__ import annotations

import numpy as np
from scipy import linalg, stats

__all__ = ["innovations", "score_test", "column_scores", "threshold_scan", "temperature_bins", "temperature_edges", "whiten"]


def whiten(lower, G):
    """``L^-1 G`` (`lower` the Cholesky factor ``L``)."""
    return linalg.solve_triangular(lower, G, lower=True, check_finite=False)


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
