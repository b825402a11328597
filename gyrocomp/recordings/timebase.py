"""The time base of a recording: order and duplicates, the sampling interval, gaps, jitter and resampling.

An interval longer than ``(1 + tolerance)`` times the median is a gap (the
recording becomes several segments, or is refused); one shorter than
``(1 - tolerance)`` times it is jitter. Every per-sample check looks at
:data:`_CHECK_ROWS` samples at a time, so that its temporaries stay small
whatever the recording's length.
"""

from __future__ import annotations

import math
from typing import Callable, Iterator

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.recordings.spec import TIME_UNITS, ColumnSpec, TimeLimits, check_length

_CHECK_ROWS = 1 << 16
"""Samples a per-sample check looks at at a time, so that its temporaries stay this small whatever the recording's length."""


_MEDIAN_ROWS = 1 << 20
"""Intervals the median interval is taken of in one array (8 MiB); a longer time axis is selected a chunk at a time."""


def _check_order(out: dict, spec: ColumnSpec, locate, intervals: tuple[float, float] | None = None) -> tuple[dict, np.ndarray | None, list[str]]:
    """Refuse time going back; refuse or merge (``spec.dedupe``) duplicate stamps.

    `intervals`, the least and the largest interval (:func:`interval_range`),
    lets a time axis whose intervals are all positive pass without a second look.
    Returns the columns, the file row of each kept row (None when all were
    kept) and the notes.
    """
    time = out["time"]
    if intervals is not None and intervals[0] > 0:
        return out, None, []
    back = _where_intervals(time, lambda dt: dt < 0)
    same = _where_intervals(time, lambda dt: dt == 0)
    if back.size and (not same.size or back[0] < same[0] or spec.dedupe is not None):
        i = int(back[0]) + 1
        raise InputError(
            f"{locate(i)}: `{spec.time}` = {float(time[i])!r} goes back from the previous "
            f"time {float(time[i - 1])!r}; time must be strictly increasing"
        )
    if not same.size:
        return out, None, []
    if spec.dedupe is None:
        i = int(same[0]) + 1
        raise InputError(
            f"{locate(i)}: `{spec.time}` = {float(time[i])!r} duplicates the previous time "
            f"{float(time[i - 1])!r}; time must be strictly increasing "
            f"({same.size} duplicate stamps; --dedupe first|mean merges them)"
        )
    starts = np.flatnonzero(np.r_[True, np.diff(time) != 0])
    if spec.dedupe == "first":
        merged = {key: values[starts] for key, values in out.items()}
    else:
        counts = np.diff(np.r_[starts, len(time)])
        merged = {key: np.add.reduceat(values, starts) / counts for key, values in out.items()}
        merged["time"] = time[starts]
    groups = int(np.count_nonzero(np.diff(np.r_[starts, len(time)]) > 1))
    how = "kept the first row" if spec.dedupe == "first" else "averaged the rows"
    note = f"merged {same.size} duplicate time stamps in {groups} places ({how}; --dedupe {spec.dedupe})"
    return merged, starts, [note]


def median_interval(time: np.ndarray) -> float:
    """The median sampling interval [s], ``np.median(np.diff(time))`` (1 for fewer than 2 stamps).

    A time axis longer than :data:`_MEDIAN_ROWS` samples never holds its
    intervals at once (:func:`_interval_rank`): the array of intervals
    would add 8 bytes a sample to a reading's peak.
    """
    if time.size < 2:
        return 1.0
    n = len(time) - 1
    if n <= _MEDIAN_ROWS:
        return _median_inplace(np.diff(time))
    k = n // 2
    if n % 2:
        return float(_interval_rank(time, k)[0])
    low, at_most_low = _interval_rank(time, k - 1)
    high = low if at_most_low > k else _interval_rank(time, k)[0]
    return float((low + high) / 2.0)


