"""Compressed CSV in: one checked, bounded stream for ``.gz``, ``.bz2``, ``.xz``, ``.zst`` and ``.zip``.

pandas decompresses each format its own way, and not all of them say when
something is wrong: a ``.csv.zst`` cut short is read up to its last
complete block (a log cut at 60 % trained on 60 % of its samples), a
damaged ``.zip`` raises ``BadZipFile`` naming no file, and nothing bounds
what a small file expands to (a 1 MB ``.csv.gz`` holding one 1 GiB field
ended in ``MemoryError``). :func:`open_csv` gives both CSV readers
(:func:`gyrocomp.recordings.read_recording` and
:mod:`gyrocomp.streaming`) the same binary stream, which refuses, as one
:class:`~gyrocomp.errors.InputError` naming the file:

* a stream that ends before its format's end marker (every format);
* more decompressed bytes than :attr:`FileLimits.max_decompressed_gib`;
* a line longer than :attr:`FileLimits.max_line_bytes`;
* a damaged or empty archive, or a ``.zip`` holding other than one file.

A ``.zst`` or ``.gz`` of several concatenated frames or members is read
whole, as ``zstd -d`` and ``gunzip`` do.
"""

from __future__ import annotations

import bz2
import contextlib
import dataclasses
import gzip
import io
import lzma
import os
import zipfile
import zlib
from pathlib import Path
from typing import Iterator, TextIO

from gyrocomp.errors import InputError

__all__ = ["FileLimits", "open_csv", "is_compressed", "csv_compression", "csv_writer"]

_SUFFIXES = (".gz", ".bz2", ".xz", ".zst", ".zip")

_METHODS = {".gz": "gzip", ".bz2": "bz2", ".xz": "xz", ".zst": "zstd", ".zip": "zip"}
"""The compression of each extension :func:`open_csv` reads (pandas' names)."""

_READ_BYTES = 1 << 16
"""Compressed bytes read at a time."""


@dataclasses.dataclass(frozen=True)
class FileLimits:
    """Bounds of a compressed recording (``configs/recordings.toml``, ``[files]``).

    Parameters
    ----------
    max_decompressed_gib : float, default=256
        Largest decompressed CSV [GiB]: a week at 1 kHz of 16 columns of
        20 characters is 6.05e8 rows of 336 bytes, 189 GiB.
    max_line_bytes : int, default=1048576
        Longest CSV line [bytes]: a row of a recording is under 1 KiB, a
        header of a thousand columns under 64 KiB.
    """

    max_decompressed_gib: float = 256.0
    max_line_bytes: int = 1 << 20


def is_compressed(name: str) -> bool:
    """Whether `name` ends in one of the compressed-CSV extensions."""
    return Path(name).suffix.lower() in _SUFFIXES


def csv_compression(name: str | os.PathLike) -> dict | None:
    """How the CSV `name` is compressed (``x.csv.gz`` and the other extensions read here): ``{"method": ...}``, None when it is not.

    A ``.zip`` holds one file named as the archive without ``.zip``
    (``archive_name``), which is what :func:`open_csv` reads back.
    """
    path = Path(name)
    method = _METHODS.get(path.suffix.lower())
    if method is None:
        return None
    if Path(path.stem).suffix.lower() not in (".csv", ".txt"):
        raise InputError(f"{name}: a compressed table must be CSV ({''.join(path.suffixes[-2:])!r}); use e.g. .csv.gz")
    return {"method": method, "archive_name": path.stem} if method == "zip" else {"method": method}


