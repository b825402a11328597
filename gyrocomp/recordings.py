"""Recordings in: reading, unit conversion and validation.

A *recording* is a table of ``time`` [s], one or more sensor axes (angular
rate in deg/s, or acceleration in m/s^2), kept under their own column
names, and, where the command needs it, one or more temperatures [degC].
It is read from CSV (compressed by extension: ``.gz``, ``.bz2``, ``.xz``,
``.zst``, ``.zip``; any separator and decimal mark), Parquet, a PX4 ULog
(``.ulg``) or an ArduPilot DataFlash log (``.bin``, see
:mod:`gyrocomp.flightlogs`); ``-`` reads CSV from standard input. Which
columns are which, and their units, is a :class:`ColumnSpec`.

Everything wrong with a recording raises :class:`~gyrocomp.errors.InputError`
naming the file, and the line (CSV) or row (Parquet, logs) and column:
nothing is guessed silently. A time column without a declared unit is read
as seconds only when the sample rate and span that implies are those of a
gyro log (:class:`TimeLimits`); otherwise the message names the likely
unit. Duplicate time stamps are refused unless merged (``dedupe``). A
recording with gaps is a list of :attr:`Recording.segments`, never
interpolated unless asked (``resample``), and then :attr:`Recording.notes`
says what was filled; every note is also issued as a
:class:`~gyrocomp.errors.RecordingNote` warning, which the command line
prints.

For a command that handles one axis, :meth:`Recording.axis` gives that axis
as a one-axis recording whose column is ``rate``; :meth:`Recording.split`
gives one recording per segment.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fnmatch
import io as _stdio
import json
import math
import os
import re
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Mapping, Sequence

import numpy as np

from gyrocomp.artefacts import file_sha256, parquet_header
from gyrocomp.columns import matching_columns
from gyrocomp.errors import InputError, RecordingNote

if TYPE_CHECKING:  # pandas is imported where a function needs it: the Parquet path of a recording never does
    import pandas as pd

__all__ = [
    "ColumnSpec",
    "Channel",
    "Recording",
    "TimeLimits",
    "AxisLimits",
    "PLAUSIBLE_DEGC",
    "read_recording",
    "read_recordings",
    "check_distinct",
    "LengthLimits",
    "length_limits",
    "check_length",
    "check_training_range",
    "TemperatureLimits",
    "recording_from_frame",
    "RATE_UNITS",
    "ACCELERATION_UNITS",
    "TIME_UNITS",
]

STANDARD_GRAVITY = 9.80665
"""m/s^2 per g (CGPM 1901, the value of g_n in the SI brochure)."""

RATE_UNITS = {"deg/s": 1.0, "deg/h": 1.0 / 3600.0, "rad/s": 180.0 / math.pi}
"""Factors that convert an angular-rate unit to deg/s."""

ACCELERATION_UNITS = {"m/s^2": 1.0, "m/s2": 1.0, "g": STANDARD_GRAVITY}
"""Factors that convert an acceleration unit to m/s^2."""

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "datetime": None}
"""Factors that convert a numeric time unit to seconds; ``datetime`` is parsed by pandas."""

TEMPERATURE_UNITS = ("degC", "K")

_SEPARATOR_WORDS = {"\\t": "\t", "tab": "\t", "\\s+": "\\s+"}
"""Separators spelled out as words or escapes on a command line."""

COMPRESSIONS = (".gz", ".bz2", ".xz", ".zst", ".zip")
"""Extensions of compressed CSV, decompressed by pandas."""

PLAUSIBLE_DEGC = (-100.0, 200.0)
"""Temperatures outside this range are refused as a probable unit mistake."""

_CHECK_ROWS = 1 << 16
"""Samples a per-sample check looks at at a time, so that its temporaries stay this small whatever the recording's length."""

_MEDIAN_ROWS = 1 << 20
"""Intervals the median interval is taken of in one array (8 MiB); a longer time axis is selected a chunk at a time."""


def _entries(value: str | Sequence[str]) -> tuple[str, ...]:
    """The comma-separated entries of an option (or the items of a sequence), stripped."""
    items = value.split(",") if isinstance(value, str) else list(value)
    return tuple(s.strip() for s in items if s.strip())


@dataclasses.dataclass(frozen=True)
class TimeLimits:
    """Sample rates and spans a gyro log has (``configs/recordings.toml``, ``[time]``).

    A time column read as seconds without ``--time-unit`` must give a
    sample rate in [`min_fs_hz`, `max_fs_hz`] and a span of at most
    `max_span_days`; otherwise it is refused, naming the unit that would
    fit (a µs ``timestamp`` read as seconds gives 1e-4 Hz at 100 Hz).

    Parameters
    ----------
    min_fs_hz : float, default=0.01
        One sample per 100 s: slower than any rate logger.
    max_fs_hz : float, default=1e5
        Above the fastest MEMS gyro output data rate (32 kHz).
    max_span_days : float, default=30
        Longer than any oven or Allan run (12-72 h).
    typical_fs_hz : float, default=100
        When several units would fit, the one giving the rate nearest to
        this (in decades) is named first.
    """

    min_fs_hz: float = 0.01
    max_fs_hz: float = 1e5
    max_span_days: float = 30.0
    typical_fs_hz: float = 100.0


