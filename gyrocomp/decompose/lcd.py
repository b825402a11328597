"""Local characteristic-scale decomposition (LCD), Cheng et al. (2012).

As Cao et al. (2021) [1]_ state it in their eqs. (4)-(11):

1. The extrema (t_u, F_u), u = 1..N, of the signal (eq. (4)).
2. For each extremum, the line l through its two neighbours (the
   neighbouring extrema of the other kind) gives
   ``C_u = F_{u-1} + (t_u - t_{u-1}) / (t_{u+1} - t_{u-1}) (F_{u+1} - F_{u-1})``
   (eq. (5)) and the baseline point ``L_u = q C_u + (1 - q) F_u`` (eq. (6)).
3. The ends: the extrema are extended beyond both ends (eq. (6)'s
   (t_0, F_0) and (t_{N+1}, F_{N+1})) by the mirror rule of the EMD
   envelopes (two extrema of each kind per end, Rilling's
   ``boundary_conditions``), so that L_1 and L_N exist and the baseline
   knots span the whole record.
4. The baseline is the cubic spline (not-a-knot) through the L_u, and is
   removed: ``I = f - DL`` (eq. (7)); this repeats (eq. (8)) until
   ``SD <= sd_stop`` (eq. (9)) or `max_sift` iterations.
5. The ISC is removed, ``R = f - S`` (eq. (10)), and steps 1-5 repeat on R
   until it is monotonic (here: fewer than three extrema, too few for a
   baseline) or `max_components` ISCs exist; then
   ``f = sum S_i + R_n`` (eq. (11)).

SD of eq. (9) is a sum of pointwise ratios that diverges at every zero of
I(t); it is computed in the energy-weighted form
``sum (I_u - I_{u-1})^2 / sum I_{u-1}^2``, which Huang et al. (1998) use
for the same Cauchy-type test.

References
----------
.. [1] H. Cao et al., "A temperature compensation approach for dual-mass
   MEMS gyroscope based on PE-LCD and ANFIS", IEEE Access 9, 95180 (2021).
.. [2] J. Cheng, J. Zheng, Y. Yang, "A nonstationary signal analysis
   approach: the local characteristic-scale decomposition method",
   J. Vib. Eng. 25(2), 215-220 (2012), in Chinese; ref. [18] of [1].
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from gyrocomp.decompose.emd import Sifting, _extrema, _mirror, _sift, _splines, count_extrema

__all__ = ["lcd", "baseline_points"]


def lcd(
    x,
    *,
    q: float = 0.5,
    sd_stop: float = 0.3,
    max_components: int = 10,
    max_sift: int = 10,
    callback: Callable[[int, int], None] | None = None,
) -> np.ndarray:
    """Local characteristic-scale decomposition of a 1-D signal.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
    q : float, default=0.5
        Baseline weight, alpha in eqs. (4) and (6) of [1]_; in (0, 1).
    sd_stop : float, default=0.3
        Sifting stops when SD (eq. (9)) is at most this.
    max_components : int, default=10
        Most ISCs; the trend keeps the rest.
    max_sift : int, default=10
        Most sifting iterations per ISC (the papers give none; SD <= 0.3
        ends the sifting within a few iterations on the test signals).
    callback : callable(done, total), optional
        Called after every ISC.

    Returns
    -------
    ndarray, shape (k + 1, n_samples)
        ISCs, fastest first, and the trend R_n last.
    """
    if not 0.0 < q < 1.0:
        raise ValueError(f"q = {q}; must lie in (0, 1) (eq. (4))")
    x = np.asarray(x, dtype=float)
    sifting = Sifting(stop="sd", sd_threshold=sd_stop, max_sift=max_sift)
    out = np.empty((max_components + 1, x.size))  # filled in place: no second copy of every ISC at the end
    trend = out[0]
    trend[:] = x
    k = 0
    while k < max_components and count_extrema(trend[None])[0] >= 3:
        isc = _sift(trend[None], sifting, _baseline, energy_stop=sd_stop, q=q)[0]
        np.subtract(trend, isc, out=out[k + 1])
        trend[:] = isc
        k += 1
        trend = out[k]
        if callback is not None:
            callback(k, max_components)
    if callback is not None:
        callback(max_components, max_components)
    return out[: k + 1]


def baseline_points(t, f, q=0.5):
    """Baseline points ``L_u = q C_u + (1 - q) F_u`` of eqs. (5)-(6) for interior extrema.

    Parameters
    ----------
    t, f : ndarray, shape (N,)
        Positions and values of alternating extrema, sorted by position.
    q : float

    Returns
    -------
    ndarray, shape (N - 2,)
        L_u for u = 2..N-1 (1-based).
    """
    t = np.asarray(t, dtype=float)
    f = np.asarray(f, dtype=float)
    c = f[:-2] + (t[1:-1] - t[:-2]) / (t[2:] - t[:-2]) * (f[2:] - f[:-2])
    return q * c + (1.0 - q) * f[1:-1]


def _baseline(rows, sifting, q):
    """Baseline DL(t) of each row (steps 1-3); the mean_fn of the sifting loop."""
    imax, imin = _extrema(rows)
    n_ext = imax.sum(axis=1) + imin.sum(axis=1)
    ok = n_ext >= 3
    t_parts, z_parts, sizes = [], [], []
    for i in np.flatnonzero(ok):
        cm, cn, x = np.flatnonzero(imax[i]), np.flatnonzero(imin[i]), rows[i]
        ends = _mirror(cm[:3].tolist(), cm[-3:].tolist(), cn[:3].tolist(), cn[-3:].tolist(), x)
        if ends is None:
            ok[i] = False
            continue
        (lt_max, lz_max, rt_max, rz_max), (lt_min, lz_min, rt_min, rz_min) = ends
        t = np.concatenate((lt_max, lt_min, cm, cn, rt_max, rt_min)).astype(np.int64)
        z = np.concatenate((lz_max, lz_min, x[cm], x[cn], rz_max, rz_min))
        order = np.argsort(t, kind="stable")
        t, z = t[order], z[order]
        if np.any(np.diff(t) <= 0):
            ok[i] = False
            continue
        t_parts.append(t[1:-1])
        z_parts.append(baseline_points(t, z, q))
        sizes.append(t.size - 2)
    base = np.zeros_like(rows)
    if sizes:
        base[ok] = _splines((np.concatenate(t_parts), np.concatenate(z_parts), np.array(sizes)), rows.shape[1])
    return base, ok, np.zeros(rows.shape[0], bool)
