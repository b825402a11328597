"""``allan``: the Allan slope a noise term claims holds at the timescales it explains (its signature, own statistics).

At every ``tau`` of :class:`gyrocomp.diagnose.checks._timescales.Timescales`
(``+1/2`` ADEV slope for a random walk, ``0`` for flicker) the
non-overlapping Allan variance of the GLS residual lies within its
interval: ``avar`` is a quadratic form ``r' A r``, whose mean and
Satterthwaite degrees of freedom ``nu`` under the model (regression
removed) are exact moments [1]_; two-sided ``chi^2_nu`` test (approximate).

References
----------
.. [1] F. E. Satterthwaite, "An approximate distribution of estimates of
   variance components", Biometrics Bulletin 2(6), 110-114 (1946).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose.checks._base import Check, Result
from gyrocomp.diagnose.gap import satterthwaite_dof


def test(ts):
    """One result per ``tau``: statistic ``nu avar / E avar``; ``where`` holds ``tau_s``, ``ratio`` and ``dof``."""
    out = []
    for m in ts.ms:
        k = ts.r.size // m
        diff, cov_d = ts.increments(m)
        form = diff / np.sqrt(2.0 * (k - 1))
        avar = float(np.sum((form @ ts.r) ** 2))
        mean = float(np.sum(np.diag(cov_d)) / (2.0 * (k - 1)))
        nu = satterthwaite_dof(cov_d)  # of |form r|^2, whose A is cov_d / (2 (k - 1))
        x = nu * avar / mean
        p = float(min(1.0, 2.0 * min(stats.chi2.cdf(x, nu), stats.chi2.sf(x, nu))))
        out.append(Result(float(x), p, {"tau_s": float(m * ts.block_s), "ratio": avar / mean, "dof": nu}))
    return out


CHECK = Check("allan", test, exact=False, families=("signature",), shape=None, scope="timescale", own=True)
