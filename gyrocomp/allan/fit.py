"""The IEEE Std 952 five-term fit to an Allan variance, and the classic slope read-offs.

References
----------
.. [1] IEEE Std 952-1997, "IEEE Standard Specification Format Guide and Test
       Procedure for Single-Axis Interferometric Fiber Optic Gyros", Annex C.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from gyrocomp.allan import ieee952

__all__ = ["fit_terms", "add_readoffs", "first_minimum"]


def fit_terms(tau: np.ndarray, avar: np.ndarray, edf: np.ndarray, identify_sigmas: float, model_error: float) -> dict:
    """Non-negative weighted least squares of the five-term model (see :func:`gyrocomp.allan.analyse`).

    Returns
    -------
    dict
        Per term of :data:`~gyrocomp.allan.ieee952.TERMS`: ``value`` and
        ``sigma`` in the datasheet unit, ``unit``, ``identified``.
    """
    basis = ieee952.avar_basis(tau)
    scale = np.linalg.norm(basis, axis=0)
    a = basis / scale
    model = avar.copy()
    coef, active, cov = np.zeros(len(ieee952.TERMS)), np.zeros(len(ieee952.TERMS), bool), np.zeros((0, 0))
    for _ in range(3):
        rel_var = 2.0 / edf + model_error**2
        w = 1.0 / (np.sqrt(rel_var) * np.maximum(model, np.finfo(float).tiny))
        coef, active, cov, chi2 = _nnls_subsets(a * w[:, None], avar * w)
        model = a @ coef
    dof = max(len(tau) - int(active.sum()), 1)
    inflate = max(1.0, chi2 / dof)
    aw = a * w[:, None]
    full_cov = np.linalg.pinv(aw.T @ aw) * inflate
    var_c = np.diag(full_cov).copy()
    var_c[active] = np.diag(cov) * inflate
    terms = {}
    for i, key in enumerate(ieee952.TERMS):
        unit, factor = ieee952.UNITS[key], ieee952.FACTORS[key]
        c = coef[i] / scale[i]
        sigma_c = math.sqrt(max(var_c[i], 0.0)) / scale[i]
        if c > 0:
            value, sigma = math.sqrt(c), sigma_c / (2.0 * math.sqrt(c))
        else:
            value, sigma = 0.0, math.sqrt(sigma_c)
        terms[key] = {
            "value": value * factor,
            "unit": unit,
            "sigma": sigma * factor,
            "identified": bool(c > identify_sigmas * sigma_c),
        }
    return terms


def _nnls_subsets(a: np.ndarray, b: np.ndarray):
    """Exact non-negative least squares for a few columns: best feasible active set."""
    k = a.shape[1]
    best = None
    for size in range(1, k + 1):
        for cols in itertools.combinations(range(k), size):
            sub = a[:, cols]
            if np.linalg.matrix_rank(sub) < size:
                continue
            sol = np.linalg.lstsq(sub, b, rcond=None)[0]
            if (sol <= 0).any():
                continue
            chi2 = float(np.sum((sub @ sol - b) ** 2))
            if best is None or chi2 < best[0]:
                best = (chi2, cols, sol, sub)
    coef = np.zeros(k)
    active = np.zeros(k, bool)
    if best is None:
        return coef, active, np.zeros((0, 0)), float(np.sum(b**2))
    chi2, cols, sol, sub = best
    coef[list(cols)] = sol
    active[list(cols)] = True
    return coef, active, np.linalg.inv(sub.T @ sub), chi2


def add_readoffs(terms: dict, tau: np.ndarray, adev: np.ndarray, clusters: np.ndarray, settings) -> None:
    """Classic IEEE 952 read-offs: N on the -1/2 line at 1 s, K on the +1/2 line at 3 s, B = minimum / 0.664.

    Only taus resting on at least `min_clusters` independent clusters are
    read (`clusters`, floor(N/m) summed over segments): the relative 1 sigma
    error of the deviation there is about 1/sqrt(2 edf), edf = K - 1 for
    K non-overlapping clusters of white rate noise (chi-square interval,
    [2]_), 25 % at K = 9; longer taus are drawn and
    fitted but give no read-off. B uses the first local minimum of the curve
    among them (the flicker floor before rate random walk or drift lifts
    it), the last of them when the curve only falls, and is read only off a
    flat region: the curve within `flat_ratio` of that minimum over a tau
    span of at least `flat_span` containing it (a flicker floor is flat over
    decades; N^2/tau + K^2 tau/3, a -1/2 line meeting a +1/2 line, stays
    within 1.25 of its minimum over a factor of 6.8 of tau at most). Each line is read in its own tau
    range, the way the terms appear on an Allan curve: the -1/2 line
    (angle random walk) at or below that minimum, the +1/2 line (rate
    random walk) at or above it. A line is the longest run there of
    consecutive log-log segments whose slope is within `slope_tolerance`
    of -1/2 (+1/2); its level is the geometric mean of
    sigma * tau^(-slope) over the run. Without a run (or a flat region, or
    enough clusters) the read-off is ``None`` and ``readoff_note`` says
    why: a denoised recording, whose curve rises first and falls as
    tau^(-1/2) only at thousands of seconds, has no angle random walk to
    read, though a -1/2 stretch exists far above 1 s.

    `settings` is the analysis' :class:`~gyrocomp.allan.analysis.AllanConfig`
    (its ``arw_tau_s``, ``rrw_tau_s``, ``slope_tolerance``,
    ``bias_factor``, ``min_clusters``, ``flat_ratio`` and ``flat_span``);
    it is not imported here, which would close a cycle.

    References
    ----------
    .. [2] W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065 (2008).
    """
    k = int(np.count_nonzero(np.asarray(clusters) >= settings.min_clusters))  # clusters fall with tau: a prefix
    if k == 0:
        note = f"fewer than {settings.min_clusters} independent clusters at every tau (from {tau[0]:.3g} s)"
        for key in ("arw", "bias_instability", "rrw"):
            terms[key].update(readoff=None, readoff_tau_s=None, readoff_note=note)
        return
    tau, adev = tau[:k], adev[:k]
    short = "" if k == len(clusters) else f" to {tau[-1]:.3g} s (at least {settings.min_clusters} independent clusters)"
    i = first_minimum(adev)
    ranges = {"arw": (-0.5, settings.arw_tau_s, slice(0, i + 1), "at or below"), "rrw": (0.5, settings.rrw_tau_s, slice(i, len(tau)), "at or above")}
    for key, (slope, at, window, where) in ranges.items():
        run = _longest_run(tau[window], adev[window], slope, settings.slope_tolerance)
        factor = ieee952.FACTORS[key]
        if run is None:
            note = f"no {slope:+.1f} slope {where} the Allan minimum (tau = {tau[i]:.3g} s){short}"
            terms[key].update(readoff=None, readoff_tau_s=None, readoff_note=note)
            continue
        run = run + window.start
        level = np.exp(np.mean(np.log(adev[run]) - slope * np.log(tau[run])))
        terms[key].update(readoff=float(level * at**slope * factor), readoff_tau_s=[float(tau[run[0]]), float(tau[run[-1]])])
    low, high = _flat_region(adev, i, settings.flat_ratio)
    flat = [float(tau[low]), float(tau[high])]
    if tau[high] / tau[low] < settings.flat_span:
        note = (
            f"no flat region at the Allan minimum (tau = {tau[i]:.3g} s){short}: within {settings.flat_ratio:g}x of it "
            f"from {flat[0]:.3g} to {flat[1]:.3g} s, a factor {tau[high] / tau[low]:.3g} (flat_span {settings.flat_span:g})"
        )
        terms["bias_instability"].update(readoff=None, readoff_tau_s=None, readoff_note=note)
        return
    terms["bias_instability"].update(
        readoff=float(adev[i] / settings.bias_factor * ieee952.FACTORS["bias_instability"]),
        readoff_tau_s=float(tau[i]),
        flat_tau_s=flat,
    )


def first_minimum(adev: np.ndarray) -> int:
    """Index of the first local minimum of an Allan curve (the last point when it only falls)."""
    rising = np.flatnonzero(np.diff(adev) > 0)
    return int(rising[0]) if rising.size else len(adev) - 1


def _flat_region(adev: np.ndarray, i: int, ratio: float) -> tuple[int, int]:
    """First and last index of the run around `i` where the deviation stays within `ratio` times adev[i]."""
    inside = adev <= ratio * adev[i]
    low, high = i, i
    while low > 0 and inside[low - 1]:
        low -= 1
    while high < len(adev) - 1 and inside[high + 1]:
        high += 1
    return low, high


def _longest_run(tau, adev, slope, tolerance):
    if len(tau) < 2:
        return None
    local = np.diff(np.log(adev)) / np.diff(np.log(tau))
    ok = np.abs(local - slope) <= tolerance
    best, start = None, None
    for i, flag in enumerate(np.append(ok, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if best is None or i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    if best is None:
        return None
    return np.arange(best[0], best[1] + 1)
