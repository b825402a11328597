"""Which candidates the selection runs can identify at all: "not identifiable" before "looked for and absent".

A candidate's detection limit (:mod:`gyrocomp.diagnose.detectability`)
says how strong it would have to be to be found. Some candidates cannot be
found at any strength on some runs: their columns there are a linear
combination of the baseline's (the per-run offset, the temperature
polynomial) and of their own per-run nuisance columns. A hysteresis whose
branch never changes on the selection runs is a constant after its first
excursion, which the offset and the power-on indicator take; a warm-up of a
log that did not start at power-on is a slow decay the polynomial in a
settling temperature takes. The report then says "not identifiable from
these runs", with the reason, instead of a detection limit.

The criterion is the shared one of :func:`gyrocomp.identifiability.separable`:
the share ``1 - R^2`` of a column's variation over the block means of the
selection runs that the columns before it leave unexplained, at least
``identifiable_min_unique``. The candidate is judged at the shape of its
one-at-a-time fit (its nonlinear parameters fitted beside the baseline).

A holdout may see what the selection runs cannot: a hysteresis whose branch
changes there. :func:`holdout_needs` asks whether the holdout's residual
needs such a candidate: identifiable on the holdout, and its columns needed
there at the shape the fit run gives it, beside every other column of the
selected model refitted on the holdout (a likelihood ratio, ``chi^2`` with
the rank the columns add, Wilks). Refitted, not frozen at the fit run's
values: a holdout at other temperatures than the fit run reads the fit
run's cubic extrapolated, and a hysteresis takes that misfit (p = 3e-106 on
a constructed pair without any). The report then says so and suggests
giving the holdout to the selection.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose.effects import PER_RUN
from gyrocomp.diagnose.nonlinear import extend
from gyrocomp.diagnose.signature import TERMS
from gyrocomp.effects.likelihood import fit_noise
from gyrocomp.identifiability import separable

__all__ = ["unidentifiable", "holdout_needs"]

HINTS = {
    "hysteresis": "its branch must change on a selection run: add a run whose temperature reverses by more than the "
    "deadband (--holdout A --holdout B)",
    "warmup": "a warm-up is seen only on a log that starts at power-on: add such a run (--holdout A --holdout B)",
}
"""What the user can do about a candidate the runs cannot identify, by effect."""


def unidentifiable(runs, start, model, effect, min_unique) -> str | None:
    """Why the selection `runs` cannot identify `effect` at `model`'s shape, or None when they can.

    Parameters
    ----------
    runs : sequence of gyrocomp.diagnose.select.Problem
        The selection runs.
    start : gyrocomp.diagnose.select.Fitted
        The model the candidates are added to (the baseline).
    model : gyrocomp.diagnose.select.Fitted
        `start` plus `effect`, fitted alone (its nonlinear parameters).
    effect : str
    min_unique : float
        Least share ``1 - R^2`` of the effect's column, over the block means
        of all runs, that the baseline's columns and the effect's per-run
        columns (one set per run) must leave unexplained.

    Returns
    -------
    str or None
        One sentence for the report; None for a noise term or an effect
        without columns of its own (a thermal lag changes the temperature
        the polynomial reads).
    """
    before = set(start.names)
    columns = {}
    sizes = [p.y.size for p in runs]
    for r, problem in enumerate(runs):
        X, names = problem.design_blocks(model.spec)
        for j, name in enumerate(names):
            key = f"{name}@{r}" if name in PER_RUN else name
            columns.setdefault(key, [np.zeros(n) for n in sizes])[r] = X[:, j]
    own = [k for k in columns if k not in before and "@" not in k]
    if not own:
        return None
    order = [k for k in columns if k.split("@")[0] not in own] + own
    _, refused = separable({k: np.concatenate(columns[k]) for k in order}, min_unique)
    lost = [x for x in refused if x.term in own]
    if not lost:
        return None
    share = min(x.unique for x in lost)
    hint = f"; {HINTS[effect]}" if effect in HINTS else ""
    return (f"not identifiable from these runs: {100 * (1 - share):.4g} % of its column's variation on the selection runs "
            f"is a linear function of the baseline's columns and its own per-run part (1 - R^2 = {share:.2g} < {min_unique:g}){hint}")


def holdout_needs(fit, holdout, selected, effect, alpha, min_unique) -> float | None:
    """The p-value with which `holdout` needs `effect`, a candidate the selection runs cannot identify; None when it does not.

    Parameters
    ----------
    fit : gyrocomp.diagnose.select.Problem
        The fit run: the effect's nonlinear parameters are fitted there,
        beside the `selected` model (:func:`gyrocomp.diagnose.nonlinear.extend`),
        so the test on the holdout is at a shape the holdout did not choose.
    holdout : gyrocomp.diagnose.select.Problem
    selected : gyrocomp.diagnose.select.Fitted
    effect : str
    alpha : float
        The level of the holdout's test (``confirm.replication_alpha``).
    min_unique : float
        As :func:`unidentifiable`, on the holdout.

    Returns
    -------
    float or None
        The p-value of the effect's columns on the holdout beside the
        selected model's, all refitted there with the noise levels (module
        docstring), when the holdout can identify the effect and that p is
        at most `alpha`.
    """
    trial = extend(fit, selected, effect)
    if unidentifiable([holdout], selected, trial, effect, min_unique) is not None:
        return None
    X = holdout.design_blocks(trial.spec)[0]
    own = holdout.own_columns(trial.spec, effect)
    terms = ("arw",) + tuple(t for t in TERMS if getattr(trial.noise, t) > 0.0)
    with_it = fit_noise(holdout.y, X, holdout.basis, trial.noise, terms)[1]
    without = fit_noise(holdout.y, X[:, ~own], holdout.basis, trial.noise, terms)[1]
    dof = np.linalg.matrix_rank(X) - np.linalg.matrix_rank(X[:, ~own])
    p = float(stats.chi2.sf(max(without - with_it, 0.0), dof)) if dof > 0 else 1.0
    return p if p <= alpha else None