@dataclasses.dataclass(frozen=True)
class AxisLimits:
    """Largest magnitude a sensor axis can read (``configs/recordings.toml``, ``[axes]``).

    A larger value is a corrupt cell or a unit mistake, refused naming the
    file, the row and the column (a ±1e300 rate overflows every statistic).

    Parameters
    ----------
    max_abs_deg_s : float, default=1e5
        Angular rate [deg/s]: 25x the widest MEMS gyro full scale (±4000 deg/s).
    max_abs_m_s2 : float, default=1e5
        Acceleration [m/s^2], about 10 000 g: 25x the widest IMU accelerometer
        full scale (±400 g).
    """

    max_abs_deg_s: float = 1e5
    max_abs_m_s2: float = 1e5

    def bound(self, unit: str) -> float:
        """The bound of a recording unit (``deg/s`` or ``m/s^2``)."""
        return self.max_abs_deg_s if unit == "deg/s" else self.max_abs_m_s2


@dataclasses.dataclass(frozen=True)
class ColumnSpec:
    """How to find, parse and convert the columns of a recording.

    Parameters
    ----------
    time : str, default="time"
        Name of the time column.
    rate : str, default="rate"
        The sensor axes: one name, comma-separated names (``"gx,gy,gz"``)
        or shell globs (``"gyro_*"``, ``"IMU_0_Gyr?"``), matched in the
        file's column order; the time and temperature columns never match a
        glob. The axes keep these names in every output.
    temperature : str, default="temperature"
        Temperature column(s), same syntax; the first is *the* temperature
        (column ``temperature`` of the recording), any others keep their
        names.
    time_unit : {None, "s", "ms", "us", "ns", "datetime"}, default=None
        Unit of the time column. ``None`` reads numbers as seconds, refused
        when implausible (:class:`TimeLimits`), and ISO 8601 text as
        datetimes; an explicit unit skips the plausibility check.
    rate_unit : str, default="deg/s"
        Unit of the axes: an angular rate (``deg/s``, ``deg/h``, ``rad/s``,
        converted to deg/s) or an acceleration (``m/s^2``, ``g``, converted
        to m/s^2). One unit for every axis, or comma-separated, one per
        entry of `rate` (``"deg/s,g"`` with ``rate="gyro_*,acc_*"``).
    temperature_unit : {"degC", "K"}, default="degC"
        Unit of the temperature column(s).
    sep : str, default=","
        CSV field separator (``";"``, a tab as ``"\\t"`` or ``"tab"``,
        ``"\\s+"`` for runs of blanks, ...).
    decimal : str, default="."
        CSV decimal mark (``","`` for decimal-comma files).
    dedupe : {None, "first", "mean"}, default=None
        Duplicate time stamps: refused (``None``), or merged keeping the
        first row or the mean of the rows.
    """

    time: str = "time"
    rate: str = "rate"
    temperature: str = "temperature"
    time_unit: str | None = None
    rate_unit: str = "deg/s"
    temperature_unit: str = "degC"
    sep: str = ","
    decimal: str = "."
    dedupe: str | None = None

    def __post_init__(self):
        for option, value, choices in (
            ("time unit", self.time_unit, (None, *TIME_UNITS)),
            ("temperature unit", self.temperature_unit, TEMPERATURE_UNITS),
            ("dedupe", self.dedupe, (None, "first", "mean")),
        ):
            if value not in choices:
                raise InputError(f"unknown {option} {value!r}; choose one of {', '.join(c for c in choices if c)}")
        for unit in self.rate_units:
            if unit not in RATE_UNITS and unit not in ACCELERATION_UNITS:
                raise InputError(f"unknown rate unit {unit!r}; choose one of {', '.join([*RATE_UNITS, *ACCELERATION_UNITS])}")
        if len(self.rate_units) not in (1, len(self.rate_patterns)):
            raise InputError(
                f"--rate-unit {self.rate_unit!r}: give one unit, or one per --rate-col entry ({len(self.rate_patterns)})"
            )
        if not self.rate_patterns:
            raise InputError("--rate-col: no column named")
        if len(self.sep) != 1 and self.sep not in _SEPARATOR_WORDS:
            raise InputError(f"--sep {self.sep!r}: give one character, or one of {', '.join(_SEPARATOR_WORDS)}")
        if len(self.decimal) != 1 or self.decimal == self.sep:
            raise InputError(f"--decimal {self.decimal!r}: give one character other than the separator")

    @property
    def rate_patterns(self) -> tuple[str, ...]:
        """The entries of `rate` (names or globs)."""
        return _entries(self.rate)

    @property
    def rate_units(self) -> tuple[str, ...]:
        """The entries of `rate_unit`."""
        return _entries(self.rate_unit)

    @property
    def temperature_patterns(self) -> tuple[str, ...]:
        """The entries of `temperature` (names or globs)."""
        return _entries(self.temperature)


@dataclasses.dataclass(frozen=True)
class Channel:
    """One sensor axis of a recording.

    Parameters
    ----------
    name : str
        The axis' name: its column in the file, kept in every output.
    column : str
        Its column in :attr:`Recording.data`: `name`, or ``rate`` in the
        one-axis recording of :meth:`Recording.axis`.
    quantity : {"angular_rate", "acceleration"}
    unit : {"deg/s", "m/s^2"}
        Unit of the recording's values.
    file_unit : str
        Unit in the file, converted to `unit`.
    """

    name: str
    column: str
    quantity: str
    unit: str
    file_unit: str


