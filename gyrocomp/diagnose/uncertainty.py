"""One-sigma uncertainties of the selected model's reported parameters, from the curvature of the likelihood.

Each selected effect reports its parameters in the simulator's units
(:meth:`gyrocomp.effects.vocabulary.Effect.report`). Their uncertainties
come from the fit run's Gaussian likelihood (the deviance
``D = -2 log L`` of :func:`gyrocomp.effects.likelihood.profile_deviance`):

* the linear coefficients: ``cov(beta) = (X' Sigma^-1 X)^-1`` under the
  fitted noise, carried to the reported values by the delta method
  (central differences of :meth:`~gyrocomp.effects.vocabulary.Effect.report`
  in each of the effect's coefficients, their covariance kept);
* a nonlinear parameter ``theta`` (a time constant, a deadband, a period):
  ``var(theta) = 2 / (d^2 D / d theta^2)`` of the profile deviance (the
  coefficients re-estimated at each ``theta``), by a central difference of
  relative step ``step``;
* a noise level ``q`` (a random walk, a bias instability and its
  correlation time): the same curvature in ``log q``, the other noise levels
  held.

The three parts add as independent (their cross terms are left out). Where
the curvature is not positive (a parameter at the edge of what the run
shows), the uncertainty is None: not estimated.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gyrocomp.diagnose.effects import DETERMINISTIC, KINDS
from gyrocomp.effects.likelihood import profile_deviance

__all__ = ["uncertainties", "NOISE_PARAMETERS"]

NOISE_PARAMETERS = {"bias_instability": ("bias_instability", "bias_correlation_s"), "rate_random_walk": ("rate_random_walk",)}
"""The :class:`~gyrocomp.effects.likelihood.NoiseModel` levels each noise effect reports."""


def uncertainties(problem, model, step: float = 0.02) -> dict:
    """``{effect: {parameter: sigma or None}}`` for every effect of `model`, in the units its report uses.

    Parameters
    ----------
    problem : gyrocomp.diagnose.select.Problem
        The fit run (its block means, noise basis and design).
    model : gyrocomp.diagnose.select.Fitted
        The selected model, fitted on `problem`.
    step : float
        Relative step of the central differences in a nonlinear parameter
        and in the log of a noise level.
    """
    Xb, names = problem.design_blocks(model.spec)
    whitener = problem.basis.whitener(model.noise)
    Xw = whitener.whiten(Xb)
    cov = np.linalg.pinv(Xw.T @ Xw, rcond=1e-12, hermitian=True)
    d0 = profile_deviance(problem.y, Xb, whitener)[0]
    out = {}
    for effect in model.order:
        values = _numeric(KINDS[effect].report(dict(zip(names, model.beta)), model.spec.get(effect, {}), model.noise))
        var = dict.fromkeys(values, 0.0)
        if effect in DETERMINISTIC:
            _add(var, _linear(problem, model, effect, names, cov, values))
            for name, theta in model.spec.get(effect, {}).items():
                if isinstance(theta, float) and name in var:
                    curvature = _curvature(lambda f: _at_parameter(problem, model, effect, name, theta * f, whitener), d0, step) / theta**2
                    var[name] = var[name] + 2.0 / curvature if curvature > 0.0 else math.inf
        for level in NOISE_PARAMETERS.get(effect, ()):
            q = getattr(model.noise, level)
            if q > 0.0:
                curvature = _curvature(lambda f: _at_noise(problem, model, level, q * f, Xb), d0, step)
                slope = _noise_slope(model, effect, level, values, step)
                _add(var, {k: s**2 * 2.0 / curvature if curvature > 0.0 else math.inf for k, s in slope.items() if s})
        out[effect] = {k: (math.sqrt(v) if math.isfinite(v) else None) for k, v in var.items()}
    return out


def _numeric(report: dict) -> dict:
    """The reported values that are real numbers (not a form's name or a count)."""
    return {k: float(v["value"]) for k, v in report.items() if isinstance(v["value"], float)}


def _add(var: dict, more: dict):
    for k, v in more.items():
        if k in var:
            var[k] += v


def _linear(problem, model, effect, names, cov, values):
    """Variance of each reported value from the effect's own coefficients (delta method, covariance kept)."""
    own = np.flatnonzero(problem.own_columns(model.spec, effect))
    if not own.size:
        return {}
    params = model.spec.get(effect, {})
    jac = np.zeros((len(values), len(own)))
    for col, j in enumerate(own):
        h = 1e-3 * math.sqrt(cov[j, j]) if cov[j, j] > 0.0 else 0.0
        if h == 0.0:
            continue
        sides = []
        for sign in (1.0, -1.0):
            beta = model.beta.copy()
            beta[j] += sign * h
            sides.append(_numeric(KINDS[effect].report(dict(zip(names, beta)), params, model.noise)))
        jac[:, col] = [(sides[0][k] - sides[1][k]) / (2.0 * h) for k in values]
    var = np.einsum("ij,jk,ik->i", jac, cov[np.ix_(own, own)], jac)
    return dict(zip(values, var))


def _curvature(deviance_at, d0, step):
    """``d^2 D / d(log x)^2`` at the fitted point by a central difference (``deviance_at(factor)``)."""
    up, down = deviance_at(math.exp(step)), deviance_at(math.exp(-step))
    return (up - 2.0 * d0 + down) / step**2


def _at_parameter(problem, model, effect, name, value, whitener):
    spec = {**model.spec, effect: {**model.spec[effect], name: value}}
    return profile_deviance(problem.y, problem.design_blocks(spec)[0], whitener)[0]


def _at_noise(problem, model, level, value, Xb):
    return profile_deviance(problem.y, Xb, problem.basis.whitener(dataclasses.replace(model.noise, **{level: value})))[0]


def _noise_slope(model, effect, level, values, step):
    """``d value / d log q`` of each reported value, by a central difference."""
    q = getattr(model.noise, level)
    sides = [_numeric(KINDS[effect].report({}, {}, dataclasses.replace(model.noise, **{level: q * math.exp(s)}))) for s in (step, -step)]
    return {k: (sides[0][k] - sides[1][k]) / (2.0 * step) for k in values}
