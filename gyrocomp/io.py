"""Recordings in, artefacts out.

A *recording* is a table of ``time`` [s], ``rate`` [deg/s] and, where the
command needs it, ``temperature`` [degC], read from CSV or Parquet (chosen
by the file's extension; ``-`` reads CSV from standard input). Other column
names are mapped and other units converted by :class:`ColumnSpec`.
Everything wrong with a recording raises :class:`~gyrocomp.errors.InputError`
naming the file, and the line (CSV) or row (Parquet) and column: nothing is
guessed silently.

Every artefact is written atomically (a temporary file in the target's
folder, then :func:`os.replace`), and carries a header made by
:func:`artefact_header`: schema name and version, gyrocomp version, the
inputs' SHA-256, the settings and the seed, and no wall-clock time, so the
same inputs and seed give the same bytes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import io as _stdio
import json
import math
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Mapping, Sequence

import numpy as np

from gyrocomp import __version__
from gyrocomp.errors import InputError, SchemaError

if TYPE_CHECKING:  # pandas is imported where a function needs it: the Parquet path of a recording never does
    import pandas as pd

__all__ = [
    "ColumnSpec",
    "Recording",
    "read_recording",
    "recording_from_frame",
    "write_table",
    "read_table",
    "write_json",
    "read_json",
    "atomic_path",
    "artefact_header",
    "check_header",
    "jsonable",
]

RATE_UNITS = {"deg/s": 1.0, "deg/h": 1.0 / 3600.0, "rad/s": 180.0 / math.pi}
"""Factors that convert a rate unit to deg/s."""

TIME_UNITS = {"s": 1.0, "ms": 1e-3}
"""Factors that convert a time unit to seconds."""

TEMPERATURE_UNITS = ("degC", "K")

_PLAUSIBLE_DEGC = (-100.0, 200.0)
"""Temperatures outside this range are refused as a probable unit mistake."""

_METADATA_KEY = b"gyrocomp"


@dataclasses.dataclass(frozen=True)
class ColumnSpec:
    """How to find and convert the columns of a recording.

    Parameters
    ----------
    time, rate, temperature : str
        Column names in the file.
    time_unit : {"s", "ms"}
        Unit of the time column.
    rate_unit : {"deg/s", "deg/h", "rad/s"}
        Unit of the rate column.
    temperature_unit : {"degC", "K"}
        Unit of the temperature column.
    """

    time: str = "time"
    rate: str = "rate"
    temperature: str = "temperature"
    time_unit: str = "s"
    rate_unit: str = "deg/s"
    temperature_unit: str = "degC"

    def __post_init__(self):
        for option, value, choices in (
            ("time unit", self.time_unit, TIME_UNITS),
            ("rate unit", self.rate_unit, RATE_UNITS),
            ("temperature unit", self.temperature_unit, TEMPERATURE_UNITS),
        ):
            if value not in choices:
                raise InputError(
                    f"unknown {option} {value!r}; choose one of {', '.join(choices)}"
                )


class Recording:
    """A validated recording.

    Parameters
    ----------
    data : pandas.DataFrame or mapping of str to numpy.ndarray
        ``time`` [s] (strictly increasing, uniform within the tolerance),
        ``rate`` [deg/s], ``temperature`` [degC] when present, and any
        further numeric columns of the file unchanged, as a frame or as
        one 1-D array per column (kept as given, not copied).
    name : str
        The file's name (``"-"`` for standard input), used in messages.
    sha256 : str
        SHA-256 of the file's bytes.
    fs_hz : float
        Sample rate, from the median sampling interval.
    metadata : dict, optional
        The ``gyrocomp`` metadata of a Parquet file written by this tool
        (the simulator stores its truth there), else empty.

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

    def __repr__(self) -> str:
        return f"Recording(name={self.name!r}, columns={self.columns!r}, fs_hz={self.fs_hz!r})"

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
    def time_s(self) -> np.ndarray:
        return self.column("time")

    @property
    def rate_dps(self) -> np.ndarray:
        return self.column("rate")

    @property
    def temperature_c(self) -> np.ndarray | None:
        if "temperature" not in self.columns:
            return None
        return self.column("temperature")

    def input_record(self) -> dict:
        """The ``inputs`` entry of an artefact header for this recording."""
        return {"name": Path(self.name).name, "sha256": self.sha256}


