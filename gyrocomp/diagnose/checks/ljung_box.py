"""``ljung_box``: the innovations are white (a noise term's signature).

Ljung-Box ``Q = n (n + 2) sum_k rho_k^2 / (n - k)`` over ``h =
min(ljung_box_lags, n / 4)`` lags, ``chi^2_h`` [1]_ (asymptotic). The
verdict's ``noise_correlation`` is the same statistic.

References
----------
.. [1] G. M. Ljung, G. E. P. Box, "On a measure of lack of fit in time
   series models", Biometrika 65(2), 297-303 (1978).
"""

from __future__ import annotations

import numpy as np
from scipy import signal, stats

from gyrocomp.diagnose.checks._base import Check, Result

__all__ = ["ljung_box", "test", "CHECK"]


def ljung_box(e, lags):
    """Ljung-Box ``Q`` of `e` over `lags` lags and its ``chi^2_lags`` p-value [1]_.

    Examples
    --------
    >>> q, p = ljung_box(np.random.default_rng(1).standard_normal(500), 10)
    >>> bool(p > 0.01)
    True
    """
    e = np.asarray(e, dtype=float) - np.mean(e)
    n = e.size
    denom = float(e @ e)
    k = np.arange(1, lags + 1)
    rho = np.array([float(e[j:] @ e[:-j]) for j in k]) / denom
    q = float(n * (n + 2) * np.sum(rho**2 / (n - k)))
    return q, float(stats.chi2.sf(q, lags))


def test(frame, e, Xw):
    """``Q`` over ``min(ljung_box_lags, n // 4)`` lags."""
    q, p = ljung_box(e, min(frame.settings.ljung_box_lags, e.size // 4))
    return Result(q, p, {})


def shape(frame, rng):
    """A first-order Gauss-Markov noise of correlation 0.8 between blocks, of innovations twice the unit."""
    return signal.lfilter([2.0], [1.0, -0.8], rng.standard_normal(frame.t.size))


CHECK = Check("ljung_box", test, exact=False, families=("signature",), shape=shape, level="noise")
