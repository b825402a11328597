"""A table as a recording: :func:`recording_from_frame` and its checks of columns and cells.

The checks run in this order, each its own function: columns present
(:func:`_select_columns`), cells numeric and finite and converted
(:func:`_time_seconds`, :func:`_numeric_column`), axes and temperature
plausible (:func:`_check_axis`, :func:`_check_temperature`), then the
time base (:mod:`gyrocomp.recordings.timebase`). Each refuses with one
:class:`~gyrocomp.errors.InputError` line naming the file, row and column.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import numpy as np

from gyrocomp.artefacts import file_sha256
from gyrocomp.columns import matching_columns
from gyrocomp.errors import InputError, RecordingNote
from gyrocomp.recordings.recording import Recording
from gyrocomp.recordings.spec import ACCELERATION_UNITS, PLAUSIBLE_DEGC, RATE_UNITS, TIME_UNITS, AxisLimits, Channel, ColumnSpec, TimeLimits
from gyrocomp.recordings.timebase import _CHECK_ROWS, _check_order, _check_time_base, _segments, interval_range, median_interval

if TYPE_CHECKING:  # pandas is imported where a function needs it: the Parquet path of a recording never does
    import pandas as pd

def recording_from_frame(
    frame: pd.DataFrame | Mapping[str, np.ndarray],
    *,
    name: str = "<table>",
    sha256: str | None = None,
    columns: ColumnSpec = ColumnSpec(),
    require_temperature: bool = False,
    min_samples: int = 2,
    jitter_tolerance: float = 0.5,
    resample: bool = False,
    allow_gaps: bool = False,
    metadata: dict | None = None,
    limits: TimeLimits = TimeLimits(),
    _where: tuple[str, int] = ("row", 1),
    _owned: bool = False,
    _views: bool = False,
    _gap_note: bool = True,
    _interval: float | None = None,
    _open_ends: tuple[bool, bool] = (False, False),
    _first_segment: int = 0,
) -> Recording:
    """Validate an in-memory table as a recording (see :func:`read_recording`).

    `frame` is a pandas DataFrame or a mapping of column name to 1-D
    integer or float NumPy array (validated without importing pandas).
    `sha256` defaults to the hash of the table's CSV form. Time and axes are
    copies (the private `_owned` says `frame` is a throw-away of
    :func:`read_recording`, whose own columns are then reused; the private
    `_views` keeps them as the views of `frame` they are, read-only ones
    too: a chunk its reader's caller only reads,
    :func:`gyrocomp.streaming.read_chunks` with ``writable=False``). The private
    `_gap_note` false leaves the note on gaps out: a chunk of a file whose
    reader reports the gaps of the whole file once (:mod:`gyrocomp.streaming`).
    The private `_interval` is the sampling interval [s] of the stream a
    chunk belongs to (its first chunk's median): gaps and jitter are judged
    against it, not against the chunk's own median, so a chunk where the
    rate changes is judged as the whole file is. The private `_open_ends`
    says whether the first and the last segment may go on in the chunks
    before and after (their length is then the streamed reader's to check), and
    `_first_segment` the number, in the whole file, of its first segment
    (0-based), for messages.

    The checks run in this order, each its own function: columns present
    (:func:`_select_columns`), cells numeric and finite and converted
    (:func:`_time_seconds`, :func:`_numeric_column`), temperature plausible,
    enough samples, time increasing or duplicates merged
    (:func:`_check_order`), time base plausible (:func:`_check_time_base`),
    then gaps and jitter (:func:`_segments`).
    """
    where, first = _where
    rows = None  # file row of each kept row, once duplicates are merged

    def locate(i: int) -> str:
        row = int(i) if rows is None else int(rows[i])
        return f"{name} {where} {row + first}"

    arrays = isinstance(frame, Mapping)
    names = [str(c) for c in (list(frame) if arrays else list(frame.columns))]
    n_rows = (len(next(iter(frame.values()))) if frame else 0) if arrays else len(frame)
    if n_rows == 0:
        raise InputError(f"{name}: has a header but no data rows")
    chosen = _select_columns(names, columns, name, require_temperature)
    time, origin = _time_seconds(frame[columns.time], columns, locate, _owned, _views)
    out = {"time": time}
    axes = []
    for (src, unit) in chosen["axes"]:
        quantity, canonical, factor = _unit_of(unit)
        values = _numeric_column(frame[src], src, locate)
        out[src] = _own(values, _owned, _views) if factor == 1.0 else values * factor
        _check_axis(out[src], src, canonical, unit, factor, locate)
        axes.append(Channel(src, src, quantity, canonical, unit))
    temperatures = []
    for k, src in enumerate(chosen["temperatures"]):
        key = "temperature" if k == 0 else src
        values = _numeric_column(frame[src], src, locate)
        out[key] = values - 273.15 if columns.temperature_unit == "K" else values
        _check_temperature(out[key], src, locate)
        temperatures.append(key)
    used = {columns.time, *out, *chosen["temperatures"]}
    for extra in names:
        if extra not in used:
            col = _numeric_extra(frame[extra])
            if col is not None:
                out[extra] = col
    n = len(out["time"])
    if n < min_samples:
        raise InputError(f"{name}: {n} samples, this command needs at least {min_samples}")
    intervals = interval_range(out["time"])
    out, rows, notes = _check_order(out, columns, locate, intervals)
    n = len(out["time"])
    if n < min_samples:
        raise InputError(f"{name}: {n} samples once duplicates are merged, this command needs at least {min_samples}")
    if rows is not None:  # rows merged: other intervals
        intervals = interval_range(out["time"])
    nominal = median_interval(out["time"]) if _interval is None else _interval
    if columns.time_unit is None and origin is None and _interval is None:  # numbers read as seconds, not datetimes
        _check_time_base(out["time"], nominal, columns.time, name, limits)
    out, segments, filled = _segments(
        out, nominal, columns.time, locate, jitter_tolerance, resample, allow_gaps, _open_ends, _first_segment, intervals
    )
    if _gap_note or len(segments) == 1:
        notes.extend(filled)
    for note in notes:
        warnings.warn(f"{name}: {note}", RecordingNote, stacklevel=2)
    if sha256 is None:
        import pandas as pd

        table = pd.DataFrame(frame, copy=False) if arrays else frame
        sha256 = file_sha256(table.to_csv(index=False).encode())
    return Recording(
        data=out,
        name=name,
        sha256=sha256,
        fs_hz=1.0 / nominal,
        metadata=metadata or {},
        axes=axes,
        temperatures=temperatures,
        segments=segments,
        notes=notes,
        time_origin=origin,
    )


def _select_columns(names: Sequence[str], spec: ColumnSpec, name: str, require_temperature: bool) -> dict:
    """The file columns of the axes (with their units) and temperatures; refuse missing ones."""
    missing = [] if spec.time in names else [spec.time]
    temperatures: list[str] = []
    for pattern in spec.temperature_patterns:
        temperatures.extend(c for c in matching_columns(names, pattern) if c != spec.time and c not in temperatures)
    if require_temperature and not temperatures:
        missing.append(spec.temperature_patterns[0])
    units = spec.rate_units * len(spec.rate_patterns) if len(spec.rate_units) == 1 else spec.rate_units
    axes: dict[str, str] = {}
    for pattern, unit in zip(spec.rate_patterns, units):
        found = [c for c in matching_columns(names, pattern) if c != spec.time and c not in temperatures]
        if not found:
            missing.append(pattern)
        for c in found:
            axes.setdefault(c, unit)
    if missing:
        hint = ""
        if any(m in spec.temperature_patterns for m in missing):
            hint = " (map it with --temp-col)"
        if len(names) == 1 and any(s in names[0] for s in ";\t|"):
            hint = " (one column only: is the separator another one? pass --sep)"
        what = "no column matches" if any(_is_glob(m) for m in missing) else "missing column"
        raise InputError(
            f"{name}: {what} {', '.join(repr(m) for m in missing)}{hint}; "
            f"the file has {', '.join(repr(c) for c in names)}"
        )
    return {"axes": list(axes.items()), "temperatures": temperatures}


def _unit_of(unit: str) -> tuple[str, str, float]:
    """Quantity, recording unit and conversion factor of an axis unit."""
    if unit in RATE_UNITS:
        return "angular_rate", "deg/s", RATE_UNITS[unit]
    return "acceleration", "m/s^2", ACCELERATION_UNITS[unit]


def _time_seconds(series, spec: ColumnSpec, locate, owned: bool, views: bool = False) -> tuple[np.ndarray, str | None]:
    """The time column in seconds, and what its 0 is when it was converted.

    Seconds are kept as they are (origin None). Any other unit becomes
    seconds since the first stamp, the origin saying what that stamp was
    (``"2024-03-07T15:45:00+00:00"``, ``"1700000000000000 us"``): integer
    stamps are differenced as integers first, so no digit of a µs or ns
    epoch is lost to float64.
    """
    unit = spec.time_unit
    if unit == "datetime" or (unit is None and _is_text(series) and not _has_numbers(series)):
        return _datetime_seconds(series, spec.time, locate)
    factor = TIME_UNITS[unit or "s"]
    raw = series if isinstance(series, np.ndarray) else (None if _is_text(series) else series.to_numpy())
    if factor != 1.0 and raw is not None and raw.dtype.kind in "iu":
        start = raw[0]
        return _signed_difference(raw, start).astype(float) * factor, f"{int(start)} {unit}"
    values = _numeric_column(series, spec.time, locate)
    if factor == 1.0:
        return _own(values, owned, views), None
    start = float(values[0])
    return (values - start) * factor, f"{start!r} {unit}"


def _signed_difference(raw: np.ndarray, start) -> np.ndarray:
    """``raw - start`` of integer stamps as signed integers: unsigned ones (PX4's µs) that reset below `start` go negative, not round the 2**64 wheel."""
    if raw.dtype.kind == "u":
        if raw.dtype.itemsize < 8:
            return raw.astype(np.int64) - np.int64(start)
        return (raw - start).view(np.int64)  # the two's complement of the wrapped difference: exact while |difference| < 2**63
    return raw - start


def _datetime_seconds(series, src: str, locate) -> tuple[np.ndarray, str]:
    import pandas as pd

    series = pd.Series(series) if isinstance(series, np.ndarray) else series
    stamps = pd.to_datetime(series, format="ISO8601", errors="coerce", utc=True)
    bad = stamps.isna().to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{locate(i)}: `{src}` = {series.iloc[i]!r} is not an ISO 8601 date and time")
    seconds = (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy()
    return seconds, stamps.iloc[0].isoformat()


def _numeric_column(series: pd.Series | np.ndarray, src: str, locate) -> np.ndarray:
    """A column as finite float64 values; a NumPy column must be integer or float."""
    if isinstance(series, np.ndarray):
        values = series.astype(float, copy=False)
    else:
        import pandas as pd

        if series.dtype == object or pd.api.types.is_string_dtype(series.dtype):
            values = pd.to_numeric(series, errors="coerce")
            bad = values.isna() & series.notna()
            if bad.any():
                i = int(np.flatnonzero(bad.to_numpy())[0])
                raise InputError(f"{locate(i)}: `{src}` = {series.iloc[i]!r} is not a number")
            series = values
        if not pd.api.types.is_numeric_dtype(series.dtype) or pd.api.types.is_bool_dtype(series.dtype):
            raise InputError(f"{locate(0)}: `{src}` is not numeric (type {series.dtype})")
        values = series.to_numpy(dtype=float)
    if math.isfinite(values.sum()):  # NaN and infinity carry into a sum: every value is finite, found in one pass
        return values
    bad = _where(values, lambda v: ~np.isfinite(v))
    if bad.size:
        i = int(bad[0])
        what = "missing or NaN" if np.isnan(values[i]) else f"{float(values[i])!r}"
        raise InputError(f"{locate(i)}: `{src}` is {what}")
    return values


def _numeric_extra(series: pd.Series | np.ndarray) -> np.ndarray | None:
    """A further column as float64 when every cell is a number (infinity included), else None."""
    if isinstance(series, np.ndarray):
        values = series.astype(float, copy=False)
        return None if math.isnan(values.sum()) and _where(values, np.isnan).size else values
    import pandas as pd

    col = pd.to_numeric(series, errors="coerce")
    return col.to_numpy(dtype=float) if col.notna().all() else None


def _check_axis(values: np.ndarray, src: str, canonical: str, unit: str, factor: float, locate) -> None:
    """Refuse an axis reading beyond :class:`AxisLimits` (in the file's unit)."""
    bound = AxisLimits().bound(canonical)
    if not values.size or -bound <= values.min() and values.max() <= bound:  # two passes, no temporaries
        return
    outside = _where(values, lambda v: np.abs(v) > bound)
    if outside.size:
        i = int(outside[0])
        raise InputError(
            f"{locate(i)}: `{src}` = {values[i] / factor:g} {unit} is beyond +-{bound / factor:g} {unit}, "
            "more than any sensor reads (configs/recordings.toml [axes]); a corrupt cell or the wrong --rate-unit?"
        )


def _check_temperature(temperature: np.ndarray, src: str, locate) -> None:
    lo, hi = PLAUSIBLE_DEGC
    if not temperature.size or lo <= temperature.min() and temperature.max() <= hi:
        return
    outside = _where(temperature, lambda t: (t < lo) | (t > hi))
    if outside.size:
        i = int(outside[0])
        raise InputError(
            f"{locate(i)}: `{src}` = {temperature[i]:g} degC is outside "
            f"[{lo:g}, {hi:g}] degC; wrong unit? (pass --temp-unit K for kelvin)"
        )


def _where(values: np.ndarray, test: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Indices where the element-wise `test` holds, evaluated :data:`_CHECK_ROWS` samples at a time.

    Same as ``np.flatnonzero(test(values))``, without its temporaries the
    size of the whole column.
    """
    hits = [start + np.flatnonzero(test(values[start : start + _CHECK_ROWS])) for start in range(0, len(values), _CHECK_ROWS)]
    return np.concatenate(hits) if hits else np.empty(0, dtype=np.intp)


def _own(values: np.ndarray, owned: bool, views: bool = False) -> np.ndarray:
    """`values` as a writable array the recording may keep, or as it is when `views`.

    Reused when `owned` and the memory under it is this column alone (a
    column of a throw-away frame, of which pandas hands out a read-only
    view); otherwise copied, so the recording neither aliases a caller's
    table nor keeps a 2-D block of other columns alive.
    """
    if views:
        return values
    base = values
    while isinstance(base.base, np.ndarray):
        base = base.base
    if owned and base.size == values.size:
        with contextlib.suppress(ValueError):  # memory numpy may not make writable: copy below
            values.setflags(write=True)
            return values
    return values.copy()


def _is_text(series) -> bool:
    if isinstance(series, np.ndarray):
        return series.dtype.kind in "OUS"
    import pandas as pd

    return series.dtype == object or pd.api.types.is_string_dtype(series.dtype)


def _has_numbers(series) -> bool:
    """Whether any cell of a text column reads as a number (then it is a numeric column with a bad cell)."""
    import pandas as pd

    return bool(pd.to_numeric(pd.Series(series), errors="coerce").notna().any())


def _is_glob(pattern: str) -> bool:
    return any(ch in pattern for ch in "*?[")
