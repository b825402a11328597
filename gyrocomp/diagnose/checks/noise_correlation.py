"""``noise_correlation``: a correlated noise the model's noise terms do not take.

A telegraph noise under white noise, or a wander the noise terms'
signature refused: Ljung-Box ``Q`` of the innovations over
``ljung_box_lags`` lags, ``chi^2_h``
(:func:`gyrocomp.diagnose.checks.ljung_box.ljung_box`), with the lag
correlations for the report.
"""

from __future__ import annotations

from gyrocomp.diagnose.checks import ljung_box as _lb
from gyrocomp.diagnose.checks._base import Check, Result


def test(frame, e, Xw):
    """``Q``, its lags and the lag correlations ``rho``."""
    lags = min(frame.settings.ljung_box_lags, e.size // 4)
    q, p = _lb.ljung_box(e, lags)
    x = e - e.mean()
    rho = [float(x[k:] @ x[:-k] / (x @ x)) for k in range(1, lags + 1)]
    return Result(q, p, {"lags": lags, "rho": rho})


CHECK = Check("noise_correlation", test, exact=False, families=("residual",), shape=_lb.shape, level="noise")
