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
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.effects import PER_RUN
from gyrocomp.identifiability import separable

__all__ = ["unidentifiable"]

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
