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

The package's modules, by concept: :mod:`~gyrocomp.recordings.spec`
(columns, units and limits), :mod:`~gyrocomp.recordings.recording` (the
:class:`Recording`), :mod:`~gyrocomp.recordings.files` (reading CSV,
Parquet and flight logs), :mod:`~gyrocomp.recordings.frame` (a table's
columns and cells checked) and :mod:`~gyrocomp.recordings.timebase` (time
order, interval, gaps, resampling). Every name is imported from here.
"""

from gyrocomp.errors import InputError, RecordingNote
from gyrocomp.recordings.files import (
    COMPRESSIONS,
    _kind,
    _parquet_arrays,
    csv_errors,
    csv_options,
    file_limits,
    keep_columns,
    open_csv_source,
    read_recording,
    read_recordings,
    wanted_columns,
)
from gyrocomp.recordings.frame import recording_from_frame
from gyrocomp.recordings.recording import Recording, check_distinct
from gyrocomp.recordings.spec import (
    _SEPARATOR_WORDS,
    ACCELERATION_UNITS,
    PLAUSIBLE_DEGC,
    RATE_UNITS,
    STANDARD_GRAVITY,
    TEMPERATURE_UNITS,
    TIME_UNITS,
    AxisLimits,
    Channel,
    ColumnSpec,
    LengthLimits,
    TemperatureLimits,
    TimeLimits,
    check_length,
    check_training_range,
    length_limits,
)
from gyrocomp.recordings.timebase import check_segment_lengths, gap_note, median_interval

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
