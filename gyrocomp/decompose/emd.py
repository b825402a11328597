"""Empirical mode decomposition (EMD) with a batched, vectorised sifting core.

The sifting follows G. Rilling's reference ``emd.m`` [2]_, which the
ICEEMDAN authors' code [3]_ calls: extrema by sign changes of the first
difference (a plateau counts once, at its middle), two extrema mirrored at
each end (``boundary_conditions``, ``nbsym = 2``), not-a-knot cubic-spline
envelopes (MATLAB ``spline``), and Rilling's stopping rule [2]_ or Huang's
SD rule [1]_.

Speed comes from sifting many signals at once: the spline systems of every
envelope of a batch are stacked into one block-diagonal tridiagonal system
(one LAPACK ``gtsv`` call) and the envelopes are evaluated interval by
interval with ``np.repeat``. Rows never mix: the blocks of the stacked
system are decoupled by exact zeros, so a row's result has the same bytes in
any batch, which keeps ensembles reproducible for any number of workers.

References
----------
.. [1] N. E. Huang et al., "The empirical mode decomposition and the Hilbert
   spectrum for nonlinear and non-stationary time series analysis",
   Proc. R. Soc. Lond. A 454, 903-995 (1998), eq. (5.5) (SD criterion).
.. [2] G. Rilling, P. Flandrin, P. Goncalves, "On empirical mode
   decomposition and its algorithms", IEEE-EURASIP NSIP (2003), section 3.2
   (stopping rule with thresholds theta1, theta2, alpha).
.. [3] M. A. Colominas, G. Schlotthauer, M. E. Torres, "Improved complete
   ensemble EMD", Biomed. Signal Process. Control 14, 19-29 (2014).
.. [4] N. E. Huang, M.-L. C. Wu, S. R. Long et al., "A confidence limit for
   the empirical mode decomposition and Hilbert spectral analysis",
   Proc. R. Soc. Lond. A 459, 2317-2345 (2003) (S-number).
.. [5] Z. Wu, N. E. Huang, "Ensemble empirical mode decomposition: a
   noise-assisted data analysis method", Adv. Adapt. Data Anal. 1, 1-41
   (2009) (fixed number of siftings).
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["Sifting", "emd", "sift", "local_mean", "count_extrema"]

_NBSYM = 2
"""Extrema mirrored at each end (``nbsym`` of Rilling's ``emd.m``)."""

STOPS = ("rilling", "sd", "s_number", "fixed")
"""Sifting stopping rules (see :class:`Sifting`)."""

_TINY = 1e-10
"""Rilling's ``emd.m`` ends the decomposition when a residue's peak falls below this fraction of the input's."""


@dataclasses.dataclass(frozen=True)
class Sifting:
    """How one IMF is sifted out.

    Parameters
    ----------
    stop : {"rilling", "sd", "s_number", "fixed"}
        ``"rilling"``: stop when ``|m(t)|/a(t) < theta1`` on all but a
        fraction `alpha` of the samples and ``< theta2`` everywhere, with m
        the mean and a the half-difference of the envelopes, and the numbers
        of extrema and zero crossings differ by at most one ([2]_).
        ``"sd"``: stop when ``sum(m**2) / sum(h**2) <= sd_threshold`` ([1]_,
        the energy-weighted form of eq. (5.5)).
        ``"s_number"``: stop when `s_number` consecutive sifting results
        have numbers of extrema and zero crossings that differ by at most
        one and stay the same ([4]_, section 3).
        ``"fixed"``: exactly `max_sift` siftings ([5]_, section 3: about 10
        for ensemble EMD).
    thresholds : tuple of float
        ``(theta1, theta2, alpha)`` of the Rilling rule.
    sd_threshold : float
        Threshold of the SD rule.
    s_number : int
        S of the S-number rule (Huang et al. 2003 suggest 4 to 8).
    max_sift : int
        Most sifting iterations per IMF (``MAXITERATIONS`` of ``emd.m``,
        ``MaxIter`` of Colominas' ``iceemdan.m``).

    Notes
    -----
    Default: 10 fixed siftings, Wu and Huang's choice for ensemble EMD
    ([5]_). Measured on the tests' two tones with ICEEMDAN-10: correlation
    of the slow tone with its mode 0.979 (fixed 10), 0.983 (Rilling, bound
    2000), 0.933 (Rilling, bound 10: realisations stopping at different
    sifts blur the average). Rilling with ``emd.m``'s bound 2000 costs ~15x
    more on noise (about 60 sifts per IMF, some slow IMFs never pass): see
    benchmarks/README.md. All four rules stay available.
    """

    stop: str = "fixed"
    thresholds: tuple = (0.05, 0.5, 0.05)
    sd_threshold: float = 0.2
    s_number: int = 4
    max_sift: int = 10

    def __post_init__(self):
        if self.stop not in STOPS:
            raise ValueError(f"stop = {self.stop!r}; choose one of {', '.join(STOPS)}")
        if self.s_number < 1:
            raise ValueError(f"s_number = {self.s_number}; must be at least 1")
        if len(self.thresholds) != 3 or min(self.thresholds) < 0:
            raise ValueError(f"thresholds = {self.thresholds!r}; expected three non-negative numbers (theta1, theta2, alpha)")
        if self.max_sift < 1:
            raise ValueError(f"max_sift = {self.max_sift}; must be at least 1")


def emd(x, sifting: Sifting = Sifting(), max_imfs: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Empirical mode decomposition of a 1-D signal.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Signal, uniformly sampled; any unit.
    sifting : Sifting
        Stopping rule and bounds of the sifting.
    max_imfs : int, default=30
        Most IMFs; what is left stays in the residue.

    Returns
    -------
    imfs : ndarray, shape (k, n_samples)
        Intrinsic mode functions, fastest first.
    residue : ndarray, shape (n_samples,)
        ``x - imfs.sum(0)``; fewer than three extrema unless `max_imfs` ended
        the decomposition.

    Notes
    -----
    As in Rilling's ``emd.m``: a mode is sifted from the residue while it
    has at least three extrema, and the decomposition ends early when the
    residue's peak is below 1e-10 of the input's.
    """
    x = np.asarray(x, dtype=float)
    residue = x.copy()
    peak = np.max(np.abs(x)) if x.size else 0.0
    imfs = []
    while len(imfs) < max_imfs and count_extrema(residue[None])[0] >= 3:
        if np.max(np.abs(residue)) < _TINY * peak:
            break
        imf = sift(residue[None], sifting)[0]
        imfs.append(imf)
        residue = residue - imf
    return (np.array(imfs) if imfs else np.empty((0, x.size))), residue


def sift(rows: np.ndarray, sifting: Sifting = Sifting()) -> np.ndarray:
    """First IMF of every row, sifted in one batch.

    Parameters
    ----------
    rows : ndarray, shape (n_rows, n_samples)
    sifting : Sifting

    Returns
    -------
    ndarray, shape (n_rows, n_samples)
        The first IMF of each row; zero for a row with fewer than three
        extrema (its local mean is the row itself).
    """
    rows = np.ascontiguousarray(rows, dtype=float)
    compiled = _compiled()
    if compiled is None:
        return _sift(rows, sifting, _mean_envelope, _energy_stop(sifting))
    theta1, theta2, alpha = (float(v) for v in sifting.thresholds)
    return compiled.sift_rows(
        rows, compiled.STOPS[sifting.stop], theta1, theta2, alpha,
        float(sifting.sd_threshold), int(sifting.s_number), int(sifting.max_sift),
    )


def local_mean(rows: np.ndarray, sifting: Sifting = Sifting()) -> np.ndarray:
    """Local mean ``M(y) = y - IMF1(y)`` of every row ([3]_ section 3)."""
    return rows - sift(rows, sifting)


def count_extrema(rows: np.ndarray) -> np.ndarray:
    """Number of local extrema (maxima + minima) per row, plateaus counted once."""
    imax, imin = _extrema(np.atleast_2d(rows))
    return imax.sum(axis=1) + imin.sum(axis=1)


def _compiled():
    """The numba kernel module, or None without numba (the numpy path then runs).

    The kernel fuses the numpy path's array passes and gives the same
    result (tests/decompose compare them); numba is imported here, on first
    use, never at ``gyrocomp --help``.
    """
    try:
        from gyrocomp.decompose import _compiled as kernel
    except ImportError:
        return None
    return kernel


def _sift(rows, sifting, mean_fn, energy_stop=None, **mean_kw):
    """Sift each row until its stopping rule holds.

    `mean_fn(h, sifting, **mean_kw)` returns the mean to remove, which rows
    could be sifted at all, and which rows already pass a stopping rule
    tested before the subtraction (Rilling's). With `energy_stop`, a row
    also stops after a subtraction that removed at most that fraction of its
    energy (SD rule). A row that could not be sifted at the first iteration
    has no IMF (zeros); one that stops later keeps its last iterate.
    """
    h = np.array(rows, dtype=float, copy=True)
    has_imf = np.zeros(h.shape[0], bool)
    active = np.arange(h.shape[0])
    streak = np.zeros((h.shape[0], 3), np.int64)  # S-number: run length, extrema, zero crossings
    count = 0
    while active.size:
        sub = h[active]
        mean, ok, passed = mean_fn(sub, sifting, **mean_kw)
        if sifting.stop == "s_number":
            passed = _s_number(sub, streak, active, count, sifting.s_number)
        if count == 0:
            has_imf[active[ok]] = True
        go = ok & ~passed
        moved = sub[go] - mean[go]
        h[active[go]] = moved
        count += 1
        keep = go.copy()
        if energy_stop is not None and go.any():
            energy = np.einsum("ij,ij->i", sub[go], sub[go])
            change = np.einsum("ij,ij->i", mean[go], mean[go])
            keep[go] = change > energy_stop * energy
        if count >= sifting.max_sift:
            break
        active = active[keep]
    h[~has_imf] = 0.0
    return h


def _s_number(rows, streak, active, count, s_number):
    """Update the S-number runs of the active rows ([4]_); True where a run reached S."""
    n_ext = count_extrema(rows)
    n_zero = _count_zero_crossings(rows)
    run, last_ext, last_zero = streak[active].T
    good = (np.abs(n_zero - n_ext) <= 1) & (count > 0)
    same = (run > 0) & (n_ext == last_ext) & (n_zero == last_zero)
    run = np.where(good, np.where(same, run + 1, 1), 0)
    streak[active] = np.column_stack((run, n_ext, n_zero))
    return run >= s_number


def _energy_stop(sifting):
    return sifting.sd_threshold if sifting.stop == "sd" else None


def _mean_envelope(rows, sifting):
    """Mean of the upper and lower envelopes of each row, and Rilling's stop test.

    Returns
    -------
    mean : ndarray, shape rows.shape
    ok : bool array
        The row has at least three extrema and its envelopes could be built.
    passed : bool array
        Rilling's rule says the row is an IMF (always False for the SD rule).
    """
    imax, imin = _extrema(rows)
    n_ext = imax.sum(axis=1) + imin.sum(axis=1)
    knots, ok = _envelope_knots(rows, imax, imin, n_ext)
    mean = np.zeros_like(rows)
    passed = np.zeros(rows.shape[0], bool)
    if knots is None:
        return mean, ok, passed
    env = _splines(knots, rows.shape[1]).reshape(-1, 2, rows.shape[1])
    upper, lower = env[:, 0], env[:, 1]
    m = 0.5 * (upper + lower)
    mean[ok] = m
    if sifting.stop == "rilling":
        theta1, theta2, alpha = sifting.thresholds
        amp = np.abs(upper - lower) * 0.5
        dev = np.abs(m)
        frac = np.count_nonzero(dev > theta1 * amp, axis=1) / rows.shape[1]
        worst = np.any(dev > theta2 * amp, axis=1)
        n_zero = _count_zero_crossings(rows if ok.all() else rows[ok])
        keep_going = (frac > alpha) | worst
        passed[ok] = ~keep_going & (np.abs(n_zero - n_ext[ok]) <= 1)
    return mean, ok, passed


def _count_zero_crossings(rows):
    """Zero crossings per row as Rilling's ``extr`` counts them (a run of exact zeros once)."""
    count = np.count_nonzero(rows[:, :-1] * rows[:, 1:] < 0, axis=1)
    zero = rows == 0
    if zero.any():
        count = count + zero[:, 0] + np.count_nonzero(zero[:, 1:] & ~zero[:, :-1], axis=1)
    return count


def _extrema(rows):
    """Boolean masks of local maxima and minima, shape rows.shape.

    A strict extremum has slopes of opposite signs on its two sides; a
    plateau (run of equal samples) between a rise and a fall is one
    extremum at its middle (index ``(a + b + 1) // 2`` for a run a..b, as
    Rilling's ``extr`` rounds), and plateaus touching an end are none.
    """
    d = np.diff(rows, axis=1)
    imax = np.zeros(rows.shape, bool)
    imin = np.zeros(rows.shape, bool)
    if np.count_nonzero(d) == d.size:
        rising = d > 0
        turn = rising[:, :-1] != rising[:, 1:]
        np.logical_and(turn, rising[:, :-1], out=imax[:, 1:-1])
        np.logical_and(turn, rising[:, 1:], out=imin[:, 1:-1])
        return imax, imin
    up = d > 0
    down = d < 0
    imax[:, 1:-1] = up[:, :-1] & down[:, 1:]
    imin[:, 1:-1] = down[:, :-1] & up[:, 1:]
    _plateaus(d, ~(up | down), imax, imin)
    return imax, imin


def _plateaus(d, flat, imax, imin):
    n_rows, n_d = d.shape
    padded = np.zeros((n_rows, n_d + 2), bool)
    padded[:, 1:-1] = flat
    edges = np.diff(padded.view(np.int8), axis=1)
    row_s, first = np.nonzero(edges == 1)
    row_e, after = np.nonzero(edges == -1)
    inner = (first > 0) & (after < n_d)
    row, first, after = row_s[inner], first[inner], after[inner]
    before_slope = d[row, first - 1]
    after_slope = d[row, after]
    middle = (first + after + 1) // 2
    is_max = (before_slope > 0) & (after_slope < 0)
    is_min = (before_slope < 0) & (after_slope > 0)
    imax[row[is_max], middle[is_max]] = True
    imin[row[is_min], middle[is_min]] = True


def _envelope_knots(rows, imax, imin, n_ext):
    """Knots of the upper and lower envelope of each usable row, stacked.

    Returns
    -------
    knots : (t, z, sizes)
        Integer positions and values of all envelopes (upper then lower for
        each usable row, in row order), and the knots per envelope.
    ok : bool array
        Rows whose envelopes exist (at least three extrema, ends spanned).
    """
    ok = n_ext >= 3
    r_max, c_max = np.nonzero(imax)
    r_min, c_min = np.nonzero(imin)
    cut_max = np.concatenate(([0], np.cumsum(np.bincount(r_max, minlength=rows.shape[0]))))
    cut_min = np.concatenate(([0], np.cumsum(np.bincount(r_min, minlength=rows.shape[0]))))
    v_max = rows[r_max, c_max]
    v_min = rows[r_min, c_min]
    t_parts, z_parts, sizes = [], [], []
    for i in np.flatnonzero(ok):
        cm = c_max[cut_max[i]:cut_max[i + 1]]
        cn = c_min[cut_min[i]:cut_min[i + 1]]
        x = rows[i]
        ends = _mirror(cm[:3].tolist(), cm[-3:].tolist(), cn[:3].tolist(), cn[-3:].tolist(), x)
        if ends is None:
            ok[i] = False
            continue
        (lt_max, lz_max, rt_max, rz_max), (lt_min, lz_min, rt_min, rz_min) = ends
        t_parts += [lt_max, cm, rt_max, lt_min, cn, rt_min]
        z_parts += [lz_max, v_max[cut_max[i]:cut_max[i + 1]], rz_max, lz_min, v_min[cut_min[i]:cut_min[i + 1]], rz_min]
        sizes += [len(lt_max) + cm.size + len(rt_max), len(lt_min) + cn.size + len(rt_min)]
    if not sizes:
        return None, ok
    t = np.concatenate([np.asarray(p, dtype=np.int64) for p in t_parts])
    z = np.concatenate([np.asarray(p, dtype=float) for p in z_parts])
    return (t, z, np.array(sizes)), ok


def _mirror(head_max, tail_max, head_min, tail_min, x, nbsym=_NBSYM):
    """Extend maxima and minima beyond both ends by mirror symmetry.

    Rilling's ``boundary_conditions`` rule [2]_: mirror `nbsym` extrema of
    each kind about the first (last) extremum, or about the first (last)
    sample when that sample lies beyond the extremum's level, and fall back
    to the end sample when the mirrored points do not reach past the end.

    Parameters
    ----------
    head_max, tail_max, head_min, tail_min : list of int
        The first and the last ``nbsym + 1`` maxima and minima (positions).
    x : ndarray
        The signal.

    Returns
    -------
    ((left_t, left_z, right_t, right_z) for maxima, the same for minima), or
    None when the extrema cannot span the signal.
    """
    if not head_max or not head_min:
        return None
    last = x.size - 1
    if head_max[0] < head_min[0]:
        if x[0] > x[head_min[0]]:
            lmax, lmin, lsym = head_max[1:nbsym + 1][::-1], head_min[:nbsym][::-1], head_max[0]
        else:
            lmax, lmin, lsym = head_max[:nbsym][::-1], head_min[:nbsym - 1][::-1] + [0], 0
    else:
        if x[0] < x[head_max[0]]:
            lmax, lmin, lsym = head_max[:nbsym][::-1], head_min[1:nbsym + 1][::-1], head_min[0]
        else:
            lmax, lmin, lsym = head_max[:nbsym - 1][::-1] + [0], head_min[:nbsym][::-1], 0
    if tail_max[-1] < tail_min[-1]:
        if x[last] < x[tail_max[-1]]:
            rmax, rmin, rsym = tail_max[-nbsym:][::-1], tail_min[-nbsym - 1:-1][::-1], tail_min[-1]
        else:
            rmax, rmin, rsym = [last] + tail_max[1 - nbsym:][::-1], tail_min[-nbsym:][::-1], last
    else:
        if x[last] > x[tail_min[-1]]:
            rmax, rmin, rsym = tail_max[-nbsym - 1:-1][::-1], tail_min[-nbsym:][::-1], tail_max[-1]
        else:
            rmax, rmin, rsym = tail_max[-nbsym:][::-1], [last] + tail_min[1 - nbsym:][::-1], last
    if not (lmax and lmin and rmax and rmin):
        return None
    if 2 * lsym - lmin[0] > 0 or 2 * lsym - lmax[0] > 0:
        if lsym == 0:
            return None
        if lsym == head_max[0]:
            lmax = head_max[:nbsym][::-1]
        else:
            lmin = head_min[:nbsym][::-1]
        lsym = 0
    if 2 * rsym - rmin[-1] < last or 2 * rsym - rmax[-1] < last:
        if rsym == last:
            return None
        if rsym == tail_max[-1]:
            rmax = tail_max[-nbsym:][::-1]
        else:
            rmin = tail_min[-nbsym:][::-1]
        rsym = last
    out = []
    for left, right, head, tail in ((lmax, rmax, head_max, tail_max), (lmin, rmin, head_min, tail_min)):
        lt = [2 * lsym - i for i in left]
        rt = [2 * rsym - i for i in right]
        if any(b <= a for a, b in zip(lt, lt[1:] + [head[0]])) or any(b <= a for a, b in zip([tail[-1]] + rt, rt)):
            return None
        out.append((lt, [x[i] for i in left], rt, [x[i] for i in right]))
    return tuple(out)


def _splines(knots, n):
    """Evaluate not-a-knot cubic splines through each knot set at 0..n-1.

    Parameters
    ----------
    knots : (t, z, sizes)
        Stacked knot sets: integer positions (strictly increasing within a
        set, the first <= 0 and the last >= n - 1, else the end pieces
        extrapolate), values, and the size of each set.
    n : int

    Returns
    -------
    ndarray, shape (len(sizes), n)

    Notes
    -----
    The slopes s_i solve the tridiagonal system of C2 continuity,
    ``h_i s_{i-1} + 2 (h_{i-1} + h_i) s_i + h_{i-1} s_{i+1} =
    3 (h_i d_{i-1} + h_{i-1} d_i)`` with d_i the secant slopes, closed by
    the not-a-knot conditions (continuous third derivative at the second
    and the last-but-one knot); three knots give the parabola, two the
    line. All sets form one block-diagonal system solved by LAPACK gtsv.
    """
    t_int, _, sizes = knots
    pieces = _spline_pieces(knots)
    g = _piece_index(t_int, pieces[5], pieces[6], n)
    samples = np.tile(np.arange(n, dtype=float), sizes.size)
    return _spline_values(pieces, g, samples).reshape(sizes.size, n)


def _spline_pieces(knots):
    """Cubic pieces of the not-a-knot splines of :func:`_splines`: (t, z, s0, c2, c3, start, end).

    Piece i runs from knot i: ``z_i + s0_i u + c2_i u^2 + c3_i u^3``, u the
    distance from ``t_i``; `start` and `end` index each set's first and last knot.
    """
    t_int, z, sizes = knots
    t = t_int.astype(float)
    start = np.cumsum(sizes) - sizes
    end = start + sizes - 1
    h = np.diff(t)
    h[end[:-1]] = 1.0
    dz = np.diff(z)
    dz[end[:-1]] = 0.0
    slope = dz / h
    one, zero = np.ones(1), np.zeros(1)
    hp = np.concatenate((one, h))  # h_{i-1} at knot i
    hn = np.concatenate((h, one))  # h_i at knot i
    dp = np.concatenate((zero, slope))
    dn = np.concatenate((slope, zero))
    diag = 2.0 * (hp + hn)
    upper = hp[:-1].copy()  # coefficient of s_{i+1} in row i
    lower = hn[1:].copy()  # coefficient of s_{i-1} in row i (stored at i - 1)
    rhs = 3.0 * (hn * dp + hp * dn)
    big = sizes >= 4
    s4, e4 = start[big], end[big]
    h0, h1 = h[s4], h[s4 + 1]
    diag[s4] = h1
    upper[s4] = h0 + h1
    rhs[s4] = ((h0 + 2.0 * (h0 + h1)) * h1 * slope[s4] + h0 * h0 * slope[s4 + 1]) / (h0 + h1)
    ha, hb = h[e4 - 2], h[e4 - 1]
    diag[e4] = ha
    lower[e4 - 1] = ha + hb
    rhs[e4] = (hb * hb * slope[e4 - 2] + (2.0 * (ha + hb) + hb) * ha * slope[e4 - 1]) / (ha + hb)
    three = sizes == 3
    s3, e3 = start[three], end[three]
    diag[s3], upper[s3], rhs[s3] = 1.0, 1.0, 2.0 * slope[s3]
    diag[e3], lower[e3 - 1], rhs[e3] = 1.0, 1.0, 2.0 * slope[e3 - 1]
    two = sizes == 2
    s2, e2 = start[two], end[two]
    diag[s2], upper[s2], rhs[s2] = 1.0, 0.0, slope[s2]
    diag[e2], lower[e2 - 1], rhs[e2] = 1.0, 0.0, slope[s2]
    upper[end[:-1]] = 0.0
    lower[end[:-1]] = 0.0
    from scipy.linalg.lapack import dgtsv  # the numpy path only: the compiled one solves in its kernel

    s = dgtsv(lower, diag, upper, rhs, 1, 1, 1, 1)[3]
    s0, s1 = s[:-1], s[1:]
    c2 = (3.0 * slope - 2.0 * s0 - s1) / h
    c3 = (s0 + s1 - 2.0 * slope) / (h * h)
    return t, z, s0, c2, c3, start, end


def _spline_values(pieces, g, samples):
    """Values of the pieces `g` (:func:`_spline_pieces`) at `samples` (float positions), in the order of :func:`_splines`."""
    t, z, s0, c2, c3 = pieces[:5]
    u = samples - np.take(t, g)
    out = np.take(c3, g)
    out *= u
    out += np.take(c2, g)
    out *= u
    out += np.take(s0, g)
    out *= u
    out += np.take(z, g)
    return out


def _piece_index(t_int, start, end, n):
    """Index of the spline piece (its left knot, in the stacked arrays) of every sample.

    Sample j of set s lies in the piece of the last knot of s at or before j;
    the first knot of a set counts as at 0 and the last as beyond n - 1, so
    the end pieces extrapolate. One ``bincount`` of the knots' flat
    positions and one ``cumsum`` give all sets' indices at once: every knot
    of earlier sets lies at or before a set's first sample.
    """
    sets = np.repeat(np.arange(start.size), end - start + 1)
    pos = np.clip(t_int, 0, n)
    pos[start] = 0
    pos[end] = n
    pos += sets * n
    g = np.cumsum(np.bincount(pos, minlength=start.size * n + 1)[:-1])
    g -= 1
    return g
