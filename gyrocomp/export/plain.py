"""``json-plain``: a causal model in physical units, with no normalisation.

Every learner of ``model.json`` sees ``(x - input_offset) / input_scale``
and returns a value that is then scaled by ``output_scale`` and shifted by
``output_offset``; ANFIS and BP normalise once more inside. Those affine
maps are folded into the learned parameters here, so that each segment is a
function of temperature [degC] and its rate [degC/s] returning deg/s:

* ``polynomial``: ``sum_k coef_dps[k] (T - reference_c)^k + rate_coef * dT/dt``;
* ``elm``: ``g(x @ input_weights + biases) @ beta + offset_dps`` ([1]_ eq. (2));
* ``anfis``: first-order Takagi-Sugeno, membership functions in degC and
  degC/s, rule ``r = i0 * n_mfs[1] + i1``, output ``sum_r wbar_r (p_r @ x + q_r)``
  ([2]_ eqs. (23)-(26));
* ``bp``: ``tanh``/``logistic``/``relu``/identity hidden layers, linear output.

The temperature rate is the causal FIR of :mod:`gyrocomp.pipeline.rate`
(``rate_estimator.causal_coefficients``, oldest sample first, primed with
the first reading); the inputs are clamped to ``clamp`` before the
segments, each segment's output to its ``output_range_dps`` when given, and
``compensated = rate - sum of segments``.

References
----------
.. [1] G.-B. Huang, Q.-Y. Zhu, C.-K. Siew, Neurocomputing 70, 489 (2006).
.. [2] J.-S. R. Jang, IEEE Trans. SMC 23, 665 (1993).
"""

from __future__ import annotations

import numpy as np

from gyrocomp import units
from gyrocomp.errors import InputError

__all__ = ["PLAIN_SCHEMA", "plain_model"]

PLAIN_SCHEMA = "gyrocomp.model-plain"


def plain_model(model, *, centred: bool = False) -> dict:
    """The causal model of a loaded ``model.json`` in physical units (see the module notes).

    Parameters
    ----------
    model : gyrocomp.pipeline.compensate.DriftModel
    centred : bool
        Express the segments in ``z = (x - centre) / half_range`` of the
        training ranges instead of degC and degC/s (``input_basis``): the
        basis the learners were trained in, which keeps single-precision
        arithmetic exact enough (the C header uses it).

    Returns
    -------
    dict
        JSON-ready: ``units``, ``rate_estimator``, ``clamp``, ``segments``.
    """
    (t_lo, t_hi), (r_lo, r_hi) = model.temperature_range_c, model.rate_range_c_per_s
    estimator = model.obj["rate_estimator"]
    centre, half = np.zeros(2), np.ones(2)
    if centred:
        centre = np.array([0.5 * (t_lo + t_hi), 0.5 * (r_lo + r_hi)])
        half = np.array([0.5 * (t_hi - t_lo), 0.5 * (r_hi - r_lo)])
        half[half <= 0] = 1.0
    segments = []
    for name, (learner, x_offset, x_scale, y_offset, y_scale, y_range) in model.learners.items():
        # the learner sees (x - o) / s with x = centre + half z: (z - (o - centre) / half) / (s / half)
        x_offset, x_scale = (np.asarray(x_offset) - centre) / half, np.asarray(x_scale) / half
        try:
            build = _SEGMENTS[learner.kind]
        except KeyError:
            raise InputError(f"{model.name}: segment {name}: no plain form of a {learner.kind} learner; known: {', '.join(_SEGMENTS)}") from None
        entry = {"name": name, "learner": learner.kind, **build(learner, x_offset, x_scale, y_offset, y_scale)}
        entry["output_range_dps"] = [float(y_range[0]), float(y_range[1])] if model.clip_output else None
        segments.append(entry)
    return {
        "schema": PLAIN_SCHEMA,
        "kind": model.kind,
        "units": {"temperature": "degC", "temperature_rate": "degC/s", "rate": units.model_unit(model)},
        "fs_hz": float(estimator["fs_hz"]),
        "rate_estimator": {
            "form": "causal FIR, oldest sample first; the window is primed with the first reading",
            "window_samples": int(estimator["window_samples"]),
            "polyorder": int(estimator["polyorder"]),
            "causal_coefficients": [float(c) for c in estimator["causal_coefficients"]],
            "recursion": estimator.get("recursion"),
        },
        "clamp": {"temperature_c": [t_lo, t_hi], "temperature_rate_c_per_s": [r_lo, r_hi]},
        "input_basis": {"centre": centre.tolist(), "half_range": half.tolist(), "meaning": "segments take z = (x - centre) / half_range"},
        "segments": segments,
        "formula": "compensated = rate - sum over segments of f(clamp(T), clamp(dT/dt)) [deg/s]",
    }


