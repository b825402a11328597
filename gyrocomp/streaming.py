"""Recordings read, and tables written, chunk by chunk in constant memory.

A log of 10^8 samples does not fit the way :func:`gyrocomp.recordings.read_recording`
reads it (every column at once), and a log still being written
(``tail -f log.csv | gyrocomp compensate - ...``) has no end to wait for.
:func:`read_chunks` reads CSV (a file or standard input) ``rows`` lines at a
time and Parquet row group by row group, and hands out chunks of exactly
``rows`` samples (the last one shorter), so any computation that processes
them in order sees the same blocks however the file was stored.
:class:`TableWriter` writes each chunk as soon as it is computed.

Each chunk is validated as :func:`gyrocomp.recordings.recording_from_frame`
validates a whole recording (columns, units, finite values, plausible
temperature and time base, strictly increasing time, no gap, jitter
against the chunk's median interval), the errors naming the line or row
in the whole file; across a chunk boundary the time must go on
increasing, within the jitter tolerance of the first chunk's interval.
A gap stops the reading (:class:`GapError`), or, with ``gaps=True``, is
the start of a new segment (:attr:`ChunkReader.breaks`; one note on the
file's gaps at the end of the first complete reading).
The sample rate is the first chunk's (its median interval): what a stream
can know when it starts. Time in seconds only (:func:`supports`): other
units count from each chunk's first stamp.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
import warnings
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np

from gyrocomp import artefacts, recordings
from gyrocomp.errors import InputError, RecordingNote
from gyrocomp.recordings import ColumnSpec

__all__ = ["CHUNK_ROWS", "FILE_CHUNK_ROWS", "GapError", "ChunkReader", "supports", "read_chunks", "TableWriter"]

CHUNK_ROWS = 1 << 16
"""Samples per chunk (the rows :meth:`gyrocomp.models._base.Learner.predict` evaluates at once)."""
FILE_CHUNK_ROWS = 1 << 18
"""Samples per chunk, after a first one of `CHUNK_ROWS`, of causal compensation reading a Parquet file.