class Recording:
    """A validated recording.

    Parameters
    ----------
    data : pandas.DataFrame or mapping of str to numpy.ndarray
        ``time`` [s] (strictly increasing, uniform within the tolerance in
        each segment), one column per axis (:attr:`axes`), ``temperature``
        [degC] when present (and any further temperatures by name), and any
        further numeric columns of the file unchanged, as a frame or as one
        1-D array per column (kept as given, not copied).
    name : str
        The file's name (``"-"`` for standard input), used in messages.
    sha256 : str
        SHA-256 of the file's bytes.
    fs_hz : float
        Sample rate, from the median sampling interval.
    metadata : dict, optional
        The ``gyrocomp`` metadata of a Parquet file written by this tool
        (the simulator stores its truth there); for one stream of a flight
        log (:func:`read_recordings`), ``stream``, its key (``sensor_gyro_0``),
        ``autopilot``, ``instance`` and PX4's ``device_id``; else empty.
    axes : sequence of Channel, optional
        The sensor axes; default one angular rate in column ``rate``.
    temperatures : sequence of str, optional
        Temperature columns, ``temperature`` first; default ``temperature``
        when the data has it.
    segments : sequence of slice, optional
        Row ranges sampled without a gap (default: one, all rows).
    notes : sequence of str, optional
        What reading changed (merged duplicates, filled gaps), one line each.
    time_origin : str, optional
        What ``time`` = 0 was in the file when its time stamps were not in
        seconds: an ISO 8601 date and time, or the first stamp and its unit
        (``"1700000000000000 us"``).

    Notes
    -----
    A recording built from arrays makes its :attr:`data` frame (and
    imports pandas) only when asked; from then on the frame is the
    recording's content, so changes made through it are what
    :meth:`column` and the properties return.
    """

    def __init__(
        self,
        data: pd.DataFrame | Mapping[str, np.ndarray],
        name: str,
        sha256: str,
        fs_hz: float,
        metadata: dict | None = None,
        *,
        axes: Sequence[Channel] | None = None,
        temperatures: Sequence[str] | None = None,
        segments: Sequence[slice] | None = None,
        notes: Sequence[str] = (),
        time_origin: str | None = None,
    ):
        self._frame = None
        self._arrays = None
        if isinstance(data, Mapping):
            self._arrays = dict(data)
        else:
            self._frame = data
        self.name = name
        self.sha256 = sha256
        self.fs_hz = fs_hz
        self.metadata = {} if metadata is None else metadata
        self.axes = tuple(axes) if axes is not None else (Channel("rate", "rate", "angular_rate", "deg/s", "deg/s"),)
        if temperatures is None:
            temperatures = ("temperature",) if "temperature" in self.columns else ()
        self.temperatures = tuple(temperatures)
        self.segments = tuple(segments) if segments is not None else (slice(0, self.n_samples),)
        self.notes = tuple(notes)
        self.time_origin = time_origin

    def __repr__(self) -> str:
        return (
            f"Recording(name={self.name!r}, axes={self.axis_names!r}, fs_hz={self.fs_hz!r}, "
            f"segments={len(self.segments)})"
        )

    @property
    def data(self) -> pd.DataFrame:
        """The columns as a pandas DataFrame (built once, sharing the arrays' memory)."""
        if self._frame is None:
            import pandas as pd

            self._frame = pd.DataFrame(self._arrays, copy=False)  # one block per column: no 2-D stacking copy
            self._arrays = None
        return self._frame

    @data.setter
    def data(self, frame: pd.DataFrame) -> None:
        self._frame, self._arrays = frame, None

    @property
    def columns(self) -> list[str]:
        """Column names, in order."""
        if self._frame is not None:
            return [str(c) for c in self._frame.columns]
        return list(self._arrays)

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return len(self.column("time"))

    def column(self, name: str) -> np.ndarray:
        """One column as a NumPy array (a view, not a copy, where possible).

        Raises
        ------
        KeyError
            No such column.
        """
        if self._frame is not None:
            return self._frame[name].to_numpy()
        return self._arrays[name]

    @property
    def axis_names(self) -> tuple[str, ...]:
        """The axes' names, in order (the names outputs keep)."""
        return tuple(a.name for a in self.axes)

    def axis(self, name: str | None = None) -> Recording:
        """One axis as a one-axis recording, its values in column ``rate``.

        Time, temperatures, segments, notes and the other non-axis columns
        are shared (no copy); :attr:`axes` holds the one channel, still
        under its own `name`.

        Parameters
        ----------
        name : str, optional
            The axis; may be omitted when the recording has one.

        Raises
        ------
        InputError
            No such axis, or several and no `name`.
        """
        if name is None:
            if len(self.axes) != 1:
                raise InputError(
                    f"{self.name}: {len(self.axes)} axes ({', '.join(self.axis_names)}); "
                    f"this command takes one: pick it with --rate-col"
                )
            channel = self.axes[0]
        else:
            found = [a for a in self.axes if a.name == name]
            if not found:
                raise InputError(f"{self.name}: no axis {name!r}; the axes are {', '.join(self.axis_names)}")
            channel = found[0]
        others = {a.column for a in self.axes}
        arrays = {"time": self.column("time"), "rate": self.column(channel.column)}
        for c in self.columns:
            if c not in others and c not in arrays:
                arrays[c] = self.column(c)
        return self._like(arrays, axes=(dataclasses.replace(channel, column="rate"),))

    def split(self) -> list[Recording]:
        """One recording per segment (rows shared, not copied), in time order."""
        if len(self.segments) == 1:
            return [self]
        parts = []
        for seg in self.segments:
            arrays = {c: self.column(c)[seg] for c in self.columns}
            parts.append(self._like(arrays, segments=(slice(0, seg.stop - seg.start),)))
        return parts

    @property
    def time_s(self) -> np.ndarray:
        return self.column("time")

    @property
    def rate_dps(self) -> np.ndarray:
        """The values of the recording's one axis (see :meth:`axis`)."""
        if len(self.axes) == 1:
            return self.column(self.axes[0].column)
        return self.axis().column("rate")  # refuses several axes, naming them

    @property
    def temperature_c(self) -> np.ndarray | None:
        if "temperature" not in self.columns:
            return None
        return self.column("temperature")

    def input_record(self) -> dict:
        """The ``inputs`` entry of an artefact header for this recording (with its :attr:`notes`, if any)."""
        record = {"name": Path(self.name).name, "sha256": self.sha256}
        if self.notes:
            record["notes"] = list(self.notes)
        return record

    def _like(self, arrays: dict, **changes) -> Recording:
        kwargs = dict(
            axes=self.axes,
            temperatures=[t for t in self.temperatures if t in arrays],
            segments=self.segments,
            notes=self.notes,
            time_origin=self.time_origin,
        )
        kwargs.update(changes)
        return Recording(arrays, self.name, self.sha256, self.fs_hz, self.metadata, **kwargs)


