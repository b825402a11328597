"""Power-law noise identification and the confidence of the overlapping Allan deviation.

Stable32's recipe [1]_: the power-law noise type is identified at each tau
by the lag-1 autocorrelation [2]_ (or by the B1 ratio where fewer than
`min_acf_points` averages exist), its equivalent degrees of freedom come
from Greenhall's algorithm [3]_, and a chi-square interval is drawn ([1]_
eq. (45)).

References
----------
.. [1] W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065
       (2008).
.. [2] W. J. Riley, C. A. Greenhall, "Power law noise identification using the
       lag 1 autocorrelation", Proc. 18th EFTF (2004).
.. [3] C. A. Greenhall, W. J. Riley, "Uncertainty of stability variances based
       on finite differences", Proc. 35th PTTI (2003).
"""

from __future__ import annotations

import math

import numpy as np

from gyrocomp.allan.chi2 import chi2_ppf
from gyrocomp.allan.deviation import _CHUNK, Phase

__all__ = ["noise_id", "edf_oadev", "chi2_interval"]


def noise_id(phase: Phase, m: int, min_points: int) -> int:
    """Power-law exponent alpha of the rate at averaging factor m, in [-2, 2].

    Lag-1 autocorrelation of the linearly detrended m-averages, differenced
    until delta = r1/(1 + r1) < 0.25 (at most twice), alpha = -round(2 delta) - 2d
    ([2]_ sec. 3). With fewer than `min_points` averages, the B1 ratio of their
    standard to Allan variance against its value for each noise type, with
    boundaries at geometric means ([1]_ sec. 5.6; white and flicker PM are
    not told apart there, both give alpha = 1).

    The m-averages (times m: alpha does not depend on scale) are the
    differences of every m-th phase point; their trend is a sum over the
    phase (summation by parts), and they are streamed in chunks from `phase`
    once per differencing order, so no array of their length is built.
    """
    n = (len(phase) - 1) // m
    if n < min_points:
        return _b1_noise_id(np.diff(phase.read(0, n * m + 1, m)))
    x_0, x_n = float(phase.read(0, 1)[0]), float(phase.read(n * m, n * m + 1)[0])
    mean = (x_n - x_0) / n  # the differences telescope
    center = (n - 1) / 2.0
    # sum_i (i - center) z_i by parts: (n - 1) x_n - sum_{0<i<n} x_i - center (x_n - x_0)
    inner = sum(float(phase.read(i * m, min(i + 4 * _CHUNK, n) * m, m).sum()) for i in range(1, n, 4 * _CHUNK))
    tz = (n - 1) * x_n - inner - center * (x_n - x_0)
    slope = tz / (n * (n * n - 1.0) / 12.0)
    for d in (0, 1):
        delta = _lag1_delta(phase, m, n, mean, slope, center, d)
        if delta < 0.25:
            return int(np.clip(-round(2.0 * delta) - 2 * d, -2, 2))
    delta = _lag1_delta(phase, m, n, mean, slope, center, 2)
    return int(np.clip(-round(2.0 * delta) - 4, -2, 2))


def _lag1_delta(phase, m, n, mean, slope, center, d) -> float:
    """delta = r1/(1 + r1) of the d-times differenced, detrended m-averages ([2]_ eq. (3))."""
    total = sq = lag = 0.0
    first = last = None
    carry = []
    step = 4 * _CHUNK
    ramp = slope * np.arange(_BLOCK, dtype=float)
    buffer = np.empty(_BLOCK)
    for start in range(0, n, step):
        stop = min(start + step, n)
        x = phase.read(start * m, stop * m + 1, m)  # every m-th phase point: the m-averages start..stop-1, times m, are its differences
        for a in range(0, stop - start, _BLOCK):
            b = min(a + _BLOCK, stop - start)
            z = buffer[: b - a]
            np.subtract(x[a + 1 : b + 1], x[a:b], out=z)
            z -= mean + slope * (start + a - center)
            z -= ramp[: b - a]
            z = _diff_streamed(z, d, carry)
            if not len(z):
                continue
            if first is None:
                first = z[0]
            else:
                lag += last * z[0]
            total += z.sum()
            sq += np.einsum("i,i->", z, z)
            lag += np.einsum("i,i->", z[:-1], z[1:])
            last = z[-1]
    n_z = n - d
    mu = total / n_z
    lag1 = lag - mu * (2.0 * total - first - last) + (n_z - 1) * mu * mu
    r1 = lag1 / (sq - n_z * mu * mu)
    return r1 / (1.0 + r1)


_BLOCK = 1 << 15
"""m-averages detrended at a time in :func:`_lag1_delta` (256 KiB: with the phase they come from, within a core's L2 cache).

The 23 octave taus of 10^7 samples took 0.18 s of CPU, against 0.24 s
four chunks at a time (one process, load 3.5).
"""


def _diff_streamed(z: np.ndarray, d: int, carry: list) -> np.ndarray:
    """The d-th difference of a chunk, continuing from the chunk before (`carry` holds its tails)."""
    for level in range(d):
        head = z[-1]
        z = np.diff(z, prepend=carry[level]) if level < len(carry) else np.diff(z)
        if level < len(carry):
            carry[level] = head
        else:
            carry.append(head)
    return z


