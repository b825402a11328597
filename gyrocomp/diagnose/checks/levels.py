"""``levels``: a flicker's level is Gaussian, not a few levels it switches between (its signature, own statistics).

A noise that switches between a few levels (random telegraph or popcorn
noise, mode hops) has a bimodal, light-tailed level. At the shortest
``tau`` the term explains (:class:`gyrocomp.diagnose.checks._timescales.Timescales`:
the most nearly independent means, where the term first dominates the
white noise) the residual's ``tau`` means ``u_i``, each in units of its
standard deviation under the model (``z_i``), give ``Q = mean He_4(z_i)``,
``He_4(z) = z^4 - 6 z^2 + 3``. Under the model ``E Q = 0`` and ``Var Q =
24 sum_ij rho_ij^4 / k^2`` exactly (Mehler: ``Cov(He_4(z_i), He_4(z_j)) =
4! rho_ij^4``), and a wrong scale moves ``E Q`` only to second order
(``3 delta^2``). The lower tail is tested, ``Phi(Q / sd)``: conservative,
since ``He_4 >= -6`` makes ``Q`` right-skewed. The runs are independent,
so their ``Q`` pool into one test, ``sum Q_r / sqrt(sum Var Q_r)``.

Under the white noise of the block means that bimodality is diluted; the
persistence of the levels shows it better: the log-likelihood ratio ``T_r``
of two levels under white noise (a two-state hidden Markov model) to a
Gauss-Markov wander under white noise, on the block-level residual, read
against ``two_level_draws`` Gaussian draws with the residual's covariance
under the model (:mod:`gyrocomp.diagnose.two_level`); the runs pool as
``sum (T_r - m_r) / sqrt(sum v_r)`` (``m_r``, ``v_r`` the draws' mean and
variance), upper tail. The two make one test, ``p = 2 min`` of theirs
(:func:`pooled`), so that the family keeps its number of tests.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose import two_level
from gyrocomp.diagnose.checks._base import Check, Result

__all__ = ["level_test", "run_levels", "pooled", "CHECK"]


def run_levels(ts):
    """One run's two statistics at the shortest ``tau`` (a dict for :func:`pooled`); None unless the term is flicker and explains a ``tau``."""
    if ts.term != "bias_instability" or not ts.ms.size:
        return None
    s, m = ts.settings, ts.ms[0]
    agg = ts.means(m)
    out = level_test(agg @ ts.r, agg @ ts.cov_r @ agg.T) | {"tau_s": float(m * ts.block_s)}
    out["two_levels"] = two_level.switching_test(ts.r, ts.sampler, s.two_level_draws,
                                                 s.two_level_iterations, s.two_level_seed)
    return out


def level_test(u, cov):
    """Whether the Gaussian levels `u` with covariance `cov` are bimodal (light-tailed): the lower tail of ``mean He_4(z)``.

    ``z_i = u_i / sqrt(cov_ii)``; ``Q = mean(z^4 - 6 z^2 + 3)`` has mean 0
    and variance ``24 sum_ij rho_ij^4 / k^2`` when ``u ~ N(0, cov)``
    (module docstring). A noise switching between two levels has ``He_4``
    near ``-2`` at every level, a Gaussian one 0 on average.

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


def pooled(tests):
    """One Gaussian-levels test of independent runs (None without any): ``2 min`` of the kurtosis and two-level p-values."""
    if not tests:
        return None
    q = [t["kurtosis"] for t in tests]
    var = [t["var"] for t in tests]
    stat = float(np.sum(q) / np.sqrt(np.sum(var)))
    p_kurtosis = float(stats.norm.cdf(stat))
    two = [t["two_levels"] for t in tests]
    z = float(sum(t["stat"] - t["mean"] for t in two) / np.sqrt(sum(t["var"] for t in two)))
    p_two = float(stats.norm.sf(z))
    return Result(stat, float(min(1.0, 2.0 * min(p_kurtosis, p_two))), {
        "by": "kurtosis" if p_kurtosis <= p_two else "two_levels",
        "p_kurtosis": p_kurtosis,
        "kurtosis": q,
        "tau_s": [t["tau_s"] for t in tests],
        "two_levels": {"z": z, "p": p_two, "gain": float(sum(t["stat"] for t in two)), "runs": two},
    })


CHECK = Check("levels", pooled, exact=False, families=("signature",), shape=None, scope="runs", own=True)
