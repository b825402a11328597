"""Artefacts out: atomic writes, the traceability header, and the one file hash.

Every artefact is written atomically (a temporary file in the target's
folder, then :func:`os.replace`), so a failed or killed run leaves the
previous file or none, never a half-written one. Each carries the header
made by :func:`artefact_header`: schema name and version, gyrocomp version,
the inputs' SHA-256 (:func:`file_sha256`), the settings and the seed, and
no wall-clock time, so the same inputs and seed give the same bytes.
Reading recordings is :mod:`gyrocomp.recordings`.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import re
import shutil
import stat
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO, Callable, Iterator, Mapping

import numpy as np

from gyrocomp import __version__
from gyrocomp.errors import InputError, SchemaError

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "SCHEMA_VERSION",
    "file_sha256",
    "file_sha256_started",
    "file_record",
    "write_table",
    "read_table",
    "write_json",
    "read_json",
    "atomic_path",
    "name_part",
    "artefact_header",
    "check_header",
    "parquet_header",
    "parquet_options",
    "open_input",
    "read_bytes",
    "jsonable",
]

SCHEMA_VERSION = "1.0"

METADATA_KEY = b"gyrocomp"
"""Key of the artefact header in a Parquet file's key-value metadata."""


def file_sha256(source: str | os.PathLike | bytes) -> str:
    """SHA-256 (hex) of a file's bytes, streamed, or of `source` itself when it is bytes.

    The one hash of every ``inputs`` entry, batch manifest and up-to-date
    check, so the same file always gets the same digest.

    Raises
    ------
    InputError
        The file is missing, a folder or unreadable.
    """
    if isinstance(source, (bytes, bytearray, memoryview)):
        return hashlib.sha256(source).hexdigest()
    with open_input(os.fspath(source)) as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def file_sha256_started(path: str | os.PathLike) -> Callable[[], str]:
    """:func:`file_sha256` of a file, computed on a thread while the caller goes on.

    The file is opened at once, so a missing file, a folder or a device is
    the same one-line :class:`InputError` as :func:`file_sha256` raises,
    here. ``hashlib`` releases the GIL while it reads and hashes, so the
    hash of a big recording runs beside its decoding where a second core is
    free (SHA-256 in software takes about 3 ns a byte: 0.4-0.6 s of a 126 MB
    file on this project's machine). The digest is the same.

    Returns
    -------
    callable
        Returns the hex digest, waiting for the thread when it has not
        finished (and raises what the hashing raised).
    """
    import threading

    stack = contextlib.ExitStack()
    fh = stack.enter_context(open_input(os.fspath(path)))
    box: list = []

    def work() -> None:
        with stack:
            try:
                digest, buffer = hashlib.sha256(), bytearray(1 << 16)  # file_digest's 256 KiB buffer would show in a streaming run's peak
                view = memoryview(buffer)
                while size := fh.readinto(buffer):
                    digest.update(view[:size])
                box.append(digest.hexdigest())
            except BaseException as err:  # handed to the caller by digest()
                box.append(err)

    thread = threading.Thread(target=work, name=f"sha256 {Path(path).name}", daemon=True)
    thread.start()

    def digest() -> str:
        thread.join()
        if isinstance(box[0], BaseException):
            raise box[0]
        return box[0]

    return digest


def file_record(path: str | os.PathLike) -> dict:
    """The ``inputs`` entry of an artefact header for a file: its name and :func:`file_sha256`."""
    return {"name": Path(path).name, "sha256": file_sha256(path)}


def write_table(path: str | os.PathLike, frame: pd.DataFrame | Mapping[str, np.ndarray], header: dict) -> None:
    """Write a table atomically: Parquet or CSV by extension, ``-`` is CSV on stdout.

    The header (see :func:`artefact_header`) goes into the Parquet file's
    key-value metadata under ``gyrocomp``; a CSV table carries no header, so
    write Parquet wherever traceability matters. A CSV is compressed by
    its extension as recordings are read (``.csv.gz``, ``.csv.bz2``,
    ``.csv.xz``, ``.csv.zst``, ``.csv.zip``;
    :func:`gyrocomp.compressed.csv_compression`). `frame` is a DataFrame or
    a mapping of column names to 1-D arrays; a mapping goes to Parquet
    without importing pandas (0.4 s of a command's start-up).
    """
    from gyrocomp.compressed import csv_compression, csv_writer

    compression = None if str(path) == "-" else csv_compression(path)
    suffix = Path(Path(path).stem if compression else path).suffix.lower()
    csv = str(path) == "-" or suffix in (".csv", ".txt")
    if isinstance(frame, Mapping) and csv:
        import pandas as pd

        frame = pd.DataFrame(dict(frame))
    if str(path) == "-":
        frame.to_csv(sys.stdout, index=False, float_format=None)
        sys.stdout.flush()
        return
    import pyarrow as pa
    import pyarrow.parquet as pq

    if suffix not in (".csv", ".txt", ".parquet", ".pq"):
        raise InputError(f"{path}: unknown extension {suffix!r}; use .csv (optionally .gz .bz2 .xz .zst .zip) or .parquet")
    with atomic_path(path) as tmp:
        if csv:
            with csv_writer(tmp, path) as stream:
                frame.to_csv(stream, index=False)
        else:
            if isinstance(frame, Mapping):
                table = pa.Table.from_arrays([_arrow_column(v) for v in frame.values()], names=list(frame))
            else:
                table = pa.Table.from_pandas(frame, preserve_index=False)
            meta = {METADATA_KEY: json.dumps(jsonable(header), sort_keys=True).encode()}
            table = table.replace_schema_metadata(meta)
            pq.write_table(table, tmp, **parquet_options(table.schema))


