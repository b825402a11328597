"""``replication``: does one run's slow residual, as a function of time or of temperature, repeat in another run? (a noise term's signature)

A noise term's wander is drawn afresh in every run, so nothing of it
repeats between runs. For every ordered pair of runs the source run's GLS
residual is averaged in ``time_bins`` equal bins of time since power-on
(and in ``temperature_bins`` equal-width temperature bins); that step
function, read at the target run's times (temperatures), is one whitened
column of a score test on the target run. The source's noise is
independent of the target's, so the statistic is ``chi^2_1`` when the
model holds (exact): one result per ordered pair and binning.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.checks._linear import score_test
from gyrocomp.effects.likelihood import block_means


def test(runs, designs, whitened, s):
    """One result per ordered pair of runs and binning; ``where`` names the binning (``of``), ``source`` and ``target``."""
    prepared = []
    for p, X, (e, Xw, lower) in zip(runs, designs, whitened):
        beta, *_ = linalg.lstsq(Xw, linalg.solve_triangular(lower, p.y, lower=True, check_finite=False), cond=1e-12)
        t = np.arange(p.y.size) * p.basis.block_s
        temp = None
        if p.run.temperature_c is not None:
            temp = block_means(p.run.temperature_c, p.run.n_per_block)[: p.y.size]
        prepared.append((p, e, Xw, lower, p.y - X @ beta, t, temp))
    out = []
    for a, (pa, _, _, _, ra, ta, Ta) in enumerate(prepared):
        for b, (pb, eb, Xwb, lowb, _, tb, Tb) in enumerate(prepared):
            if a == b:
                continue
            shapes = {"time": _binned(ta, ra, tb, np.linspace(0.0, min(ta[-1], tb[-1]), s.time_bins + 1)[1:-1])}
            if Ta is not None and Tb is not None:
                edges = np.linspace(Ta.min(), Ta.max(), s.temperature_bins + 1)[1:-1]
                shapes["temperature"] = _binned(Ta, ra, Tb, edges)
            for of, g in shapes.items():
                gw = linalg.solve_triangular(lowb, g[:, None], lower=True, check_finite=False)
                stat, dof, p, *_ = score_test(eb, Xwb, gw)
                out.append(Result(stat, p, {"of": of, "source": pa.run.name, "target": pb.run.name}))
    return out


def _binned(x_source, r_source, x_target, edges):
    """The bin means of `r_source` over `x_source` (bins cut at `edges`), read at `x_target`."""
    k = edges.size + 1
    src = np.searchsorted(edges, x_source, side="right")
    means = np.bincount(src, weights=r_source, minlength=k) / np.maximum(np.bincount(src, minlength=k), 1)
    return means[np.searchsorted(edges, x_target, side="right")]


CHECK = Check("replication", test, exact=True, families=("signature",), shape=None, scope="runs")
