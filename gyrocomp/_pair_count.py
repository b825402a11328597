"""Compiled kernels that count template pairs for sample entropy.

Imported lazily by :func:`gyrocomp.entropy.sample_entropy` (numba compiles
on first use and caches to disk). Every kernel counts, never enumerates, so
its cost does not depend on how many pairs match.

Conventions shared by the kernels: templates are indexed by their position
in the sort by their first value ``a``; ``brank`` / ``crank`` are the ranks
of the second / third values (a permutation of 0 .. n-1, ties in any
order), and ``[blo, bhi)`` / ``[clo, chi)`` the rank windows of the values
strictly closer than r (from :func:`window_bounds`, so ties and distances
equal to r are decided exactly as ``abs(u - v) < r``).
"""

from __future__ import annotations

import numba
import numpy as np

_BASE = 32
"""Events per block counted by direct comparison before the divide and conquer."""

_SHIFT = 34
"""Bit offset of the second-value rank in a packed event (payload below it)."""

_PAYLOAD = (1 << 32) - 1
"""Mask of the 32-bit payload of a packed event (third-value rank or template)."""


@numba.njit(cache=True)
def window_bounds(v, r):
    """For sorted `v`: ``lo[p]`` first k with v[p] - v[k] < r, ``hi[p]`` first k with v[k] - v[p] >= r.

    Two pointers; ``fl(u - w)`` is monotone in both arguments, so each
    window is a contiguous range and its ends only move forward.
    """
    n = v.size
    lo = np.empty(n, np.int64)
    hi = np.empty(n, np.int64)
    k = 0
    for p in range(n):
        while v[p] - v[k] >= r:
            k += 1
        lo[p] = k
    k = 0
    for p in range(n):
        while k < n and v[k] - v[p] < r:
            k += 1
        hi[p] = k
    return lo, hi


@numba.njit(cache=True)
def _fenwick_add(tree, i, d):
    i += 1
    while i < tree.size:
        tree[i] += d
        i += i & -i


@numba.njit(cache=True)
def _fenwick_prefix(tree, i):
    s = 0
    while i > 0:
        s += tree[i]
        i -= i & -i
    return s


@numba.njit(cache=True)
def count_2d(a_hi, brank, blo, bhi):
    """Pairs matching in a and b: sweep over a with a window of width r, Fenwick tree over b ranks.

    O(n log n) time, O(n) memory.
    """
    n = brank.size
    tree = np.zeros(n + 1, np.int32)
    total = 0
    out = 0
    for q in range(n):
        while a_hi[out] <= q:  # a_q - a_out >= r: leaves the window for good
            _fenwick_add(tree, brank[out], -1)
            out += 1
        total += _fenwick_prefix(tree, bhi[q]) - _fenwick_prefix(tree, blo[q])
        _fenwick_add(tree, brank[q], 1)
    return total


@numba.njit(cache=True)
def count_3d(a_lo, a_hi, brank, blo, bhi, crank, clo, chi, by_b):
    """Pairs matching in a, b and c. O(n log^2 n) time, O(n) memory.

    The sort by a is cut into cells [s, a_hi[s]): inside one cell every
    pair matches in a, and only neighbouring cells can hold pairs that
    match. Pairs inside a cell are a 2-D count (sweep over b, Fenwick tree
    over c). A pair across neighbouring cells P, Q matches in a when p >=
    a_lo[q]: with updates p in descending order and each query q placed
    after update a_lo[q], that is a 3-D dominance count, done offline by
    divide and conquer over that event order (:func:`_cdq`). `by_b` lists
    the templates cell by cell (cells in order), each cell sorted by b.
    """
    n = brank.size
    tree = np.zeros(n + 1, np.int32)
    bounds = np.empty((n, 4), np.int64)
    for p in range(n):  # the four windows of a query side by side: one cache line
        bounds[p, 0] = blo[p]
        bounds[p, 1] = bhi[p]
        bounds[p, 2] = clo[p]
        bounds[p, 3] = chi[p]
    events = np.empty(n, np.int64)  # two neighbouring cells hold at most n templates
    buffer = np.empty(n, np.int64)
    total = 0
    start = 0
    prev = -1
    while start < n:
        stop = a_hi[start]
        total += _count_in_cell(by_b[start:stop], brank, blo, crank, clo, chi, tree)
        if prev >= 0:
            e = 0
            q = stop - 1
            while q >= start and a_lo[q] >= start:  # reaches no template of the previous cell
                q -= 1
            for t in range(start - 1, prev - 1, -1):
                events[e] = (brank[t] << _SHIFT) | (crank[t] << 2)
                e += 1
                while q >= start and a_lo[q] == t:
                    events[e] = (brank[q] << _SHIFT) | (q << 2) | 1
                    e += 1
                    q -= 1
            total += _cdq(events, buffer, e, bounds, tree)
        prev = start
        start = stop
    return total