def read_recording(
    path: str | os.PathLike,
    columns: ColumnSpec = ColumnSpec(),
    *,
    require_temperature: bool = False,
    min_samples: int = 2,
    jitter_tolerance: float = 0.5,
    resample: bool = False,
    allow_gaps: bool = False,
    usecols: Sequence[str] | None = None,
    limits: TimeLimits = TimeLimits(),
) -> Recording:
    """Read and validate a recording from CSV, Parquet, ULog or DataFlash.

    Parameters
    ----------
    path : path-like or "-"
        ``.csv`` (``.txt``; also ``.csv.gz``, ``.csv.bz2``, ``.csv.xz``,
        ``.csv.zst``, ``.csv.zip``), ``.parquet`` (``.pq``), ``.ulg`` or
        ``.bin``; ``"-"`` reads CSV from stdin.
    columns : ColumnSpec
        Column names, units and CSV format.
    require_temperature : bool
        Refuse a recording without the temperature column.
    min_samples : int
        Fewest samples the calling command can work with.
    jitter_tolerance : float
        Largest allowed deviation of a sampling interval from the median
        interval, as a fraction of the median. A longer interval is a gap.
    resample : bool
        Instead of refusing a jittered or gapped time axis, interpolate every
        column linearly onto a uniform grid at the median interval;
        :attr:`Recording.notes` says how many gaps were filled and the
        longest.
    allow_gaps : bool
        Accept gaps: the recording becomes several :attr:`Recording.segments`
        (for commands that handle them); otherwise a gap is refused.
    usecols : sequence of str, optional
        File columns (names or globs) to load beside the time and the axes,
        e.g. the temperature; the others are never read (Parquet), or
        parsed but not kept (CSV: :func:`keep_columns`). Default: all.
        When a column is missing, the whole file is read so that the error
        names every column it has.
    limits : TimeLimits
        The plausible sample rates and spans of a time column in seconds.

    Returns
    -------
    Recording

    Raises
    ------
    InputError
        Missing, empty or header-only file; missing column; non-numeric,
        NaN or infinite cell; time not strictly increasing or duplicated;
        implausible time base; jitter or gap beyond the tolerance; fewer than
        `min_samples` samples; temperature outside a plausible range for the
        declared unit.
    """
    name = "-" if str(path) == "-" else os.fspath(path)
    kind = _kind(name)
    if kind in ("ulog", "dataflash"):
        from gyrocomp import flightlogs

        sha = file_sha256(name)  # also the one-line error for a missing file
        frame, columns = flightlogs.read_log(name, kind, columns)
        metadata, where = {}, ("message", 1)
    else:
        frame, metadata, sha, where = _read_table(name, kind, columns, usecols)
    return recording_from_frame(
        frame,
        name=name,
        sha256=sha,
        columns=columns,
        require_temperature=require_temperature,
        min_samples=min_samples,
        jitter_tolerance=jitter_tolerance,
        resample=resample,
        allow_gaps=allow_gaps,
        metadata=metadata,
        limits=limits,
        _where=where,
        _owned=True,
    )