def read_recording(
    path: str | os.PathLike,
    columns: ColumnSpec = ColumnSpec(),
    *,
    require_temperature: bool = False,
    min_samples: int = 2,
    jitter_tolerance: float = 0.5,
    resample: bool = False,
    usecols: Sequence[str] | None = None,
) -> Recording:
    """Read and validate a recording from CSV or Parquet.

    Parameters
    ----------
    path : path-like or "-"
        ``.csv`` or ``.parquet`` (also ``.pq``); ``"-"`` reads CSV from stdin.
    columns : ColumnSpec
        Column names and units in the file.
    require_temperature : bool
        Refuse a recording without the temperature column.
    min_samples : int
        Fewest samples the calling command can work with.
    jitter_tolerance : float
        Largest allowed deviation of a sampling interval from the median
        interval, as a fraction of the median.
    resample : bool
        Instead of refusing a jittered or gapped time axis, interpolate every
        column linearly onto a uniform grid at the median interval.
    usecols : sequence of str, optional
        File columns to load (names as in the file, e.g. ``columns.time``);
        the others are never read (Parquet) or parsed (CSV). Default: all.
        When one of them is missing, the whole file is read so that the
        error names every column it has.

    Returns
    -------
    Recording

    Raises
    ------
    InputError
        Missing, empty or header-only file; missing column; non-numeric,
        NaN or infinite cell; time not strictly increasing or duplicated;
        jitter beyond the tolerance; fewer than `min_samples` samples;
        temperature outside a plausible range for the declared unit.
    """
    name, source, sha = _open_source(path)
    kind = _kind(name)
    metadata = {}
    wanted = None if usecols is None else list(dict.fromkeys(usecols))
    while True:
        if kind == "parquet":
            frame, metadata = _parse_parquet(name, source, usecols=wanted, direct=True)
            where = "row"
            first = 1
        else:
            frame = _parse_csv(name, source, usecols=wanted)
            where = "line"
            first = 2  # line 1 is the header
        have = frame if isinstance(frame, dict) else frame.columns
        if wanted is None or all(c in have for c in wanted):
            break
        wanted = None  # a column is missing: read them all for the error message
    del source
    return recording_from_frame(
        frame,
        name=name,
        sha256=sha,
        columns=columns,
        require_temperature=require_temperature,
        min_samples=min_samples,
        jitter_tolerance=jitter_tolerance,
        resample=resample,
        metadata=metadata,
        _where=(where, first),
        _owned=True,
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
    metadata: dict | None = None,
    _where: tuple[str, int] = ("row", 1),
    _owned: bool = False,
) -> Recording:
    """Validate an in-memory table as a recording (see :func:`read_recording`).

    `frame` is a pandas DataFrame or a mapping of column name to 1-D
    integer or float NumPy array (validated without importing pandas).
    `sha256` defaults to the hash of the table's CSV form. Time and rate are
    copies (the private `_owned` says `frame` is a throw-away of
    :func:`read_recording`, whose own columns are then reused).
    """
    where, first = _where

    def locate(i: int) -> str:
        return f"{name} {where} {int(i) + first}"

    arrays = isinstance(frame, Mapping)
    names = list(frame) if arrays else list(frame.columns)
    n_rows = (len(next(iter(frame.values()))) if frame else 0) if arrays else len(frame)
    if n_rows == 0:
        raise InputError(f"{name}: has a header but no data rows")
    wanted = {"time": columns.time, "rate": columns.rate}
    if require_temperature or columns.temperature in names:
        wanted["temperature"] = columns.temperature
    missing = [src for src in wanted.values() if src not in names]
    if missing:
        hint = ""
        if "temperature" in wanted and wanted["temperature"] in missing:
            hint = " (map it with --temp-col)"
        raise InputError(
            f"{name}: missing column {', '.join(repr(m) for m in missing)}{hint}; "
            f"the file has {', '.join(repr(str(c)) for c in names)}"
        )
    out = {}
    for key, src in wanted.items():
        out[key] = _numeric_column(frame[src], src, locate)
    scale = {"time": TIME_UNITS[columns.time_unit], "rate": RATE_UNITS[columns.rate_unit]}
    for key, factor in scale.items():
        out[key] = _own(out[key], _owned) if factor == 1.0 else out[key] * factor
    if "temperature" in out and columns.temperature_unit == "K":
        out["temperature"] = out["temperature"] - 273.15
    for extra in names:
        if extra not in wanted.values() and extra not in out:
            col = _numeric_extra(frame[extra])
            if col is not None:
                out[str(extra)] = col
    if "temperature" in out:
        _check_temperature(out["temperature"], columns.temperature, locate)
    n = len(out["time"])
    if n < min_samples:
        raise InputError(f"{name}: {n} samples, this command needs at least {min_samples}")
    time = out["time"]
    dt = np.diff(time)  # the one N-sized temporary of the checks; partitioned in place below
    nominal = 1.0
    if dt.size:
        i_min, i_max = int(np.argmin(dt)), int(np.argmax(dt))
        dt_min, dt_max = float(dt[i_min]), float(dt[i_max])
        if dt_min <= 0:
            b = int(np.flatnonzero(dt <= 0)[0])
            i = b + 1
            what = "duplicates" if dt[b] == 0 else "goes back from"
            raise InputError(
                f"{locate(i)}: `{columns.time}` = {float(time[i])!r} {what} the previous "
                f"time {float(time[i - 1])!r}; time must be strictly increasing"
            )
        nominal = _median_inplace(dt)
        # the largest |dt - nominal| is at the largest or the smallest interval
        worst, dt_worst = (i_max, dt_max) if dt_max - nominal >= nominal - dt_min else (i_min, dt_min)
        if abs(dt_worst - nominal) > jitter_tolerance * nominal:
            if not resample:
                raise InputError(
                    f"{locate(worst + 1)}: sampling interval {dt_worst:.6g} s in "
                    f"`{columns.time}`, the median is {nominal:.6g} s (tolerance "
                    f"{jitter_tolerance:.0%}); pass --resample to interpolate onto "
                    f"a uniform grid"
                )
            out = _resample(out, nominal)
    del dt
    if sha256 is None:
        import pandas as pd

        table = pd.DataFrame(frame, copy=False) if arrays else frame
        sha256 = hashlib.sha256(table.to_csv(index=False).encode()).hexdigest()
    return Recording(
        data=out,
        name=name,
        sha256=sha256,
        fs_hz=1.0 / nominal,
        metadata=metadata or {},
    )