@contextlib.contextmanager
def csv_writer(target: str | os.PathLike, name: str | os.PathLike) -> Iterator[TextIO]:
    """A text stream writing CSV into the file `target`, compressed as the extension of `name` says (:func:`csv_compression`).

    `target` is where the bytes go (a temporary file that becomes `name`);
    the stream is one compressed frame, member or archive entry, however
    many writes it takes, and is finished when the context closes.
    """
    compression = csv_compression(name)
    method = None if compression is None else compression["method"]
    with contextlib.ExitStack() as stack:
        if method is None:
            stream = stack.enter_context(open(target, "w", newline="", encoding="utf-8"))
        elif method == "zip":
            archive = stack.enter_context(zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED))
            raw = stack.enter_context(archive.open(compression["archive_name"], "w", force_zip64=True))
            stream = stack.enter_context(io.TextIOWrapper(raw, encoding="utf-8", newline=""))
        elif method == "zstd":
            import zstandard

            stream = stack.enter_context(zstandard.open(target, "wt", encoding="utf-8", newline=""))
        elif method == "gzip":  # no name and no time in the header: the same table gives the same bytes
            raw = stack.enter_context(open(target, "wb"))
            member = stack.enter_context(gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0))
            stream = stack.enter_context(io.TextIOWrapper(member, encoding="utf-8", newline=""))
        else:
            opener = {"bz2": bz2.open, "xz": lzma.open}[method]
            stream = stack.enter_context(opener(target, "wt", encoding="utf-8", newline=""))
        yield stream


def open_csv(name: str, limits: FileLimits = FileLimits()) -> io.BufferedReader:
    """A binary stream of the decompressed CSV of the file `name` (checked as the module says).

    Raises
    ------
    InputError
        The file is missing or unreadable, or the archive is damaged or
        empty (at once); while reading: truncation, a bound crossed.
    """
    suffix = Path(name).suffix.lower()
    try:
        raw = open(name, "rb")
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{name}: is a directory, expected a file") from None
    except PermissionError:
        raise InputError(f"{name}: permission denied") from None
    if suffix == ".zip":
        raw = _zip_member(name, raw)
        return io.BufferedReader(_Checked(name, raw, None, limits), buffer_size=_READ_BYTES)
    return io.BufferedReader(_Checked(name, raw, _DECOMPRESSORS[suffix], limits), buffer_size=_READ_BYTES)


def _zstd():
    import zstandard

    return zstandard.ZstdDecompressor().decompressobj()


_DECOMPRESSORS = {
    ".gz": lambda: zlib.decompressobj(wbits=zlib.MAX_WBITS | 16),
    ".bz2": bz2.BZ2Decompressor,
    ".xz": lzma.LZMADecompressor,
    ".zst": _zstd,
}
"""A fresh decompressor of one frame (member, stream) per extension; each has ``decompress``, ``eof`` and ``unused_data``."""


_ZIP_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflate", zipfile.ZIP_BZIP2: "bzip2", zipfile.ZIP_LZMA: "lzma"}
"""The zip compression methods Python's zipfile decompresses (method number: name)."""


def _zip_member(name: str, raw):
    """The one member of a ``.zip`` as a stream (zipfile checks its CRC at the end)."""
    try:
        archive = zipfile.ZipFile(raw)
        members = [m for m in archive.infolist() if not m.is_dir()]
        if len(members) != 1:
            raise InputError(f"{name}: a zipped recording holds exactly one file, this one {len(members)}")
        member = members[0]
        if member.compress_type not in _ZIP_METHODS:
            raise InputError(f"{name}: {member.filename} is compressed with zip method {member.compress_type}, which gyrocomp does not read "
                             f"({', '.join(_ZIP_METHODS.values())}); recompress it, or decompress it first")
        return archive.open(member)
    except InputError:
        raw.close()
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError) as err:
        raw.close()
        raise InputError(f"{name}: damaged zip archive ({err})") from None


