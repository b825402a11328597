"""The nonlinear search of one effect: its nonlinear parameter and form, fitted on the fit run.

:func:`extend` adds an effect to a model: a deterministic effect at the
nonlinear parameter (a time constant, a deadband, a period) and the form of
lowest BIC on its grid, refined in log scale (:func:`_best_nonlinear`), and
the nonlinear parameters of the effects already in are refitted beside it
in one coordinate-descent pass (a warm-up fitted alone stretches its time
constant over a ramp; :func:`_descend`); ``bias_instability`` takes flicker
or its Markov form (:func:`_bias_forms`). A periodic's period is searched
jointly over the runs with its per-run phases (:class:`_JointPart`), its
number of harmonics by BIC (:func:`_periodic_waveform`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize

from gyrocomp.diagnose.criterion import Fitted, Problem, _n_params
from gyrocomp.diagnose.effects import DETERMINISTIC, KINDS, PER_RUN, periodic_block_means
from gyrocomp.effects.likelihood import NoiseModel, fit_noise, merge_blocks
from gyrocomp.effects.vocabulary.periodic import harmonic_names

__all__ = ["extend"]


def extend(problem: Problem, current: Fitted, effect: str) -> Fitted:
    """`current` plus `effect`, its parameters fitted on the fit run.

    ``bias_instability`` takes the form of lowest BIC: flicker, or its
    Markov form at each correlation time of its grid (one parameter more;
    :class:`~gyrocomp.effects.likelihood.NoiseModel`).
    """
    stochastic = [e for e in current.order if e not in DETERMINISTIC]
    spec = dict(current.spec)
    starts = [current.noise]
    if effect in DETERMINISTIC:
        spec[effect] = _best_nonlinear(problem, current, effect)
        # The earlier effects' nonlinear parameters were fitted without this
        # one (a warm-up fitted alone stretches its tau over a ramp): refit
        # each with the new effect in.
        spec = _descend(problem, current, spec, current.spec)
    else:
        stochastic.append(effect)
    Xb, names = problem.design_blocks(spec)
    free = ("arw",) + tuple(stochastic)
    if effect == "bias_instability":
        starts = _bias_forms(problem, current.noise, Xb, free)
    order = current.order + (effect,)
    best = None
    for start in starts:
        noise, deviance, beta = fit_noise(problem.y, Xb, problem.basis, start, free)
        k = current.n_params + _n_params(order, spec, noise) - _n_params(current.order, current.spec, current.noise)
        trial = Fitted(order, spec, noise, beta, names, deviance, k, problem.bic(deviance, k))
        if best is None or trial.bic < best.bic:
            best = trial
    return best


def _bias_forms(problem: Problem, noise: NoiseModel, Xb, free) -> list:
    """Noise models to fit ``bias_instability`` from: flicker, and its Markov form at each correlation time of the grid.

    Beside a random walk every likelihood evaluation factorises the whole
    covariance (:meth:`NoiseBasis.whitener`), so the correlation time is
    chosen on the block means merged to ``bias_correlation_search_blocks``
    (:func:`~gyrocomp.effects.likelihood.merge_blocks`; the Markov forms
    have one parameter count, so their deviances rank them) and only that
    form is fitted beside flicker on the full blocks.
    """
    run, s = problem.run, problem.settings
    grid = KINDS["bias_instability"].grid(s, run.n_blocks * run.block_s, run.block_s)
    markov = [dataclasses.replace(noise, bias_correlation_s=float(tc)) for tc in grid]
    flicker = dataclasses.replace(noise, bias_correlation_s=0.0)
    if not noise.rate_random_walk or not markov or problem.y.size <= s.bias_correlation_search_blocks:
        return [flicker] + markov
    y, X, basis = merge_blocks(problem.y, Xb, problem.basis, s.bias_correlation_search_blocks)
    deviance = [fit_noise(y, X, basis, start, free)[1] for start in markov]
    return [flicker, markov[int(np.argmin(deviance))]]


def _descend(problem: Problem, model: Fitted, spec: dict, effects) -> dict:
    """One coordinate-descent pass: `spec` with each of `effects` that has a nonlinear parameter or forms
    refitted in turn (:func:`_best_nonlinear`) at `model`'s noise, beside the others' parameters as they stand."""
    spec = dict(spec)
    for effect in effects:
        if KINDS[effect].nonlinear or KINDS[effect].forms:
            spec[effect] = _best_nonlinear(problem, dataclasses.replace(model, spec=spec), effect)
    return spec


def _best_nonlinear(problem: Problem, current: Fitted, effect: str, others_problems=()) -> dict:
    """Grid search (then bounded refinement in log scale) of the effect's nonlinear parameter, in its best form.

    An effect with :attr:`~gyrocomp.effects.vocabulary.Effect.forms` takes the
    form of lowest BIC, ``-2 log L + k ln n`` with ``k`` the form's
    parameter count and ``n`` the blocks of the runs, each form at its own
    best nonlinear parameter: a richer form's extra columns earn their
    place like an effect's (a temperature-rate asymmetry that is not there
    must not charge a symmetric sensitivity a parameter its look-alike, a
    short thermal lag, does not pay), and between forms with as many
    parameters the likelihood decides (a hysteresis relay or play).

    Every parameter is refined between the grid's neighbours of the best
    point, the hysteresis deadband too: a relay's switching width is
    anything from half a degree to 15 degC, and a width between two grid
    points moves every switch by tens of seconds on a 1 degC/min ramp,
    which a strong hysteresis shows (and a noise term would absorb).

    The noise is held at the current model's; the other columns are
    block-averaged once. With `others_problems` (``(problem, model)`` pairs:
    the holdout with its own noise, in the joint criterion of
    :func:`joint_gain`) the deviance is summed over the runs, the per-run
    columns separate and the rest shared.
    """
    kind = KINDS[effect]
    if not kind.nonlinear and not kind.forms:
        return {}
    parts = [_JointPart(problem, current, effect)] + [_JointPart(p, m, effect) for p, m in others_problems]
    log_n = np.log(sum(part.y_w.size for part in parts))
    fitted = [_best_in_form(problem, parts, effect, dict(form)) for form in kind.forms or ({},)]
    bic = [value + kind.n_params_of(params) * log_n for params, value in fitted]
    return fitted[int(np.argmin(bic))][0]


def _best_in_form(problem: Problem, parts, effect: str, form: dict):
    """The nonlinear parameter of `effect` in one of its forms (:func:`_best_nonlinear`): ``(params, -2 log L)``."""
    kind = KINDS[effect]
    key = kind.nonlinear

    def deviance(params):
        return float(_joint_deviance(parts, params, effect).sum())

    if not key or key in form:
        return form, deviance(form)
    run = problem.run
    length_s = run.n_blocks * run.block_s
    grid = kind.grid(problem.settings, length_s, run.block_s)
    if effect == "periodic":
        return _periodic_waveform(parts, grid, problem.settings, length_s, run.block_s, lambda p: deviance(form | p))
    pair = kind.paired(form, problem.settings, length_s)
    if pair:
        return _best_pair(parts, effect, form, grid, *pair, deviance)
    values = np.array([deviance(form | {key: float(v)}) for v in grid])
    value, best = _refine(grid, values, lambda v: deviance(form | {key: v}))
    return form | {key: value}, best


def _refine(grid, values, deviance):
    """The grid point of least deviance refined (bounded, in log scale) between its neighbours: ``(value, deviance)``.

    The grid may run either way (a period grid descends)."""
    i = int(np.argmin(values))
    lo, hi = sorted((grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]))
    return _refine_between(lo, hi, float(grid[i]), float(values[i]), deviance)


def _refine_between(lo, hi, x0, d0, deviance):
    """`x0` (of deviance `d0`) refined (bounded, in log scale) between `lo` and `hi`: ``(value, deviance)``."""
    a, b = np.log(lo), np.log(hi)
    if b > a:
        best = optimize.minimize_scalar(
            lambda z: deviance(float(np.exp(z))), bounds=(a, b), method="bounded", options={"xatol": 1e-3}
        )
        if best.fun < d0:
            return float(np.exp(best.x)), float(best.fun)
    return x0, d0


def _best_pair(parts, effect, form, grid, key2, ratio, top, deviance):
    """Both nonlinear parameters of a paired form (:meth:`~gyrocomp.effects.vocabulary.Effect.paired`): ``(params, -2 log L)``.

    Every pair of grid values ``(x, x2)`` with ``ratio x <= x2 <= top`` is
    scored at once (:func:`_pair_grid_deviances`); the best pair's ``x`` is
    then refined between its grid neighbours with ``x2`` held, and ``x2``
    with the refined ``x`` held, neither crossing the ratio nor `top`.

    An ``x2`` that settles at `top` asks for more than `top`, which the run
    cannot tell from another effect (a warm-up slower than half the run
    is a drift there, ``rate_ramp``'s): the form is then given an infinite
    deviance (never kept), as on a run too short for any pair.
    """
    key = KINDS[effect].nonlinear
    i, j = np.triu_indices(grid.size, 1)
    keep = (grid[j] >= ratio * grid[i]) & (grid[j] <= top)
    i, j = i[keep], j[keep]
    if not i.size:
        return form | {key: float(grid[0]), key2: float(ratio * grid[0])}, np.inf
    values = _pair_grid_deviances(parts, effect, grid, i, j)
    b = int(np.argmin(values))
    x, x2, best = float(grid[i[b]]), float(grid[j[b]]), float(values[b])
    last = grid.size - 1
    x, best = _refine_between(grid[max(i[b] - 1, 0)], min(grid[min(i[b] + 1, last)], x2 / ratio), x, best, lambda v: deviance(form | {key: v, key2: x2}))
    x2, best = _refine_between(max(grid[max(j[b] - 1, 0)], x * ratio), min(grid[min(j[b] + 1, last)], top), x2, best,
                               lambda v: deviance(form | {key: x, key2: v}))
    at_top = np.log(top / x2) < 1e-2
    return form | {key: x, key2: x2}, (np.inf if at_top else best)


def _pair_grid_deviances(parts, effect, grid, first, second):
    """:func:`_joint_deviance` of `effect`'s paired form at the grid pairs ``(grid[first], grid[second])``, in a few
    matrix products.

    The paired form's columns are the plain form's at either value, shared
    by the runs; the plain form's whitened columns at every grid value
    (:meth:`_JointPart.candidate`, cached) stacked over the runs as ``C``, the
    deviance of a pair ``S`` is ``constant + |y_perp|^2 - b_S' A_SS^+ b_S``
    with ``b = C' y_perp`` and ``A = C'C - (U'C)'(U'C)`` (:func:`_base_projection`).
    """
    key = KINDS[effect].nonlinear
    u, y_perp, residual = _base_projection(parts)
    c = np.vstack([np.hstack([part.candidate(effect, {key: float(v)})[0] for v in grid]) for part in parts])
    uc = u.T @ c
    a = c.T @ c - uc.T @ uc
    b = c.T @ y_perp
    pair = np.stack([first, second], axis=1)
    a_s = a[pair[:, :, None], pair[:, None, :]]
    b_s = b[pair]
    return residual - np.einsum("gi,gij,gj->g", b_s, np.linalg.pinv(a_s, rcond=1e-12, hermitian=True), b_s)


def _base_projection(parts):
    """The base columns' orthonormal basis ``U`` (stacked over the runs, the per-run columns apart), ``y_perp = y - U U' y``
    and the deviance of the base alone, ``constant + |y_perp|^2``."""
    free = [np.array([n in PER_RUN for n in part.base_names]) for part in parts]
    shared = np.vstack([part.base_w[:, ~f] for part, f in zip(parts, free)])
    per_run = linalg.block_diag(*[part.base_w[:, f] for part, f in zip(parts, free)])
    u, sv, _ = linalg.svd(np.hstack([shared, per_run]), full_matrices=False, check_finite=False)
    u = u[:, sv > sv[0] * 1e-12]
    y = np.concatenate([part.y_w for part in parts])
    y_perp = y - u @ (u.T @ y)
    return u, y_perp, sum(part.constant for part in parts) + float(y_perp @ y_perp)


def _periodic_waveform(parts, periods, settings, length_s, block_s, deviance):
    """The multiharmonic periodogram: the period and the number of harmonics ``H`` of least BIC.

    For every ``H`` from 1 to ``periodic_harmonics`` the deviance of a
    Fourier series of ``H`` harmonics is scanned over the periods that may
    carry ``H`` (:meth:`gyrocomp.effects.vocabulary.periodic._Periodic.max_harmonics`)
    and its best period refined (harmonic ``k`` moves ``k`` times faster
    with the period than the fundamental, so each ``H`` is refined apart);
    the ``H`` of least ``deviance + 2 H R ln n`` wins (``2 H`` per-run
    coefficients on each of the ``R`` runs, ``n`` their blocks: the
    selection's parameter count). The harmonics summed, a pulse train's
    fundamental scores its whole power, not the fundamental's share
    (Schwarzenberg-Czerny 1996).

    Returns
    -------
    params : dict
        ``{"period_s": P, "harmonics": H}``.
    deviance : float
        Its ``-2 log L``.
    """
    effect = KINDS["periodic"]
    h_max = np.array([effect.max_harmonics(settings, p, length_s, block_s) for p in periods])
    log_n = np.log(sum(part.y_w.size for part in parts))
    best_score, best = np.inf, None
    grid = _periodic_grid_deviances(parts, periods, h_max)
    for h in range(1, int(h_max.max()) + 1):
        period, dev = _refine(periods, grid[h - 1], lambda p: deviance({"period_s": p, "harmonics": h}))
        score = dev + 2 * h * len(parts) * log_n
        if score < best_score:
            best_score, best = score, ({"period_s": period, "harmonics": h}, dev)
    return best


class _JointPart:
    """One run's whitened block means and fixed columns for a candidate `effect`."""

    def __init__(self, problem: Problem, current: Fitted, effect: str):
        self.problem = problem
        self.whitener = problem.basis.whitener(current.noise)
        others = {k: v for k, v in current.spec.items() if k != effect}
        X, names = problem.design_blocks(others)
        if effect == "thermal_lag":
            keep = [i for i, n in enumerate(names) if not n.startswith("temperature^")]
            X, names = X[:, keep], [names[i] for i in keep]
        # Whitening is linear: whiten the fixed columns and y once, then only the candidate's.
        self.base_w = self.whitener.whiten(X)
        self.base_names = names
        self.y_w = self.whitener.whiten(problem.y)
        self.constant = self.whitener.logdet + problem.y.size * np.log(2.0 * np.pi)

    def candidate(self, effect, params):
        if effect is None:
            return np.empty((self.y_w.size, 0)), []
        if effect == "periodic":
            harmonics = int(params.get("harmonics", 1))
            return self.whitener.whiten(periodic_block_means(self.problem.run, params["period_s"], harmonics)), harmonic_names(harmonics)
        names = self.problem.effect_blocks(effect, params)[1]
        key = (effect, tuple(sorted(params.items())))
        return self.problem.whitened(self.whitener, key, lambda: self.problem.effect_blocks(effect, params)[0]), names


def _whitened_harmonics(part: _JointPart, periods, h_max) -> dict:
    """Whitened block means of each period's sin/cos columns up to its own largest number of harmonics `h_max`.

    Returns a dict ``{H: (index, columns)}`` over the values ``H > 0`` of
    `h_max`: the periods ``index`` of that ``H`` and their columns, an array
    of shape ``(len(index), n_blocks, 2 H)`` (in
    :func:`~gyrocomp.diagnose.effects.periodic_block_means` order, so the
    first ``2 h`` are the series of ``h`` harmonics), whitened in one
    product (:meth:`~gyrocomp.diagnose.criterion.Problem.whitened`).
    """
    out = {}
    for h in np.unique(h_max[h_max > 0]):
        index = np.flatnonzero(h_max == h)
        key = ("periodic", int(h), periods[index].tobytes())
        cols = part.problem.whitened(part.whitener, key, lambda: np.hstack([periodic_block_means(part.problem.run, periods[i], h) for i in index]))
        out[int(h)] = (index, cols.reshape(cols.shape[0], index.size, 2 * h).transpose(1, 0, 2))
    return out


def _periodic_grid_deviances(parts, periods, h_max):
    """:func:`_joint_deviance` of ``periodic`` at every period of a grid and every number of harmonics up to the
    period's own largest `h_max`, in a few matrix products.

    The base columns do not change along the grid: with ``U`` an orthonormal
    basis of the (stacked, whitened) base design, ``y_perp = y - U U' y``
    and the sin/cos columns ``C`` of one period (per run), the deviance is
    ``constant + |y_perp|^2 - b' A^+ b`` with ``b = C' y_perp`` and
    ``A = C'C - (U'C)'(U'C)`` (:func:`_base_projection`). ``A`` and ``b`` of ``h`` harmonics are the
    leading rows and columns (per run) of those of the period's `h_max`
    (:func:`_whitened_harmonics`), so each period's are formed once.

    Returns
    -------
    ndarray, shape (h_max.max(), len(periods))
        Row ``h - 1``: the deviances of ``h`` harmonics (inf where ``h`` exceeds `h_max`).
    """
    u, y_perp, residual = _base_projection(parts)
    whitened = [_whitened_harmonics(part, periods, h_max) for part in parts]
    out = np.full((int(h_max.max()), len(periods)), np.inf)
    for h_top, (index, _) in whitened[0].items():
        c, n_parts = 2 * h_top, len(parts)
        gram = np.zeros((index.size, c * n_parts, c * n_parts))
        b = np.zeros((index.size, c * n_parts))
        ucs = np.zeros((index.size, u.shape[1], c * n_parts))
        row = 0
        for j, part in enumerate(parts):
            k, cw = part.y_w.size, whitened[j][h_top][1]  # (G, k, c)
            # stacked matrix products (BLAS), not einsum: the same sums, an order of magnitude faster
            cwt = cw.transpose(0, 2, 1)
            gram[:, c * j : c * j + c, c * j : c * j + c] = cwt @ cw
            b[:, c * j : c * j + c] = cwt @ y_perp[row : row + k]
            ucs[:, :, c * j : c * j + c] = u[row : row + k].T @ cw
            row += k
        a = gram - ucs.transpose(0, 2, 1) @ ucs
        for h in range(1, h_top + 1):
            keep = (c * np.arange(n_parts)[:, None] + np.arange(2 * h)).ravel()
            a_h, b_h = a[:, keep][:, :, keep], b[:, keep]
            out[h - 1, index] = residual - np.einsum("gi,gij,gj->g", b_h, np.linalg.pinv(a_h, rcond=1e-12, hermitian=True), b_h)
    return out


def _joint_deviance(parts, params, effect):
    """``-2 log L`` of each run: shared coefficients, per-run :data:`PER_RUN` columns.

    Returns an array, one deviance per run (their sum is the joint one).
    """
    blocks, ys, constants = [], [], []
    for part in parts:
        cols, names = part.candidate(effect, params)
        X = np.hstack([part.base_w, cols])
        names = part.base_names + names
        blocks.append((X, np.array([n in PER_RUN for n in names])))
        ys.append(part.y_w)
        constants.append(part.constant)
    if len(parts) == 1:
        X = blocks[0][0]
    else:
        free = blocks[0][1]
        shared = np.vstack([X[:, ~free] for X, _ in blocks])
        per_run = linalg.block_diag(*[X[:, free] for X, _ in blocks])
        X = np.hstack([shared, per_run])
    y = np.concatenate(ys)
    beta, *_ = linalg.lstsq(X, y, cond=1e-12, lapack_driver="gelsy", check_finite=False)
    r = y - X @ beta
    ends = np.cumsum([part.y_w.size for part in parts])[:-1]
    return np.array([c + float(rk @ rk) for c, rk in zip(constants, np.split(r, ends))])
