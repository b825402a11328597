"""LCD of a long record block by block, its components and sifting iterates on disk.

:func:`gyrocomp.decompose.lcd.lcd` holds the record, its components, its
sifting iterates, extrema and baseline spline in memory: about 150 bytes a
sample at its peak, so memory grows with the log. :func:`lcd_on_disk`
computes the same decomposition (Cao et al. 2021, eqs. (4)-(11); see
:mod:`gyrocomp.decompose.lcd`) with every pass over the record reading and
writing ``block`` samples at a time from files in a directory
(:class:`RowFile`: ``os.preadv``/``os.pwrite``, never a memory map, so the
pages read stay in the page cache and out of the process). Step by step,
against the whole-record computation:

* **extrema** (eq. (4)) are found in each block with margins that hold
  every plateau touching the block whole: *exact*, the same positions;
* the **mirrored end extrema** (step 3) use only the record's first and
  last three extrema of each kind: *exact*;
* the **baseline points** ``L_u`` (eqs. (5)-(6)) need only their two
  neighbours: *exact*, the same bits;
* the **baseline spline** (eq. (7)) is global. For each block it is solved
  on the knots of the block and ``overlap`` knots on either side, with
  not-a-knot ends there: a *bounded* join. The slopes solve a system
  diagonally dominant 2:1, so the error of an artificial end decays
  geometrically into the window (by 2 - sqrt(3) = 0.27 a knot on even
  knots): with 64 knots it is below rounding. A window that reaches both
  ends of the record is the whole record's system: the same bits;
* **SD** (eq. (9)) is summed block by block: the same sums in another
  order, so it differs by rounding; it only decides, against ``sd_stop``,
  whether to sift again.

A component therefore equals the whole-record one to rounding where the
sifting makes no comparison within rounding (an extremum between two
samples equal to 1e-16, an SD at the threshold); where it does, the
iterates part locally. The measured change of a trained model is in
``docs/performance.md`` (training memory, PE-LCD-ANFIS).
"""

from __future__ import annotations

import os
from typing import Callable

import numpy as np

from gyrocomp.decompose.emd import _extrema, _mirror, _spline_pieces, _spline_values
from gyrocomp.decompose.lcd import baseline_points

__all__ = ["BLOCK", "OVERLAP", "RowFile", "lcd_on_disk"]

BLOCK = 1 << 18
"""Samples a pass over a long record reads and writes at a time (2 MB a row); a record longer than this decomposes on disk in training."""

OVERLAP = 64
"""Knots on either side of a block in its baseline spline's window (their end error decays below rounding; module notes)."""


class RowFile:
    """Rows of `n` values of one dtype in a file, read and written a range at a time.

    Parameters
    ----------
    path : path-like
        Created (or truncated) and sized to ``rows * n`` values.
    rows, n : int
    dtype : numpy dtype
    """

    def __init__(self, path, rows: int, n: int, dtype=np.float64):
        self.path, self.rows, self.n, self.dtype = os.fspath(path), rows, n, np.dtype(dtype)
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o600)
        os.ftruncate(self._fd, rows * n * self.dtype.itemsize)

    def read(self, row: int, lo: int, hi: int) -> np.ndarray:
        """Values ``lo .. hi - 1`` of `row`, a new array."""
        out = np.empty(max(0, hi - lo), self.dtype)
        view, offset, done = memoryview(out).cast("B"), (row * self.n + lo) * self.dtype.itemsize, 0
        while done < len(view):
            got = os.preadv(self._fd, [view[done:]], offset + done)
            if got <= 0:
                raise EOFError(f"{self.path}: short read at byte {offset + done}")
            done += got
        return out

    def write(self, row: int, lo: int, values) -> None:
        """Store `values` from position `lo` of `row`."""
        values = np.ascontiguousarray(values, dtype=self.dtype)
        view, offset, done = memoryview(values).cast("B"), (row * self.n + lo) * self.dtype.itemsize, 0
        while done < len(view):
            done += os.pwrite(self._fd, view[done:], offset + done)

    def close(self) -> None:
        os.close(self._fd)


class _Row:
    """One row of a :class:`RowFile` as :func:`~gyrocomp.decompose.emd._mirror` reads it: its size and single values."""

    def __init__(self, store: RowFile, row: int):
        self.store, self.row, self.size = store, row, store.n

    def read(self, lo: int, hi: int) -> np.ndarray:
        return self.store.read(self.row, lo, hi)

    def write(self, lo: int, values) -> None:
        self.store.write(self.row, lo, values)

    def __getitem__(self, i: int) -> float:
        return float(self.read(int(i), int(i) + 1)[0])