class _Checked(io.RawIOBase):
    """Decompressed bytes of `raw` (already decompressed when `make` is None), checked for truncation and bounds."""

    def __init__(self, name: str, raw, make, limits: FileLimits):
        self.name = name
        self._raw = raw
        self._make = make
        self._decompressor = make() if make is not None else None
        self._limits = limits
        self._max_bytes = int(limits.max_decompressed_gib * (1 << 30))
        self._input = b""  # compressed bytes read but not yet given to the decompressor
        self._pending = b""  # decompressed bytes not yet handed out
        self._total = 0
        self._line = 0  # bytes since the last newline

    def readable(self) -> bool:
        return True

    def close(self) -> None:
        if not self.closed:
            self._raw.close()
        super().close()

    def readinto(self, buffer) -> int:
        if not self._pending:
            self._pending = self._next_piece()
        n = min(len(buffer), len(self._pending))
        buffer[:n] = self._pending[:n]
        self._pending = self._pending[n:]
        return n

    def _next_piece(self) -> bytes:
        """The next decompressed bytes (at most ``max_line_bytes``, b"" at the end), checked."""
        try:
            piece = self._raw.read(self._limits.max_line_bytes) if self._make is None else self._decompress()
        except InputError:
            raise
        except Exception as err:  # each library its own: OSError, EOFError, zlib.error, LZMAError, BadZipFile, ZstdError
            raise InputError(f"{self.name}: damaged compressed file after {self._total} decompressed bytes ({err})") from None
        self._check(piece)
        return piece

    def _decompress(self) -> bytes:
        d = self._decompressor
        while True:
            if d.eof:  # a frame (member) ended: another may follow, as in `cat a.gz b.gz`
                self._input = d.unused_data + self._input or self._raw.read(_READ_BYTES)
                if not self._input:
                    return b""
                self._decompressor = d = self._make()
            if not self._input and _needs_input(d):
                self._input = self._raw.read(_READ_BYTES)
                if not self._input:
                    if self._total == 0:
                        return b""  # an empty file: the CSV reader says so
                    raise InputError(
                        f"{self.name}: truncated: the compressed stream ends after {self._total} decompressed bytes, before its end marker"
                    )
            piece = self._feed(d)
            if piece:
                return piece

    def _feed(self, d) -> bytes:
        """Give the decompressor input and take at most ``max_line_bytes`` of output."""
        limit = self._limits.max_line_bytes
        if isinstance(d, (bz2.BZ2Decompressor, lzma.LZMADecompressor)):
            data, self._input = self._input, b""
            return d.decompress(data, max_length=limit)  # keeps what it did not use
        if isinstance(d, _ZLIB):
            piece = d.decompress(self._input, limit)
            self._input = d.unconsumed_tail
            return piece
        # zstandard takes no output bound: feed it slices of _ZSTD_SLICE bytes,
        # which expand to at most 128 MiB (a 128 KiB block takes >= 4 input bytes).
        data, self._input = self._input[:_ZSTD_SLICE], self._input[_ZSTD_SLICE:]
        return d.decompress(data)

    def _check(self, piece: bytes) -> None:
        """Refuse when the decompressed total or a line passes its bound."""
        before = self._total
        self._total += len(piece)
        if self._total > self._max_bytes:
            raise InputError(
                f"{self.name}: decompresses to more than max_decompressed_gib = {self._limits.max_decompressed_gib:g} GiB "
                "(configs/recordings.toml [files])"
            )
        last = piece.rfind(b"\n")
        if last < 0:
            self._line += len(piece)
            longest = self._line
        else:
            longest = self._line + piece.find(b"\n")
            if len(piece) > self._limits.max_line_bytes:  # else the lines inside it are shorter than the bound
                longest = max(longest, *map(len, piece[:last].split(b"\n")))
            self._line = len(piece) - last - 1
        if longest > self._limits.max_line_bytes:
            raise InputError(
                f"{self.name}: a line longer than max_line_bytes = {self._limits.max_line_bytes} bytes, near decompressed byte {before} "
                "(configs/recordings.toml [files]); not a recording"
            )


_ZLIB = type(zlib.decompressobj())

_ZSTD_SLICE = 4096
"""Compressed bytes given to zstandard at a time (its decompressor takes no bound on its output)."""


def _needs_input(d) -> bool:
    """Whether a decompressor has nothing left to give without more input."""
    return getattr(d, "needs_input", True)