def read_recordings(path: str | os.PathLike, columns: ColumnSpec = ColumnSpec(), **options) -> list[Recording]:
    """The recordings of a file, one per time base: several for the streams of a flight log, else one.

    A ULog logs ``sensor_gyro`` and ``sensor_accel`` (and each instance)
    with their own time stamps. Given columns of several such streams,
    each stream becomes a recording of its own, on its own time stamps,
    with its own temperature and ``metadata`` what the log says about it
    (``stream``, its key: ``sensor_gyro_0``; ``autopilot``, ``instance``,
    PX4's ``device_id``: :func:`gyrocomp.flightlogs.read_logs`): nothing is
    interpolated from one time base onto another. Any other file is :func:`read_recording`.

    Parameters
    ----------
    path, columns, **options
        As :func:`read_recording`.

    Returns
    -------
    list of Recording
        In the log's stream order; a stream's axes keep their column names.
    """
    name = "-" if str(path) == "-" else os.fspath(path)
    if _kind(name) not in ("ulog", "dataflash"):
        return [read_recording(path, columns, **options)]
    from gyrocomp import flightlogs

    options.pop("usecols", None)  # a log's streams are read whole
    sha = file_sha256(name)  # also the one-line error for a missing file
    return [
        recording_from_frame(frame, name=name, sha256=sha, columns=spec, metadata=info, _where=("message", 1), _owned=True, **options)
        for info, frame, spec in flightlogs.read_logs(name, _kind(name), columns)
    ]


@dataclasses.dataclass(frozen=True)
class TemperatureLimits:
    """How fast a gyro's temperature can change (``configs/recordings.toml``, ``[temperature]``).

    Parameters
    ----------
    max_abs_rate_c_per_s : float, default=100
        Largest |dT/dt| [degC/s] of a model's training range: a thermal-shock
        chamber moves about 0.5 degC/s, a hot-air gun on the package some 50.
    """

    max_abs_rate_c_per_s: float = 100.0


def check_training_range(model: str, key: str, low: float, high: float) -> None:
    """Refuse a model's training range that no recording gives: it would switch the clamp (and its warning) off.

    `key` is ``temperature_c`` (within :data:`PLAUSIBLE_DEGC`, as a
    recording's temperature is) or ``temperature_rate_c_per_s`` (within
    :class:`TemperatureLimits`).

    Raises
    ------
    InputError
        Naming the model, the range and the bound (exit 2).
    """
    from gyrocomp.config import bind, load_config

    if key == "temperature_c":
        bound, source = PLAUSIBLE_DEGC, "a recording's plausible temperatures"
    else:
        limit = bind(TemperatureLimits, load_config("recordings").get("temperature"), "recordings.toml [temperature]").max_abs_rate_c_per_s
        bound, source = (-limit, limit), "max_abs_rate_c_per_s (configs/recordings.toml [temperature])"
    if low < bound[0] or high > bound[1]:
        raise InputError(f"{model}: training {key} = [{low:.6g}, {high:.6g}] leaves [{bound[0]:g}, {bound[1]:g}], {source}; a corrupted model")


@dataclasses.dataclass(frozen=True)
class LengthLimits:
    """Most samples a command makes up rather than reads (``configs/recordings.toml``, ``[lengths]``).

    Each is generous enough for a week at 1 kHz (6.05e8 samples); beyond
    it the request is refused, naming the setting, before memory runs out
    (a 29-day gap resampled at 1 kHz asked for 18.7 GiB).

    Parameters
    ----------
    resample_max_samples : int, default=1_000_000_000
        Samples of a recording interpolated onto a uniform grid (``--resample``).
    simulate_max_samples : int, default=1_000_000_000
        Samples of a simulated recording (duration times sample rate).
    export_max_vectors : int, default=1_000_000_000
        Test vectors of a C header (``export --n-vectors``).
    """

    resample_max_samples: int = 1_000_000_000
    simulate_max_samples: int = 1_000_000_000
    export_max_vectors: int = 1_000_000_000


def length_limits() -> LengthLimits:
    """The :class:`LengthLimits` of ``configs/recordings.toml``."""
    from gyrocomp.config import bind, load_config

    return bind(LengthLimits, load_config("recordings").get("lengths"), "recordings.toml [lengths]")


def check_length(setting: str, n: float, what: str) -> None:
    """Refuse making `n` samples where :class:`LengthLimits` field `setting` allows fewer; `what` says what asked for them.

    Raises
    ------
    InputError
        Naming `what`, the count and the setting (exit 2).
    """
    limit = getattr(length_limits(), setting)
    if not n <= limit:
        raise InputError(f"{what} needs {n:.4g} samples, more than {setting} = {limit} (configs/recordings.toml [lengths])")


def check_distinct(runs: Sequence[Recording]) -> None:
    """Refuse two runs with the same bytes among recordings that must be different runs (a fit run and its held-out ones).

    A held-out figure is only one when its run took no part in the fit: the
    same file given twice, or a byte-identical copy of it, would report the
    fit as held out. Compared by content (:attr:`Recording.sha256`), so a
    path, a link or a copy are all caught.

    Raises
    ------
    InputError
        Naming both files and the shared digest (exit 2).
    """
    seen: dict[str, Recording] = {}
    for run in runs:
        first = seen.setdefault(run.sha256, run)
        if first is not run:
            raise InputError(
                f"{run.name}: the same bytes as {first.name} (SHA-256 {run.sha256[:12]}...); a held-out run must be another recording"
            )


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
    :func:`read_recording`, whose own columns are then reused). The private
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
    time, origin = _time_seconds(frame[columns.time], columns, locate, _owned)
    out = {"time": time}
    axes = []
    for (src, unit) in chosen["axes"]:
        quantity, canonical, factor = _unit_of(unit)
        values = _numeric_column(frame[src], src, locate)
        out[src] = _own(values, _owned) if factor == 1.0 else values * factor
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
    out, rows, notes = _check_order(out, columns, locate)
    n = len(out["time"])
    if n < min_samples:
        raise InputError(f"{name}: {n} samples once duplicates are merged, this command needs at least {min_samples}")
    nominal = _nominal_interval(out["time"]) if _interval is None else _interval
    if columns.time_unit is None and origin is None and _interval is None:  # numbers read as seconds, not datetimes
        _check_time_base(out["time"], nominal, columns.time, name, limits)
    out, segments, filled = _segments(out, nominal, columns.time, locate, jitter_tolerance, resample, allow_gaps, _open_ends, _first_segment)
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


