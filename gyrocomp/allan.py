"""Overlapping Allan deviation with confidence intervals and IEEE Std 952 noise terms.

The rate samples are integrated once (a cumulative sum, the "phase" of
NIST SP 1065 [1]_); every averaging time is then a second difference of that
sum, evaluated in cache-sized chunks so that no array of N x taus, nor a new
N-sized array per tau, is ever built. Confidence intervals follow Stable32
[1]_: the power-law noise type is identified at each tau by the lag-1
autocorrelation [2]_ (or by the B1 ratio where fewer than `min_acf_points`
averages exist), its equivalent degrees of freedom come from Greenhall's
algorithm [3]_, and a chi-square interval is drawn ([1]_ eq. (45)). The five
IEEE Std 952 terms [4]_ are fitted to the Allan variance by weighted
non-negative least squares, and the classic slope read-offs are given beside
them.

References
----------
.. [1] W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065
       (2008).
.. [2] W. J. Riley, C. A. Greenhall, "Power law noise identification using the
       lag 1 autocorrelation", Proc. 18th EFTF (2004).
.. [3] C. A. Greenhall, W. J. Riley, "Uncertainty of stability variances based
       on finite differences", Proc. 35th PTTI (2003).
.. [4] IEEE Std 952-1997, "IEEE Standard Specification Format Guide and Test
       Procedure for Single-Axis Interferometric Fiber Optic Gyros", Annex C.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import warnings
from typing import Sequence

import numpy as np

from gyrocomp.errors import InputError, ThresholdError

__all__ = [
    "AllanConfig",
    "AllanSeries",
    "get_config",
    "oadev",
    "analyse",
    "allan_artefact",
    "check_thresholds",
]

_CHUNK = 1 << 16
"""Samples per chunk of the second-difference sums (512 KiB: with its lag buffer, about an L2 cache)."""

_LN2_PI = 2.0 * math.log(2.0) / math.pi
"""Bias-instability factor of the Allan variance, 2 ln2 / pi ([4]_ Table C.1)."""

# term: (Allan-variance basis b(tau) in sigma^2 = c * b(tau), unit, factor from
# the SI-like value sqrt(c) [deg/s, s] to the reported unit), [4]_ Annex C.
_TERMS = {
    "quantization": (lambda t: 3.0 / t**2, "deg", 1.0),
    "arw": (lambda t: 1.0 / t, "deg/sqrt(h)", 60.0),
    "bias_instability": (lambda t: _LN2_PI * np.ones_like(t), "deg/h", 3600.0),
    "rrw": (lambda t: t / 3.0, "deg/h/sqrt(h)", 3600.0 * 60.0),
    "rate_ramp": (lambda t: t**2 / 2.0, "deg/h/h", 3600.0**2),
}


@dataclasses.dataclass(frozen=True)
class AllanConfig:
    """Settings of the Allan analysis; defaults equal ``configs/allan.toml``.

    Attributes
    ----------
    taus : str
        ``"octave"``, ``"decade"``, ``"all"`` or a comma-separated list of tau [s].
    confidence : float
        Two-sided confidence level of ``adev_lo``/``adev_hi`` (0.683 = 1 sigma).
    min_acf_points : int
        Fewest m-averages for the lag-1 ACF noise identification [2]_; below
        it the B1 ratio ([1]_ sec. 5.6) decides.
    model_error : float
        Relative error of the five-term model itself in the Allan variance,
        added in quadrature to the statistical error sqrt(2/edf) in the fit
        weights.
    identify_sigmas : float
        A fitted term is *identified* when its Allan-variance coefficient
        exceeds this many standard errors.
    arw_tau_s, rrw_tau_s : float
        Where the -1/2 and +1/2 lines are read ([4]_: 1 s and 3 s).
    slope_tolerance : float
        Largest deviation of a local log-log slope from -1/2 (+1/2) for a
        segment to count as the ARW (RRW) line of a read-off.
    bias_factor : float
        sigma_min / B for flicker rate noise, sqrt(2 ln2/pi) ~ 0.664 ([4]_).
    """

    taus: str = "octave"
    confidence: float = 0.683
    min_acf_points: int = 30
    model_error: float = 0.1
    identify_sigmas: float = 2.0
    arw_tau_s: float = 1.0
    rrw_tau_s: float = 3.0
    slope_tolerance: float = 0.1
    bias_factor: float = 0.664

    def __post_init__(self):
        if not 0.0 < self.confidence < 1.0:
            raise InputError(f"allan confidence = {self.confidence!r}; must be in (0, 1)")
        if self.min_acf_points < 3:
            raise InputError(f"allan min_acf_points = {self.min_acf_points!r}; must be >= 3")


def get_config(path: str | os.PathLike = "allan") -> AllanConfig:
    """Read the ``[allan]`` table of a TOML config (default ``configs/allan.toml``)."""
    from gyrocomp.config import bind, check_tables, load_config

    return bind(AllanConfig, check_tables(load_config(path), ("allan",), str(path)).get("allan"), f"{path} [allan]")


@dataclasses.dataclass
class AllanSeries:
    """Allan deviation of one series, its confidence interval and noise terms.

    Attributes
    ----------
    name, column : str
        Where the series came from.
    fs_hz : float
        Sample rate.
    tau_s, adev, adev_lo, adev_hi : ndarray
        Averaging times [s], overlapping Allan deviation and its two-sided
        chi-square interval at `confidence` [unit of the input, deg/s for rate].
    n : ndarray of int
        Second differences averaged at each tau (N - 2m + 1).
    alpha : ndarray of int
        Identified power-law exponent of the rate PSD, S(f) ~ f^alpha
        (2 white PM/quantization, 0 white rate, -1 flicker, -2 random walk).
    edf : ndarray
        Equivalent degrees of freedom [3]_.
    confidence : float
        Level of the interval.
    terms : dict
        ``quantization``, ``arw``, ``bias_instability``, ``rrw``,
        ``rate_ramp``; each ``{value, unit, sigma, identified}`` from the
        five-term fit, plus ``readoff`` and ``readoff_tau_s`` for ``arw``,
        ``bias_instability`` and ``rrw`` (``None`` where the curve has no such
        line).
    """

    name: str
    column: str
    fs_hz: float
    tau_s: np.ndarray
    adev: np.ndarray
    adev_lo: np.ndarray
    adev_hi: np.ndarray
    n: np.ndarray
    alpha: np.ndarray
    edf: np.ndarray
    confidence: float
    terms: dict

    def to_dict(self) -> dict:
        """The series in the ``allan.json`` contract shape (plain JSON values)."""
        return {
            "name": self.name,
            "column": self.column,
            "fs_hz": float(self.fs_hz),
            "confidence": float(self.confidence),
            "tau_s": self.tau_s.tolist(),
            "adev": self.adev.tolist(),
            "adev_lo": self.adev_lo.tolist(),
            "adev_hi": self.adev_hi.tolist(),
            "n": [int(v) for v in self.n],
            "alpha": [int(v) for v in self.alpha],
            "edf": self.edf.tolist(),
            "terms": self.terms,
        }


def oadev(x, fs_hz: float, taus="octave") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of rate samples.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Rate samples (the "fractional frequency" y of [1]_), any unit.
    fs_hz : float
        Sample rate; tau0 = 1/fs_hz.
    taus : {"octave", "decade", "all"} or sequence of float
        ``"octave"``: m = 1, 2, 4, ...; ``"decade"``: m = 1, 2, 5 x 10^k;
        ``"all"``: every m; or taus in seconds, rounded to whole m. Taus
        with fewer than two second differences (2m >= n_samples) are left out.

    Returns
    -------
    tau_s : ndarray
        m / fs_hz.
    adev : ndarray
        Overlapping Allan deviation, in the unit of `x`.
    n : ndarray of int
        Number of second differences at each tau, n_samples - 2m + 1.

    Notes
    -----
    With the phase x_i = tau0 * sum_{k<i} (y_k - mean(y)), x_0 = 0 ([1]_ eq. (4)),

        sigma^2(m tau0) = sum_{i=0}^{n-1} (x_{i+2m} - 2 x_{i+m} + x_i)^2 / (2 n (m tau0)^2)

    ([1]_ eq. (11)), the convention of Stable32 and of allantools
    ``oadev(data_type="freq")``. Memory: one float64 copy of `x`.

    Examples
    --------
    >>> tau, dev, n = oadev([892, 809, 823, 798, 671, 644, 883, 903, 677], 1.0, [1, 2])
    >>> np.round(dev, 5)  # NBS14 10-point set, NIST SP 1065 p. 107
    array([91.22945, 85.95287])
    """
    fs_hz = _check_fs(fs_hz)
    phase = _phase(x)
    m = _averaging_factors(taus, len(phase) - 1, fs_hz)
    n = len(phase) - 2 * m
    adev = np.sqrt(_second_difference_sums(phase, m) / (2.0 * n * m.astype(float) ** 2))
    return m / fs_hz, adev, n


