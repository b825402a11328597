"""Temperature-drift models of the two papers and their comparators.

Every model is a scikit-learn-style estimator (``fit(X, y)`` returns self,
``predict(X)``, ``get_params`` / ``set_params``) with an exact plain-JSON
round trip: ``from_dict(json.loads(json.dumps(m.to_dict())))`` predicts
bit for bit what ``m`` did. No pickle anywhere.

X convention for the drift models: column 0 temperature [degC], column 1
temperature rate [degC/s]; y is the drift (bias) in the rate's unit.

=====================  ==========  ============================================
class                  ``kind``    scales its inputs itself?
=====================  ==========  ============================================
:class:`ANFIS`         anfis       yes, to [0, 1] over the training range
:class:`ELM`           elm         no: give it inputs normalised to ~[-1, 1]
:class:`NSGA2ELM`      nsga2elm    no (as ELM)
:class:`BPNetwork`     bp          yes, standardises inputs and output
:class:`PolynomialDrift` polynomial no: needs degC (T_ref is in degC)
=====================  ==========  ============================================

Defaults equal ``configs/models.toml``, where each paper number has its source.
"""

from __future__ import annotations

from typing import Any

from gyrocomp.errors import InputError
from gyrocomp.models._base import Learner, NotFittedError
from gyrocomp.models.anfis import ANFIS
from gyrocomp.models.bp import BPNetwork
from gyrocomp.models.elm import ELM
from gyrocomp.models.nsga2elm import NSGA2ELM
from gyrocomp.models.polynomial import PolynomialDrift

__all__ = [
    "ANFIS",
    "ELM",
    "NSGA2ELM",
    "BPNetwork",
    "PolynomialDrift",
    "NotFittedError",
    "KINDS",
    "make_model",
    "from_dict",
]

KINDS: dict[str, type[Learner]] = {
    cls.kind: cls for cls in (ANFIS, ELM, NSGA2ELM, BPNetwork, PolynomialDrift)
}
"""Model class by its ``kind`` (the key of ``to_dict()`` and of configs/models.toml)."""


def make_model(kind: str, params: dict[str, Any] | None = None, source: str = "model") -> Learner:
    """A model of `kind` with `params` (e.g. a config table; lists become tuples).

    Raises
    ------
    InputError
        Unknown kind or parameter, named with `source`.
    """
    if kind not in KINDS:
        raise InputError(f"{source}: unknown model kind {kind!r}; known: {', '.join(KINDS)}")
    cls = KINDS[kind]
    params = dict(params or {})
    unknown = sorted(set(params) - set(cls._param_names()))
    if unknown:
        raise InputError(
            f"{source}: unknown {kind} parameter(s) {', '.join(unknown)}; "
            f"known: {', '.join(cls._param_names())}"
        )
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in params.items()})


def from_dict(d: dict[str, Any]) -> Learner:
    """Rebuild any model from its ``to_dict()``, dispatching on ``d["kind"]``.

    Raises
    ------
    InputError
        Not a dict, or an unknown kind.
    """
    if not isinstance(d, dict) or d.get("kind") not in KINDS:
        kind = d.get("kind") if isinstance(d, dict) else None
        raise InputError(f"model: unknown `kind` {kind!r}; known: {', '.join(KINDS)}")
    return KINDS[d["kind"]].from_dict(d)
