"""The Allan analysis of a recording: deviation, confidence, IEEE Std 952 terms, artefact.

:func:`analyse` puts the pieces together for a series in memory, and
:func:`analyse_chunks` for one read chunk by chunk, as long as the disk
holds it: the overlapping deviation (:mod:`gyrocomp.allan.deviation`), the
noise identification and chi-square interval
(:mod:`gyrocomp.allan.noise_id`) and the five-term fit with the classic
read-offs (:mod:`gyrocomp.allan.fit`, model in
:mod:`gyrocomp.allan.ieee952`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
from typing import Callable, Iterable, Sequence

import numpy as np

from gyrocomp.allan.deviation import Phase, _phase, averaging_factors, check_fs, integrate, integrate_stored, second_difference_sums
from gyrocomp.allan.fit import add_readoffs, fit_terms
from gyrocomp.allan.noise_id import chi2_interval, edf_oadev, noise_id
from gyrocomp.errors import InputError, ThresholdError

__all__ = [
    "AllanConfig",
    "AllanSeries",
    "get_config",
    "analyse",
    "analyse_chunks",
    "analyse_segment_chunks",
    "pool_segments",
    "allan_artefact",
    "check_thresholds",
]


@dataclasses.dataclass(frozen=True)
class AllanConfig:
    """Settings of the Allan analysis; defaults equal ``configs/allan.toml``.

    Attributes
    ----------
    taus : str
        ``"octave"``, ``"decade"``, ``"all"`` or a comma-separated list of tau [s]
        (a TOML list of seconds is joined into this form by :func:`get_config`).
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
    thermal_alpha : float
        Level of the test whether the long-tau rise follows temperature
        (:func:`gyrocomp.allan.thermal.temperature_test`).
    min_clusters : int
        Fewest independent clusters (floor(N/m), summed over segments) at a
        tau for a read-off there (:func:`~gyrocomp.allan.fit.add_readoffs`).
    flat_ratio, flat_span : float
        B is read only when the curve stays within `flat_ratio` of its
        minimum over a tau span of at least `flat_span` (a ratio of taus).
    bias_factor : float
        sigma_min / B for flicker rate noise, sqrt(2 ln2/pi) ~ 0.664 ([4]_).
    max_phase_in_memory : int
        Longest series [samples] whose phase :func:`analyse_chunks` keeps
        in memory (8 bytes a sample); a longer one is spilled to a file.
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
    min_clusters: int = 9
    thermal_alpha: float = 0.01
    flat_ratio: float = 1.25
    flat_span: float = 8.0
    max_phase_in_memory: int = 20_000_000

    def __post_init__(self):
        positive = ("model_error", "identify_sigmas", "arw_tau_s", "rrw_tau_s", "slope_tolerance", "bias_factor")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0):
                raise InputError(f"allan {name} = {value!r}; must be a finite number > 0")
        for name in ("confidence", "thermal_alpha"):
            if not 0.0 < getattr(self, name) < 1.0:
                raise InputError(f"allan {name} = {getattr(self, name)!r}; must be in (0, 1)")
        if not (self.flat_ratio > 1.0 and self.flat_span >= 1.0):
            raise InputError(f"allan flat_ratio = {self.flat_ratio!r}, flat_span = {self.flat_span!r}; need flat_ratio > 1 and flat_span >= 1")
        if self.min_clusters < 2:
            raise InputError(f"allan min_clusters = {self.min_clusters!r}; must be >= 2")
        if self.min_acf_points < 3:
            raise InputError(f"allan min_acf_points = {self.min_acf_points!r}; must be >= 3")
        if self.max_phase_in_memory < 0:
            raise InputError(f"allan max_phase_in_memory = {self.max_phase_in_memory!r}; must be >= 0")


def get_config(path: str | os.PathLike = "allan") -> AllanConfig:
    """Read the ``[allan]`` table of a TOML config (default ``configs/allan.toml``)."""
    from gyrocomp.config import bind, check_tables, load_config

    table = dict(check_tables(load_config(path), ("allan",), str(path)).get("allan") or {})
    if isinstance(table.get("taus"), list):  # the documented list form: seconds, as --taus takes them
        table["taus"] = ",".join(repr(t) for t in table["taus"])
    return bind(AllanConfig, table, f"{path} [allan]")


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
        Second differences averaged at each tau (N - 2m + 1; summed over
        the segments of a pooled series).
    clusters : ndarray of int
        Independent (non-overlapping) clusters of m samples at each tau,
        floor(N/m), summed over the segments: how many samples of the
        tau-average the deviation rests on.
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
    segments : int
        Gap-free segments pooled into the series (:func:`pool_segments`).
    thermal : dict or None
        Whether the long-tau rise follows temperature
        (:func:`gyrocomp.allan.thermal.judge`); None without a temperature.
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
    clusters: np.ndarray
    confidence: float
    terms: dict
    segments: int = 1
    thermal: dict | None = None

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
            "clusters": [int(v) for v in self.clusters],
            "segments": int(self.segments),
            "thermal": self.thermal,
            "terms": self.terms,
        }


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
    fs_hz = check_fs(fs_hz)
    return _series(Phase(_phase(x)), fs_hz, taus, name, column, settings)