def _arrow_column(values) -> "pa.Array":
    """A 1-D array as an Arrow column; float64 by its buffer (``pa.array`` imports pandas to test its argument)."""
    import pyarrow as pa

    values = np.asarray(values)
    if values.ndim == 1 and values.dtype == np.dtype("<f8"):
        values = np.ascontiguousarray(values)
        return pa.Array.from_buffers(pa.float64(), values.size, [None, pa.py_buffer(values)])
    return pa.array(values)


def parquet_options(schema) -> dict:
    """Writer options of every Parquet table: dictionary encoding for the columns that are not floating point only, no compression.

    Measured values (time, rates, temperatures) hardly ever repeat, so a
    dictionary of them is built and then dropped page after page: 7.2e6
    rows of five float columns took 5.4 s to write with it, 1.5 s without.
    Nor do their low mantissa bits compress: Snappy made those rows 36.3
    instead of 40.0 bytes (9 %) for 0.83 instead of 0.60 s of CPU.
    """
    import pyarrow as pa

    return {"use_dictionary": [field.name for field in schema if not pa.types.is_floating(field.type)], "compression": "none"}


def read_table(path: str | os.PathLike, schema: str) -> tuple[pd.DataFrame, dict]:
    """Read a Parquet artefact written by :func:`write_table` and check its schema.

    Returns
    -------
    frame : pandas.DataFrame
    header : dict
        The artefact header; :func:`check_header` has accepted it.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    name, raw = read_bytes(path)
    if Path(name).suffix.lower() not in (".parquet", ".pq"):
        raise InputError(f"{name}: expected a .parquet artefact")
    if not raw:
        raise InputError(f"{name}: file is empty")
    try:
        table = pq.read_table(pa.BufferReader(raw))
    except (pa.ArrowInvalid, OSError) as err:
        raise InputError(f"{name}: not a readable Parquet file ({err})") from None
    header = parquet_header(name, table.schema.metadata)
    check_header(header, schema, name)
    return table.to_pandas(), header


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
    name, raw = read_bytes(path)
    obj = parse_json(name, raw)
    if not isinstance(obj, dict):
        raise InputError(f"{name}: expected a JSON object at the top level")
    if schema is not None:
        check_header(obj, schema, name)
    return obj


def parse_json(name: str, raw: bytes) -> Any:
    """Strict JSON of `raw` (UTF-8, finite numbers, bounded nesting); errors name `name` and the line.

    Raises
    ------
    InputError
        Not UTF-8, not JSON, NaN/Infinity or an overflowing number, a
        huge integer, or nesting deeper than the interpreter's recursion.
    """
    try:
        return json.loads(raw.decode("utf-8"), parse_constant=_no_constant, parse_float=_finite_float, parse_int=_double_int)
    except (UnicodeDecodeError, ValueError) as err:  # JSONDecodeError is a ValueError
        line = getattr(err, "lineno", None) or _line_of(raw, getattr(err, "token", None))
        at = f" line {line}" if line else ""
        raise InputError(f"{name}{at}: not valid JSON ({err.args[0] if err.args else err})") from None
    except RecursionError:
        raise InputError(f"{name}: not valid JSON (nested too deeply)") from None


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


def _double_int(text: str) -> int:
    """A JSON integer beyond a double's range (no artefact number is) is refused, not read to overflow later."""
    value = int(text)
    if abs(value) > _LARGEST_DOUBLE_INT:
        raise _BadNumber(text[:20] + "...", f"({len(text)} digits) overflows a double")
    return value


_LARGEST_DOUBLE_INT = int(sys.float_info.max)