def write_table(path: str | os.PathLike, frame: pd.DataFrame, header: dict) -> None:
    """Write a table atomically: Parquet or CSV by extension, ``-`` is CSV on stdout.

    The header (see :func:`artefact_header`) goes into the Parquet file's
    key-value metadata under ``gyrocomp``; a CSV table carries no header, so
    write Parquet wherever traceability matters.
    """
    if str(path) == "-":
        frame.to_csv(sys.stdout, index=False, float_format=None)
        sys.stdout.flush()
        return
    import pyarrow as pa
    import pyarrow.parquet as pq

    kind = _kind(str(path))
    with atomic_path(path) as tmp:
        if kind == "csv":
            frame.to_csv(tmp, index=False)
        else:
            table = pa.Table.from_pandas(frame, preserve_index=False)
            meta = {_METADATA_KEY: json.dumps(jsonable(header), sort_keys=True).encode()}
            table = table.replace_schema_metadata(meta)
            pq.write_table(table, tmp)


def read_table(path: str | os.PathLike, schema: str) -> tuple[pd.DataFrame, dict]:
    """Read a Parquet artefact written by :func:`write_table` and check its schema.

    Returns
    -------
    frame : pandas.DataFrame
    header : dict
        The artefact header; :func:`check_header` has accepted it.
    """
    name, raw = _read_bytes(path)
    if _kind(name) != "parquet":
        raise InputError(f"{name}: expected a .parquet artefact")
    frame, header = _parse_parquet(name, raw)
    check_header(header, schema, name)
    return frame, header