def _polynomial(learner, o, s, y_offset, y_scale) -> dict:
    # p((T - o0)/s0 - r) = p((T - (o0 + s0 r)) / s0)
    coef = np.asarray(learner.coef_, dtype=float) * y_scale / s[0] ** np.arange(len(learner.coef_))
    coef[0] += y_offset
    rate = float(learner.rate_coef_) * y_scale / s[1] if learner.rate_term else 0.0
    coef[0] -= rate * o[1]
    reference = float(o[0] + s[0] * learner.reference_temperature)
    return {"reference_c": reference, "coef_dps": coef.tolist(), "rate_coef_dps_per_c_per_s": rate}


def _elm(learner, o, s, y_offset, y_scale) -> dict:
    learner = getattr(learner, "estimator_", learner)  # NSGA2ELM: the picked ELM
    w = np.asarray(learner.input_weights_, dtype=float)  # (n_features, n_hidden)
    weights = w / s[:, None]
    biases = np.asarray(learner.biases_, dtype=float) - (o / s) @ w
    return {
        "learner": "elm",  # NSGA2ELM exports the ELM it picked
        "activation": learner.activation,
        "input_weights": weights.tolist(),
        "biases": biases.tolist(),
        "beta": (np.asarray(learner.beta_, dtype=float) * y_scale).tolist(),
        "offset_dps": float(y_offset),
    }


def _anfis(learner, o, s, y_offset, y_scale) -> dict:
    offset = o + s * np.asarray(learner.input_offset_, dtype=float)  # z = (x - offset) / scale
    scale = s * np.asarray(learner.input_scale_, dtype=float)
    premises = []
    for j, p in enumerate(learner.premises_):
        p = np.array(p, dtype=float)
        if learner.mf == "gbell":  # a, b, c: |(z - c) / a|^(2b)
            p[:, 0] *= scale[j]
            p[:, 2] = offset[j] + scale[j] * p[:, 2]
        else:  # c, sigma
            p[:, 0] = offset[j] + scale[j] * p[:, 0]
            p[:, 1] *= scale[j]
        premises.append(p.tolist())
    c = np.asarray(learner.consequents_, dtype=float)  # (n_rules, n_features + 1): p . z + q
    slopes = c[:, :-1] / scale
    intercepts = c[:, -1] - slopes @ offset
    return {
        "mf": learner.mf,
        "premises": premises,
        "slopes": (slopes * y_scale).tolist(),
        "intercepts": (intercepts * y_scale + y_offset).tolist(),
    }


def _bp(learner, o, s, y_offset, y_scale) -> dict:
    offset = o + s * np.asarray(learner.x_mean_, dtype=float)
    scale = s * np.asarray(learner.x_scale_, dtype=float)
    weights = [np.asarray(w, dtype=float) for w in learner.coefs_]
    biases = [np.asarray(b, dtype=float) for b in learner.intercepts_]
    first = weights[0] / scale[:, None]
    biases[0] = biases[0] - (offset / scale) @ weights[0]
    weights[0] = first
    out_scale = y_scale * float(learner.y_scale_)
    weights[-1] = weights[-1] * out_scale
    biases[-1] = biases[-1] * out_scale + y_scale * float(learner.y_mean_) + y_offset
    return {
        "activation": learner.activation,
        "weights": [w.tolist() for w in weights],
        "biases": [b.tolist() for b in biases],
    }


_SEGMENTS = {"polynomial": _polynomial, "elm": _elm, "nsga2elm": _elm, "anfis": _anfis, "bp": _bp}
"""Plain form of each learner kind (``models.KINDS`` names)."""