def analyse_chunks(
    chunks: Callable[[], Iterable[np.ndarray]],
    fs_hz: Callable[[], float] | float,
    *,
    taus=None,
    name: str = "",
    column: str = "rate",
    settings: AllanConfig = AllanConfig(),
    folder: str | None = None,
) -> AllanSeries:
    """:func:`analyse` of a series read chunk by chunk, in memory that does not grow with its length.

    Parameters
    ----------
    chunks : callable returning an iterable of ndarray
        Each call reads the series again from its start, in consecutive
        chunks [deg/s]; it is called twice (the mean, then the phase).
    fs_hz : float, or callable returning float
        Sample rate; a callable is asked after the first reading (a
        streamed recording knows it from its first chunk).
    taus, name, column, settings
        As in :func:`analyse`.
    folder : str, optional
        Where the phase of a series longer than
        ``settings.max_phase_in_memory`` samples is spilled (a temporary
        float64 file, 8 bytes a sample; default the system's temporary folder).

    Returns
    -------
    AllanSeries
        Equal to :func:`analyse` of the whole series to rounding (the mean
        is summed chunk by chunk), whatever the chunks.

    Notes
    -----
    Memory: the chunks, and windows of `_CHUNK` samples of the phase
    (3 of them per tau beyond a chunk). A series of 3e8 samples spills a
    2.4 GB phase file, which the operating system's page cache, not the
    process, holds.
    """
    (series,) = analyse_segment_chunks(
        lambda: ((0, y) for y in chunks()), fs_hz, taus=taus, name=name, column=column, settings=settings, folder=folder
    )
    return series


def analyse_segment_chunks(
    pieces: Callable[[], Iterable[tuple[int, np.ndarray]]],
    fs_hz: Callable[[], float] | float,
    *,
    taus=None,
    name: str = "",
    column: str = "rate",
    settings: AllanConfig = AllanConfig(),
    folder: str | None = None,
    n_samples: int | None = None,
) -> list[AllanSeries]:
    """:func:`analyse_chunks` of a series with gaps: each gap-free segment a series of its own, in one or two readings.

    Parameters
    ----------
    pieces : callable returning an iterable of (int, ndarray)
        Each call reads the series again from its start, as consecutive
        pieces ``(segment, samples)`` [deg/s]: the segment's index (0, 1,
        ...; increasing, a segment's pieces together) and samples of that
        segment alone, so that no piece spans a gap. Called twice, or once
        (see `n_samples`).
    fs_hz, taus, column, settings, folder
        As :func:`analyse_chunks`.
    name : str
        The series' name; with several segments, ``<name> segment <k>`` (k from 1).
    n_samples : int, optional
        The most samples a reading can give (a Parquet file's row count).
        When their phase fits in memory (``settings.max_phase_in_memory``),
        `pieces` is read once: each sample is kept where its phase value
        will be, and integrated there once its segment's mean is known
        (:func:`~gyrocomp.allan.deviation.integrate_stored`, the same bits
        as a second reading). A series of more than
        :data:`_SEGMENT_SLOTS` segments is then read a second time.

    Returns
    -------
    list of AllanSeries
        One per segment, each equal to :func:`analyse` of that segment to
        rounding; with several segments, those of fewer than 3 samples are
        left out (no deviation), as the whole-file reading leaves them out.
    """
    store = None
    if n_samples is not None and n_samples <= settings.max_phase_in_memory:
        store = np.empty(n_samples + _SEGMENT_SLOTS)
        sums = _segment_sums(pieces(), store)
        if sums is None:  # more segments than slots: read twice
            store = None
    if store is None:
        sums = _segment_sums(pieces())
    seen = sum(n for _, n, _ in sums.values())
    if len(sums) <= 1 and seen < 3:
        raise InputError(f"Allan deviation needs at least 3 samples, got {seen}")
    fs_hz = check_fs(fs_hz() if callable(fs_hz) else fs_hz)
    labels = {k: name if len(sums) == 1 else f"{name} segment {k + 1}" for k in sums}
    if store is not None:
        return [
            _series(integrate_stored(store[at : at + n + 1], total / n), fs_hz, taus, labels[k], column, settings)
            for k, (total, n, at) in sums.items()
            if n >= 3  # only with several segments (checked above)
        ]
    out = []
    for k, group in itertools.groupby(pieces(), key=lambda piece: piece[0]):
        total, n, _ = sums[k]
        if n < 3:  # only with several segments (checked above)
            continue
        values = (y for _, y in group)
        phase = integrate(values, total / n, n, in_memory=n <= settings.max_phase_in_memory, folder=folder)
        try:
            out.append(_series(phase, fs_hz, taus, labels[k], column, settings))
        finally:
            phase.close()
    return out


_SEGMENT_SLOTS = 64
"""Places beyond the samples in a one-reading store: x_0 of each segment's phase (a segment per gap)."""