def analyse(
    x,
    fs_hz: float,
    *,
    taus=None,
    name: str = "",
    column: str = "rate",
    settings: AllanConfig = AllanConfig(),
) -> AllanSeries:
    """Allan deviation with confidence intervals and IEEE Std 952 noise terms.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Rate samples [deg/s].
    fs_hz : float
        Sample rate.
    taus : see :func:`oadev`, default ``settings.taus`` (``"octave"``)
    name, column : str
        Labels carried into the result.
    settings : AllanConfig

    Returns
    -------
    AllanSeries

    Notes
    -----
    Five-term model ([4]_ eq. (C.16)), fitted to sigma^2(tau) by non-negative
    weighted least squares in the coefficients Q^2, N^2, B^2, K^2, R^2:

        sigma^2(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2

    with weights 1 / (sigma_model^4 (2/edf + e^2)): the inverse variance of a
    chi-square variance estimate plus a relative model error e
    (`settings.model_error`), so that the thousands of degrees of freedom at
    the shortest taus do not let unmodelled effects there (sensor filters,
    correlated noise) pull the whole fit; iterated three times from the
    measured values. The reported sigma propagates the coefficient covariance, scaled
    up by the reduced chi-square when that exceeds one; it ignores the
    correlation between overlapping estimates at neighbouring taus.
    """
    fs_hz = _check_fs(fs_hz)
    phase = _phase(x)
    n_samples = len(phase) - 1
    m = _averaging_factors(settings.taus if taus is None else taus, n_samples, fs_hz)
    n = len(phase) - 2 * m
    avar = _second_difference_sums(phase, m) / (2.0 * n * m.astype(float) ** 2)
    adev = np.sqrt(avar)
    alpha = np.array([_noise_id(phase, int(k), settings.min_acf_points) for k in m], dtype=int)
    edf = np.array([_edf_oadev(int(a), int(k), n_samples + 1) for a, k in zip(alpha, m)])
    lo, hi = _chi2_interval(adev, edf, settings.confidence)
    tau = m / fs_hz
    terms = _fit_terms(tau, avar, edf, settings.identify_sigmas, settings.model_error)
    _add_readoffs(terms, tau, adev, settings)
    return AllanSeries(
        name=name,
        column=column,
        fs_hz=fs_hz,
        tau_s=tau,
        adev=adev,
        adev_lo=lo,
        adev_hi=hi,
        n=n,
        alpha=alpha,
        edf=edf,
        confidence=settings.confidence,
        terms=terms,
    )


