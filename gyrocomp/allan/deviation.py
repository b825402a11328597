"""Overlapping Allan deviation: the integrated rate ("phase") and its second differences.

The rate samples are integrated once (a cumulative sum, the "phase" of NIST
SP 1065 [1]_); every averaging time is then a second difference of that
sum, evaluated in cache-sized chunks so that no array of N x taus, nor a new
N-sized array per tau, is ever built.

The phase is read through a :class:`Phase`: an array in memory, or, for a
recording bigger than memory, a float64 file written chunk by chunk
(:func:`integrate`) and read back window by window. Both run the same
arithmetic on the same numbers, so they give the same bits.

References
----------
.. [1] W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065
       (2008).
"""

from __future__ import annotations

import math
import os
import tempfile
import warnings
from typing import Iterable

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["Phase", "oadev", "integrate", "integrate_stored", "averaging_factors", "second_difference_sums", "check_fs"]

_CHUNK = 1 << 15
"""Samples per chunk of the second-difference sums (256 KiB: with the window and lag buffer of a short tau, within a core's L2 cache).

The 23 octave taus of 10^7 samples take 0.60 s of CPU, against 0.69 s in
chunks of 2^16 (whose arrays spill to L3) and 0.72 s in chunks of 2^13
(more calls). The sums are added chunk by chunk, so the chunk is part of
their rounding: from 2^16 to 2^15 they moved by at most 1.4e-15 (relative).
"""