def _segment_sums(pieces: Iterable[tuple[int, np.ndarray]], store: np.ndarray | None = None) -> dict | None:
    """``{segment: [sum, count, place]}`` of `pieces`, every sample checked finite.

    With `store`, segment k's samples are copied to ``store[place + 1 :
    place + 1 + count]`` (``store[place]`` is left for its x_0, the
    segments one after the other); None when they do not fit.
    """
    sums: dict[int, list] = {}
    seen = at = 0
    for k, y in pieces:
        y = np.asarray(y, dtype=float)
        part = float(y.sum())
        if not math.isfinite(part):
            i = int(np.flatnonzero(~np.isfinite(y))[0])
            raise InputError(f"rate sample {seen + i} is {y[i]!r}; the Allan deviation needs finite values")
        entry = sums.get(k)
        if entry is None:
            entry = sums[k] = [0.0, 0, at]
            at += 1
        if store is not None:
            if at + len(y) > len(store):
                return None
            store[at : at + len(y)] = y
        at += len(y)
        entry[0] += part
        entry[1] += len(y)
        seen += len(y)
    return sums


def _series(phase: Phase, fs_hz: float, taus, name: str, column: str, settings: AllanConfig) -> AllanSeries:
    n_samples = len(phase) - 1
    m = averaging_factors(settings.taus if taus is None else taus, n_samples, fs_hz)
    n = len(phase) - 2 * m
    avar = second_difference_sums(phase, m) / (2.0 * n * m.astype(float) ** 2)
    adev = np.sqrt(avar)
    if not (adev > 0).all():
        tau0 = m[np.flatnonzero(~(adev > 0))[0]] / fs_hz
        raise InputError(
            f"{name} `{column}`: Allan deviation 0 at tau = {tau0:g} s: the series does not vary "
            "(a stuck sensor or a constant column?); no noise to identify"
        )
    alpha = np.array([noise_id(phase, int(k), settings.min_acf_points) for k in m], dtype=int)
    edf = np.array([edf_oadev(int(a), int(k), n_samples + 1) for a, k in zip(alpha, m)])
    return _with_terms(name, column, fs_hz, m, avar, n, alpha, edf, n_samples // m, 1, settings)


def pool_segments(series: Sequence[AllanSeries], *, name: str, settings: AllanConfig = AllanConfig()) -> AllanSeries:
    """One Allan deviation of a series with gaps: the segments' variances averaged at each tau, weighted by their terms.

    Parameters
    ----------
    series : sequence of AllanSeries
        The gap-free segments of one axis (:func:`analyse_segment_chunks`),
        at one sample rate.
    name : str
        The pooled series' name.
    settings : AllanConfig

    Returns
    -------
    AllanSeries
        At every tau that some segment reaches: sigma^2 = sum_k n_k sigma_k^2 / sum_k n_k,
        n_k the second differences of segment k (N_k - 2m + 1; a segment
        shorter than 2m + 1 samples adds none), which is the gap-resistant
        overlapping estimator (allantools ``gradev``) of the whole record:
        the mean of every squared second difference that spans no gap.
        The edf of the average of independent chi-square estimates is
        Satterthwaite's, (sum n_k)^2 / sum(n_k^2 / edf_k); the noise type
        at a tau is that of the segment with the most terms there. Terms
        and read-offs are fitted to the pooled curve.
    """
    fs_hz = series[0].fs_hz
    by_m: dict[int, list[tuple]] = {}
    for s in series:
        for m, adev, n, alpha, edf, clusters in zip(np.rint(s.tau_s * fs_hz).astype(np.int64), s.adev, s.n, s.alpha, s.edf, s.clusters):
            by_m.setdefault(int(m), []).append((float(adev) ** 2, int(n), int(alpha), float(edf), int(clusters)))
    m = np.array(sorted(by_m), dtype=np.int64)
    rows = [np.array(by_m[k], dtype=float) for k in m]
    n = np.array([r[:, 1].sum() for r in rows])
    avar = np.array([np.dot(r[:, 0], r[:, 1]) for r in rows]) / n
    edf = np.array([r[:, 1].sum() ** 2 / np.sum(r[:, 1] ** 2 / r[:, 3]) for r in rows])
    alpha = np.array([r[np.argmax(r[:, 1]), 2] for r in rows], dtype=int)
    clusters = np.array([r[:, 4].sum() for r in rows], dtype=np.int64)
    column = series[0].column
    return _with_terms(name, column, fs_hz, m, avar, n.astype(np.int64), alpha, edf, clusters, len(series), settings)


def _with_terms(name, column, fs_hz, m, avar, n, alpha, edf, clusters, segments, settings: AllanConfig) -> AllanSeries:
    """The series of an Allan variance at factors `m`: deviation, interval, fitted terms and read-offs."""
    adev = np.sqrt(avar)
    lo, hi = chi2_interval(adev, edf, settings.confidence)
    tau = m / fs_hz
    terms = fit_terms(tau, avar, edf, settings.identify_sigmas, settings.model_error)
    add_readoffs(terms, tau, adev, clusters, settings)
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
        clusters=np.asarray(clusters, dtype=np.int64),
        confidence=settings.confidence,
        terms=terms,
        segments=segments,
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
