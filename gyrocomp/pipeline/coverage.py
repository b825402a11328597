"""What a training run's temperature can teach a model: quantisation, span and ramp checks, and an even weighting over temperature.

Autopilot users hit these before any model question: a Bosch IMU reports
whole degrees (PX4 issues #13551, #12412), so the temperature rate is a
staircase; a calibration over a few degrees, or one that never ramps,
extrapolates everywhere else (ArduPilot issue #21438); and a warm-up that
lingers near its end temperature gives those degrees most of the weight of
a least-squares fit, which PX4 counters by resampling into temperature bins
(PX4 PR #14091). :func:`check_run` warns about the first two in one line
each, :func:`even_over_temperature` is the third (``train
--even-temperature``). The thresholds are in ``configs/coverage.toml``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from typing import Sequence

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["CoverageConfig", "get_config", "check_run", "quantum", "even_over_temperature"]


@dataclasses.dataclass(frozen=True)
class CoverageConfig:
    """The ``[coverage]`` table; defaults equal ``configs/coverage.toml``.

    Attributes
    ----------
    min_span_c : float
        Warn when the temperature spans less [degC].
    min_ramp_c_per_min : float
        Warn when |dT/dt| over `ramp_window_s` never reaches this [degC/min].
    ramp_window_s : float
        Window of the means whose differences judge the ramp [s].
    min_quantum_c : float
        Coarsest grid step [degC] below which a temperature is not called quantised.
    bin_c : float
        Width of the temperature bins of :func:`even_over_temperature` [degC].
    """

    min_span_c: float = 10.0
    min_ramp_c_per_min: float = 0.1
    ramp_window_s: float = 60.0
    min_quantum_c: float = 0.25
    bin_c: float = 1.0

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
                raise InputError(f"coverage {field.name} = {value!r}; must be a finite number > 0")


def get_config(path: str | os.PathLike = "coverage") -> CoverageConfig:
    """Read the ``[coverage]`` table of a TOML config (default ``configs/coverage.toml``)."""
    from gyrocomp.config import bind, check_tables, load_config

    table = check_tables(load_config(path), ("coverage",), str(path)).get("coverage")
    return bind(CoverageConfig, table, f"{path} [coverage]")


def quantum(temperature_c: np.ndarray) -> float:
    """The grid step [degC] every temperature sits on (to 0.1 % of it), 0 when the values are on no grid coarser than their spread allows.

    The step is the smallest difference between distinct values; the
    temperature is on that grid when every value is a whole number of
    steps from the first (Kelvin converted to degC keeps the grid).
    """
    values = np.unique(np.asarray(temperature_c, dtype=float))
    if values.size < 2:
        return 0.0
    step = float(np.min(np.diff(values)))
    steps = (values - values[0]) / step
    return step if np.all(np.abs(steps - np.rint(steps)) <= 1e-3) else 0.0


def check_run(name: str, time_s: np.ndarray, temperature_c: np.ndarray, segments: Sequence[slice], rate_window_s: float, settings: CoverageConfig = CoverageConfig()) -> list[str]:
    """Warn, one line each, about a training run whose temperature is quantised, spans too little or never ramps.

    Parameters
    ----------
    name : str
        The run, for the messages.
    time_s, temperature_c : ndarray
        The run's time stamps [s] and temperature [degC].
    segments : sequence of slice
        Its gap-free row ranges (a ramp is judged within them).
    rate_window_s : float
        The window of the pipeline's dT/dt estimate ([rate] window_s), for
        what a quantised temperature does to it.
    settings : CoverageConfig

    Returns
    -------
    list of str
        The warnings given (also issued with :func:`warnings.warn`).
    """
    temperature = np.asarray(temperature_c, dtype=float)
    time = np.asarray(time_s, dtype=float)
    messages = []
    q = _coarse_quantum(temperature, settings.min_quantum_c)
    if q >= settings.min_quantum_c:
        messages.append(
            f"{name}: temperature quantised to {q:.3g} degC steps: dT/dt over the {rate_window_s:g} s window moves in steps "
            f"of {q / rate_window_s:.3g} degC/s ({60 * q / rate_window_s:.3g} degC/min) and is 0 between level changes"
        )
    span = float(np.ptp(temperature))
    if span < settings.min_span_c:
        messages.append(
            f"{name}: temperature spans {span:.3g} degC ({temperature.min():.4g} to {temperature.max():.4g}), under min_span_c "
            f"{settings.min_span_c:g}: the model extrapolates outside it"
        )
    steepest = _steepest_ramp(time, temperature, segments, settings.ramp_window_s)
    if steepest is not None and steepest < settings.min_ramp_c_per_min:
        messages.append(
            f"{name}: the run never ramps: |dT/dt| over {settings.ramp_window_s:g} s windows reaches {steepest:.3g} degC/min, "
            f"under min_ramp_c_per_min {settings.min_ramp_c_per_min:g}"
        )
    for message in messages:
        warnings.warn(message, stacklevel=2)
    return messages


def even_over_temperature(X: np.ndarray, y: np.ndarray, temperature_c: np.ndarray, bin_c: float) -> tuple[np.ndarray, np.ndarray]:
    """The means of the rows of `X` and `y` within temperature bins of `bin_c` degC: every bin weighs the same in a least-squares fit.

    Parameters
    ----------
    X : ndarray, shape (n, k)
        Training inputs (block means).
    y : ndarray, shape (n,)
        Their targets.
    temperature_c : ndarray, shape (n,)
        The temperature of each row [degC], which picks its bin.
    bin_c : float
        Bin width [degC]; bins start at whole multiples of it.

    Returns
    -------
    X, y : ndarray
        One row per occupied bin, in temperature order.
    """
    _, inverse, counts = np.unique(np.floor(np.asarray(temperature_c) / bin_c), return_inverse=True, return_counts=True)
    means = np.column_stack([np.bincount(inverse, weights=column) for column in np.column_stack([X, y]).T]) / counts[:, None]
    return means[:, :-1], means[:, -1]


def _coarse_quantum(temperature: np.ndarray, coarsest: float) -> float:
    """:func:`quantum` of the run where it can reach `coarsest` [degC], else at most that, in memory of `_ROWS` readings.

    On a grid of step >= `coarsest` the run takes at most ``ptp / coarsest + 1``
    distinct values; they are gathered `_ROWS` readings at a time, and once
    there are more (a noisy temperature: at the first chunk) the step is
    finer than `coarsest` and 0 is returned. Otherwise :func:`quantum` of the
    distinct values, which equals that of the run.
    """
    limit = float(np.ptp(temperature)) / coarsest + 2
    values = np.empty(0)
    for lo in range(0, temperature.size, _ROWS):
        values = np.union1d(values, temperature[lo : lo + _ROWS])
        if values.size > limit:
            return 0.0
    return quantum(values)


def _steepest_ramp(time: np.ndarray, temperature: np.ndarray, segments: Sequence[slice], window_s: float) -> float | None:
    """Largest |difference of consecutive window means| / window [degC/min] within the segments; None when no segment holds two windows.

    The window sums are taken whole windows at a time, about `_ROWS`
    readings (each window's sum in reading order, as one ``np.bincount``
    of the segment gives it).
    """
    steepest = None
    for seg in segments:
        lo, hi = seg.indices(len(time))[:2]
        if hi - lo < 2 or time[hi - 1] - time[lo] < 2 * window_s:
            continue
        t0 = time[lo]
        n_windows = int(np.floor((time[hi - 1 : hi] - t0) / window_s)[0]) + 1
        sums, counts = np.zeros(n_windows), np.zeros(n_windows, np.int64)
        start = lo
        while start < hi:
            stop, index = _whole_windows(time, start, hi, t0, window_s)
            first = index[0]
            sums[first : index[-1] + 1] += np.bincount(index - first, weights=temperature[start:stop])
            counts[first : index[-1] + 1] += np.bincount(index - first)
            start = stop
        means = sums[counts > 0] / counts[counts > 0]
        rate = float(np.max(np.abs(np.diff(means)))) / window_s * 60.0
        steepest = rate if steepest is None else max(steepest, rate)
    return steepest


def _whole_windows(time: np.ndarray, start: int, hi: int, t0: float, window_s: float) -> tuple[int, np.ndarray]:
    """The end of a run of whole windows from `start` (about `_ROWS` readings; the segment's end `hi` closes the last) and their window index."""
    size = _ROWS
    while True:
        stop = min(hi, start + size)
        index = np.floor((time[start:stop] - t0) / window_s).astype(np.int64)
        if stop == hi:
            return stop, index
        cut = int(np.searchsorted(index, index[-1]))
        if cut:
            return start + cut, index[:cut]
        size *= 2


_ROWS = 1 << 18
"""Readings the coverage checks take at a time (their memory does not grow with the run)."""