def write_json(path: str | os.PathLike, obj: Any) -> None:
    """Write JSON atomically (``-`` writes to stdout); NaN becomes ``null``."""
    text = json.dumps(jsonable(obj), indent=2, allow_nan=False) + "\n"
    if str(path) == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def read_json(path: str | os.PathLike, schema: str | None = None) -> dict:
    """Read a JSON artefact; with `schema`, check its header (:func:`check_header`)."""
    name, raw = _read_bytes(path)
    try:
        obj = json.loads(raw.decode("utf-8"), parse_constant=_no_constant, parse_float=_finite_float)
    except (UnicodeDecodeError, ValueError) as err:  # JSONDecodeError is a ValueError
        line = getattr(err, "lineno", None) or _line_of(raw, getattr(err, "token", None))
        at = f" line {line}" if line else ""
        raise InputError(f"{name}{at}: not valid JSON ({err.args[0] if err.args else err})") from None
    except RecursionError:
        raise InputError(f"{name}: not valid JSON (nested too deeply)") from None
    if not isinstance(obj, dict):
        raise InputError(f"{name}: expected a JSON object at the top level")
    if schema is not None:
        check_header(obj, schema, name)
    return obj


class _BadNumber(ValueError):
    """A number JSON cannot hold; `token` is its text, to find its line."""

    def __init__(self, token: str, why: str):
        super().__init__(f"{token} {why}")
        self.token = token


def _no_constant(text: str):
    """JSON has no NaN or Infinity; Python's reader would accept them."""
    raise _BadNumber(text, "is not a JSON number")


def _finite_float(text: str) -> float:
    """A JSON number that overflows a double (``1e999``) is refused, not read as infinity."""
    value = float(text)
    if not math.isfinite(value):
        raise _BadNumber(text, "overflows a double")
    return value


def _line_of(raw: bytes, token: str | None) -> int | None:
    """Line (1-based) of the first bare `token` in `raw`, or None."""
    if not token:
        return None
    found = re.search(rb'(?<![\w."])' + re.escape(token.encode()) + rb'(?![\w."])', raw)
    return raw.count(b"\n", 0, found.start()) + 1 if found else None


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[str]:
    """Yield a temporary path beside `path`; on success rename it onto `path`.

    The parent folder is created. If the body raises, the temporary file is
    removed and `path` is left as it was.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


SCHEMA_VERSION = "1.0"


def artefact_header(
    schema: str,
    *,
    inputs: list[dict] | None = None,
    settings: dict | None = None,
    seed: int | None = None,
    version: str = SCHEMA_VERSION,
) -> dict:
    """The traceability header every artefact starts with.

    Parameters
    ----------
    schema : str
        Artefact kind, e.g. ``"gyrocomp.allan"``.
    inputs : list of dict
        ``{"name", "sha256"}`` per input (:meth:`Recording.input_record`).
    settings : dict
        The fully resolved settings.
    seed : int or None
        The seed of every random step.
    version : str
        ``"major.minor"``; readers refuse a newer major.
    """
    return {
        "schema": {"name": schema, "version": version},
        "gyrocomp_version": __version__,
        "inputs": list(inputs or []),
        "settings": settings or {},
        "seed": seed,
    }


def check_header(obj: dict, schema: str, name: str, supported_major: int | None = None) -> None:
    """Refuse an artefact of a foreign schema or of a newer major version.

    Raises
    ------
    SchemaError
    """
    major_supported = supported_major or int(SCHEMA_VERSION.split(".")[0])
    info = obj.get("schema") if isinstance(obj, dict) else None
    if not isinstance(info, dict) or "name" not in info or "version" not in info:
        raise SchemaError(f"{name}: not a gyrocomp artefact (no `schema` name and version)")
    if info["name"] != schema:
        raise SchemaError(f"{name}: is a {info['name']!r} artefact, expected {schema!r}")
    try:
        major = int(str(info["version"]).split(".")[0])
    except ValueError:
        raise SchemaError(f"{name}: unreadable schema version {info['version']!r}") from None
    if major > major_supported:
        raise SchemaError(
            f"{name}: schema {schema} version {info['version']} is newer than this "
            f"gyrocomp ({__version__}) reads (major {major_supported}); upgrade gyrocomp"
        )


def jsonable(obj: Any) -> Any:
    """Convert numpy scalars and arrays, paths and tuples to plain JSON values.

    Non-finite floats become ``None`` (JSON has no NaN).
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    return obj


