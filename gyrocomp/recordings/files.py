"""Reading recordings from files: CSV (compressed or not, any dialect), Parquet, flight logs, standard input.

:func:`read_recording` reads a file into a table (CSV with pandas, Parquet
column by column straight into NumPy arrays) and validates it with
:func:`gyrocomp.recordings.frame.recording_from_frame`. The CSV helpers
(:func:`csv_options`, :func:`csv_errors`, :func:`open_csv_source`,
:func:`keep_columns`) are shared with the chunked reader of
:mod:`gyrocomp.streaming`, so both read and refuse a file the same way.
"""

from __future__ import annotations

import contextlib
import fnmatch
import io as _stdio
import json
import os
import re
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Sequence

import numpy as np

from gyrocomp.artefacts import file_sha256, parquet_header
from gyrocomp.columns import matching_columns
from gyrocomp.errors import InputError
from gyrocomp.recordings.frame import recording_from_frame
from gyrocomp.recordings.recording import Recording
from gyrocomp.recordings.spec import _SEPARATOR_WORDS, ColumnSpec, TimeLimits

if TYPE_CHECKING:  # pandas is imported where a function needs it: the Parquet path of a recording never does
    import pandas as pd

COMPRESSIONS = (".gz", ".bz2", ".xz", ".zst", ".zip")
"""Extensions of compressed CSV, decompressed by pandas."""


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
