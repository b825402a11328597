"""``spectral_line``: a sinusoid at an unknown frequency.

Fisher's ``g`` -- the largest periodogram ordinate of the innovations over
their sum -- at the Fourier frequencies of at least ``line_min_cycles``
cycles in the run; ``P = m (1 - g)^(m-1)``, the first term of Fisher's
exact series [1]_ (an upper bound, accurate in the tail).

References
----------
.. [1] R. A. Fisher, "Tests of significance in harmonic analysis",
   Proc. R. Soc. Lond. A 125, 54-59 (1929).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result, log10

__all__ = ["fisher_g", "test", "CHECK"]


def fisher_g(e, min_cycles=1):
    """Fisher's ``g`` (largest periodogram ordinate over their sum) of `e` and its p-value [1]_.

    The Fourier frequencies ``j / n``, ``min_cycles <= j < n / 2`` (slower
    ones are drifts, not lines: the ``time`` check looks for them); the
    p-value is the first (upper-bound) term ``m (1 - g)^(m - 1)`` of
    Fisher's exact series, accurate in the tail where a decision is made.

    Returns
    -------
    g : float
    p : float
    index : int
        ``j`` of the largest ordinate (period ``n / j`` samples).

    Examples
    --------
    >>> t = np.arange(256)
    >>> g, p, j = fisher_g(np.sin(2 * np.pi * 10 * t / 256) + np.random.default_rng(0).standard_normal(256))
    >>> j, bool(p < 1e-6)
    (10, True)
    """
    e = np.asarray(e, dtype=float)
    n = e.size
    power = np.abs(np.fft.rfft(e - e.mean())) ** 2
    power = power[min_cycles : (n - 1) // 2 + 1]
    m = power.size
    j = int(np.argmax(power))
    g = float(power[j] / power.sum())
    return g, float(min(1.0, m * (1.0 - g) ** (m - 1))), j + min_cycles


def test(frame, e, Xw):
    """Fisher's ``g`` of the innovations, its p and the line's period [s]."""
    cycles = frame.settings.line_min_cycles
    g, p, j = fisher_g(e, cycles)
    m = (e.size - 1) // 2 - cycles + 1
    return Result(g, p, {"period_s": e.size * frame.block_s / j,
                         "log10_p": min(0.0, log10(np.log(m) + (m - 1) * np.log1p(-min(g, 1.0 - 1e-16))))})


def shape(frame, rng):
    """A sinusoid of 17 cycles in the run."""
    return np.sin(2.0 * np.pi * 17.0 * np.arange(frame.t.size) / frame.t.size)


CHECK = Check("spectral_line", test, exact=False, families=("residual",), shape=shape)