def allan_artefact(series: Sequence[AllanSeries], *, inputs: list[dict], settings: dict) -> dict:
    """The ``allan.json`` artefact: header (schema ``gyrocomp.allan``) and ``series``."""
    from gyrocomp.artefacts import artefact_header

    header = artefact_header("gyrocomp.allan", inputs=inputs, settings=settings)
    return {**header, "series": [s.to_dict() for s in series]}


def check_thresholds(
    series: Sequence[AllanSeries],
    *,
    max_arw: float | None = None,
    max_bias_instability: float | None = None,
    max_rrw: float | None = None,
) -> None:
    """Raise :class:`~gyrocomp.errors.ThresholdError` when a read-off exceeds its bound.

    The bounds apply to every series and compare the classic read-offs
    (datasheet convention): N [deg/sqrt(h)], B [deg/h], K [deg/h/sqrt(h)].
    A series without the relevant line (read-off ``None``) falls back to
    the fitted value.
    """
    bounds = {"arw": max_arw, "bias_instability": max_bias_instability, "rrw": max_rrw}
    for s in series:
        for key, bound in bounds.items():
            if bound is None:
                continue
            term = s.terms[key]
            value = term["readoff"] if term["readoff"] is not None else term["value"]
            if value > bound:
                raise ThresholdError(
                    f"{s.name} `{s.column}`: {key} = {value:.4g} {term['unit']} exceeds "
                    f"--max-{key.replace('_', '-')} {bound:g}"
                )