# ----------------------------------------------------------------------------- reading files


def _kind(name: str) -> str:
    if name == "-":
        return "csv"
    path = Path(name)
    suffix = path.suffix.lower()
    if suffix in COMPRESSIONS:
        suffix = Path(path.stem).suffix.lower()
        if suffix not in (".csv", ".txt"):
            raise InputError(f"{name}: a compressed recording must be CSV ({''.join(path.suffixes[-2:])!r}); use e.g. .csv.gz")
        return "csv"
    if suffix in (".parquet", ".pq"):
        return "parquet"
    if suffix in (".csv", ".txt"):
        return "csv"
    if suffix == ".ulg":
        return "ulog"
    if suffix == ".bin":
        return "dataflash"
    raise InputError(
        f"{name}: unknown extension {suffix!r}; use .csv (optionally .gz .bz2 .xz .zst .zip), "
        f".parquet, .ulg (PX4) or .bin (ArduPilot)"
    )


def _read_table(name: str, kind: str, spec: ColumnSpec, usecols: Sequence[str] | None):
    """Frame (or arrays), Parquet metadata, SHA-256 and row naming of a CSV or Parquet file.

    A file is hashed by streaming and parsed from its path, so its bytes
    are never held in memory twice. Parquet is not memory-mapped: the pages
    of a mapped file count in the process' resident memory, about the
    file's size on top of the columns decoded from it.
    """
    if name == "-":
        source = sys.stdin.buffer.read()
        sha = file_sha256(source)
    else:
        source, sha = name, file_sha256(name)
    wanted = wanted_columns(spec, usecols)
    while True:
        if kind == "parquet":
            frame, metadata = _parse_parquet(name, source, wanted)
            where = ("row", 1)
        else:
            frame, metadata = keep_columns(_parse_csv(name, source, spec), wanted), {}
            where = ("line", 2)  # line 1 is the header
        have = [str(c) for c in (frame if isinstance(frame, dict) else frame.columns)]
        if wanted is None or _has_columns(have, spec):
            return frame, metadata, sha, where
        wanted = None  # a column is missing: read them all for the error message


def wanted_columns(spec: ColumnSpec, usecols: Sequence[str] | None) -> Callable[[str], bool] | None:
    """The file columns a reader keeps, as a predicate on names (None: all): the time, the axes, `usecols` (names or globs)."""
    if usecols is None:
        return None
    patterns = (spec.time, *spec.rate_patterns, *usecols)
    return lambda c: any(str(c) == p or fnmatch.fnmatchcase(str(c), p) for p in patterns)


def keep_columns(frame: pd.DataFrame, wanted: Callable[[str], bool] | None) -> pd.DataFrame:
    """The columns of a parsed CSV frame that `wanted` keeps (all when None).

    CSV is parsed whole and cut afterwards, not with ``read_csv(usecols=)``:
    with `usecols` pandas skips its check that no row has more fields than
    the header, and a row with an extra field would pass one command and be
    refused by another (issue 21 item 12). Parsing the unkept columns costs
    the chunked reader 11 % when one column of three is not kept (``allan``
    on time, rate, temperature; 10^6 rows, min of 5 runs alternated in one
    process) and nothing when every column is kept.
    """
    if wanted is None:
        return frame
    return frame[[c for c in frame.columns if wanted(c)]]


def _has_columns(have: Sequence[str], spec: ColumnSpec) -> bool:
    needed = (spec.time, *spec.rate_patterns)
    return all(matching_columns(have, p) for p in needed)


def _parse_csv(name: str, source: str | bytes, spec: ColumnSpec) -> pd.DataFrame:
    import pandas as pd

    with csv_errors(name), open_csv_source(name, source) as stream:
        return pd.read_csv(stream, compression=None, **csv_options(spec))


@contextlib.contextmanager
def open_csv_source(name: str, source: str | bytes | None = None):
    """What ``pandas.read_csv`` reads for a CSV recording: the file, its checked decompressed stream (:func:`gyrocomp.compressed.open_csv`), or `source` bytes.

    Both CSV readers (this module's and :mod:`gyrocomp.streaming`'s) read
    through it, so a compressed file is decompressed, bounded and checked
    for truncation the same way by both.
    """
    from gyrocomp import compressed

    if isinstance(source, bytes):
        yield _stdio.BytesIO(source)
    elif compressed.is_compressed(name):
        with compressed.open_csv(name, file_limits()) as stream:
            yield stream
    else:
        yield name


def file_limits():
    """The bounds of a compressed recording (:class:`gyrocomp.compressed.FileLimits`, ``configs/recordings.toml`` ``[files]``)."""
    from gyrocomp import compressed
    from gyrocomp.config import bind, load_config

    return bind(compressed.FileLimits, load_config("recordings").get("files"), "recordings.toml [files]")