The causal dT/dt recomputes the part of its current window row a chunk
starts in (:class:`gyrocomp.pipeline.rate.CausalRate`): with the 60 s window
at 1 kHz, 7.2e6 samples took 0.55-0.72 s in chunks of 2^16 and 0.33-0.39 s
in chunks of 2^18. The sample rate is the first chunk's, so that one keeps
`CHUNK_ROWS` samples and the output does not depend on this number.
Standard input keeps `CHUNK_ROWS` throughout (each chunk is written as
soon as it is compensated).
"""


class GapError(InputError):
    """A gap in the time of a streamed recording (a stream is one gap-free run; a file with gaps is read whole)."""


class ChunkReader:
    """Iterate over a recording in chunks of `rows` samples (see :func:`read_chunks`).

    Attributes
    ----------
    name : str
        The file's name (``"-"`` for standard input).
    fs_hz : float or None
        Sample rate, from the first chunk's median interval (None before it).
    metadata : dict
        The ``gyrocomp`` metadata of a Parquet file written by this tool.
    n_samples : int
        Samples read so far in this reading.
    breaks : list of int
        With ``gaps``: the samples (counted from the start) after a gap, each
        the first of a segment, found so far in this reading.
    n_rows : int or None
        Rows of a Parquet file, from its footer, once a reading has begun
        (None for CSV): the most samples a reading can give.
    """

    def __init__(
        self,
        path,
        columns: ColumnSpec,
        *,
        rows: int,
        require_temperature: bool,
        usecols,
        jitter_tolerance: float,
        gaps: bool = False,
        first_rows: int | None = None,
        writable: bool = True,
    ):
        self.name = "-" if str(path) == "-" else os.fspath(path)
        self.columns = columns
        self.rows = int(rows)
        self.first_rows = self.rows if first_rows is None else int(first_rows)
        self.require_temperature = require_temperature
        self.usecols = None if usecols is None else list(dict.fromkeys(usecols))
        self.jitter_tolerance = jitter_tolerance
        self.gaps = bool(gaps)
        self.writable = bool(writable)
        self.breaks = []
        self._noted = False
        self.fs_hz = None
        self.metadata = {}
        self.n_samples = 0
        self.n_rows = None
        self._kind = recordings._kind(self.name)
        self._hash = hashlib.sha256()
        self._sha256 = None if self.name == "-" else artefacts.file_sha256_started(self.name)
        self._done = False

    @property
    def sha256(self) -> str:
        """SHA-256 of the file's bytes, hashed on a thread from the start (of standard input: once it has been read to the end)."""
        if self._sha256 is not None:
            return self._sha256()
        if not self._done:
            raise RuntimeError("the SHA-256 of standard input is known once it has been read to the end")
        return self._hash.hexdigest()

    def input_record(self) -> dict:
        """The ``inputs`` entry of an artefact header for this recording."""
        return {"name": Path(self.name).name, "sha256": self.sha256}

    def __iter__(self) -> Iterator[recordings.Recording]:
        where, first = ("row", 1) if self._kind == "parquet" else ("line", 2)
        last_time = None
        nominal = None
        longest = 0.0
        self.n_samples, self.breaks = 0, []
        frames = self._csv_frames() if self._kind == "csv" else _exact_rows(self._parquet_frames(), self.rows, self.first_rows)
        for frame in frames:
            goes_on = self._goes_on(frame, last_time, nominal)
            chunk = recordings.recording_from_frame(
                frame,
                name=self.name,
                sha256="",
                columns=self.columns,
                require_temperature=self.require_temperature,
                min_samples=2 if self.n_samples == 0 else 1,
                jitter_tolerance=self.jitter_tolerance,
                allow_gaps=True,
                _where=(where, first + self.n_samples),
                _owned=True,
                _views=not self.writable,
                _gap_note=not self.gaps,
                _interval=nominal,
                _open_ends=(goes_on, True),
                _first_segment=len(self.breaks) + (last_time is not None and not goes_on),
            )
            if len(chunk.segments) > 1:
                if not self.gaps:
                    row = first + self.n_samples + chunk.segments[1].start
                    raise GapError(f"{self.name} {where} {row}: a gap in `{self.columns.time}`; a streamed recording is one gap-free run")
                starts = np.array([seg.start for seg in chunk.segments[1:]])
                self.breaks += (self.n_samples + starts).tolist()
                longest = max(longest, float(np.max(chunk.time_s[starts] - chunk.time_s[starts - 1])))
            if chunk.time_origin is not None:
                raise InputError(f"{self.name}: a streamed recording needs its time in seconds (--time-unit s)")
            time = chunk.time_s
            if nominal is None:
                nominal = 1.0 / chunk.fs_hz
                self.fs_hz = chunk.fs_hz
            else:
                step = float(time[0]) - last_time
                if step > nominal * (1 + self.jitter_tolerance):
                    if not self.gaps:
                        raise GapError(f"{self.name} {where} {first + self.n_samples}: a gap in `{self.columns.time}` after {last_time!r}; a streamed recording is one gap-free run")
                    self.breaks.append(self.n_samples)
                    longest = max(longest, step)
                elif step <= 0 or abs(step - nominal) > self.jitter_tolerance * nominal:
                    raise InputError(
                        f"{self.name} {where} {first + self.n_samples}: `{self.columns.time}` = {float(time[0])!r} "
                        f"after {last_time!r}; a streamed recording needs strictly increasing time at the "
                        f"interval of its start, {nominal:.6g} s (tolerance {self.jitter_tolerance:.0%})"
                    )
            last_time = float(time[-1])
            self.n_samples += len(time)
            self._check_segments(where, first, ended=False)
            yield chunk
        if self.n_samples == 0:
            raise InputError(f"{self.name}: has a header but no data rows")
        self._check_segments(where, first, ended=True)
        self._done = True
        if self._kind == "parquet":  # the row groups' decoding buffers, which Arrow's allocator keeps for reuse
            import pyarrow as pa

            pa.default_memory_pool().release_unused()
        if self.breaks and not self._noted:  # the file's gaps, once however often it is read
            warnings.warn(f"{self.name}: {recordings.gap_note(len(self.breaks), longest)}", RecordingNote, stacklevel=2)
            self._noted = True

    def _goes_on(self, frame, last_time: float | None, nominal: float | None) -> bool:
        """Whether a chunk's first sample continues the previous chunk's last segment (no gap between them)."""
        if last_time is None:
            return False
        try:
            step = float(next(iter(frame[self.columns.time]))) - last_time
        except (KeyError, StopIteration, TypeError, ValueError):
            return True  # the chunk's own checks will say what is wrong
        return step <= nominal * (1 + self.jitter_tolerance)

    def _check_segments(self, where: str, first: int, ended: bool) -> None:
        """Refuse a segment of one sample among those read so far (as the whole-file reader does), the last one once `ended`."""
        starts = np.array([0, *self.breaks])
        ends = np.r_[starts[1:], self.n_samples]
        lengths = ends - starts
        if not ended:
            lengths[-1] = 2  # the open segment may go on
        alone = np.flatnonzero(lengths == 1)
        if alone.size:
            k = int(alone[0])
            raise InputError(
                f"{self.name} {where} {first + int(starts[k])}: segment {k + 1} is one sample (alone after a gap in `{self.columns.time}`; "
                f"the interval is {1.0 / self.fs_hz:.6g} s); drop it, or pass --resample to interpolate onto a uniform grid"
            )

    def _csv_frames(self):
        import pandas as pd

        wanted = recordings.wanted_columns(self.columns, self.usecols)
        with contextlib.ExitStack() as stack:
            if self.name == "-":
                source = _HashingReader(sys.stdin.buffer, self._hash)
            else:
                with recordings.csv_errors(self.name):
                    source = stack.enter_context(recordings.open_csv_source(self.name))
            with recordings.csv_errors(self.name):
                reader = stack.enter_context(
                    pd.read_csv(source, compression=None, chunksize=self.rows, **recordings.csv_options(self.columns))
                )
            while True:
                with recordings.csv_errors(self.name):  # each chunk's rows checked as the whole-file reader checks them
                    frame = next(reader, None)
                if frame is None:
                    return
                yield recordings.keep_columns(frame, wanted)

    def _parquet_frames(self):
        import pyarrow as pa
        import pyarrow.parquet as pq

        if os.path.getsize(self.name) == 0:
            raise InputError(f"{self.name}: file is empty")
        try:
            parquet = pq.ParquetFile(self.name)
        except (pa.ArrowInvalid, OSError) as err:
            raise InputError(f"{self.name}: not a readable Parquet file ({err})") from None
        self.metadata = artefacts.parquet_header(self.name, parquet.schema_arrow.metadata)
        self.n_rows = parquet.metadata.num_rows
        keep = recordings.wanted_columns(self.columns, self.usecols)
        wanted = [c for c in parquet.schema_arrow.names if keep is None or keep(c)]
        for group in range(parquet.num_row_groups):
            table = parquet.read_row_group(group, columns=wanted)
            yield {c: _numpy(table.column(c)) for c in table.column_names}