def _check_fs(fs_hz) -> float:
    fs = float(fs_hz)
    if not math.isfinite(fs) or fs <= 0:
        raise InputError(f"sample rate fs_hz = {fs_hz!r}; must be a positive number")
    return fs


def _phase(x) -> np.ndarray:
    """x_0 = 0, x_{i+1} = sum_{k<=i} (y_k - mean y), in samples x rate unit ([1]_ eq. (4))."""
    y = np.asarray(x, dtype=float)
    if y.ndim != 1:
        raise InputError(f"rate samples must be 1-D, got shape {y.shape}")
    if len(y) < 3:
        raise InputError(f"Allan deviation needs at least 3 samples, got {len(y)}")
    mean = y.mean()  # finite exactly when every sample is (NaN and inf propagate), else look closer
    if not math.isfinite(mean) and not np.isfinite(y).all():
        i = int(np.flatnonzero(~np.isfinite(y))[0])
        raise InputError(f"rate sample {i} is {y[i]!r}; the Allan deviation needs finite values")
    phase = np.empty(len(y) + 1)
    phase[0] = 0.0
    np.subtract(y, mean, out=phase[1:])
    np.cumsum(phase[1:], out=phase[1:])
    return phase


def _averaging_factors(taus, n_samples: int, fs_hz: float) -> np.ndarray:
    """Whole averaging factors m with 2m < n_samples, sorted and unique."""
    m_max = (n_samples - 1) // 2
    if isinstance(taus, str) and taus in ("octave", "decade", "all"):
        if taus == "all":
            m = np.arange(1, m_max + 1)
        elif taus == "octave":
            m = 2 ** np.arange(int(math.log2(max(m_max, 1))) + 1)
        else:
            decades = 10 ** np.arange(int(math.log10(max(m_max, 1))) + 1)
            m = np.outer(decades, [1, 2, 5]).ravel()
        return m[m <= m_max].astype(np.int64)
    if isinstance(taus, str):
        try:
            taus = [float(t) for t in taus.split(",") if t.strip()]
        except ValueError:
            raise InputError(
                f"taus = {taus!r}; use octave, decade, all or a comma-separated list of seconds"
            ) from None
    tau = np.asarray(taus, dtype=float).ravel()
    if tau.size == 0 or not np.isfinite(tau).all() or (tau <= 0).any():
        raise InputError(f"taus = {list(tau)!r}; need positive finite seconds")
    m = np.unique(np.round(tau * fs_hz)).astype(np.int64)
    m = m[m >= 1]
    dropped = m[m > m_max]
    if dropped.size:
        warnings.warn(
            f"taus {', '.join(f'{v / fs_hz:g}' for v in dropped)} s left out: a record of "
            f"{n_samples} samples reaches tau = {m_max / fs_hz:g} s",
            stacklevel=3,
        )
    m = m[m <= m_max]
    if m.size == 0:
        raise InputError(f"no tau fits a record of {n_samples} samples at {fs_hz:g} Hz")
    return m


