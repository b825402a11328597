"""Which terms of a least-squares drift model the training runs can identify.

A term whose column on the training runs is (nearly) a linear combination
of the columns before it cannot be told from them: least squares gives it
a coefficient set by noise, the others compensate, the fit is as good on
the training run as without it, and the model is wrong wherever the
relation between the columns differs (a steady temperature, another
ramp). The standard case is a single exponential warm-up, where
``dT/dt = (T_inf - T) / tau`` is a linear function of ``T``: a cubic plus a
dT/dt term fitted on it had a bias at dT/dt = 0 off by over 1000 deg/h
(issue 35). Another is a run held at two temperatures, which fixes a
straight line and no curvature.

The criterion is the share of a column's variation over the training
samples that the columns before it do not explain, ``1 - R^2`` of the
column regressed on them (the reciprocal of its variance inflation factor
in that order). Terms are taken in the order of the model's physics, so
that a term is judged only against those it would compete with: the
powers of temperature first, each against the lower ones, then the
optional terms. A term whose share is below ``min_unique`` is not fitted,
and the reason names it. The powers are judged on the temperature scaled
to ``[-1, 1]`` over the training range, so the verdict depends on where
the run spent its time, never on the reference temperature the polynomial
is written about.

The cut-off: a coefficient's variance grows as ``1 / (1 - R^2)``, so at the
default 0.01 (a variance inflation factor of 100, the usual mark of severe
collinearity) it is ten times less certain than on an orthogonal design.
On the sample oven runs dT/dt keeps 0.97 of its variation and the cubic
power 0.07; on a 45 min exponential warm-up dT/dt keeps 7e-5.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["Refusal", "separable", "polynomial_terms"]

ROUNDOFF = 1e-12
"""A column whose standard deviation is below this share of its largest magnitude does not vary (round-off)."""


@dataclasses.dataclass(frozen=True)
class Refusal:
    """A term left out of a fit, and why.

    Attributes
    ----------
    term : str
        The term's name as reports give it (``"(T - T_ref)^3"``, ``"dT/dt"``).
    unique : float
        Share of the term's variation over the training samples that the
        terms before it leave unexplained, ``1 - R^2``.
    reason : str
        One sentence for the user.
    """

    term: str
    unique: float
    reason: str

    def to_dict(self) -> dict:
        return {"term": self.term, "unique_variance": self.unique, "reason": self.reason}


def separable(columns: dict, min_unique: float, hints: dict | None = None) -> tuple[dict, list]:
    """Keep each column that the kept columns before it do not explain.

    Parameters
    ----------
    columns : dict of str to ndarray
        Design columns over the training samples, in priority order (the
        first is judged against nothing but a constant, unless it is one).
    min_unique : float
        Least share ``1 - R^2`` of a column's variation, about its mean,
        that the kept columns before it (and a constant) must leave unexplained.
    hints : dict of str to str or None
        What the user can do about a refused term, appended to its reason.

    Returns
    -------
    kept : dict of str to float
        The kept columns' names and shares, in order.
    refused : list of Refusal

    Examples
    --------
    >>> T = np.linspace(5, 55, 500)
    >>> kept, refused = separable({"T": T, "dT/dt": (55.0 - T) / 600}, 0.01)
    >>> list(kept), refused[0].term, refused[0].unique < 1e-12
    (['T'], 'dT/dt', True)
    """
    hints = hints or {}
    kept, refused, basis = {}, [], []
    for name, column in columns.items():
        x = np.asarray(column, dtype=float)
        centred = x - x.mean()
        total = float(centred @ centred)
        if total <= (ROUNDOFF * float(np.abs(x).max())) ** 2 * len(x):
            total = 0.0  # a constant up to round-off: no variation to judge
        residual = centred.copy()
        for q in basis:
            residual -= (q @ residual) * q
        share = float(residual @ residual) / total if total > 0 else 0.0
        if share >= min_unique:
            kept[name] = share
            basis.append(residual / np.sqrt(residual @ residual))
            continue
        against = ", ".join(kept) or "a constant"
        if total > 0:
            why = f"{100 * (1 - share):.4g} % of its variation on the training runs is a linear function of {against} (1 - R^2 = {share:.2g} < {min_unique:g})"
        else:
            why = "it does not vary on the training runs"
        hint = f"; {hints[name]}" if name in hints else ""
        refused.append(Refusal(name, share, f"{name} not fitted: {why}, so its coefficient cannot be told from theirs{hint}"))
    return kept, refused


def polynomial_terms(temperature_c, rate_c_per_s, degree: int, rate_term: bool, min_unique: float) -> tuple[int, bool, list]:
    """The degree and dT/dt term of a cubic-plus-rate model that a run can identify.

    The powers of temperature are judged on ``x = (T - T_mid) / T_half``
    over the training range, each against the lower powers; the highest
    power kept is the degree (a power that fails stops the series: a run
    at two temperatures fixes a line, whatever comes after). dT/dt is
    judged against every kept power.

    Parameters
    ----------
    temperature_c, rate_c_per_s : ndarray
        The training samples (block means) the model is fitted on.
    degree : int
        Highest power the config asks for.
    rate_term : bool
        Whether the config asks for a dT/dt term.
    min_unique : float
        See :func:`separable`.

    Returns
    -------
    degree : int
        Highest power the run identifies (at most the one asked for).
    rate_term : bool
        Whether dT/dt is kept.
    refused : list of Refusal
    """
    T = np.asarray(temperature_c, dtype=float)
    lo, hi = float(T.min()), float(T.max())
    x = (T - (hi + lo) / 2) / ((hi - lo) / 2 if hi > lo else 1.0)
    names = ["(T - T_ref)"] + [f"(T - T_ref)^{k}" for k in range(2, degree + 1)]
    columns = {name: x ** (k + 1) for k, name in enumerate(names)}
    if rate_term:
        columns["dT/dt"] = np.asarray(rate_c_per_s, dtype=float)
    hints = {
        "dT/dt": "in a single warm-up or cool-down dT/dt follows T; add a run that heats and cools at other rates, "
        "or use --config firmware (a cubic in T, what PX4 and ArduPilot fit)",
        **{name: "the run visits too few temperatures for this power; ramp through the whole range" for name in names},
    }
    kept, refused = separable({name: columns[name] for name in names}, min_unique, hints)
    powers = next((k for k, name in enumerate(names) if name not in kept), len(names))
    first = {r.term: r for r in refused}
    stopped = [
        first.get(name) or Refusal(name, kept[name], f"{name} not fitted: a lower power is not identifiable, so the series stops there")
        for name in names[powers:]
    ]
    if not rate_term:
        return powers, False, stopped
    kept, refused = separable({**{name: columns[name] for name in names[:powers]}, "dT/dt": columns["dT/dt"]}, min_unique, hints)
    return powers, "dT/dt" in kept, stopped + refused