def csv_options(spec: ColumnSpec) -> dict:
    """The ``pandas.read_csv`` arguments of a column spec's CSV dialect (shared with the chunked reader).

    ``index_col=False``: a first data row with more fields than the header
    is an error (:func:`csv_errors`), not a row index that shifts every
    column by one.
    """
    sep = _SEPARATOR_WORDS.get(spec.sep, spec.sep)
    return {
        "sep": sep,
        "decimal": spec.decimal,
        "comment": "#",
        "skipinitialspace": True,
        "index_col": False,
        "engine": "python" if sep == r"\s+" else "c",
    }


@contextlib.contextmanager
def csv_errors(name: str) -> Iterator[None]:
    """Turn what ``pandas.read_csv`` raises on a bad file into one :class:`InputError` line naming `name`.

    A row with more fields than the header is named by its line (counted
    in the file, comments and blank lines included) and its field count;
    pandas warns, rather than refuses, when it is the first data row, and
    that warning is an error here too.
    """
    import pandas as pd

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            yield
    except InputError:  # a compressed stream's own check (gyrocomp.compressed), already one line naming the file
        raise
    except pd.errors.EmptyDataError:
        raise InputError(f"{name}: file is empty") from None
    except pd.errors.ParserError as err:
        text = str(err).strip().splitlines()[-1]
        extra = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", text)
        if extra:
            header, line, fields = extra.groups()
            raise InputError(f"{name} line {line}: {fields} fields, the header has {header}") from None
        raise InputError(f"{name}: unreadable CSV ({text})") from None
    except pd.errors.ParserWarning:
        raise InputError(
            f"{name}: the first data row has more fields than the header (a header read as one column: pass --sep)"
        ) from None
    except UnicodeDecodeError:
        raise InputError(f"{name}: not a text CSV file") from None
    except (OSError, EOFError, ValueError) as err:  # a damaged .gz/.zip, or one pandas cannot decompress
        if isinstance(err, FileNotFoundError):
            raise InputError(f"{name}: no such file") from None
        raise InputError(f"{name}: unreadable CSV ({str(err).strip().splitlines()[-1] if str(err).strip() else type(err).__name__})") from None
    except ImportError as err:
        raise InputError(f"{name}: pandas needs {err.name} to decompress this file (pip install {err.name})") from None


def _parse_parquet(name: str, source: str | bytes, usecols: Callable | None) -> tuple[pd.DataFrame | dict[str, np.ndarray], dict]:
    """Frame (or, from a file, arrays) and gyrocomp metadata of a Parquet file.

    `usecols` (a predicate on column names) reads only those of the file's
    columns. A file's null-free numeric columns are decoded row group by row
    group straight into NumPy arrays (:func:`_parquet_arrays`), without the
    whole Arrow table, pandas' consolidating copy or pandas at all.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    empty = len(source) == 0 if isinstance(source, bytes) else os.path.getsize(source) == 0
    if empty:
        raise InputError(f"{name}: file is empty")
    try:
        if isinstance(source, bytes):
            table = pq.read_table(pa.BufferReader(source))
        else:
            parquet = pq.ParquetFile(source, memory_map=False)
            names = [c for c in parquet.schema_arrow.names if usecols is None or usecols(c)]
            arrays = _parquet_arrays(parquet, names)
            pa.default_memory_pool().release_unused()  # the row groups' buffers, kept by Arrow's allocator for reuse
            if arrays is not None:
                return arrays, parquet_header(name, parquet.schema_arrow.metadata)
            table = pq.read_table(source, columns=names, memory_map=False)
    except (pa.ArrowInvalid, OSError) as err:
        raise InputError(f"{name}: not a readable Parquet file ({err})") from None
    return table.to_pandas(), parquet_header(name, table.schema.metadata)


def _parquet_arrays(parquet, names: Sequence[str]) -> dict[str, np.ndarray] | None:
    """What ``read_table(columns=names).to_pandas()`` gives a recording, as arrays, or None.

    Each column is allocated once as a NumPy array and filled row group by
    row group, so only one row group is ever held by Arrow. A stored pandas
    index is left out, as :func:`recording_from_frame` does not use it.
    None (read the table the ordinary way) when a column is not a null-free
    integer or float column, or pandas renamed columns.
    """
    import pyarrow as pa

    schema = parquet.schema_arrow
    index_names, renamed = set(), False
    pandas_meta = (schema.metadata or {}).get(b"pandas")
    if pandas_meta:
        meta = json.loads(pandas_meta)
        index_names = {c for c in meta.get("index_columns", []) if isinstance(c, str)}
        renamed = any(c.get("name") != c.get("field_name") for c in meta.get("columns", []) if c.get("field_name") not in index_names)
    names = [c for c in names if c not in index_names]
    types = [schema.field(c).type for c in names]
    if renamed or not names or len(set(schema.names)) != len(schema.names):
        return None
    if not all(pa.types.is_floating(t) or pa.types.is_integer(t) for t in types):
        return None
    arrays = {c: np.empty(parquet.metadata.num_rows, dtype=t.to_pandas_dtype()) for c, t in zip(names, types)}
    start = 0
    for group in range(parquet.num_row_groups):
        part = parquet.read_row_group(group, columns=names)
        for c in names:
            column = part.column(c)
            if column.null_count:
                return None
            at = start
            dtype = arrays[c].dtype
            for chunk in column.chunks:  # the data buffer as it is (Array.to_numpy would import pandas)
                values = np.frombuffer(chunk.buffers()[1], dtype=dtype, count=len(chunk), offset=chunk.offset * dtype.itemsize)
                arrays[c][at : at + len(chunk)] = values
                at += len(chunk)
        start += part.num_rows
    return arrays


# ----------------------------------------------------------------------------- the checks


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


def _time_seconds(series, spec: ColumnSpec, locate, owned: bool) -> tuple[np.ndarray, str | None]:
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
        return _own(values, owned), None
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


def _check_order(out: dict, spec: ColumnSpec, locate) -> tuple[dict, np.ndarray | None, list[str]]:
    """Refuse time going back; refuse or merge (``spec.dedupe``) duplicate stamps.

    Returns the columns, the file row of each kept row (None when all were
    kept) and the notes.
    """
    time = out["time"]
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


def _nominal_interval(time: np.ndarray) -> float:
    """The median sampling interval [s], ``np.median(np.diff(time))``.

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

    Selection by pivots, each pass over the intervals :data:`_CHECK_ROWS`
    at a time: the pivot is a quantile of a strided sample of the
    intervals still in play, so a regular time axis (a few distinct
    intervals) takes one pass; once no more than :data:`_MEDIAN_ROWS`
    remain in play they are gathered and partitioned. Exact: the value
    is one of the intervals, the same as ``np.partition(np.diff(time), k)[k]``.
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
        sample = sample[(sample > lo) & (sample < hi)]
        if not sample.size:  # the sample missed every interval in play: take the first chunk holding one
            sample = next(d for d in _intervals_between(time, lo, hi) if d.size)
        q = min(int((k - below) / left * sample.size), sample.size - 1)
        pivot = np.partition(sample, q)[q]
        less = equal = 0
        for d in _intervals_between(time, lo, hi):
            less += int(np.count_nonzero(d < pivot))
            equal += int(np.count_nonzero(d == pivot))
        if below + less <= k < below + less + equal:
            return pivot, below + less + equal
        if k < below + less:
            hi, left = pivot, less
        else:
            lo, below, left = pivot, below + less + equal, left - less - equal


