"""``temperature``: a function of temperature beyond the model's.

Indicators of ``temperature_bins`` equal-width temperature bins, scored
(``chi^2`` of their rank beyond the design); and, for a structure narrower
than a bin (a dip over a few degC), a scan of the single bins of the
``temperature_scan_bins`` equal-width binnings (bins of fewer than
``min_step_blocks`` blocks left out), each bin's whitened score ``z``
``N(0, 1)`` under the model, the union bound ``n 2 Phi(-max |z|)``. The two
make one test, ``p = 2 min`` of theirs (conservative).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose.checks._base import Check, Result, log10, score_columns
from gyrocomp.diagnose.checks._linear import column_scores


def test(frame, e, Xw):
    """The bins' score and the scan of narrow bands (module docstring); None without temperature."""
    bins = score_columns(frame, e, Xw, "temperature")
    if bins is None or not frame.bands.shape[1]:
        return bins
    z, live, _ = column_scores(e, Xw, frame.lower, frame.bands)
    j = int(np.argmax(np.abs(z)))
    log_scan = np.log(2.0 * live.sum()) + stats.norm.logsf(abs(z[j]))
    scan_p = float(min(1.0, np.exp(log_scan)))
    by = "band" if scan_p < bins.pvalue else "bins"
    log_p = min(0.0, np.log(2.0) + (log_scan if by == "band" else stats.chi2.logsf(bins.statistic, bins.where["dof"])))
    return Result(bins.statistic, float(min(1.0, 2.0 * min(scan_p, bins.pvalue))), bins.where | {
        "log10_p": log10(log_p),
        "by": by,
        "band": {"stat": float(abs(z[j])), "column": j, "temperature_c": frame.band_c[j], "p": scan_p},
    })


def shape(frame, rng):
    """A dip over the middle fifth of the temperature range."""
    lo, hi = np.quantile(frame.temp, [0.4, 0.6])
    return -((frame.temp >= lo) & (frame.temp <= hi)).astype(float)


CHECK = Check("temperature", test, exact=False, families=("residual",), shape=shape)