def _interval_rank(time: np.ndarray, k: int) -> tuple[np.float64, int]:
    """The `k`-th smallest (0-based) of the intervals ``np.diff(time)``, and how many intervals are at most it.

    Selection by two pivots (Floyd and Rivest's), each pass over the
    intervals :data:`_CHECK_ROWS` at a time: the pivots are the quantiles
    of a strided sample of the intervals still in play, 2 sqrt(size) ranks
    either side of the `k`-th's, so the `k`-th lies between them but few
    others do. A regular time axis (a few distinct intervals) takes one
    pass, a jittered one two; once no more than :data:`_MEDIAN_ROWS` remain
    in play they are gathered and partitioned. Exact: the value is one of
    the intervals, the same as ``np.partition(np.diff(time), k)[k]``.
    """
    n = len(time) - 1
    lo, hi, below, left = -np.inf, np.inf, 0, n  # the k-th lies in (lo, hi); `below` intervals are <= lo, `left` in (lo, hi)
    stride = max(1, n // _CHECK_ROWS)
    while True:
        if left <= _MEDIAN_ROWS:
            inside = np.concatenate(list(_intervals_between(time, lo, hi)))
            value = np.partition(inside, k - below)[k - below]
            return value, below + int(np.count_nonzero(inside <= value))
        start = time[:-1:stride]
        sample = time[1::stride][: len(start)] - start
        sample = np.sort(sample[(sample > lo) & (sample < hi)])
        if not sample.size:  # the sample missed every interval in play: take the first chunk holding one
            sample = np.sort(next(d for d in _intervals_between(time, lo, hi) if d.size))
        q = (k - below) / left * sample.size
        spread = 2.0 * math.sqrt(sample.size)
        a = sample[min(max(int(q - spread), 0), sample.size - 1)]
        b = sample[min(max(int(q + spread), 0), sample.size - 1)]
        below_a = upto_a = below_b = upto_b = 0  # in play and < a, <= a, < b, <= b
        for d in _intervals_between(time, lo, hi):
            below_a += int(np.count_nonzero(d < a))
            upto_a += int(np.count_nonzero(d <= a))
            below_b += int(np.count_nonzero(d < b))
            upto_b += int(np.count_nonzero(d <= b))
        rank = k - below
        if rank < below_a:
            hi, left = a, below_a
        elif rank < upto_a:
            return a, below + upto_a
        elif rank < below_b:
            lo, hi, below, left = a, b, below + upto_a, below_b - upto_a
        elif rank < upto_b:
            return b, below + upto_b
        else:
            lo, below, left = b, below + upto_b, left - upto_b


def _intervals_between(time: np.ndarray, lo: float, hi: float) -> Iterator[np.ndarray]:
    """The intervals ``np.diff(time)`` strictly between `lo` and `hi`, :data:`_CHECK_ROWS` intervals at a time."""
    for start in range(0, len(time) - 1, _CHECK_ROWS):
        d = np.diff(time[start : start + _CHECK_ROWS + 1])
        yield d[(d > lo) & (d < hi)]


def _median_inplace(values: np.ndarray) -> float:
    """``np.median(values)`` without its copy; reorders `values`."""
    n = len(values)
    k = n // 2
    if n % 2:
        values.partition(k)
        return float(values[k])
    values.partition((k - 1, k))
    return float((values[k - 1] + values[k]) / 2.0)


def _check_time_base(time: np.ndarray, nominal: float, src: str, name: str, limits: TimeLimits) -> None:
    """Refuse a time column read as seconds whose rate or span no gyro log has; name the likely unit."""
    span = float(time[-1] - time[0])
    day = 86400.0

    def plausible(factor: float) -> bool:
        fs = 1.0 / (nominal * factor)
        return limits.min_fs_hz <= fs <= limits.max_fs_hz and span * factor <= limits.max_span_days * day

    if plausible(1.0):
        return
    fitting = [unit for unit in ("ms", "us", "ns") if plausible(TIME_UNITS[unit])]
    # the likeliest unit gives the rate nearest (in decades) to a typical gyro log's
    fitting.sort(key=lambda unit: abs(math.log10(1.0 / (nominal * TIME_UNITS[unit]) / limits.typical_fs_hz)))
    if fitting:
        likely = f"it looks like {_UNIT_WORDS[fitting[0]]}: pass --time-unit {fitting[0]}"
        if len(fitting) > 1:
            likely += f" ({' or '.join(fitting[1:])} would also fit)"
    else:
        likely = "pass --time-unit"
    raise InputError(
        f"{name}: `{src}` read as seconds gives {1.0 / nominal:.3g} Hz over {span / day:.3g} days, "
        f"which no gyro log has; {likely}, or --time-unit s to keep seconds"
    )


_UNIT_WORDS = {"ms": "milliseconds (ms)", "us": "microseconds (µs, us)", "ns": "nanoseconds (ns)"}


def _segments(
    out: dict,
    nominal: float,
    src: str,
    locate,
    tolerance: float,
    resample: bool,
    allow_gaps: bool,
    open_ends: tuple[bool, bool] = (False, False),
    first_segment: int = 0,
    intervals: tuple[float, float] | None = None,
):
    """Segments of a time axis, or its uniform resampling; refuse what neither allows.

    An interval longer than ``(1 + tolerance)`` times the median is a gap;
    one shorter than ``(1 - tolerance)`` times it is jitter. `intervals`,
    the least and the largest interval (:func:`interval_range`), lets a
    time axis with neither pass without a second look.

    Returns
    -------
    out : dict
        The columns (resampled when asked).
    segments : list of slice
    notes : list of str
    """
    time = out["time"]
    n = len(time)
    if n < 2:
        return out, [slice(0, n)], []
    slack = 1e-9 * nominal  # an interval exactly at the tolerance (ms stamps: 10 or 30 ms at 20 ms) is within it
    if intervals is not None and (1.0 - tolerance) * nominal - slack <= intervals[0] and intervals[1] <= (1.0 + tolerance) * nominal + slack:
        return out, [slice(0, n)], []
    short = _where_intervals(time, lambda dt: dt < (1.0 - tolerance) * nominal - slack)
    long = _where_intervals(time, lambda dt: dt > (1.0 + tolerance) * nominal + slack)

    def dt(i: np.ndarray) -> np.ndarray:
        return time[i + 1] - time[i]
    if not short.size and not long.size:
        return out, [slice(0, n)], []
    if resample:
        note = (
            f"resampled onto a uniform {nominal:.6g} s grid: {long.size} gaps filled by linear "
            f"interpolation, the longest {float(dt(long).max()):.6g} s"
            if long.size
            else f"resampled onto a uniform {nominal:.6g} s grid: no gap, {short.size} short intervals"
        )
        out = _resample(out, nominal, src, locate)
        return out, [slice(0, len(out["time"]))], [note]
    if short.size or not allow_gaps:
        candidates = short if allow_gaps else np.r_[short, long]
        worst = int(candidates[np.argmax(np.abs(dt(candidates) - nominal))])
        raise InputError(
            f"{locate(worst + 1)}: sampling interval {float(time[worst + 1] - time[worst]):.6g} s in `{src}`, the median is "
            f"{nominal:.6g} s (tolerance {tolerance:.0%}); pass --resample to interpolate onto a uniform grid"
        )
    bounds = np.r_[0, long + 1, n]
    lengths = np.diff(bounds)
    if open_ends[0]:  # a chunk's first or last segment may go on in its neighbours
        lengths[0] = 2
    if open_ends[1]:
        lengths[-1] = 2
    check_segment_lengths(lengths, bounds[:-1], time, nominal, src, locate, first_segment)
    segments = [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
    return out, segments, [gap_note(long.size, float(dt(long).max()))]


def check_segment_lengths(lengths: np.ndarray, starts: np.ndarray, time: np.ndarray, nominal: float, src: str, locate, first_segment: int = 0) -> None:
    """Refuse a segment of one sample: no interval, no rate, nothing a command can use.

    Several in a row are a change of sample rate read as gaps (10 Hz, then
    2 Hz against the 0.1 s of the start), which no segment list describes.

    Parameters
    ----------
    lengths, starts : numpy.ndarray
        Samples in each segment and the index (into `time`) of its first.
    time : numpy.ndarray
        The time [s] those indices point into.
    nominal : float
        The sampling interval [s] the gaps were judged against.
    first_segment : int
        Number (0-based) of the first of these segments in the whole file.
    """
    alone = np.flatnonzero(lengths == 1)
    if not alone.size:
        return
    k = int(alone[0])
    i = int(starts[k])
    facts = [f"`{src}` = {float(time[i])!r}"]
    if i > 0:
        facts.append(f"{float(time[i] - time[i - 1]):.6g} s after the previous sample")
    facts.append(f"{float(time[i + 1] - time[i]):.6g} s before the next" if i + 1 < len(time) else "the last sample")
    change = "; the sample rate changes here" if k + 1 < len(lengths) and lengths[k + 1] == 1 else ""
    raise InputError(
        f"{locate(i)}: segment {first_segment + k + 1} is one sample ({', '.join(facts)}; the interval is {nominal:.6g} s){change}; "
        "drop it, or pass --resample to interpolate onto a uniform grid"
    )


def gap_note(n_gaps: int, longest_s: float) -> str:
    """The note on a recording's gaps: the segments, the gaps and the longest [s]."""
    return f"{n_gaps + 1} segments: {n_gaps} gaps, the longest {longest_s:.6g} s (not interpolated)"


def _resample(columns: dict[str, np.ndarray], interval: float, src: str = "time", locate=None) -> dict[str, np.ndarray]:
    time = columns["time"]
    n = math.floor((time[-1] - time[0]) / interval + 1e-9) + 1
    where = f"{locate(len(time) - 1).rsplit(' ', 2)[0]}: " if locate is not None else ""
    check_length("resample_max_samples", n, f"{where}--resample onto a {interval:.6g} s grid over {time[-1] - time[0]:.6g} s of `{src}`")
    grid = time[0] + interval * np.arange(n)
    return {key: (grid if key == "time" else np.interp(grid, time, values)) for key, values in columns.items()}


def interval_range(time: np.ndarray) -> tuple[float, float]:
    """The least and the largest interval ``np.diff(time)``, :data:`_CHECK_ROWS` at a time (NaN when one is NaN; inf, -inf for fewer than 2 stamps).

    One pass that clears a regular time axis of every per-interval check
    (:func:`_check_order`, :func:`_segments`); only an axis it does not
    clear is looked at interval by interval, for the message.
    """
    least, largest = math.inf, -math.inf
    for start in range(0, len(time) - 1, _CHECK_ROWS):
        d = np.diff(time[start : start + _CHECK_ROWS + 1])
        low, high = d.min(), d.max()
        if math.isnan(low) or math.isnan(high):
            return math.nan, math.nan
        least, largest = min(least, float(low)), max(largest, float(high))
    return least, largest


def _where_intervals(time: np.ndarray, test: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Indices ``i`` where `test` holds for the interval ``time[i + 1] - time[i]``, :data:`_CHECK_ROWS` at a time.

    Same as ``np.flatnonzero(test(np.diff(time)))``, without a full-length
    array of intervals.
    """
    n = len(time) - 1
    hits = [start + np.flatnonzero(test(np.diff(time[start : start + _CHECK_ROWS + 1]))) for start in range(0, n, _CHECK_ROWS)]
    return np.concatenate(hits) if hits else np.empty(0, dtype=np.intp)