def _second_difference_sums(phase: np.ndarray, m: np.ndarray) -> np.ndarray:
    """sum_i (x_{i+2m} - 2 x_{i+m} + x_i)^2 for every m, chunk by chunk.

    The outer loop walks the record in chunks, the inner loop the taus, so
    the windows of a short tau are still in cache when read again. For
    m <= chunk the second difference is taken as a difference of the lag-m
    first differences D_i = x_{i+m} - x_i (one pass fewer).
    """
    total = np.zeros(len(m))
    diff = np.empty(2 * _CHUNK)
    buf = np.empty(_CHUNK)
    n = len(phase) - 2 * m
    for start in range(0, int(n.max()), _CHUNK):
        for j, k in enumerate(m):
            k = int(k)
            stop = min(start + _CHUNK, int(n[j]))
            if stop <= start:
                continue
            size = stop - start
            w = buf[:size]
            if k <= _CHUNK:
                d = diff[: size + k]
                np.subtract(phase[start + k : stop + 2 * k], phase[start : stop + k], out=d)
                np.subtract(d[k:], d[:size], out=w)
            else:
                np.add(phase[start + 2 * k : stop + 2 * k], phase[start:stop], out=w)
                mid = phase[start + k : stop + k]
                np.subtract(w, mid, out=w)
                np.subtract(w, mid, out=w)
            total[j] += np.einsum("i,i->", w, w)
    return total


def _noise_id(phase: np.ndarray, m: int, min_points: int) -> int:
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
        return _b1_noise_id(np.diff(phase[: n * m + 1 : m]))
    x = phase[: n * m + 1 : m]
    mean = (x[-1] - x[0]) / n  # the differences telescope
    center = (n - 1) / 2.0
    # sum_i (i - center) z_i by parts: (n - 1) x_n - sum_{0<i<n} x_i - center (x_n - x_0)
    tz = (n - 1) * x[-1] - x[1:-1].sum() - center * (x[-1] - x[0])
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
    ramp = slope * np.arange(step, dtype=float)
    for start in range(0, n, step):
        stop = min(start + step, n)
        z = np.diff(phase[start * m : stop * m + 1 : m])  # the m-averages start..stop-1, times m
        z -= mean + slope * (start - center)
        z -= ramp[: stop - start]
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


def _edf_oadev(alpha: int, m: int, n_phase: int) -> float:
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


