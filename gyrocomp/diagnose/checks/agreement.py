"""``agreement``: the runs agree on a noise term's level (its signature, own statistics).

A noise term's level is a property of the gyro, so the runs must agree on
it: the likelihood-ratio statistic of one shared level against one level
per run (each run's white level profiled out; each run's likelihood on at
most ``agreement_max_blocks`` merged block means), profiled over ``profile_points``
values of the term's log-variance across ``profile_span`` nats, is
``chi^2`` with ``n_runs - 1`` degrees of freedom under that hypothesis
(Wilks; asymptotic). Each run's 95 % profile-likelihood interval is reported.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import optimize, stats

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.effects.likelihood import NoiseModel, merge_blocks, profile_deviance

__all__ = ["test", "CHECK"]


def test(runs, designs, noise: NoiseModel, term, s):
    """Test (a): profile ``-2 log L`` of each run over the term's log-variance, white level profiled out."""
    grid = np.log(getattr(noise, term) ** 2) + np.linspace(*s.profile_span, s.profile_points)
    curves = []
    for p, X in zip(runs, designs):
        y, Xm, basis = merge_blocks(p.y, X, p.basis, s.agreement_max_blocks)
        curves.append(np.array([_profile_white(y, Xm, basis, noise, term, g) for g in grid]))
    curves = np.array(curves)
    lows = curves.min(axis=1)
    stat = float(max(0.0, curves.sum(axis=0).min() - lows.sum()))
    p = float(stats.chi2.sf(stat, len(runs) - 1))
    crit = stats.chi2.ppf(0.95, 1)
    scale = 3600.0 * 60.0 if term == "rate_random_walk" else 3600.0
    unit = "deg/h/sqrt(h)" if term == "rate_random_walk" else "deg/h"
    level, interval = [], []
    for c, low in zip(curves, lows):
        inside = grid[c - low <= crit]
        level.append(float(np.exp(0.5 * grid[np.argmin(c)]) * scale))
        interval.append([float(np.exp(0.5 * inside.min()) * scale), float(np.exp(0.5 * inside.max()) * scale)])
    return Result(stat, p, {"level": level, "interval_95": interval, "unit": unit})


def _profile_white(y, X, basis, noise: NoiseModel, term, log_var):
    """``min`` over the white level of ``-2 log L`` with `term`'s variance ``exp(log_var)``."""
    start = np.log(noise.arw**2)

    def dev(z):
        trial = dataclasses.replace(noise, arw=float(np.exp(0.5 * z)), **{term: float(np.exp(0.5 * log_var))})
        return profile_deviance(y, X, basis.whitener(trial))[0]

    best = optimize.minimize_scalar(dev, bounds=(start - 4.0, start + 4.0), method="bounded", options={"xatol": 1e-3})
    return float(best.fun)


CHECK = Check("agreement", test, exact=False, families=("signature",), shape=None, scope="runs", own=True)