def _b1_noise_id(z: np.ndarray) -> int:
    n = len(z)
    if n < 3:
        return 0
    b1 = np.var(z, ddof=1) / (0.5 * np.mean(np.diff(z) ** 2))
    # Barnes' B1(N, r=1, mu) for mu = -2 (PM), -1 (white FM), 0 (flicker FM), 1 (RW FM)
    expected = np.array([2.0 * (n + 1) / (3.0 * n), 1.0, n * math.log(n) / (2.0 * (n - 1) * math.log(2.0)), n / 2.0])
    bounds = np.sqrt(expected[:-1] * expected[1:])
    return int([1, 0, -1, -2][int(np.searchsorted(bounds, b1))])


_J_MAX = 100
# Greenhall & Riley [3]_ Table 2 (d = 2 column): (a0, a1) for the r > d+1 asymptote
_TABLE2_D2 = {1: (790.0, 410.0), 0: (2.0 / 3.0, 1.0 / 3.0), -1: (0.852, 0.375), -2: (1.079, 0.368)}
_TABLE3_D2 = (15.23, 12.0)  # Table 3, alpha = 1, d = 2: (b0, b1)


def edf_oadev(alpha: int, m: int, n_phase: int) -> float:
    """Equivalent degrees of freedom of the overlapping Allan variance ([3]_ sec. 4).

    d = 2, unmodified (F = m), fully overlapped (S = m); `n_phase` phase
    points. M = n_phase - 2m second differences, r = M/m.
    """
    d = 2
    big_m = n_phase - 2 * m
    J = min(big_m, (d + 1) * m)
    r = big_m / m
    if alpha == 2:
        if r > d:
            a0 = math.comb(4 * d, 2 * d) / math.comb(2 * d, d) ** 2
            return 1.0 / ((a0 - (d / 2.0) / r) / big_m)
        mp = _J_MAX / r
        return _J_MAX * _sz(0.0, mp, 2) ** 2 / _basic_sum(_J_MAX, _J_MAX, mp, mp, 2)
    if alpha == 1:
        if J <= _J_MAX:
            return big_m * _sz(0.0, m, 1) ** 2 / _basic_sum(J, big_m, m, m, 1)
        b0, b1 = _TABLE3_D2
        scale = (b0 + b1 * math.log(m)) ** 2
        if r > d + 1:
            a0, a1 = _TABLE2_D2[1]
            return scale * r / (a0 - a1 / r)
        mp = _J_MAX / r
        return scale * _J_MAX / _basic_sum(_J_MAX, _J_MAX, mp, mp, 1)
    if J <= _J_MAX:
        f = m if m * (d + 1) <= _J_MAX else math.inf
        return big_m * _sz(0.0, f, alpha) ** 2 / _basic_sum(J, big_m, m, f, alpha)
    if r > d + 1:
        a0, a1 = _TABLE2_D2[alpha]
        return r / (a0 - a1 / r)
    mp = _J_MAX / r
    return _J_MAX * _sz(0.0, math.inf, alpha) ** 2 / _basic_sum(_J_MAX, _J_MAX, mp, math.inf, alpha)


def _basic_sum(J, M, S, F, alpha) -> float:
    """[3]_ eq. (10)."""
    j = np.arange(1, int(J), dtype=float)
    inner = 2.0 * np.sum((1.0 - j / M) * _sz(j / S, F, alpha) ** 2)
    return float(_sz(0.0, F, alpha) ** 2 + (1.0 - J / M) * _sz(J / S, F, alpha) ** 2 + inner)


def _sz(t, F, alpha):
    """[3]_ eq. (9) for d = 2."""
    return (
        6.0 * _sx(t, F, alpha)
        - 4.0 * _sx(t - 1.0, F, alpha)
        - 4.0 * _sx(t + 1.0, F, alpha)
        + _sx(t - 2.0, F, alpha)
        + _sx(t + 2.0, F, alpha)
    )


def _sx(t, F, alpha):
    """[3]_ eq. (8)."""
    if math.isinf(F):
        return _sw(t, alpha + 2)
    return F**2 * (2.0 * _sw(t, alpha) - _sw(t - 1.0 / F, alpha) - _sw(t + 1.0 / F, alpha))


def _sw(t, alpha):
    """[3]_ eq. (7): the generalised autocovariance of the phase for S_y ~ f^alpha."""
    t = np.abs(np.asarray(t, dtype=float))
    if alpha in (2, 0, -2):
        return {2: -t, 0: t**3, -2: t**5}[alpha]
    power = {1: 2, -1: 4}[alpha]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(t > 0, t**power * np.log(np.where(t > 0, t, 1.0)), 0.0)


def chi2_interval(adev: np.ndarray, edf: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """sigma * sqrt(edf / chi2_{1-p}(edf)), sigma * sqrt(edf / chi2_p(edf)), p = (1 - level)/2 ([1]_ eq. (45)).

    The quantiles are :func:`gyrocomp.allan.chi2.chi2_ppf`'s (scipy's
    ``2 gammaincinv(edf/2, p)`` to 1e-13, without importing ``scipy.special``).
    """
    p = (1.0 - confidence) / 2.0
    chi2_lo = chi2_ppf(p, edf)
    chi2_hi = chi2_ppf(1.0 - p, edf)
    return adev * np.sqrt(edf / chi2_hi), adev * np.sqrt(edf / chi2_lo)