def supports(path: str | os.PathLike, columns: ColumnSpec = ColumnSpec()) -> bool:
    """Whether :func:`read_chunks` reads this recording: CSV or Parquet, time in seconds, no duplicates to merge.

    Without a time unit, a file whose time column holds text (ISO datetimes,
    which :func:`gyrocomp.recordings.read_recording` parses) is read whole:
    its first row is looked at.
    """
    name = "-" if str(path) == "-" else os.fspath(path)
    kind = recordings._kind(name)
    if kind not in ("csv", "parquet") or columns.time_unit not in (None, "s") or columns.dedupe is not None:
        return False
    return columns.time_unit == "s" or name == "-" or not _text_time(name, kind, columns)


def _text_time(name: str, kind: str, columns: ColumnSpec) -> bool:
    """Whether the time column's first value is text (False when that cannot be read: the reader will say why)."""
    if kind == "parquet":  # the schema says it, without pandas
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            stored = pq.read_schema(name).field(columns.time).type
        except (KeyError, pa.ArrowInvalid, OSError):
            return False
        return not (pa.types.is_integer(stored) or pa.types.is_floating(stored))
    import pandas as pd

    sep = recordings._SEPARATOR_WORDS.get(columns.sep, columns.sep)
    try:
        with recordings.open_csv_source(name) as source:
            head = pd.read_csv(
                source, sep=sep, decimal=columns.decimal, comment="#", skipinitialspace=True, nrows=1,
                usecols=[columns.time], engine="python" if sep == r"\s+" else "c",
            )
    except (ValueError, OSError, EOFError, pd.errors.ParserError, pd.errors.EmptyDataError):  # InputError is a ValueError
        return False
    return not pd.api.types.is_numeric_dtype(head[columns.time].dtype)


