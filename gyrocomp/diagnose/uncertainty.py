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
  relative step ``step``; an effect's two nonlinear parameters (``warmup``'s
  time constants) from the inverse of their whole Hessian;
* a noise level ``q`` (a random walk, a bias instability and its
  correlation time): the same curvature in ``log q``, the other noise levels
  held.

The linear part holds the nonlinear parameters at their estimates; their
own spread reaches every reported value along the profile (an amplitude
moves with its time constant). The noise part adds as independent. Where
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
            _add(var, _nonlinear(problem, model, effect, values, names, whitener, d0, step))
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


def _nonlinear(problem, model, effect, values, names, whitener, d0, step):
    """Variance each reported value takes from the effect's nonlinear parameters: ``g' C g``.

    ``C = 2 H^-1`` is the covariance of the parameters' logs, ``H`` the
    Hessian of the profile deviance in them (central differences, a cross
    term from the four corners: where two parameters trade, as ``warmup``'s
    time constants do, the curvature in one with the other held understates
    its spread); ``g`` is each reported value's change along the profile per
    unit log (a parameter's own: itself; an amplitude: its coefficient
    re-estimated there, which a time constant's spread moves). ``H`` not
    positive definite: inf (not estimated).
    """
    spec = model.spec.get(effect, {})
    keys = [k for k, theta in spec.items() if isinstance(theta, float) and k in values]
    if not keys:
        return {}
    eye = step * np.eye(len(keys))
    cache = {}

    def at(shift):
        if tuple(shift) not in cache:
            params = {**spec, **{k: spec[k] * math.exp(h) for k, h in zip(keys, shift)}}
            deviance, beta = _at_parameters(problem, model, effect, params, whitener)
            cache[tuple(shift)] = deviance, _numeric(KINDS[effect].report(dict(zip(names, beta)), params, model.noise))
        return cache[tuple(shift)]

    hess = np.empty((len(keys), len(keys)))
    for i in range(len(keys)):
        hess[i, i] = (at(eye[i])[0] - 2.0 * d0 + at(-eye[i])[0]) / step**2
        for j in range(i):
            corners = [at(a * eye[i] + b * eye[j])[0] for a, b in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
            hess[i, j] = hess[j, i] = (corners[0] - corners[1] - corners[2] + corners[3]) / (4.0 * step**2)
    if np.any(np.linalg.eigvalsh(hess) <= 0.0):
        return {k: math.inf for k in values if k in keys}
    cov = 2.0 * np.linalg.inv(hess)
    grad = np.array([[(at(eye[i])[1][v] - at(-eye[i])[1][v]) / (2.0 * step) for i in range(len(keys))] for v in values])
    return dict(zip(values, np.einsum("vi,ij,vj->v", grad, cov, grad)))


def _curvature(deviance_at, d0, step):
    """``d^2 D / d(log x)^2`` at the fitted point by a central difference (``deviance_at(factor)``)."""
    up, down = deviance_at(math.exp(step)), deviance_at(math.exp(-step))
    return (up - 2.0 * d0 + down) / step**2


def _at_parameters(problem, model, effect, params, whitener):
    """The profile deviance and coefficients with `effect` at `params`."""
    return profile_deviance(problem.y, problem.design_blocks({**model.spec, effect: params})[0], whitener)


def _at_noise(problem, model, level, value, Xb):
    return profile_deviance(problem.y, Xb, problem.basis.whitener(dataclasses.replace(model.noise, **{level: value})))[0]


def _noise_slope(model, effect, level, values, step):
    """``d value / d log q`` of each reported value, by a central difference."""
    q = getattr(model.noise, level)
    sides = [_numeric(KINDS[effect].report({}, {}, dataclasses.replace(model.noise, **{level: q * math.exp(s)}))) for s in (step, -step)]
    return {k: (sides[0][k] - sides[1][k]) / (2.0 * step) for k in values}