def _line_of(raw: bytes, token: str | None) -> int | None:
    """Line (1-based) of the first bare `token` in `raw`, or None."""
    if not token:
        return None
    found = re.search(rb'(?<![\w."])' + re.escape(token.encode()) + rb'(?![\w."])', raw)
    return raw.count(b"\n", 0, found.start()) + 1 if found else None


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[str]:
    """Yield a temporary path for `path`; on success put what was written there onto `path`.

    Only a regular file (or a new path) is replaced atomically: a temporary
    file beside it is renamed onto it, and the parent folder is created. A
    symbolic link is followed to its target, which is then written the same
    way (the link stays). A character device or a FIFO (``/dev/null``,
    ``/dev/stdout``, a named pipe) is never replaced: the bytes are written
    into it once the body has finished. If the body raises, the temporary
    file is removed and `path` is left as it was.

    Raises
    ------
    InputError
        `path` is a folder, a socket or a block device.
    """
    target = Path(os.path.realpath(path))
    kind = _output_kind(path, target)
    folder = target.parent if kind == "file" else None
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    os.close(fd)
    try:
        yield tmp
        if kind == "stream":
            with open(tmp, "rb") as source, open(target, "wb") as sink:
                shutil.copyfileobj(source, sink)
            os.unlink(tmp)
            return
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def sidecar_path(table: str | os.PathLike) -> Path:
    """The JSON sidecar of a table: ``run1.parquet`` (``.csv``, ``.csv.gz``, ...) -> ``run1.meta.json``.

    ``.meta.json`` is a name no ``model.json`` of ``train --out run1.json``
    takes, so ``compensate ... run1.json --out run1.parquet`` keeps the
    model (the sidecar used to be ``run1.json``; an output naming an input
    is still refused, :func:`gyrocomp.commands.guarded`).
    """
    from gyrocomp.compressed import is_compressed

    path = Path(table)
    stem = path.stem if is_compressed(path.name) else path.name
    if Path(stem).suffix.lower() in (".parquet", ".pq", ".csv", ".txt"):
        stem = Path(stem).stem
    return path.with_name(f"{stem}.meta.json")


def _output_kind(path: str | os.PathLike, target: Path) -> str:
    """``"file"`` (a regular file or a new path) or ``"stream"`` (a character device or FIFO) for an output `path` resolving to `target`."""
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        return "file"
    if stat.S_ISREG(mode):
        return "file"
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return "stream"
    what = "a directory" if stat.S_ISDIR(mode) else "a socket" if stat.S_ISSOCK(mode) else "a block device"
    raise InputError(f"{os.fspath(path)}: is {what}, expected a file to write")


def name_part(value, what: str) -> str:
    """`value` (a column, axis or stream name) as one component of a file or folder name.

    A name that holds a path separator, a NUL or is ``.`` or ``..`` (or
    empty) would write outside the output folder (``gy/../../X``, an
    absolute path) or fail half-way through the writes: refused before
    anything is written.

    Raises
    ------
    InputError
        ``<what> '<value>' cannot name a file or folder``.
    """
    text = str(value)
    if text in ("", ".", "..") or any(c in text for c in ("/", "\\", "\x00")):
        raise InputError(f"{what} {text!r} cannot name a file or folder (a path separator, or . or ..); rename the column")
    return text


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
        ``{"name", "sha256"}`` per input
        (:meth:`gyrocomp.recordings.Recording.input_record`).
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


def parquet_header(name: str, meta: dict | None) -> dict:
    """The artefact header stored under ``gyrocomp`` in Parquet key-value metadata, else {}."""
    meta = meta or {}
    if METADATA_KEY not in meta:
        return {}
    header = parse_json(f"{name}: gyrocomp metadata", meta[METADATA_KEY])
    if not isinstance(header, dict):
        raise InputError(f"{name}: gyrocomp metadata: expected a JSON object")
    return header


@contextlib.contextmanager
def open_input(name: str) -> Iterator[BinaryIO]:
    """``open(name, "rb")``, its failures as one-line :class:`InputError` naming the file.

    A device (``/dev/zero``, a disk) is refused: it has no end, or is no
    file; a FIFO (``<(zcat log.gz)``) is read like a file.
    """
    try:
        fh = open(name, "rb")
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{name}: is a directory, expected a file") from None
    except PermissionError:
        raise InputError(f"{name}: permission denied") from None
    with fh:
        mode = os.fstat(fh.fileno()).st_mode
        if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):  # /dev/zero never ends, /dev/sda is no recording
            raise InputError(f"{name}: is a device, not a file (give - to read standard input)")
        yield fh


def read_bytes(path: str | os.PathLike) -> tuple[str, bytes]:
    """Name and bytes of a file (``-`` reads standard input)."""
    if str(path) == "-":
        return "-", sys.stdin.buffer.read()
    name = os.fspath(path)
    with open_input(name) as fh:
        return name, fh.read()


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
