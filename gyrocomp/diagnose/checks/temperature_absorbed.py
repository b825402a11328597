"""``temperature_absorbed``: a function of temperature that a noise term absorbed (its signature).

The score statistic of ``temperature_bins`` equal-width temperature-bin
indicators, whitened (``chi^2`` of their rank beyond the design), and a
step at one temperature: the largest score of ``1[T >= c]`` at the inner
edges of ``temperature_step_bins`` equal-width bins (a bias discontinuity
the noise absorbed) with the union bound over the edges
(:func:`gyrocomp.diagnose.checks._linear.threshold_scan`). The two make one
test, ``p = 2 min`` of theirs (conservative), so that the family keeps its
number of tests.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.checks._linear import score_test, temperature_bins, temperature_edges, threshold_scan, whiten


def test(frame, e, Xw):
    """The bins' score and the step scan, ``2 min`` of the two; None without temperature."""
    if frame.temp is None:
        return None
    s = frame.settings
    stat, dof, p, *_ = score_test(e, Xw, whiten(frame.lower, temperature_bins(frame.temp, s.temperature_bins)))
    edges = temperature_edges(frame.temp, s.temperature_step_bins, s.min_step_blocks)
    if not edges.size:
        return Result(stat, p, {"dof": dof, "by": "bins"})
    found = threshold_scan(e, Xw, frame.lower, frame.temp, edges)
    return Result(stat, float(min(1.0, 2.0 * min(p, found["p"]))), {
        "dof": dof,
        "by": "bins" if p <= found["p"] else "step",
        "step": {"stat": found["stat"], "temperature_c": float(edges[found["index"]]), "p": found["p"]},
    })


def shape(frame, rng):
    """A step where the temperature crosses its median."""
    return (frame.temp >= np.median(frame.temp)).astype(float)


CHECK = Check("temperature_absorbed", test, exact=False, families=("signature",), shape=shape)