def _chi2_interval(adev: np.ndarray, edf: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """sigma * sqrt(edf / chi2_{1-p}(edf)), sigma * sqrt(edf / chi2_p(edf)), p = (1 - level)/2 ([1]_ eq. (45))."""
    from scipy.special import gammaincinv

    p = (1.0 - confidence) / 2.0
    chi2_lo = 2.0 * gammaincinv(edf / 2.0, p)
    chi2_hi = 2.0 * gammaincinv(edf / 2.0, 1.0 - p)
    return adev * np.sqrt(edf / chi2_hi), adev * np.sqrt(edf / chi2_lo)


def _fit_terms(tau: np.ndarray, avar: np.ndarray, edf: np.ndarray, identify_sigmas: float, model_error: float) -> dict:
    """Non-negative weighted least squares of the five-term model (see :func:`analyse`)."""
    basis = np.column_stack([b(tau) for b, _, _ in _TERMS.values()])
    scale = np.linalg.norm(basis, axis=0)
    a = basis / scale
    model = avar.copy()
    coef, active, cov = np.zeros(len(_TERMS)), np.zeros(len(_TERMS), bool), np.zeros((0, 0))
    for _ in range(3):
        rel_var = 2.0 / edf + model_error**2
        w = 1.0 / (np.sqrt(rel_var) * np.maximum(model, np.finfo(float).tiny))
        coef, active, cov, chi2 = _nnls_subsets(a * w[:, None], avar * w)
        model = a @ coef
    dof = max(len(tau) - int(active.sum()), 1)
    inflate = max(1.0, chi2 / dof)
    aw = a * w[:, None]
    full_cov = np.linalg.pinv(aw.T @ aw) * inflate
    var_c = np.diag(full_cov).copy()
    var_c[active] = np.diag(cov) * inflate
    terms = {}
    for i, (key, (_, unit, factor)) in enumerate(_TERMS.items()):
        c = coef[i] / scale[i]
        sigma_c = math.sqrt(max(var_c[i], 0.0)) / scale[i]
        if c > 0:
            value, sigma = math.sqrt(c), sigma_c / (2.0 * math.sqrt(c))
        else:
            value, sigma = 0.0, math.sqrt(sigma_c)
        terms[key] = {
            "value": value * factor,
            "unit": unit,
            "sigma": sigma * factor,
            "identified": bool(c > identify_sigmas * sigma_c),
        }
    return terms


def _nnls_subsets(a: np.ndarray, b: np.ndarray):
    """Exact non-negative least squares for a few columns: best feasible active set."""
    k = a.shape[1]
    best = None
    for size in range(1, k + 1):
        for cols in itertools.combinations(range(k), size):
            sub = a[:, cols]
            if np.linalg.matrix_rank(sub) < size:
                continue
            sol = np.linalg.lstsq(sub, b, rcond=None)[0]
            if (sol <= 0).any():
                continue
            chi2 = float(np.sum((sub @ sol - b) ** 2))
            if best is None or chi2 < best[0]:
                best = (chi2, cols, sol, sub)
    coef = np.zeros(k)
    active = np.zeros(k, bool)
    if best is None:
        return coef, active, np.zeros((0, 0)), float(np.sum(b**2))
    chi2, cols, sol, sub = best
    coef[list(cols)] = sol
    active[list(cols)] = True
    return coef, active, np.linalg.inv(sub.T @ sub), chi2


def _add_readoffs(terms: dict, tau: np.ndarray, adev: np.ndarray, settings: AllanConfig) -> None:
    """Classic IEEE 952 read-offs: N on the -1/2 line at 1 s, K on the +1/2 line at 3 s, B = minimum / 0.664.

    B uses the first local minimum of the curve (the flicker floor before
    rate random walk or drift lifts it), the last point when the curve only
    falls. Each line is read in its own tau range, the way the terms appear
    on an Allan curve: the -1/2 line (angle random walk) at or below that
    minimum, the +1/2 line (rate random walk) at or above it. A line is the
    longest run there of consecutive log-log segments whose slope is within
    `slope_tolerance` of -1/2 (+1/2); its level is the geometric mean of
    sigma * tau^(-slope) over the run. Without a run the read-off is
    ``None`` and ``readoff_note`` says so: a denoised recording, whose curve
    rises first and falls as tau^(-1/2) only at thousands of seconds, has no
    angle random walk to read, though a -1/2 stretch exists far above 1 s.
    """
    rising = np.flatnonzero(np.diff(adev) > 0)
    i = int(rising[0]) if rising.size else len(adev) - 1
    ranges = {"arw": (-0.5, settings.arw_tau_s, slice(0, i + 1), "at or below"), "rrw": (0.5, settings.rrw_tau_s, slice(i, len(tau)), "at or above")}
    for key, (slope, at, window, where) in ranges.items():
        run = _longest_run(tau[window], adev[window], slope, settings.slope_tolerance)
        factor = _TERMS[key][2]
        if run is None:
            note = f"no {slope:+.1f} slope {where} the Allan minimum (tau = {tau[i]:.3g} s)"
            terms[key].update(readoff=None, readoff_tau_s=None, readoff_note=note)
            continue
        run = run + window.start
        level = np.exp(np.mean(np.log(adev[run]) - slope * np.log(tau[run])))
        terms[key].update(readoff=float(level * at**slope * factor), readoff_tau_s=[float(tau[run[0]]), float(tau[run[-1]])])
    terms["bias_instability"].update(
        readoff=float(adev[i] / settings.bias_factor * _TERMS["bias_instability"][2]),
        readoff_tau_s=float(tau[i]),
    )


def _longest_run(tau, adev, slope, tolerance):
    if len(tau) < 2:
        return None
    local = np.diff(np.log(adev)) / np.diff(np.log(tau))
    ok = np.abs(local - slope) <= tolerance
    best, start = None, None
    for i, flag in enumerate(np.append(ok, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if best is None or i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    if best is None:
        return None
    return np.arange(best[0], best[1] + 1)