def _umask() -> int:
    """The process umask (reading it means setting it; it is set straight back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _open_source(path: str | os.PathLike) -> tuple[str, str | bytes, str]:
    """Name, what to parse (a path, or the bytes of stdin) and SHA-256 of a recording.

    A file is hashed by streaming and parsed from its path (Parquet memory-mapped),
    so its bytes are never held in memory twice.
    """
    if str(path) == "-":
        raw = sys.stdin.buffer.read()
        return "-", raw, hashlib.sha256(raw).hexdigest()
    name = os.fspath(path)
    with _open_input(name) as fh:
        return name, name, hashlib.file_digest(fh, "sha256").hexdigest()


def _read_bytes(path: str | os.PathLike) -> tuple[str, bytes]:
    if str(path) == "-":
        return "-", sys.stdin.buffer.read()
    name = os.fspath(path)
    with _open_input(name) as fh:
        return name, fh.read()


@contextlib.contextmanager
def _open_input(name: str):
    """``open(name, "rb")``, its failures as one-line :class:`InputError` naming the file."""
    try:
        fh = open(name, "rb")
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{name}: is a directory, expected a file") from None
    except PermissionError:
        raise InputError(f"{name}: permission denied") from None
    with fh:
        yield fh


def _kind(name: str) -> str:
    if name == "-":
        return "csv"
    suffix = Path(name).suffix.lower()
    if suffix in (".parquet", ".pq"):
        return "parquet"
    if suffix in (".csv", ".txt"):
        return "csv"
    raise InputError(f"{name}: unknown extension {suffix!r}; use .csv or .parquet")


def _parse_csv(name: str, source: str | bytes, usecols: Sequence[str] | None = None) -> pd.DataFrame:
    import pandas as pd

    if isinstance(source, bytes):
        source = _stdio.BytesIO(source)
    keep = None if usecols is None else set(usecols).__contains__
    try:
        return pd.read_csv(source, comment="#", skipinitialspace=True, usecols=keep)
    except pd.errors.EmptyDataError:
        raise InputError(f"{name}: file is empty") from None
    except pd.errors.ParserError as err:
        raise InputError(f"{name}: unreadable CSV ({str(err).strip().splitlines()[-1]})") from None
    except UnicodeDecodeError:
        raise InputError(f"{name}: not a text CSV file") from None


def _parse_parquet(
    name: str, source: str | bytes, usecols: Sequence[str] | None = None, direct: bool = False
) -> tuple[pd.DataFrame | dict[str, np.ndarray], dict]:
    """Frame (or, on the direct path, arrays) and gyrocomp metadata of a Parquet file.

    `usecols` reads only those of the file's columns. `direct` (a file, for
    :func:`read_recording`) decodes null-free numeric columns row group by
    row group straight into NumPy arrays (:func:`_parquet_frame`), without
    the whole Arrow table, pandas' consolidating copy or pandas at all.
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
            if direct:
                parquet = pq.ParquetFile(source, memory_map=True)
                frame = _parquet_frame(parquet, usecols)
                if frame is not None:
                    return frame, _gyrocomp_header(name, parquet.schema_arrow.metadata)
            if usecols is not None:
                present = set(pq.read_schema(source, memory_map=True).names)
                usecols = [c for c in usecols if c in present]
            table = pq.read_table(source, columns=usecols, memory_map=True)
    except (pa.ArrowInvalid, OSError) as err:
        raise InputError(f"{name}: not a readable Parquet file ({err})") from None
    return table.to_pandas(), _gyrocomp_header(name, table.schema.metadata)