def read_chunks(
    path: str | os.PathLike,
    columns: ColumnSpec = ColumnSpec(),
    *,
    rows: int = CHUNK_ROWS,
    require_temperature: bool = False,
    usecols: Sequence[str] | None = None,
    jitter_tolerance: float = 0.5,
    gaps: bool = False,
    first_rows: int | None = None,
    writable: bool = True,
) -> ChunkReader:
    """A recording as an iterable of validated chunks of `rows` samples.

    Parameters
    ----------
    path : path-like or "-"
        ``.csv`` or ``.parquet``; ``"-"`` reads CSV from standard input.
    columns : ColumnSpec
        Column names, units and CSV format (see :func:`supports`).
    rows : int
        Samples per chunk (the last chunk holds the rest).
    require_temperature : bool
        Refuse a recording without the temperature column.
    usecols : sequence of str, optional
        File columns (names or globs) to read beside the time and the axes; default all.
    jitter_tolerance : float
        As in :func:`gyrocomp.recordings.read_recording`.
    gaps : bool
        Read on past a gap (a chunk may then hold several segments;
        :attr:`ChunkReader.breaks` says where each starts) instead of
        raising :class:`GapError`.
    first_rows : int, optional
        Samples of the first chunk of a Parquet file, from which the sample
        rate is estimated (default `rows`; CSV chunks are all `rows` long).
    writable : bool
        False lets a chunk's time and axes be views of the arrays decoded
        from the file (which may be read-only), not copies of them: for a
        caller that only reads the chunks (``allan``: 0.07-0.09 s of CPU
        less on 10^7 samples).

    Returns
    -------
    ChunkReader
        Iterating it yields :class:`gyrocomp.recordings.Recording` chunks; a second
        iteration reads the file again (not standard input).
    """
    if min(rows, rows if first_rows is None else first_rows) < 2:
        raise InputError(f"chunks of {rows} rows (the first {first_rows}); need at least 2")
    return ChunkReader(
        path, columns, rows=rows, require_temperature=require_temperature, usecols=usecols, jitter_tolerance=jitter_tolerance, gaps=gaps,
        first_rows=first_rows, writable=writable,
    )


class TableWriter:
    """Write a table chunk by chunk: CSV (``-`` is standard output) or Parquet by extension.

    Parameters
    ----------
    path : path-like or "-"
    header : callable returning dict, or dict
        The artefact header (:func:`gyrocomp.artefacts.artefact_header`) stored in a
        Parquet file's metadata; a callable is asked when the header is
        needed: at the first chunk when `header_known_first`, else at
        :meth:`close` (the Parquet file is then copied once, row group by
        row group, into one carrying the header).
    header_known_first : bool

    Notes
    -----
    A file is written under a temporary name and renamed by :meth:`close`
    (:func:`gyrocomp.artefacts.atomic_path`), so a failure leaves nothing half
    written; standard output gets each chunk as it comes and is flushed.
    The CSV bytes of consecutive chunks are those of the whole table
    written at once by :func:`gyrocomp.artefacts.write_table`.
    """

    def __init__(self, path, header: Callable[[], dict] | dict, *, header_known_first: bool = True):
        self.path = str(path)
        self._header = header if callable(header) else (lambda: header)
        self._first = header_known_first
        self._kind = "csv" if self.path == "-" else recordings._kind(self.path)
        self._atomic = None
        self._tmp = None
        self._parquet = None
        self._csv = contextlib.ExitStack()
        self._stream = sys.stdout
        self._rows = 0

    def __enter__(self) -> "TableWriter":
        from gyrocomp.compressed import csv_writer

        if self.path != "-":
            self._atomic = artefacts.atomic_path(self.path)
            self._tmp = self._atomic.__enter__()
            if self._kind == "csv":  # one stream (compressed by extension) for every chunk
                self._stream = self._csv.enter_context(csv_writer(self._tmp, self.path))
        return self

    def write(self, columns: dict) -> None:
        """Append rows: a dict of equally long 1-D NumPy arrays, by column name in order."""
        if self._kind == "csv":
            import pandas as pd

            pd.DataFrame(columns).to_csv(self._stream, index=False, header=self._rows == 0)
            if self.path == "-":
                sys.stdout.flush()
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            table = pa.Table.from_arrays([_arrow(v) for v in columns.values()], names=list(columns))
            if self._parquet is None:
                schema = table.schema
                if self._first:
                    schema = schema.with_metadata(_header_metadata(self._header()))
                target = self._tmp if self._first else self._tmp + ".unheaded"
                self._parquet = pq.ParquetWriter(target, schema, **artefacts.parquet_options(schema))
            self._parquet.write_table(table.cast(self._parquet.schema))
        self._rows += len(next(iter(columns.values())))

    def __exit__(self, kind, value, tb) -> None:
        try:
            self._csv.close()
            if kind is None and self._parquet is not None:
                self._parquet.close()
                if not self._first:
                    _copy_with_header(self._tmp + ".unheaded", self._tmp, _header_metadata(self._header()))
        finally:
            if self._parquet is not None and not self._first and os.path.exists(self._tmp + ".unheaded"):
                os.remove(self._tmp + ".unheaded")
            if self._atomic is not None:
                self._atomic.__exit__(kind, value, tb)