def lcd_on_disk(
    x,
    directory,
    *,
    q: float = 0.5,
    sd_stop: float = 0.3,
    max_components: int = 10,
    max_sift: int = 10,
    block: int = BLOCK,
    overlap: int = OVERLAP,
    callback: Callable[[int, int], None] | None = None,
) -> tuple[RowFile, int]:
    """LCD of `x` as :func:`gyrocomp.decompose.lcd.lcd`, `block` samples at a time, into a file.

    Parameters
    ----------
    x : ndarray, shape (n_samples,)
        The record (read a block at a time).
    directory : path-like
        Where the components and the scratch files go (a temporary directory).
    q, sd_stop, max_components, max_sift, callback
        As :func:`~gyrocomp.decompose.lcd.lcd`.
    block : int
        Samples a pass handles at a time.
    overlap : int
        Knots on either side of a block in its baseline spline's window.

    Returns
    -------
    components : RowFile
        ``max_components + 1`` rows of ``n_samples``: the ISCs, fastest
        first, then the trend; rows past the trend are unused.
    count : int
        ISCs and trend, ``k + 1``.
    """
    n = int(np.size(x))
    out = RowFile(os.path.join(directory, "components.f8"), max_components + 1, n)
    scratch = RowFile(os.path.join(directory, "sifting.f8"), 2, n)
    knots = RowFile(os.path.join(directory, "extrema.f8"), 1, n)
    places = RowFile(os.path.join(directory, "extrema.i8"), 1, n, np.int64)
    try:
        for lo in range(0, n, block):
            out.write(0, lo, x[lo : lo + block])
        k = 0
        while k < max_components:
            trend = _Row(out, k)
            found = _extrema_pass(trend, block, knots, places)
            if found["count"] < 3:
                break
            isc = _sift(trend, found, scratch, knots, places, q, sd_stop, max_sift, block, overlap)
            for lo in range(0, n, block):
                hi = min(n, lo + block)
                values = trend.read(lo, hi)
                part = isc.read(lo, hi) if isc is not None else np.zeros(hi - lo)
                out.write(k + 1, lo, values - part)
                out.write(k, lo, part)
            k += 1
            if callback is not None:
                callback(k, max_components)
        if callback is not None:
            callback(max_components, max_components)
    except BaseException:
        out.close()
        raise
    finally:
        for store in (scratch, knots, places):
            store.close()
    return out, k + 1


def _sift(trend: _Row, found: dict, scratch: RowFile, knots, places, q, sd_stop, max_sift, block, overlap):
    """One ISC (:func:`gyrocomp.decompose.emd._sift` with the baseline of eq. (7) and the SD rule), or None when none exists."""
    h, count = trend, 0
    while True:
        ends = _ends(h, found, knots, places)
        if ends is None:
            return h if count else None
        target = _Row(scratch, count % 2)
        change, energy = _baseline_pass(h, found, ends, target, knots, places, q, block, overlap)
        h, count = target, count + 1
        if count >= max_sift or not change > sd_stop * energy:
            return h
        found = _extrema_pass(h, block, knots, places)


def _extrema_pass(row: _Row, block: int, knots: RowFile, places: RowFile) -> dict:
    """Extrema of a row (positions and values, in order, to `places` and `knots`), block by block.

    Returns the count, the count before each block, and the first and last
    three maxima and minima (what the mirror rule reads).
    """
    n = row.size
    before, total = [0], 0
    head = {"max": [], "min": []}
    tail = {"max": [], "min": []}
    for lo in range(0, n, block):
        hi = min(n, lo + block)
        values, start = _window(row, lo, hi)
        imax, imin = _extrema(values[None])
        inner = slice(lo - start, hi - start)
        for kind, mask in (("max", imax[0, inner]), ("min", imin[0, inner])):
            at = (np.flatnonzero(mask) + lo).tolist()
            head[kind] += at[: 3 - len(head[kind])]
            tail[kind] = (tail[kind] + at[-3:])[-3:]
        where = np.flatnonzero(imax[0, inner] | imin[0, inner])
        places.write(0, total, where + lo)
        knots.write(0, total, values[where + (lo - start)])
        total += where.size
        before.append(total)
    return {"count": total, "before": before, "head": head, "tail": tail}


