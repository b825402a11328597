"""``temperature_step``: a step at an unknown temperature, the same when heating and when cooling.

A bias discontinuity: a mode that switches at one temperature, a solder or
package transition. The column ``1[T >= c]`` at each inner edge ``c`` of
``temperature_step_bins`` equal-width bins (at least ``min_step_blocks``
blocks on either side), its whitened score ``z`` ``N(0, 1)`` under the
model, the union bound ``n 2 Phi(-max |z|)`` (conservative). A run that
crosses ``c`` several times shows it as several steps in time, and a
hysteresis (which switches with the direction of the temperature change,
wherever that is) takes part of it.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result, log10
from gyrocomp.diagnose.checks._linear import threshold_scan


def test(frame, e, Xw):
    """The edge of largest ``|z|`` and its union-bound p; None without temperature or edges."""
    if frame.temp is None or not frame.threshold_c.size:
        return None
    found = threshold_scan(e, Xw, frame.lower, frame.temp, frame.threshold_c)
    return Result(found["stat"], found["p"], {"temperature_c": float(frame.threshold_c[found["index"]]),
                                             "size": found["size"], "log10_p": log10(found["log_p"])})


def shape(frame, rng):
    """A step where the temperature crosses its median."""
    return (frame.temp >= np.median(frame.temp)).astype(float)


CHECK = Check("temperature_step", test, exact=False, families=("residual",), shape=shape)
