"""Whether the long-tau rise of an Allan curve follows temperature, and the cubic in T to remove first.

An Allan variance at tau is half the mean square difference of
consecutive cluster means, sigma^2(tau) = <(ybar_{k+1} - ybar_k)^2> / 2
(the definition in [1]_, Annex C). When the rise beyond the curve's minimum is a
temperature effect, those differences follow the differences of the
temperature's cluster means; when it is rate random walk or a drift in
time, they do not. :func:`temperature_test` tests that with an F-test on
the cluster-mean differences, :func:`cubic_in_temperature` fits the cubic
that ``allan --detrend-temperature`` removes. Both read a series as pieces
``(segment, rate, temperature)`` and hold only block sums and a 4 x 4
system, so that a recording read chunk by chunk is read once more for
each, never whole.

References
----------
.. [1] IEEE Std 952-1997, Annex C.
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Iterable

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["Cubic", "cubic_in_temperature", "temperature_test", "judge"]

_SCALE_C = 10.0
"""Temperatures enter the cubic as (T - T0) / 10 degC, which keeps its normal equations well conditioned."""


@dataclasses.dataclass(frozen=True)
class Cubic:
    """b0 + b1 u + b2 u^2 + b3 u^3 with u = (T - t0) / 10 degC: a drift [deg/s] as a function of temperature [degC]."""

    t0: float
    coef: tuple[float, float, float, float]

    def __call__(self, temperature_c: np.ndarray) -> np.ndarray:
        return np.polynomial.polynomial.polyval((np.asarray(temperature_c, dtype=float) - self.t0) / _SCALE_C, self.coef)


def cubic_in_temperature(pieces: Iterable[tuple[int, np.ndarray, np.ndarray]], name: str) -> Cubic:
    """Least-squares cubic in temperature of a rate, from its pieces ``(segment, rate [deg/s], temperature [degC])``.

    Raises InputError when the temperature spans too little for a cubic
    (fewer than 4 distinct values).
    """
    gram, moment, t0, distinct = np.zeros((4, 4)), np.zeros(4), None, set()
    for _, y, t in pieces:
        t0 = float(t[0]) if t0 is None else t0
        if len(distinct) < 4:
            distinct.update(np.unique(t[:1000]).tolist())
        v = np.vander((np.asarray(t, dtype=float) - t0) / _SCALE_C, 4, increasing=True)
        gram += v.T @ v
        moment += v.T @ np.asarray(y, dtype=float)
    if t0 is None or len(distinct) < 4:
        raise InputError(f"{name}: --detrend-temperature needs at least 4 distinct temperatures to fit a cubic in T")
    return Cubic(t0, tuple(float(c) for c in np.linalg.lstsq(gram, moment, rcond=None)[0]))


def temperature_test(
    pieces: Callable[[], Iterable[tuple[int, np.ndarray, np.ndarray]]],
    series,
    *,
    min_clusters: int,
    alpha: float,
) -> dict | None:
    """Whether an Allan curve's rise beyond its minimum follows temperature.

    Parameters
    ----------
    pieces : callable returning an iterable of (int, ndarray, ndarray)
        Reads the series once: ``(segment, rate, temperature)``, a
        segment's pieces together and in order, none spanning a gap.
    series : gyrocomp.allan.AllanSeries
        The analysis of that rate (its taus, deviation and clusters).
    min_clusters : int
        Fewest independent clusters at a tested tau.
    alpha : float
        Level of the test, Bonferroni-corrected over the tested taus.

    Returns
    -------
    dict or None
        ``None`` when the curve does not rise beyond its minimum among the
        taus with `min_clusters` clusters; else ``follows_temperature``,
        ``tau_s`` (the tested taus), ``explained`` (the share of the
        variance of the cluster-mean differences that a cubic in T explains
        at each), ``p`` (each tau's F-test p-value), ``confounded`` (taus
        where the temperature moved at a constant rate, so that a drift in
        T and one in time are the same regressor).

    Notes
    -----
    At each tau above the first rise, the rate's cluster means ybar_k and
    those of u, u^2, u^3 (u the scaled temperature) are differenced within
    segments; the differences of ybar are regressed on an intercept (a
    drift in time) and those of u^j, and the cubic is tested against the
    intercept alone (F-test, 3 and n - 4 degrees of freedom, fewer when the
    temperature regressors are collinear). Differences of cluster means of
    white or random-walk rate noise are nearly uncorrelated, which is what
    the F-test assumes; the overlapping Allan variance is not used because
    its terms are correlated.
    """
    from scipy import stats

    fs = series.fs_hz
    m = np.rint(series.tau_s * fs).astype(np.int64)
    usable = np.asarray(series.clusters) >= min_clusters
    adev = np.asarray(series.adev)[usable]
    rising = np.flatnonzero(np.diff(adev) > 0)
    if not rising.size:
        return None
    tested = m[usable][rising[0] + 1 :]
    base = int(tested[0])
    tested = tested[tested % base == 0]
    blocks = _block_means(pieces(), base)
    results = []
    for mj in tested:
        dy, du = _cluster_differences(blocks, int(mj // base))
        if len(dy) < 6:
            continue
        results.append((float(mj / fs), *_f_test(dy, du, stats)))
    if not results:
        return None
    p = np.array([r[2] for r in results])
    return {
        "follows_temperature": bool((p * len(results) < alpha).any()),
        "tau_s": [r[0] for r in results],
        "explained": [r[1] for r in results],
        "p": p.tolist(),
        "confounded": [r[0] for r in results if r[3]],
    }


def judge(series, result: dict | None, *, detrended: bool) -> str | None:
    """Keep :func:`temperature_test`'s `result` on `series` (``thermal``) and, when the rise follows temperature, withdraw its long-tau terms.

    Rate random walk and rate ramp are then not identified and K has no
    read-off: what rises is the thermal drift, not a noise of the sensor.
    Returns the one-line warning to give, or None.
    """
    if result is None:
        series.thermal = {"detrended": detrended, "follows_temperature": None}
        return None
    series.thermal = {"detrended": detrended, **result}
    if not result["follows_temperature"]:
        return None
    best = int(np.argmin(result["p"]))
    tau, share, p = result["tau_s"][best], result["explained"][best], result["p"][best]
    why = f"follows temperature (a cubic in T explains {share:.0%} of the cluster-mean differences at tau = {tau:.3g} s, F-test p = {p:.2g})"
    for key in ("rrw", "rate_ramp"):
        series.terms[key].update(identified=False, note=why)
    series.terms["rrw"].update(readoff=None, readoff_tau_s=None, readoff_note=why)
    hint = "" if detrended else "; --detrend-temperature removes a fitted cubic in T first"
    return f"{series.name} `{series.column}`: the Allan deviation's rise {why}: rrw and rate_ramp not identified{hint}"


def _block_means(pieces: Iterable, base: int) -> list[np.ndarray]:
    """Per segment, means of consecutive blocks of `base` samples of the rate and of u, u^2, u^3 (columns), a short tail dropped."""
    segments: dict[int, list] = {}
    carry: dict[int, np.ndarray] = {}
    t0 = None
    for k, y, t in pieces:
        t0 = float(t[0]) if t0 is None else t0
        u = (np.asarray(t, dtype=float) - t0) / _SCALE_C
        rows = np.column_stack([np.asarray(y, dtype=float), u, u**2, u**3])
        if k in carry:
            rows = np.concatenate([carry.pop(k), rows])
        n = len(rows) // base
        segments.setdefault(k, []).append(rows[: n * base].reshape(n, base, 4).mean(axis=1))
        carry[k] = rows[n * base :]
    return [np.concatenate(parts) for parts in segments.values()]


def _cluster_differences(blocks: list[np.ndarray], j: int) -> tuple[np.ndarray, np.ndarray]:
    """Differences of consecutive cluster means of j blocks within each segment: the rate's and those of u, u^2, u^3."""
    diffs = []
    for b in blocks:
        n = len(b) // j
        if n >= 2:
            diffs.append(np.diff(b[: n * j].reshape(n, j, 4).mean(axis=1), axis=0))
    d = np.concatenate(diffs) if diffs else np.zeros((0, 4))
    return d[:, 0], d[:, 1:]


def _f_test(dy: np.ndarray, du: np.ndarray, stats) -> tuple[float, float, bool]:
    """Share of the variance of `dy` explained by `du` (with an intercept), its F-test p-value, and whether `du` is only the intercept."""
    du = du - du.mean(axis=0)
    scale = np.abs(du).max(axis=0)
    du = du[:, scale > 0] / scale[scale > 0]
    rank = np.linalg.matrix_rank(du, tol=1e-8 * np.sqrt(len(dy))) if du.size else 0
    centred = dy - dy.mean()
    total = float(centred @ centred)
    if rank == 0 or total == 0.0:
        return 0.0, 1.0, True
    beta = np.linalg.lstsq(du, centred, rcond=1e-8)[0]
    residual = centred - du @ beta
    rss = float(residual @ residual)
    dof = len(dy) - 1 - rank
    f = ((total - rss) / rank) / (rss / dof) if rss > 0 else np.inf
    return 1.0 - rss / total, float(stats.f.sf(f, rank, dof)), False