def _gyrocomp_header(name: str, meta: dict | None) -> dict:
    """The artefact header stored under ``gyrocomp`` in Parquet key-value metadata, else {}."""
    meta = meta or {}
    if _METADATA_KEY not in meta:
        return {}
    try:
        return json.loads(meta[_METADATA_KEY])
    except json.JSONDecodeError:
        raise InputError(f"{name}: corrupted gyrocomp metadata") from None


def _parquet_frame(parquet, usecols: Sequence[str] | None) -> dict[str, np.ndarray] | None:
    """What ``read_table(columns=usecols).to_pandas()`` gives a recording, as arrays, or None.

    Each (wanted) column is allocated once as a NumPy array and filled row
    group by row group, so only one row group is ever held by Arrow. A
    stored pandas index is left out, as :func:`recording_from_frame` does
    not use it. None (read the table the ordinary way) when a column is
    not a null-free integer or float column, or pandas renamed columns.
    """
    import pyarrow as pa

    schema = parquet.schema_arrow
    index_names, renamed = set(), False
    pandas_meta = (schema.metadata or {}).get(b"pandas")
    if pandas_meta:
        meta = json.loads(pandas_meta)
        index_names = {c for c in meta.get("index_columns", []) if isinstance(c, str)}
        renamed = any(c.get("name") != c.get("field_name") for c in meta.get("columns", []) if c.get("field_name") not in index_names)
    names = [c for c in schema.names if c not in index_names and (usecols is None or c in usecols)]
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
    finite = np.isfinite(values)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        what = "missing or NaN" if np.isnan(values[i]) else f"{float(values[i])!r}"
        raise InputError(f"{locate(i)}: `{src}` is {what}")
    return values


def _numeric_extra(series: pd.Series | np.ndarray) -> np.ndarray | None:
    """A further column as float64 when every cell is a number (infinity included), else None."""
    if isinstance(series, np.ndarray):
        values = series.astype(float, copy=False)
        return None if np.isnan(values).any() else values
    import pandas as pd

    col = pd.to_numeric(series, errors="coerce")
    return col.to_numpy(dtype=float) if col.notna().all() else None


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


def _check_temperature(temperature: np.ndarray, src: str, locate) -> None:
    lo, hi = _PLAUSIBLE_DEGC
    outside = (temperature < lo) | (temperature > hi)
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        raise InputError(
            f"{locate(i)}: `{src}` = {temperature[i]:g} degC is outside "
            f"[{lo:g}, {hi:g}] degC; wrong unit? (pass --temp-unit K for kelvin)"
        )


def _resample(columns: dict[str, np.ndarray], interval: float) -> dict[str, np.ndarray]:
    time = columns["time"]
    n = int(math.floor((time[-1] - time[0]) / interval + 1e-9)) + 1
    grid = time[0] + interval * np.arange(n)
    return {key: (grid if key == "time" else np.interp(grid, time, values)) for key, values in columns.items()}
