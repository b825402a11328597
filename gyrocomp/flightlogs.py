"""Flight-controller logs as recordings: PX4 ULog (``.ulg``) and ArduPilot DataFlash (``.bin``).

Each logged sensor stream becomes columns named ``<stream>_<instance>_<field>``:

=========================  ===================================  ==========  ===========
log                        columns                              axes unit   time stamps
=========================  ===================================  ==========  ===========
ULog ``sensor_gyro``       ``sensor_gyro_0_x`` .. ``_z``,       rad/s       µs
                           ``sensor_gyro_0_temperature`` [degC]
ULog ``sensor_accel``      ``sensor_accel_0_x`` .. ``_z``,      m/s^2       µs
                           ``sensor_accel_0_temperature``
DataFlash ``IMU``          ``IMU_0_GyrX`` .. ``GyrZ``,          rad/s,      µs
                           ``IMU_0_AccX`` .. ``AccZ``,          m/s^2       (``TimeUS``)
                           ``IMU_0_T`` [degC]
=========================  ===================================  ==========  ===========

for every instance (``I`` field of ``IMU``; older logs' ``IMU2``, ``IMU3``
are instances 1 and 2). Choose axes with the ordinary column options, e.g.
``--rate-col 'sensor_gyro_1_[xyz]' --temp-col sensor_gyro_1_temperature``
or ``--rate-col 'IMU_0_Gyr?,IMU_0_Acc?'``; by default the first gyro and its
temperature are read. The units and the µs time base come from the log
format, so ``--rate-unit`` and ``--time-unit`` do not apply. One recording
has one time base: columns of one stream and instance (an ``IMU`` message
carries gyro, accelerometer and temperature together; ULog logs the gyro
and the accelerometer as separate topics with their own time stamps).
Columns of several streams (``--rate-col 'sensor_*_0_[xyz]'``) are read
as one recording per stream (:func:`read_logs`), each on its own time
stamps and with its own temperature; nothing is interpolated from one
time base onto another.

pyulog and pymavlink are the optional extra ``gyrocomp[logs]``.

References
----------
.. [1] PX4 ULog file format, https://docs.px4.io/main/en/dev_log/ulog_file_format.html
.. [2] ArduPilot onboard log (DataFlash) messages ``FMT`` and ``IMU``,
       https://ardupilot.org/copter/docs/logmessages.html
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import warnings
from typing import Iterator

import numpy as np

from gyrocomp import logparams
from gyrocomp.columns import matching_columns
from gyrocomp.errors import InputError, RecordingNote

__all__ = ["read_log", "read_logs"]

ULOG_TOPICS = {"sensor_gyro": "rad/s", "sensor_accel": "m/s^2"}
"""ULog topics read, with the unit of their x, y, z fields."""

DATAFLASH_FIELDS = {"GyrX": "rad/s", "GyrY": "rad/s", "GyrZ": "rad/s", "AccX": "m/s^2", "AccY": "m/s^2", "AccZ": "m/s^2"}
"""Axis fields of a DataFlash ``IMU`` message, with their units; ``T`` is the temperature [degC]."""

_DEFAULT_RATE = {"ulog": "sensor_gyro_0_[xyz]", "dataflash": "IMU_0_Gyr?"}
"""The axes read when the column options are left at their defaults: the first gyro."""


@dataclasses.dataclass(frozen=True)
class _Stream:
    """One sensor stream of a log: its name, its key (the columns' prefix), its time stamps [µs] and columns.

    `instance` is the sensor's instance in the log (ULog ``multi_id``,
    DataFlash ``I``), `device_id` PX4's ``device_id`` field (None in a
    DataFlash log, whose calibrations go by instance).
    """

    name: str
    key: str
    time_us: np.ndarray
    columns: dict
    units: dict
    instance: int = 0
    device_id: int | None = None


def read_log(name: str, kind: str, spec) -> tuple:
    """The columns of the one stream `spec` selects, and `spec` resolved for them.

    As :func:`read_logs`, for a caller that takes one time base.

    Returns
    -------
    columns : dict of str to numpy.ndarray
        ``time`` [µs, int64] and the stream's columns.
    spec : ColumnSpec
        With the axes and temperatures named one by one, their units, and
        ``time_unit="us"``.

    Raises
    ------
    InputError
        As :func:`read_logs`, and columns of several streams (each has its
        own time stamps; the message names the streams and the commands that
        take them).
    """
    found = read_logs(name, kind, spec)
    if len(found) > 1:
        raise InputError(
            f"{name}: the columns selected belong to {', '.join(info['stream'] for info, _, _ in found)}, "
            "which are logged with their own time stamps; read one stream per run "
            "(allan, train and compensate take several, each on its own time base)"
        )
    _, columns, resolved = found[0]
    return columns, resolved


def read_logs(name: str, kind: str, spec) -> list[tuple]:
    """The columns of every stream `spec` selects, each with its own time stamps, and `spec` resolved for each.

    Parameters
    ----------
    name : str
        Path of the log.
    kind : {"ulog", "dataflash"}
    spec : gyrocomp.recordings.ColumnSpec
        The column options (not imported here: :mod:`gyrocomp.recordings`
        imports this module); the default ``rate`` selects the first gyro, the
        default ``temperature`` each chosen stream's own temperature (an
        explicit one is looked up in each stream's columns).

    Returns
    -------
    list of (dict, dict, ColumnSpec)
        Per stream, in the log's order: what the log says about it
        (``stream``, its name: ``sensor_gyro_0``, ``IMU_1``; ``autopilot``,
        ``px4`` or ``ardupilot``; ``instance``; ``device_id`` for PX4), its
        columns (``time`` [µs, int64] and the stream's columns, as the
        sensor gave them: :mod:`gyrocomp.logparams`) and `spec` with the
        axes and temperatures named one by one, their units, and
        ``time_unit="us"``.

    Raises
    ------
    InputError
        Unreadable log, no such stream or column (the message lists them),
        a unit option (the format fixes the units), or log parameters that
        say the data cannot be read as the sensor gave them
        (:mod:`gyrocomp.logparams`).
    """
    options = (("--time-unit", spec.time_unit, None), ("--rate-unit", spec.rate_unit, "deg/s"), ("--temp-unit", spec.temperature_unit, "degC"))
    given = [option for option, value, default in options if value != default]
    if given:
        raise InputError(f"{name}: a log's units come from its format (rad/s, m/s^2, degC, us); drop {', '.join(given)}")
    streams = _read_ulog(name) if kind == "ulog" else _read_dataflash(name)
    if not streams:
        raise InputError(f"{name}: no {'sensor_gyro or sensor_accel topic' if kind == 'ulog' else 'IMU message'} in the log")
    patterns = [p.strip() for p in spec.rate.split(",") if p.strip()]
    if spec.rate == "rate":  # the column options' default: the first gyro
        patterns = [_DEFAULT_RATE[kind]]
    chosen = [s for s in streams if any(matching_columns(list(s.columns), p) for p in patterns)]
    if not chosen:
        every = [c for s in streams for c in s.columns]
        raise InputError(f"{name}: no column matches {', '.join(repr(p) for p in patterns)}; the log has {', '.join(every)}")
    found = []
    for stream in chosen:
        axes = [c for c in stream.units if any(c in matching_columns(list(stream.units), p) for p in patterns)]  # a glob skips the temperature
        if not axes:
            raise InputError(f"{name}: {', '.join(repr(p) for p in patterns)} selects no sensor axis; {stream.name} has {', '.join(stream.units)}")
        if spec.temperature == "temperature":  # the default: the stream's own temperature
            temps = [c for c in stream.columns if c not in stream.units]
        else:
            wanted = [p.strip() for p in spec.temperature.split(",") if p.strip()]
            temps = [c for c in stream.columns if any(c in matching_columns(list(stream.columns), p) for p in wanted)]
        resolved = dataclasses.replace(
            spec,
            time="time",
            time_unit="us",
            rate=",".join(axes),
            rate_unit=",".join(stream.units[c] for c in axes),
            temperature=",".join(temps) or "temperature",
            temperature_unit="degC",
        )
        info = {"stream": stream.key, "autopilot": "px4" if kind == "ulog" else "ardupilot", "instance": stream.instance}
        if stream.device_id is not None:
            info["device_id"] = stream.device_id
        found.append((info, {"time": stream.time_us, **stream.columns}, resolved))
    return found


class _Printed(io.TextIOBase):
    """A text stream that keeps what a library prints: the number of lines and the first one."""

    def __init__(self):
        self.lines = 0
        self.first = ""

    def writable(self) -> bool:
        return True

    def write(self, text: str) -> int:
        if not self.first and text.strip():
            self.first = text.strip().splitlines()[0]
        self.lines += text.count("\n")
        return len(text)


@contextlib.contextmanager
def _quiet(name: str, library: str) -> Iterator[None]:
    """Keep what `library` prints (pyulog's warnings go to stdout, pymavlink prints per message) out of the tool's output.

    ``--out -`` writes data to stdout, which a library's print would corrupt.
    What it printed becomes one :class:`~gyrocomp.errors.RecordingNote`
    (its line count and first line) when the reading succeeds; an error
    is one line on its own.
    """
    printed = _Printed()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
        yield
    if printed.lines or printed.first:
        warnings.warn(f"{name}: {library} printed {max(printed.lines, 1)} lines while reading it, the first: {printed.first[:200]}", RecordingNote, stacklevel=3)


def _read_ulog(name: str) -> list[_Stream]:
    pyulog = _require("pyulog", name)
    try:
        with _quiet(name, "pyulog"):
            log = pyulog.ULog(name, list(ULOG_TOPICS))
    except Exception as err:  # pyulog raises bare exceptions on a damaged file
        raise InputError(f"{name}: not a readable ULog file ({type(err).__name__}: {err})") from None
    logparams.px4_note(name, log.initial_parameters)
    streams = []
    for data in sorted(log.data_list, key=lambda d: (list(ULOG_TOPICS).index(d.name), d.multi_id)):
        fields = data.data
        prefix = f"{data.name}_{data.multi_id}_"
        stamp = fields["timestamp_sample"] if "timestamp_sample" in fields else fields["timestamp"]
        columns = {prefix + axis: np.asarray(fields[axis], dtype=float) for axis in "xyz" if axis in fields}
        units = dict.fromkeys(columns, ULOG_TOPICS[data.name])
        if "temperature" in fields:
            columns[prefix + "temperature"] = np.asarray(fields["temperature"], dtype=float)
        device_id = int(np.median(fields["device_id"])) if "device_id" in fields and len(fields["device_id"]) else None  # as PX4's process_sensor_caldata.py
        streams.append(_Stream(f"{data.name} instance {data.multi_id}", prefix[:-1], np.asarray(stamp, dtype=np.int64), columns, units, data.multi_id, device_id))
    return streams


def _read_dataflash(name: str) -> list[_Stream]:
    _require("pymavlink", name)
    from pymavlink import DFReader

    with _quiet(name, "pymavlink"):
        rows, params = _dataflash_rows(name, DFReader)
    fields = ["TimeUS", *DATAFLASH_FIELDS, "T"]
    undo = logparams.ardupilot_undo(name, params)
    streams = []
    for instance in sorted(rows):
        table = undo(instance, np.array(rows[instance], dtype=float))
        prefix = f"IMU_{instance}_"
        columns = {prefix + f: table[:, k + 1] for k, f in enumerate(fields[1:]) if not np.isnan(table[:, k + 1]).all()}
        units = {prefix + f: u for f, u in DATAFLASH_FIELDS.items()}
        time_us = np.array([r[0] for r in rows[instance]], dtype=np.int64)
        streams.append(_Stream(f"IMU instance {instance}", prefix[:-1], time_us, columns, units, instance))
    return streams


def _dataflash_rows(name: str, DFReader) -> tuple[dict[int, list], dict[str, list]]:
    """The IMU rows of a DataFlash log by instance (TimeUS, the DATAFLASH_FIELDS, T), and every value of each ``PARM`` in the log's order."""
    try:
        log = DFReader.DFReader_binary(name, zero_time_base=True)
    except Exception as err:  # pymavlink raises bare exceptions on a damaged file
        raise InputError(f"{name}: not a readable DataFlash log ({type(err).__name__}: {err})") from None
    rows: dict[int, list] = {}
    params: dict[str, list] = {}
    fields = ["TimeUS", *DATAFLASH_FIELDS, "T"]
    while True:
        try:
            msg = log.recv_match(type=["IMU", "IMU2", "IMU3", "PARM"])
        except Exception as err:
            raise InputError(f"{name}: damaged DataFlash log ({type(err).__name__}: {err})") from None
        if msg is None:
            break
        kind = msg.get_type()
        if kind == "PARM":
            params.setdefault(str(msg.Name), []).append(float(msg.Value))
            continue
        instance = int(getattr(msg, "I", 0)) if kind == "IMU" else int(kind[-1]) - 1
        rows.setdefault(instance, []).append([getattr(msg, f, np.nan) for f in fields])
    log.close()
    return rows, params


def _require(module: str, name: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"{name}: reading it needs {module}: pip install 'gyrocomp[logs]'") from None
