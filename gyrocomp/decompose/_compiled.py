"""Compiled sifting kernel (numba): one pass per sift over one row at a time.

The numpy path of :mod:`~gyrocomp.decompose.emd` needs some 40 array
passes per sift and is bound by memory traffic; this kernel fuses them
(extrema scan, end mirroring, spline solve, envelope evaluation, stop test
and subtraction) per row. It computes the same thing in the same
floating-point order: the extrema and mirror rules of ``emd._extrema`` and
``emd._mirror``, the not-a-knot system of ``emd._splines`` solved by the
algorithm of LAPACK ``dgtsv`` (Gaussian elimination with partial pivoting),
and Horner evaluation in the same order. Imported lazily by
:func:`gyrocomp.decompose.emd.sift` (numba compiles on first use and caches
the machine code beside this file, ``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

STOPS = {"rilling": 0, "sd": 1, "s_number": 2, "fixed": 3}
"""Codes of the stopping rules inside the kernel."""


@numba.njit(cache=True)
def sift_rows(rows, stop, theta1, theta2, alpha, sd_threshold, s_number, max_sift):
    """First IMF of every row; the semantics of ``emd._sift`` with ``emd._mean_envelope``."""
    n_rows, n = rows.shape
    out = np.empty_like(rows)
    w = _work(n)
    for r in range(n_rows):
        _sift_one(rows[r], out[r], stop, theta1, theta2, alpha, sd_threshold, s_number, max_sift, w)
    return out


@numba.njit(cache=True)
def _work(n):
    """Buffers reused by every sift of a call: extrema, knots, tridiagonal system, envelopes."""
    m = n + 8
    return (
        np.empty(n, np.int64), np.empty(n, np.int64), np.empty(m, np.int64), np.empty(m), np.empty(m),
        np.empty(m), np.empty(m), np.empty(m), np.empty(n), np.empty(n), np.empty(16, np.int64),
    )


@numba.njit(cache=True)
def _sift_one(x, h, stop, theta1, theta2, alpha, sd_threshold, s_number, max_sift, w):
    n = x.size
    for j in range(n):
        h[j] = x[j]
    imax, imin, upper, lower, ends = w[0], w[1], w[8], w[9], w[10]
    streak = 0
    last_ext = -1
    last_zero = -1
    for count in range(max_sift):
        n_max, n_min = _extrema(h, imax, imin)
        ok = n_max + n_min >= 3 and _mirror(h, imax, n_max, imin, n_min, ends)
        if ok:
            ok = _envelope(h, imax, n_max, ends, 0, w, upper) and _envelope(h, imin, n_min, ends, 8, w, lower)
        if not ok:
            if count == 0:
                for j in range(n):
                    h[j] = 0.0
            return
        n_ext = n_max + n_min
        if stop == 0 or stop == 2:
            n_zero = _zero_crossings(h)
            if stop == 2:
                if count > 0 and abs(n_zero - n_ext) <= 1:
                    same = streak > 0 and n_ext == last_ext and n_zero == last_zero
                    streak = streak + 1 if same else 1
                else:
                    streak = 0
                last_ext, last_zero = n_ext, n_zero
                if streak >= s_number:
                    return
            else:
                beyond = 0
                worst = False
                for j in range(n):
                    m = 0.5 * (upper[j] + lower[j])
                    amp = abs(upper[j] - lower[j]) * 0.5
                    dev = abs(m)
                    if dev > theta1 * amp:
                        beyond += 1
                    if dev > theta2 * amp:
                        worst = True
                if not (beyond / n > alpha or worst) and abs(n_zero - n_ext) <= 1:
                    return
        if stop == 1:
            energy = 0.0
            change = 0.0
            for j in range(n):
                m = 0.5 * (upper[j] + lower[j])
                energy += h[j] * h[j]
                change += m * m
                h[j] = h[j] - m
            if not change > sd_threshold * energy:
                return
        else:
            for j in range(n):
                h[j] = h[j] - 0.5 * (upper[j] + lower[j])


@numba.njit(cache=True)
def _zero_crossings(x):
    count = 0
    for j in range(x.size - 1):
        if x[j] * x[j + 1] < 0:
            count += 1
    if x[0] == 0:
        count += 1
    for j in range(1, x.size):
        if x[j] == 0 and x[j - 1] != 0:
            count += 1
    return count


@numba.njit(cache=True)
def _extrema(x, imax, imin):
    """Positions of maxima and minima, as ``emd._extrema`` (a plateau once, at its middle)."""
    n_max = 0
    n_min = 0
    before = 0  # sign of the last non-zero slope
    flat_from = -1  # first slope index of the current run of zero slopes
    for i in range(x.size - 1):
        d = x[i + 1] - x[i]
        if d == 0:
            if flat_from < 0:
                flat_from = i
            continue
        sign = 1 if d > 0 else -1
        at = i if flat_from < 0 else (flat_from + i + 1) // 2
        imax[n_max] = at  # written always, kept when counted: no branch on noisy data
        imin[n_min] = at
        n_max += before > 0 and sign < 0
        n_min += before < 0 and sign > 0
        before = sign
        flat_from = -1
    return n_max, n_min


@numba.njit(cache=True)
def _mirror(x, cm, n_max, cn, n_min, ends):
    """Rilling's end mirroring, as ``emd._mirror`` with nbsym = 2.

    Fills `ends`: for maxima at offset 0 and minima at offset 8,
    [n_left, left_0, left_1, n_right, right_0, right_1] (source positions,
    in the order of ``emd._mirror``'s lists), then lsym at 6 and rsym at 7.
    Returns False when the extrema cannot span the signal.
    """
    if n_max == 0 or n_min == 0:
        return False
    last = x.size - 1
    # left: lists (reversed slices of the heads)
    if cm[0] < cn[0]:
        if x[0] > x[cn[0]]:
            _rev(cm, 1, min(3, n_max), ends, 0)
            _rev(cn, 0, min(2, n_min), ends, 8)
            lsym = cm[0]
        else:
            _rev(cm, 0, min(2, n_max), ends, 0)
            _rev(cn, 0, min(1, n_min), ends, 8)
            ends[9 + ends[8]] = 0
            ends[8] += 1
            lsym = 0
    else:
        if x[0] < x[cm[0]]:
            _rev(cm, 0, min(2, n_max), ends, 0)
            _rev(cn, 1, min(3, n_min), ends, 8)
            lsym = cn[0]
        else:
            _rev(cm, 0, min(1, n_max), ends, 0)
            ends[1 + ends[0]] = 0
            ends[0] += 1
            _rev(cn, 0, min(2, n_min), ends, 8)
            lsym = 0
    if cm[n_max - 1] < cn[n_min - 1]:
        if x[last] < x[cm[n_max - 1]]:
            _rev(cm, max(0, n_max - 2), n_max, ends, 3)
            _rev(cn, max(0, n_min - 3), n_min - 1, ends, 11)
            rsym = cn[n_min - 1]
        else:
            ends[3] = 2
            ends[4] = last
            ends[5] = cm[n_max - 1]
            _rev(cn, max(0, n_min - 2), n_min, ends, 11)
            rsym = last
    else:
        if x[last] > x[cn[n_min - 1]]:
            _rev(cm, max(0, n_max - 3), n_max - 1, ends, 3)
            _rev(cn, max(0, n_min - 2), n_min, ends, 11)
            rsym = cm[n_max - 1]
        else:
            _rev(cm, max(0, n_max - 2), n_max, ends, 3)
            ends[11] = 2
            ends[12] = last
            ends[13] = cn[n_min - 1]
            rsym = last
    if ends[0] == 0 or ends[8] == 0 or ends[3] == 0 or ends[11] == 0:
        return False
    if 2 * lsym - ends[9] > 0 or 2 * lsym - ends[1] > 0:
        if lsym == 0:
            return False
        if lsym == cm[0]:
            _rev(cm, 0, min(2, n_max), ends, 0)
        else:
            _rev(cn, 0, min(2, n_min), ends, 8)
        lsym = 0
    if 2 * rsym - ends[11 + ends[11]] < last or 2 * rsym - ends[3 + ends[3]] < last:
        if rsym == last:
            return False
        if rsym == cm[n_max - 1]:
            _rev(cm, max(0, n_max - 2), n_max, ends, 3)
        else:
            _rev(cn, max(0, n_min - 2), n_min, ends, 11)
        rsym = last
    ends[6] = lsym
    ends[7] = rsym
    return _increasing(ends, 0, cm, n_max) and _increasing(ends, 8, cn, n_min)


@numba.njit(cache=True)
def _increasing(ends, base, pos, count):
    """The mirrored knots continue the inner extrema strictly increasingly at both ends."""
    lsym, rsym = ends[6], ends[7]
    prev = 2 * lsym - ends[base + 1]
    for k in range(1, ends[base]):
        cur = 2 * lsym - ends[base + 1 + k]
        if cur <= prev:
            return False
        prev = cur
    if pos[0] <= prev:
        return False
    prev = pos[count - 1]
    for k in range(ends[base + 3]):
        cur = 2 * rsym - ends[base + 4 + k]
        if cur <= prev:
            return False
        prev = cur
    return True


@numba.njit(cache=True)
def _rev(src, lo, hi, ends, at):
    """ends[at] = count; ends[at+1..] = src[lo:hi] reversed."""
    count = max(0, hi - lo)
    ends[at] = count
    for k in range(count):
        ends[at + 1 + k] = src[hi - 1 - k]


@numba.njit(cache=True)
def _envelope(x, pos, count, ends, base, w, out):
    """Not-a-knot spline through the mirrored and inner extrema, at 0..n-1 (``emd._splines``)."""
    lsym, rsym = ends[6], ends[7]
    t, z = w[2], w[3]
    m = 0
    for k in range(ends[base]):
        src = ends[base + 1 + k]
        t[m] = 2 * lsym - src
        z[m] = x[src]
        m += 1
    for k in range(count):
        t[m] = pos[k]
        z[m] = x[pos[k]]
        m += 1
    for k in range(ends[base + 3]):
        src = ends[base + 4 + k]
        t[m] = 2 * rsym - src
        z[m] = x[src]
        m += 1
    if not _slopes(t, z, m, w):
        return False
    s = w[4]
    n = x.size
    j = 0
    for k in range(m - 1):
        stop = n if k == m - 2 else min(max(t[k + 1], 0), n)
        if j >= stop:
            continue
        h = float(t[k + 1] - t[k])
        slope = (z[k + 1] - z[k]) / h
        c2 = (3.0 * slope - 2.0 * s[k] - s[k + 1]) / h
        c3 = (s[k] + s[k + 1] - 2.0 * slope) / (h * h)
        s0, z0, t0 = s[k], z[k], float(t[k])
        while j < stop:
            u = float(j) - t0
            out[j] = ((c3 * u + c2) * u + s0) * u + z0
            j += 1
    return True


@numba.njit(cache=True)
def _slopes(t, z, m, w):
    """Knot slopes s_i of the not-a-knot spline (the system of ``emd._splines``), in w[4]."""
    s, dl, d, du = w[4], w[5], w[6], w[7]
    for i in range(m):
        hp = float(t[i] - t[i - 1]) if i > 0 else 1.0
        hn = float(t[i + 1] - t[i]) if i < m - 1 else 1.0
        dp = (z[i] - z[i - 1]) / hp if i > 0 else 0.0
        dn = (z[i + 1] - z[i]) / hn if i < m - 1 else 0.0
        d[i] = 2.0 * (hp + hn)
        if i < m - 1:
            du[i] = hp
            dl[i] = float(t[i + 2] - t[i + 1]) if i + 2 < m else 1.0
        s[i] = 3.0 * (hn * dp + hp * dn)
    if m >= 4:
        h0, h1 = float(t[1] - t[0]), float(t[2] - t[1])
        sl0, sl1 = (z[1] - z[0]) / h0, (z[2] - z[1]) / h1
        d[0] = h1
        du[0] = h0 + h1
        s[0] = ((h0 + 2.0 * (h0 + h1)) * h1 * sl0 + h0 * h0 * sl1) / (h0 + h1)
        e = m - 1
        ha, hb = float(t[e - 1] - t[e - 2]), float(t[e] - t[e - 1])
        sla, slb = (z[e - 1] - z[e - 2]) / ha, (z[e] - z[e - 1]) / hb
        d[e] = ha
        dl[e - 1] = ha + hb
        s[e] = (hb * hb * sla + (2.0 * (ha + hb) + hb) * ha * slb) / (ha + hb)
    elif m == 3:
        sl0, sl1 = (z[1] - z[0]) / float(t[1] - t[0]), (z[2] - z[1]) / float(t[2] - t[1])
        d[0], du[0], s[0] = 1.0, 1.0, 2.0 * sl0
        d[2], dl[1], s[2] = 1.0, 1.0, 2.0 * sl1
    else:
        sl0 = (z[1] - z[0]) / float(t[1] - t[0])
        d[0], du[0], s[0] = 1.0, 0.0, sl0
        d[1], dl[0], s[1] = 1.0, 0.0, sl0
    return _gtsv(dl, d, du, s, m)


@numba.njit(cache=True)
def _gtsv(dl, d, du, b, n):
    """Solve a tridiagonal system in place (b), the algorithm of LAPACK ``dgtsv`` (one right-hand side)."""
    for i in range(n - 2):
        if abs(d[i]) >= abs(dl[i]):
            if d[i] == 0.0:
                return False
            fact = dl[i] / d[i]
            d[i + 1] = d[i + 1] - fact * du[i]
            b[i + 1] = b[i + 1] - fact * b[i]
            dl[i] = 0.0
        else:
            fact = d[i] / dl[i]
            d[i] = dl[i]
            temp = d[i + 1]
            d[i + 1] = du[i] - fact * temp
            dl[i] = du[i + 1]
            du[i + 1] = -fact * dl[i]
            du[i] = temp
            temp = b[i]
            b[i] = b[i + 1]
            b[i + 1] = temp - fact * b[i + 1]
    if n > 1:
        i = n - 2
        if abs(d[i]) >= abs(dl[i]):
            if d[i] == 0.0:
                return False
            fact = dl[i] / d[i]
            d[i + 1] = d[i + 1] - fact * du[i]
            b[i + 1] = b[i + 1] - fact * b[i]
        else:
            fact = d[i] / dl[i]
            d[i] = dl[i]
            temp = d[i + 1]
            d[i + 1] = du[i] - fact * temp
            du[i] = temp
            temp = b[i]
            b[i] = b[i + 1]
            b[i + 1] = temp - fact * b[i + 1]
    if d[n - 1] == 0.0:
        return False
    b[n - 1] = b[n - 1] / d[n - 1]
    if n > 1:
        b[n - 2] = (b[n - 2] - du[n - 2] * b[n - 1]) / d[n - 2]
    for i in range(n - 3, -1, -1):
        b[i] = (b[i] - du[i] * b[i + 1] - dl[i] * b[i + 2]) / d[i]
    return True