class _HashingReader:
    """A binary stream that feeds what is read from it into a hash."""

    def __init__(self, raw, digest):
        self._raw, self._digest = raw, digest

    def read(self, size: int = -1) -> bytes:
        data = self._raw.read(size)
        self._digest.update(data)
        return data

    def readinto(self, buffer) -> int:
        data = self.read(len(buffer))
        buffer[: len(data)] = data
        return len(data)

    def readable(self) -> bool:
        return True

    def __iter__(self):
        return iter(self.readline, b"")

    def readline(self, size: int = -1) -> bytes:
        data = self._raw.readline(size)
        self._digest.update(data)
        return data


def _numpy(column) -> np.ndarray:
    """An Arrow column as NumPy: a null-free numeric one from its data buffers (no pandas), else ``to_numpy``."""
    import pyarrow as pa

    if column.null_count or not (pa.types.is_floating(column.type) or pa.types.is_integer(column.type)):
        return column.to_numpy()
    dtype = np.dtype(column.type.to_pandas_dtype())
    parts = [np.frombuffer(c.buffers()[1], dtype=dtype, count=len(c), offset=c.offset * dtype.itemsize) for c in column.chunks]
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _arrow(values) -> "pyarrow.Array":
    """A NumPy column as Arrow: a contiguous float64 one over its own buffer (no pandas, no copy), else ``pa.array``.

    ``pa.array`` imports pandas to ask whether it was given a Series (half a
    second of a ``compensate`` that needs nothing else from it). NaN stays
    a NaN value, not a null, either way.
    """
    import pyarrow as pa

    values = np.asarray(values)
    if values.dtype != np.float64 or values.ndim != 1 or not values.flags.c_contiguous:
        return pa.array(values)
    return pa.Array.from_buffers(pa.float64(), len(values), [None, pa.py_buffer(values)])


def _exact_rows(frames, rows: int, first: int):
    """Re-cut a sequence of column dicts into dicts of exactly `first`, then `rows` rows (the last one shorter)."""
    pending = []
    held = 0
    size = first
    for frame in frames:
        length = len(next(iter(frame.values()))) if frame else 0
        if length == 0:
            continue
        pending.append(frame)
        held += length
        while held >= size:
            yield _take(pending, size)
            held -= size
            size = rows
    if held:
        yield _take(pending, held)


def _take(pending: list, rows: int) -> dict:
    """The first `rows` rows of the queued frames, removed from the queue."""
    parts = []
    need = rows
    while need:
        frame = pending[0]
        length = len(next(iter(frame.values())))
        if length <= need:
            parts.append(pending.pop(0))
            need -= length
        else:
            parts.append({c: v[:need] for c, v in frame.items()})
            pending[0] = {c: v[need:] for c, v in frame.items()}
            need = 0
    if len(parts) == 1:
        return parts[0]
    return {c: np.concatenate([p[c] for p in parts]) for c in parts[0]}


def _header_metadata(header: dict) -> dict:
    """Parquet key-value metadata holding an artefact header, as :func:`gyrocomp.artefacts.write_table` stores it."""
    import json

    return {artefacts.METADATA_KEY: json.dumps(artefacts.jsonable(header), sort_keys=True).encode()}


def _copy_with_header(source: str, target: str, metadata: dict) -> None:
    import pyarrow.parquet as pq

    parquet = pq.ParquetFile(source)
    schema = parquet.schema_arrow.with_metadata(metadata)
    with pq.ParquetWriter(target, schema, **artefacts.parquet_options(schema)) as writer:
        for group in range(parquet.num_row_groups):
            writer.write_table(parquet.read_row_group(group))