def _window(row: _Row, lo: int, hi: int, margin: int = 16) -> tuple[np.ndarray, int]:
    """Samples around ``lo .. hi - 1`` in which every extremum of that range is found as in the whole row.

    The window reaches one sample past each end of the range, and past the
    run of equal samples through each end (a plateau is one extremum at its
    middle, or none when it touches an end of the row), widened until it does.
    """
    n = row.size
    while True:
        start, stop = max(0, lo - margin), min(n, hi + margin)
        values = row.read(start, stop)
        left = start == 0 or np.any(values[: lo - start] != values[1 : lo - start + 1])
        right = stop == n or np.any(values[hi - start : stop - start] != values[hi - start - 1 : stop - start - 1])
        if left and right:
            return values, start
        margin *= 4


def _ends(row: _Row, found: dict, knots, places):
    """The mirrored end knots of a row (sorted positions and values), or None when the row has no baseline.

    As :func:`gyrocomp.decompose.lcd._baseline`: at least three extrema,
    ends that :func:`~gyrocomp.decompose.emd._mirror` can build, and
    strictly increasing knots. The left mirror points lie before the first
    extremum and the right ones after the last, so the whole sequence is
    the left points, the extrema in order and the right points.
    """
    if found["count"] < 3:
        return None
    head, tail = found["head"], found["tail"]
    ends = _mirror(head["max"], tail["max"], head["min"], tail["min"], row)
    if ends is None:
        return None
    (lt_max, lz_max, rt_max, rz_max), (lt_min, lz_min, rt_min, rz_min) = ends
    sides = []
    for t, z in (((lt_max, lt_min), (lz_max, lz_min)), ((rt_max, rt_min), (rz_max, rz_min))):
        t = np.concatenate([np.asarray(p, dtype=np.int64) for p in t])
        z = np.concatenate([np.asarray(p, dtype=float) for p in z])
        order = np.argsort(t, kind="stable")
        t, z = t[order], z[order]
        if np.any(np.diff(t) <= 0):
            return None
        sides.append((t, z))
    return sides


def _sequence(found: dict, ends, knots, places, i0: int, i1: int) -> tuple[np.ndarray, np.ndarray]:
    """Knots ``i0 .. i1 - 1`` of the whole sequence: left mirror points, extrema, right mirror points."""
    (lt, lz), (rt, rz) = ends
    m = found["count"]
    a, b = max(0, i0 - lt.size), min(m, i1 - lt.size)
    t = np.concatenate((lt[i0:i1], places.read(0, a, b) if b > a else np.empty(0, np.int64), rt[max(0, i0 - lt.size - m) : max(0, i1 - lt.size - m)]))
    z = np.concatenate((lz[i0:i1], knots.read(0, a, b) if b > a else np.empty(0), rz[max(0, i0 - lt.size - m) : max(0, i1 - lt.size - m)]))
    return t, z


def _baseline_pass(h: _Row, found: dict, ends, target: _Row, knots, places, q, block: int, overlap: int) -> tuple[float, float]:
    """Write ``h - DL`` (eq. (7)) to `target`, block by block; return the sums of ``DL^2`` and ``h^2`` (eq. (9))."""
    n, left = h.size, ends[0][0].size
    total = left + found["count"] + ends[1][0].size
    change = energy = 0.0
    cached = None
    for k, lo in enumerate(range(0, n, block)):
        hi = min(n, lo + block)
        i0 = max(0, left + found["before"][k] - overlap - 2)
        i1 = min(total, left + found["before"][k + 1] + overlap + 2)
        if cached is None or cached[0] != (i0, i1):
            t, z = _sequence(found, ends, knots, places, i0, i1)
            spline = t[1:-1]
            pieces = _spline_pieces((spline, baseline_points(t, z, q), np.array([spline.size])))
            cached = ((i0, i1), np.clip(spline, 0, n), pieces)
        _, positions, pieces = cached
        samples = np.arange(lo, hi)
        g = np.clip(np.searchsorted(positions, samples, side="right") - 1, 0, positions.size - 2)
        base = _spline_values(pieces, g, samples.astype(float))
        values = h.read(lo, hi)
        energy += float(np.dot(values, values))
        change += float(np.dot(base, base))
        target.write(lo, values - base)
    return change, energy