class Phase:
    """The phase x_0 .. x_N of a rate series, in memory or in a float64 file.

    Parameters
    ----------
    values : ndarray, optional
        The phase in memory.
    path : str, optional
        A file of N + 1 native float64 values (:func:`integrate` writes it).

    Notes
    -----
    :meth:`read` returns x[start:stop:step]: a view in memory, a copy read
    with ``os.pread`` from the file (the page cache holds it, the process
    does not: its peak memory is that of the windows it reads).
    """

    def __init__(self, values: np.ndarray | None = None, path: str | None = None):
        self._values = values
        self._fd = None if path is None else os.open(path, os.O_RDONLY)
        self._len = len(values) if values is not None else os.fstat(self._fd).st_size // 8

    def __len__(self) -> int:
        return self._len

    def read(self, start: int, stop: int, step: int = 1) -> np.ndarray:
        """x[start:stop:step] (0 <= start <= stop <= len)."""
        if self._values is not None:
            return self._values[start:stop:step]
        if step == 1:
            return np.frombuffer(os.pread(self._fd, 8 * (stop - start), 8 * start), dtype=np.float64)
        count = len(range(start, stop, step))
        if step >= _SPARSE_STEP:  # far apart: one read per value
            return np.array([np.frombuffer(os.pread(self._fd, 8, 8 * i), dtype=np.float64)[0] for i in range(start, stop, step)])
        out = np.empty(count)
        per_read = max(1, _CHUNK * 4 // step)  # values per contiguous read
        for at in range(0, count, per_read):
            first = start + at * step
            take = min(per_read, count - at)
            block = np.frombuffer(os.pread(self._fd, 8 * ((take - 1) * step + 1), 8 * first), dtype=np.float64)
            out[at : at + take] = block[::step]
        return out

    def close(self) -> None:
        """Close the file (a phase in memory has nothing to close)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

_SPARSE_STEP = 1 << 13
"""Strides (samples) from which a strided read fetches each value alone rather than the range (64 KiB apart)."""


def oadev(x, fs_hz: float, taus="octave") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of rate samples.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Rate samples (the "fractional frequency" y of [1]_), any unit.
    fs_hz : float
        Sample rate; tau0 = 1/fs_hz.
    taus : {"octave", "decade", "all"} or sequence of float
        ``"octave"``: m = 1, 2, 4, ...; ``"decade"``: m = 1, 2, 5 x 10^k;
        ``"all"``: every m; or taus in seconds, rounded to whole m. Taus
        with fewer than two second differences (2m >= n_samples) are left out.

    Returns
    -------
    tau_s : ndarray
        m / fs_hz.
    adev : ndarray
        Overlapping Allan deviation, in the unit of `x`.
    n : ndarray of int
        Number of second differences at each tau, n_samples - 2m + 1.

    Notes
    -----
    With the phase x_i = tau0 * sum_{k<i} (y_k - mean(y)), x_0 = 0 ([1]_ eq. (4)),

        sigma^2(m tau0) = sum_{i=0}^{n-1} (x_{i+2m} - 2 x_{i+m} + x_i)^2 / (2 n (m tau0)^2)

    ([1]_ eq. (11)), the convention of Stable32 and of allantools
    ``oadev(data_type="freq")``. Memory: one float64 copy of `x`.

    Examples
    --------
    >>> tau, dev, n = oadev([892, 809, 823, 798, 671, 644, 883, 903, 677], 1.0, [1, 2])
    >>> np.round(dev, 5)  # NBS14 10-point set, NIST SP 1065 p. 107
    array([91.22945, 85.95287])
    """
    fs_hz = check_fs(fs_hz)
    phase = Phase(_phase(x))
    m = averaging_factors(taus, len(phase) - 1, fs_hz)
    n = len(phase) - 2 * m
    adev = np.sqrt(second_difference_sums(phase, m) / (2.0 * n * m.astype(float) ** 2))
    return m / fs_hz, adev, n



def integrate(chunks: Iterable[np.ndarray], mean: float, n_samples: int, *, in_memory: bool, folder: str | None = None) -> Phase:
    """The phase of a rate series given chunk by chunk, in memory or spilled to a file.

    ``x_0 = 0, x_{i+1} = sum_{k<=i} (y_k - mean)``, the same running sum
    as :func:`_phase` gives for the whole series (NumPy's cumulative sum
    runs in order, so adding the running total to a chunk's first value
    first gives the same bits).

    Parameters
    ----------
    chunks : iterable of ndarray
        Consecutive rate samples.
    mean : float
        Their mean.
    n_samples : int
        Their total number.
    in_memory : bool
        Keep the phase in memory, else in a temporary file in `folder`
        (default the system's), removed when no longer open.
    """
    if in_memory:
        values = np.empty(n_samples + 1)
        values[0] = 0.0
        at = 1
        for y in chunks:
            part = values[at : at + len(y)]
            np.subtract(y, mean, out=part)
            part[0] += values[at - 1]
            np.cumsum(part, out=part)
            at += len(y)
        return Phase(values)
    handle, path = tempfile.mkstemp(prefix="gyrocomp-phase-", suffix=".f64", dir=folder)
    try:
        with os.fdopen(handle, "wb") as fh:
            carry = 0.0
            fh.write(np.zeros(1).tobytes())
            for y in chunks:
                part = np.subtract(y, mean)
                part[0] += carry
                np.cumsum(part, out=part)
                carry = float(part[-1])
                fh.write(part.tobytes())
        return Phase(path=path)
    finally:
        os.remove(path)  # the open descriptor keeps the data until the phase is closed

def integrate_stored(values: np.ndarray, mean: float) -> Phase:
    """The phase of rate samples kept in ``values[1:]``, computed in place: the bits of :func:`integrate` in memory.

    Parameters
    ----------
    values : ndarray of float64, shape (n_samples + 1,)
        The samples from index 1; overwritten with x_0 = 0 and
        ``x_{i+1} = sum_{k<=i} (y_k - mean)``.
    mean : float
        The samples' mean.
    """
    values[0] = 0.0
    rest = values[1:]
    np.subtract(rest, mean, out=rest)
    rest[0] += values[0]
    np.cumsum(rest, out=rest)
    return Phase(values)


def check_fs(fs_hz) -> float:
    fs = float(fs_hz)
    if not math.isfinite(fs) or fs <= 0:
        raise InputError(f"sample rate fs_hz = {fs_hz!r}; must be a positive number")
    return fs


def _phase(x) -> np.ndarray:
    """x_0 = 0, x_{i+1} = sum_{k<=i} (y_k - mean y), in samples x rate unit ([1]_ eq. (4))."""
    y = np.asarray(x, dtype=float)
    if y.ndim != 1:
        raise InputError(f"rate samples must be 1-D, got shape {y.shape}")
    if len(y) < 3:
        raise InputError(f"Allan deviation needs at least 3 samples, got {len(y)}")
    mean = y.mean()  # finite exactly when every sample is (NaN and inf propagate), else look closer
    if not math.isfinite(mean) and not np.isfinite(y).all():
        i = int(np.flatnonzero(~np.isfinite(y))[0])
        raise InputError(f"rate sample {i} is {y[i]!r}; the Allan deviation needs finite values")
    phase = np.empty(len(y) + 1)
    phase[0] = 0.0
    np.subtract(y, mean, out=phase[1:])
    np.cumsum(phase[1:], out=phase[1:])
    return phase


def averaging_factors(taus, n_samples: int, fs_hz: float) -> np.ndarray:
    """Whole averaging factors m with 2m < n_samples, sorted and unique."""
    m_max = (n_samples - 1) // 2
    if isinstance(taus, str) and taus in ("octave", "decade", "all"):
        if taus == "all":
            m = np.arange(1, m_max + 1)
        elif taus == "octave":
            m = 2 ** np.arange(int(math.log2(max(m_max, 1))) + 1)
        else:
            decades = 10 ** np.arange(int(math.log10(max(m_max, 1))) + 1)
            m = np.outer(decades, [1, 2, 5]).ravel()
        return m[m <= m_max].astype(np.int64)
    if isinstance(taus, str):
        try:
            taus = [float(t) for t in taus.split(",") if t.strip()]
        except ValueError:
            raise InputError(
                f"taus = {taus!r}; use octave, decade, all or a comma-separated list of seconds"
            ) from None
    tau = np.asarray(taus, dtype=float).ravel()
    if tau.size == 0 or not np.isfinite(tau).all() or (tau <= 0).any():
        raise InputError(f"taus = {list(tau)!r}; need positive finite seconds")
    m = np.unique(np.round(tau * fs_hz)).astype(np.int64)
    m = m[m >= 1]
    dropped = m[m > m_max]
    if dropped.size:
        warnings.warn(
            f"taus {', '.join(f'{v / fs_hz:g}' for v in dropped)} s left out: a record of "
            f"{n_samples} samples reaches tau = {m_max / fs_hz:g} s",
            stacklevel=3,
        )
    m = m[m <= m_max]
    if m.size == 0:
        raise InputError(f"no tau fits a record of {n_samples} samples at {fs_hz:g} Hz")
    return m


def second_difference_sums(phase: Phase, m: np.ndarray) -> np.ndarray:
    """sum_i (x_{i+2m} - 2 x_{i+m} + x_i)^2 for every m, chunk by chunk.

    The outer loop walks the record in chunks, the inner loop the taus, so
    the windows of a short tau are still in cache when read again. For
    m <= chunk the second difference is taken as a difference of the lag-m
    first differences D_i = x_{i+m} - x_i (one pass fewer).
    """
    total = np.zeros(len(m))
    diff = np.empty(2 * _CHUNK)
    buf = np.empty(_CHUNK)
    n = len(phase) - 2 * m
    short = int(max([int(k) for k in m if k <= _CHUNK], default=0))
    for start in range(0, int(n.max()), _CHUNK):
        # one window serves every m <= chunk: x[start : start + chunk + 2m]
        window = phase.read(start, min(start + _CHUNK + 2 * short, len(phase)))
        for j, k in enumerate(m):
            k = int(k)
            stop = min(start + _CHUNK, int(n[j]))
            if stop <= start:
                continue
            size = stop - start
            w = buf[:size]
            if k <= _CHUNK:
                d = diff[: size + k]
                np.subtract(window[k : size + 2 * k], window[: size + k], out=d)
                np.subtract(d[k:], d[:size], out=w)
            else:
                np.add(phase.read(start + 2 * k, stop + 2 * k), phase.read(start, stop), out=w)
                mid = phase.read(start + k, stop + k)
                np.subtract(w, mid, out=w)
                np.subtract(w, mid, out=w)
            total[j] += np.einsum("i,i->", w, w)
    return total