def _intervals_between(time: np.ndarray, lo: float, hi: float) -> Iterator[np.ndarray]:
    """The intervals ``np.diff(time)`` strictly between `lo` and `hi`, :data:`_CHECK_ROWS` intervals at a time."""
    for start in range(0, len(time) - 1, _CHECK_ROWS):
        d = np.diff(time[start : start + _CHECK_ROWS + 1])
        yield d[(d > lo) & (d < hi)]


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


def _segments(out: dict, nominal: float, src: str, locate, tolerance: float, resample: bool, allow_gaps: bool, open_ends: tuple[bool, bool] = (False, False), first_segment: int = 0):
    """Segments of a time axis, or its uniform resampling; refuse what neither allows.

    An interval longer than ``(1 + tolerance)`` times the median is a gap;
    one shorter than ``(1 - tolerance)`` times it is jitter.

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
        return None if _where(values, np.isnan).size else values
    import pandas as pd

    col = pd.to_numeric(series, errors="coerce")
    return col.to_numpy(dtype=float) if col.notna().all() else None


def _check_axis(values: np.ndarray, src: str, canonical: str, unit: str, factor: float, locate) -> None:
    """Refuse an axis reading beyond :class:`AxisLimits` (in the file's unit)."""
    bound = AxisLimits().bound(canonical)
    outside = _where(values, lambda v: np.abs(v) > bound)
    if outside.size:
        i = int(outside[0])
        raise InputError(
            f"{locate(i)}: `{src}` = {values[i] / factor:g} {unit} is beyond +-{bound / factor:g} {unit}, "
            "more than any sensor reads (configs/recordings.toml [axes]); a corrupt cell or the wrong --rate-unit?"
        )


def _check_temperature(temperature: np.ndarray, src: str, locate) -> None:
    lo, hi = PLAUSIBLE_DEGC
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


def _where_intervals(time: np.ndarray, test: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Indices ``i`` where `test` holds for the interval ``time[i + 1] - time[i]``, :data:`_CHECK_ROWS` at a time.

    Same as ``np.flatnonzero(test(np.diff(time)))``, without a full-length
    array of intervals.
    """
    n = len(time) - 1
    hits = [start + np.flatnonzero(test(np.diff(time[start : start + _CHECK_ROWS + 1]))) for start in range(0, n, _CHECK_ROWS)]
    return np.concatenate(hits) if hits else np.empty(0, dtype=np.intp)


def _own(values: np.ndarray, owned: bool) -> np.ndarray:
    """`values` as a writable array the recording may keep.

    Reused when `owned` and the memory under it is this column alone (a
    column of a throw-away frame, of which pandas hands out a read-only
    view); otherwise copied, so the recording neither aliases a caller's
    table nor keeps a 2-D block of other columns alive.
    """
    base = values
    while isinstance(base.base, np.ndarray):
        base = base.base
    if owned and base.size == values.size:
        with contextlib.suppress(ValueError):  # memory numpy may not make writable: copy below
            values.setflags(write=True)
            return values
    return values.copy()


def _median_inplace(values: np.ndarray) -> float:
    """``np.median(values)`` without its copy; reorders `values`."""
    n = len(values)
    k = n // 2
    if n % 2:
        values.partition(k)
        return float(values[k])
    values.partition((k - 1, k))
    return float((values[k - 1] + values[k]) / 2.0)


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