@numba.njit(cache=True)
def _count_in_cell(order, brank, blo, crank, clo, chi, tree):
    """Pairs of one a-cell (templates `order`, sorted by b) matching in b and c: sweep, Fenwick tree over c ranks."""
    total = 0
    out = 0
    for k in range(order.size):
        q = order[k]
        while brank[order[out]] < blo[q]:
            _fenwick_add(tree, crank[order[out]], -1)
            out += 1
        total += _fenwick_prefix(tree, chi[q]) - _fenwick_prefix(tree, clo[q])
        _fenwick_add(tree, crank[q], 1)
    for k in range(out, order.size):
        _fenwick_add(tree, crank[order[k]], -1)
    return total


@numba.njit(cache=True)
def _cdq(events, buffer, e, bounds, tree):
    """Sum over queries of the earlier updates in their (b, c) box: offline divide and conquer.

    The first `e` `events` are packed ``brank << 34 | payload << 2 | kind``: kind 0 an
    update (payload its c rank), kind 1 a query (payload its template, whose
    rank windows are in `bounds`). Bottom-up merge sort by b rank: blocks of
    :data:`_BASE` events are compared directly; at each wider level the
    updates of a left half meet the queries of its right half in a sweep
    over b (a sliding window of b ranks) with a Fenwick tree over c ranks,
    which is left empty again.
    """
    total = 0
    for s in range(0, e, _BASE):
        end = min(s + _BASE, e)
        for k in range(s, end):
            if events[k] & 3 == 1:
                t = (events[k] >> 2) & _PAYLOAD
                for j in range(s, k):
                    u = events[j]
                    if u & 3 == 0:
                        b = u >> _SHIFT
                        c = (u >> 2) & _PAYLOAD
                        if bounds[t, 0] <= b < bounds[t, 1] and bounds[t, 2] <= c < bounds[t, 3]:
                            total += 1
        for k in range(s + 1, end):  # insertion sort of the block
            u = events[k]
            j = k
            while j > s and events[j - 1] > u:
                events[j] = events[j - 1]
                j -= 1
            events[j] = u
    w = _BASE
    while w < e:
        for s in range(0, e - w, 2 * w):
            mid = s + w
            end = min(s + 2 * w, e)
            add = s
            rem = s
            for k in range(mid, end):
                if events[k] & 3 != 1:
                    continue
                t = (events[k] >> 2) & _PAYLOAD
                hi = bounds[t, 1] << _SHIFT
                while add < mid and events[add] < hi:
                    if events[add] & 3 == 0:
                        _fenwick_add(tree, (events[add] >> 2) & _PAYLOAD, 1)
                    add += 1
                lo = bounds[t, 0] << _SHIFT
                while rem < add and events[rem] < lo:
                    if events[rem] & 3 == 0:
                        _fenwick_add(tree, (events[rem] >> 2) & _PAYLOAD, -1)
                    rem += 1
                total += _fenwick_prefix(tree, bounds[t, 3]) - _fenwick_prefix(tree, bounds[t, 2])
            for k in range(rem, add):
                if events[k] & 3 == 0:
                    _fenwick_add(tree, (events[k] >> 2) & _PAYLOAD, -1)
            i, j, o = s, mid, s
            while i < mid and j < end:
                if events[j] < events[i]:
                    buffer[o] = events[j]
                    j += 1
                else:
                    buffer[o] = events[i]
                    i += 1
                o += 1
            for k in range(i, mid):
                buffer[o] = events[k]
                o += 1
            for k in range(s, o):  # the right half's tail is already in place
                events[k] = buffer[k]
        w *= 2
    return total
