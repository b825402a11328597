"""``extreme``: one increment far beyond the noise's spread, or increments whose spread changes (a noise term's signature).

At the timescales the term explains
(:class:`gyrocomp.diagnose.checks._timescales.Timescales`), the largest
increment of the residual's ``tau`` means in units of its standard
deviation under the model (a step is one large increment where a random
walk spreads its wander over all of them), with the union bound ``n 2
Phi(-z)``, times the number of taus; and whether those increments keep one
spread over the run (a random walk's and a flicker's increments are
stationary, where a transient -- a wander that starts late, a burst -- puts
its spread in one part): at each of those taus with at least
``stationarity_segments * min_segment_increments`` increments,
:func:`bartlett`, times the number of such taus. The two make one test,
``p = 2 min(p_extreme, p_stationary)`` (conservative); it is of the term's
own statistics when the stationarity drives it.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.gap import effective_dof

__all__ = ["bartlett", "test", "CHECK"]


def test(ts):
    """The extreme increment and the stationarity, ``2 min`` of the two; ``where`` says which (``by``)."""
    s = ts.settings
    if not ts.ms.size:
        return Result(0.0, 1.0, {"by": "extreme", "stationary": None})
    n = ts.r.size
    extreme, steady = {"p": 1.0}, {"p": 1.0}
    n_steady = int(np.sum(n // ts.ms - 1 >= s.stationarity_segments * s.min_segment_increments))
    for m in ts.ms:
        k = n // m
        diff, cov_d = ts.increments(m)
        d = diff @ ts.r
        z = np.abs(d) / np.sqrt(np.diag(cov_d))
        p_max = float(min(1.0, z.size * 2.0 * stats.norm.sf(z.max())))
        if p_max * ts.ms.size < extreme["p"]:
            j = int(np.argmax(z))
            extreme = {"stat": float(z.max()), "tau_s": float(m * ts.block_s), "time_s": float((j + 1) * m * ts.block_s),
                       "p": p_max * ts.ms.size}
        if k - 1 >= s.stationarity_segments * s.min_segment_increments:
            found = bartlett(d, cov_d, s.stationarity_segments)
            if found["p"] * n_steady < steady["p"]:
                steady = found | {"tau_s": float(m * ts.block_s), "p": float(min(1.0, found["p"] * n_steady))}
    by, p = ("stationary", steady["p"]) if steady["p"] < extreme["p"] else ("extreme", extreme["p"])
    where = {k: v for k, v in extreme.items() if k not in ("p", "stat")}
    return Result(extreme.get("stat", 0.0), float(min(1.0, 2.0 * p)),
                  where | {"by": by, "stationary": steady if "tau_s" in steady else None})


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


CHECK = Check("extreme", test, exact=False, families=("signature",), shape=None, scope="timescale")
