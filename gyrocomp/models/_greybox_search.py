"""The grey-box model's term search: runs reduced to block means, and forward selection by BIC.

:class:`Prepared` reduces a training run for the likelihood (group means,
blocks, their start times); :class:`Search` adds, one at a time, the term
and nonlinear parameter that lower the diagnosis' BIC most, each tried only
where the runs identify it (:func:`gyrocomp.identifiability.separable`),
then refines the nonlinear parameters off their grids.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import linalg, optimize

from gyrocomp.effects.shapes import first_excursion, hysteresis_branch
from gyrocomp.errors import InputError
from gyrocomp.identifiability import Refusal, separable
from gyrocomp.models._greybox_state import JOINS, Spec, columns_of, element_column, kernel

__all__ = ["Prepared", "Search", "RATE_GRID_POINTS", "SATURATION_GRID_POINTS", "SETTLE_TAUS"]

RATE_GRID_POINTS = 6
"""Points of the log grid of the dT/dt filter's time constant (then refined)."""

SERIES_SHARES = (0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5)
"""Shares of the first stage in the total time constant of two lags in series (then both refined)."""

SATURATION_GRID_POINTS = 13
"""Points of the log grid of the dT/dt saturation rate (then refined)."""

ASYMMETRY = "temp_rate_heating_cooling_apart"
"""The name under which ``not_fitted`` reports a dT/dt sensitivity the runs cannot split into heating and cooling
(runs that only heat or only cool, where ``|dT/dt|`` is ``dT/dt`` or its negative)."""

SETTLE_TAUS = 5.0
"""The causal dT/dt starts at 0 (the filter cold); the first ``SETTLE_TAUS * rate_tau_s[1]`` seconds of a run
(of every segment when gaps are not bridged) take no part in the fit, so its settling is never read as an effect
(e^-5: under 1 % of the true rate is missing after them)."""


@dataclasses.dataclass
class Prepared:
    """A training run reduced for the likelihood: group means, blocks and their covariance basis."""

    run: TrainingRun
    time_s: np.ndarray
    temperature_c: np.ndarray
    segments: list
    block_of: np.ndarray  # block index of each reduced sample, -1 when in no whole block
    n_blocks: int
    block_s: float
    starts: np.ndarray
    y: np.ndarray
    duration_s: float

    @classmethod
    def of(cls, run: TrainingRun, model) -> "Prepared":
        t, T, y = (np.asarray(a, dtype=float) for a in (run.time_s, run.temperature_c, run.rate))
        duration = float(sum(t[s][-1] - t[s][0] for s in run.segments))
        interval = float(np.median(np.diff(t))) if t.size > 1 else 1.0
        block_s = max(model.block_s, duration / model.max_blocks, interval)
        per_block = max(1, int(round(block_s / interval)))
        group = max(1, per_block // 10)  # ten group means a block: the shapes are slow beside that
        pb = per_block // group  # group means a block
        settle_s = SETTLE_TAUS * model.rate_tau_s[1]
        run_start = t[run.segments[0].indices(t.size)[0]]
        times, temps, rates, blocks, starts, segs = [], [], [], [], [], []
        n_blocks = offset = 0
        for number, s in enumerate(run.segments):
            lo, hi = s.indices(t.size)[:2]
            k = (hi - lo) // group
            if k == 0:
                continue
            ts, Ts, ys = (a[lo : lo + k * group].reshape(k, group).mean(axis=1) for a in (t, T, y))
            skip = int(np.searchsorted(ts, ts[0] + settle_s)) if number == 0 or not model.bridge_gaps else 0
            whole = max(k - skip, 0) // pb
            idx = np.full(k, -1)
            idx[skip : skip + whole * pb] = n_blocks + np.arange(whole * pb) // pb
            starts.extend(ts[skip : skip + whole * pb : pb] - run_start)
            n_blocks += whole
            times.append(ts), temps.append(Ts), rates.append(ys), blocks.append(idx)
            segs.append(slice(offset, offset + k))
            offset += k
        if n_blocks < 8:
            raise InputError(f"{run.name}: {n_blocks} blocks of {block_s:g} s; the grey-box model needs at least 8 (a longer run)")
        block_of = np.concatenate(blocks)
        y_all = np.concatenate(rates)
        return cls(run, np.concatenate(times), np.concatenate(temps), segs, block_of, n_blocks, per_block * interval,
                   np.asarray(starts), block_means(y_all, block_of, n_blocks), duration)

    def raw(self, spec: Spec, bridge: bool) -> np.ndarray:
        from gyrocomp.effects._stateful import new_state

        state = new_state()
        out = np.empty((self.time_s.size, 5))
        for s in self.segments:
            if not bridge:
                state[:] = 0.0
            out[s] = kernel(self.time_s[s], self.temperature_c[s], state, spec)
        return out

    def ranges(self, model, spec: Spec) -> tuple:
        raw = self.raw(spec, model.bridge_gaps)
        element = raw[:, element_column(spec)]
        return float(element.min()), float(element.max()), float(raw[:, 1].min()), float(raw[:, 1].max())


def block_means(x: np.ndarray, block_of: np.ndarray, n_blocks: int) -> np.ndarray:
    keep = block_of >= 0
    counts = np.bincount(block_of[keep], minlength=n_blocks)
    if x.ndim == 1:
        return np.bincount(block_of[keep], weights=x[keep], minlength=n_blocks) / counts
    return np.column_stack([np.bincount(block_of[keep], weights=c[keep], minlength=n_blocks) / counts for c in x.T])


class Search:
    """Forward selection of the terms by BIC, each tried only where the runs identify it."""

    def __init__(self, model, runs: list):
        from gyrocomp.effects.likelihood import NoiseBasis

        self.model = model
        self.runs = runs
        self.bases = [NoiseBasis(r.n_blocks, r.block_s, r.starts) for r in runs]
        self.n_blocks = sum(r.n_blocks for r in runs)
        self._raw = {}  # the kernel's columns of each run, by the states' parameters
        self._power_on = {}  # the power-on columns of each run, by the hysteresis' parameters
        self._whiteners = ((), [])  # the last noise levels' factorisations: the trials of a round share them

    # design ---------------------------------------------------------------
    def design(self, spec: Spec) -> tuple[list, list, list]:
        """Block-mean design of each run, full-rate design of each run and the column names (per-run columns first)."""
        m = self.model
        n_runs = len(self.runs)
        blocks, full, names = [], [], None
        for i, run in enumerate(self.runs):
            power_on = run.run.power_on_s if run.run.power_on_s is not None else run.time_s[0]
            cols = columns_of(self._raw_of(i, spec), run.time_s, spec, power_on, m.centre_c_, m.half_range_c_, m.degree)
            per_run = {f"offset_{j}": np.full(run.time_s.size, float(j == i)) for j in range(n_runs)}
            for name, column in self._power_on_of(i, spec).items():
                per_run |= {f"{name}_{j}": column * (j == i) for j in range(n_runs)}
            columns = per_run | cols
            names = list(columns)
            X = np.column_stack(list(columns.values()))
            full.append(X)
            blocks.append(block_means(X, run.block_of, run.n_blocks))
        return blocks, full, names

    def n_params(self, spec: Spec, names: list, noise_free: int) -> int:
        return len(names) + spec.n_nonlinear() + noise_free

    # likelihood -------------------------------------------------------------
    def deviance(self, blocks: list, noise) -> tuple[float, np.ndarray]:
        """-2 log L with beta at its GLS estimate, the runs independent (block-diagonal covariance)."""
        from gyrocomp.effects.likelihood import NoiseModel

        noise = tuple(noise)
        if self._whiteners[0] != noise:
            model = NoiseModel(*noise)
            self._whiteners = (noise, [basis.whitener(model) for basis in self.bases])
        yw, Xw, logdet = [], [], 0.0
        for run, w, X in zip(self.runs, self._whiteners[1], blocks):
            yw.append(w.whiten(run.y))
            Xw.append(w.whiten(X))
            logdet += w.logdet
        yw, Xw = np.concatenate(yw), np.vstack(Xw)
        beta, *_ = linalg.lstsq(Xw, yw, cond=1e-12, lapack_driver="gelsy", check_finite=False)
        r = yw - Xw @ beta
        return float(logdet + r @ r + yw.size * np.log(2 * np.pi)), beta

    def fit_noise(self, blocks: list, start=None) -> tuple:
        """ML white, flicker and random-walk levels (log-variances by Nelder-Mead); (noise, deviance, beta)."""
        X = np.vstack(blocks)
        y = np.concatenate([r.y for r in self.runs])
        beta = np.linalg.lstsq(X, y, rcond=None)[0]
        s2 = max(float(np.mean((y - X @ beta) ** 2)), 1e-300)
        block_s = self.runs[0].block_s
        arw0 = math.sqrt(s2 * block_s)
        x0 = np.log([arw0, 0.3 * math.sqrt(s2), 0.3 * math.sqrt(s2) / math.sqrt(block_s)]) if start is None else np.log(np.maximum(start, 1e-30))
        floor = np.log(arw0) - 12.0

        def objective(v):
            noise = np.exp(np.maximum(v, floor))
            return self.deviance(blocks, noise)[0]

        result = optimize.minimize(objective, x0, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-3, "maxiter": 400})
        noise = tuple(float(v) for v in np.exp(np.maximum(result.x, floor)))
        deviance, beta = self.deviance(blocks, noise)
        return noise, deviance, beta

    def bic(self, deviance: float, k: int) -> float:
        return deviance + k * math.log(self.n_blocks)

    # identifiability ----------------------------------------------------------
    def _stacked(self, spec: Spec) -> dict:
        """Block-mean columns of `spec` over every run, what the fit sees (offsets of runs after the first; the constant is implicit)."""
        blocks, _, names = self.design(spec)
        X = np.vstack(blocks)
        shown = {f"z{k}": ("T_e" if spec.tau_e else "T") + ("" if k == 1 else f"^{k}") for k in range(1, self.model.degree + 1)}
        return {shown.get(n, n): X[:, j] for j, n in enumerate(names) if n != "offset_0"}

    def identified(self, spec: Spec, trial: Spec, term: str):
        """None when the runs identify `term` at `trial` beside the columns of `spec`, else the :class:`Refusal`.

        The columns judged are those `term` adds, beside those of `spec` as
        `trial` holds them (a second play is judged beside the first at the
        width the trial gives it) and the trial's power-on columns, a nuisance
        never judged itself; for the thermal lag, which
        replaces T by T_e in the cubic, the difference ``T_e - T``; for the
        saturation, which replaces dT/dt by ``s tanh(dT/dt / s)``, their difference.
        """
        width = {"hysteresis": trial.width, "second_hysteresis": trial.width2}.get(term)
        inputs = [self._raw_of(i, trial)[:, 0] if trial.on_element and trial.tau_e else r.temperature_c for i, r in enumerate(self.runs)]
        if width is not None and not any(_reverses(x, width) for x in inputs):
            return Refusal(
                term, 0.0,
                f"{term} not fitted: the temperature never reverses by more than {width:.3g} degC after its first excursion "
                "on the training runs, so the branch never changes and the play is a function of T alone; add a run that heats and cools",
            )
        stacked = self._stacked(trial)
        # The unknown power-on state's columns are a nuisance of the trial: part of what the term is judged beside,
        # never judged themselves (two plays' columns overlap; least squares takes them as they come).
        base = self._stacked(spec) | {n: c for n, c in stacked.items() if n.startswith("power_on")}
        if term == "thermal_lag":
            lag = [block_means(self._raw_of(i, trial)[:, 0] - r.temperature_c, r.block_of, r.n_blocks) for i, r in enumerate(self.runs)]
            added = {"thermal_lag (T_e - T)": np.concatenate(lag)}
        elif term == "second_lag" and trial.series:  # the cubic moves from T_e to the second stage: judge the difference
            stage = [block_means(self._raw_of(i, trial)[:, 3] - self._raw_of(i, trial)[:, 0], r.block_of, r.n_blocks)
                     for i, r in enumerate(self.runs)]
            added = {"second_lag (T_e2 - T_e, in series)": np.concatenate(stage)}
        elif term == "rate_saturation":  # the saturated dT/dt replaces the linear one: judge what it adds
            added = {f"rate_saturation ({n}: saturated less linear)": stacked[n] - base[n] for n in ("rate", "rate_abs") if n in base}
        else:  # beside the others as the trial holds them (a second play re-searches the first play's width too)
            added = {f"{term} ({n})": c for n, c in stacked.items() if n not in base}
            base = {n: stacked.get(n, c) for n, c in base.items()}
        _, refused = separable({**base, **added}, self.model.min_unique_variance)
        return next((r for r in refused if r.term in added), None)

    def _power_on_of(self, i: int, spec: Spec) -> dict:
        """Columns of run `i` spanning what the hysteresis' unknown state at power-on adds (free per run).

        A relay: 1 until its first switch (before it, its output is 0 and the
        branch is +1 or -1, a constant). A play (and a second play): its start
        on either branch less its centred start
        (:func:`~gyrocomp.effects._stateful.play_start_spread`): not a
        constant, since a play started on a branch follows the temperature at
        once while the centred one waits for half the width.
        """
        from gyrocomp.effects._stateful import play_start_spread

        key = (i, spec.tau_e, spec.width, spec.relay, spec.width2, spec.on_element)
        if key not in self._power_on:
            raw, run = self._raw_of(i, spec), self.runs[i]
            x = raw[:, 0] if spec.on_element and spec.tau_e else run.temperature_c
            restart = np.zeros(x.size, dtype=bool)
            restart[[s.start for s in (run.segments if not self.model.bridge_gaps else run.segments[:1])]] = True
            columns = {}
            if spec.width and spec.relay:
                columns["power_on"] = (raw[:, 2] == 0.0).astype(float)
            for name, width in (("power_on_play", 0.0 if spec.relay else spec.width), ("power_on_play2", spec.width2 if spec.width else 0.0)):
                if width:
                    spread = np.empty((x.size, 2))
                    play_start_spread(x, restart, 0.5 * width, spread)
                    columns |= {f"{name}_high": spread[:, 0], f"{name}_low": spread[:, 1]}
            self._power_on[key] = columns
        return self._power_on[key]

    def _raw_of(self, i: int, spec: Spec) -> np.ndarray:
        key = (i, spec.tau_e, spec.width, spec.tau_r, spec.relay, spec.tau_e2, spec.series, spec.width2, spec.on_element)
        if key not in self._raw:
            states = Spec(spec.tau_e, 1, spec.width, 0.0, spec.tau_r, spec.relay, spec.tau_e2, series=spec.series, width2=spec.width2,
                          on_element=spec.on_element)
            self._raw[key] = self.runs[i].raw(states, self.model.bridge_gaps)
        return self._raw[key]

    # search -------------------------------------------------------------------
    def grids(self, spec: Spec) -> dict:
        """Each term's candidate changes to `spec`. Two lags in series are searched about the lag `spec` holds: a single
        lag's time constant is their sum (the mean delay), so the grid is of the first stage's share of it. A second play
        beside a play: both widths anew (:func:`_pairs`); beside a relay, which gains only at its own width, the play's alone.
        With both a lag and a hysteresis, the hysteresis may switch on the measured T or on T_e: the hysteresis is tried
        on either beside a lag, and the lag with the hysteresis on either."""
        m = self.model
        series = [{"tau_e": f * spec.tau_e, "tau_e2": (1 - f) * spec.tau_e, "series": True} for f in SERIES_SHARES] if spec.tau_e else []
        widths = np.asarray(sorted(m.widths_c))
        inputs = (False, True) if spec.tau_e else (False,)
        lag_inputs = (False, True) if spec.width else (False,)
        plays = [{"width2": float(v)} for v in widths] if spec.relay else _pairs("width", "width2", widths)
        return {
            "thermal_lag": [{"tau_e": float(v), "on_element": e} for e in lag_inputs for v in np.geomspace(*m.lag_tau_s, m.grid_points)],
            "temp_rate": [{"rate_form": form, "tau_r": float(v)} for form in (1, 2) for v in np.geomspace(*m.rate_tau_s, RATE_GRID_POINTS)],
            "hysteresis": [{"width": float(v), "relay": relay, "on_element": e} for e in inputs for relay in (False, True) for v in m.widths_c],
            "warmup": [{"tau_w": float(v)} for v in np.geomspace(*m.warmup_tau_s, m.grid_points)],
            "second_lag": _pairs("tau_e", "tau_e2", np.geomspace(*m.lag_tau_s, m.grid_points)) + series,
            "second_warmup": _pairs("tau_w", "tau_w2", np.geomspace(*m.warmup_tau_s, m.grid_points)),
            "rate_saturation": [{"rate_sat": float(v)} for v in np.geomspace(*m.rate_saturation_c_per_s, SATURATION_GRID_POINTS)],
            "second_hysteresis": plays,
        }

    def run(self) -> tuple[Spec, list, list]:
        """Forward selection; the spec, the accepted steps and the terms the runs cannot identify (with reasons)."""
        m = self.model
        spec = Spec()
        blocks, _, names = self.design(spec)
        noise, deviance, _ = self.fit_noise(blocks)
        score = self.bic(deviance, self.n_params(spec, names, 3))
        not_fitted, one_way_reason = {}, None
        if "warmup" in m.terms and any(r.run.power_on_s is None for r in self.runs):
            not_fitted["warmup"] = (
                "warmup not fitted: a training run does not start at power-on and gives no power-on time, so the time since power-on is unknown"
            )
        grids = self.grids(spec)
        for term in m.terms:  # judged against the baseline: a term no parameter of its grid separates from it
            if term in not_fitted or term in JOINS:  # a joining term is judged beside the term it joins, once that is in
                continue
            refusals = [self.identified(spec, dataclasses.replace(spec, **change), term) for change in grids[term]]
            if all(r is not None for r in refusals):
                not_fitted[term] = max(refusals, key=lambda r: r.unique).reason  # the nearest miss (the narrowest play)
            elif term == "temp_rate" and all(r is not None for r, c in zip(refusals, grids[term]) if c["rate_form"] == 2):
                one_way = max((r for r, c in zip(refusals, grids[term]) if c["rate_form"] == 2), key=lambda r: r.unique)
                seen, unseen = ("cool", "heating") if sum(float(r.temperature_c[-1] - r.temperature_c[0]) for r in self.runs) < 0 else ("heat", "cooling")
                one_way_reason = (
                    f"{ASYMMETRY} not fitted: the training runs only {seen} (|dT/dt| is a linear function of dT/dt and the cubic, "
                    f"1 - R^2 = {one_way.unique:.2g} < {m.min_unique_variance:g}), so a {unseen} sensitivity apart cannot be told; "
                    f"the one dT/dt sensitivity fitted is applied to {unseen} too; add a run that {'heats' if seen == 'cool' else 'cools'}"
                )
        for second, first in JOINS.items():  # a joining term where the term it joins cannot be fitted
            if second in m.terms and first in not_fitted:
                not_fitted[second] = f"{second} not fitted: {first} is not ({not_fitted[first].split(': ', 1)[1]})"
        remaining = [t for t in m.terms if t not in not_fitted]
        steps = []
        while remaining:
            best = None
            grids = self.grids(spec)
            for term in remaining:
                for change in grids[term]:
                    if term == "temp_rate" and change["rate_form"] <= spec.rate_form:
                        continue  # a selected sensitivity may still split into heating and cooling
                    if term in JOINS and JOINS[term] not in spec.terms():
                        continue  # a second time constant or a saturation only beside the term it joins
                    trial = dataclasses.replace(spec, **change)
                    if self.identified(spec, trial, term) is not None:
                        continue  # not separable, at this parameter, from what the model holds
                    t_blocks, _, t_names = self.design(trial)
                    trial_score = self.bic(self.deviance(t_blocks, noise)[0], self.n_params(trial, t_names, 3))
                    if best is None or trial_score < best[0]:
                        best = (trial_score, term, trial)
            if best is None:
                break
            _, term, trial = best
            trial = self.refine(trial, noise)  # the BIC is of the maximum likelihood, not of a grid point
            t_blocks, _, t_names = self.design(trial)
            # The noise fit is local (Nelder-Mead) and the likelihood has several optima (white against flicker at the
            # block scale): the trial starts from the model's levels and from its own residual's, the model is refitted
            # from the trial's, and the trial again from the model's, so that a drop is the term's, not the optimiser's.
            t_noise, t_dev = min((self.fit_noise(t_blocks, start)[:2] for start in (noise, None)), key=lambda r: r[1])
            b_noise, b_dev, _ = self.fit_noise(blocks, t_noise)
            if self.bic(b_dev, self.n_params(spec, names, 3)) < score:
                noise, score = b_noise, self.bic(b_dev, self.n_params(spec, names, 3))
                t_noise, t_dev = min([(t_noise, t_dev), self.fit_noise(t_blocks, b_noise)[:2]], key=lambda r: r[1])
            t_score = self.bic(t_dev, self.n_params(trial, t_names, 3))
            upgrade = term == "temp_rate" and spec.rate_form > 0  # heating and cooling apart must pay, whatever `selection`
            if (m.selection == "bic" or upgrade) and score - t_score <= m.bic_margin:
                if upgrade and m.selection == "all" and len(remaining) > 1:
                    remaining.remove(term)
                    continue
                break
            steps.append({"term": term, "params": _params(trial, term), "delta_bic": float(t_score - score)})
            spec, noise, score, blocks, names = trial, t_noise, t_score, t_blocks, t_names
            if term == "thermal_lag" and spec.width:  # the hysteresis may now switch on T_e: its width and form anew
                moved = self.replace(spec, "hysteresis", noise)
                if moved != spec:
                    spec = self.refine(moved, noise)
                    blocks, _, names = self.design(spec)
                    noise, deviance, _ = self.fit_noise(blocks, noise)
                    score = self.bic(deviance, self.n_params(spec, names, 3))
            if term != "temp_rate" or spec.rate_form == 2:
                remaining.remove(term)
        spec = self.refine(spec, noise)
        blocks, _, _ = self.design(spec)
        self.noise = self.fit_noise(blocks, noise)[0]
        for step in steps:
            step["params"] = _params(spec, step["term"])
        refused = [{"term": t, "reason": not_fitted[t]} for t in m.terms if t in not_fitted]
        if spec.rate_form == 1 and one_way_reason:  # a sensitivity of one direction, applied to the other: say so
            refused.append({"term": ASYMMETRY, "reason": one_way_reason})
        return spec, steps, refused

    def replace(self, spec: Spec, term: str, noise) -> Spec:
        """`spec` with the parameters of `term`, already in, at the best point of its grid beside the others (lowest
        deviance, the number of parameters unchanged), or `spec` itself when none is better."""
        base = dataclasses.replace(spec, width=0.0, width2=0.0) if term == "hysteresis" else spec
        best, best_deviance = spec, self.deviance(self.design(spec)[0], noise)[0]
        for change in self.grids(spec)[term]:
            trial = dataclasses.replace(spec, **change)
            if self.identified(base, trial, term) is not None:
                continue
            deviance = self.deviance(self.design(trial)[0], noise)[0]
            if deviance < best_deviance:
                best, best_deviance = trial, deviance
        return best

    def refine(self, spec: Spec, noise) -> Spec:
        """Each selected nonlinear parameter off its grid: two rounds of a bounded search of the deviance in its logarithm.

        The bounds are the grid's neighbours of the value (a factor of the
        grid's spacing either way, within the configured range), so the
        search settles the value the grid bracketed and never wanders to
        another minimum. A parameter
        at which the runs no longer identify its term is not taken.
        """
        spacing = {
            "tau_e": (self.model.lag_tau_s[1] / self.model.lag_tau_s[0]) ** (1 / (self.model.grid_points - 1)),
            "tau_w": (self.model.warmup_tau_s[1] / self.model.warmup_tau_s[0]) ** (1 / (self.model.grid_points - 1)),
            "width": max(b / a for a, b in zip(sorted(self.model.widths_c), sorted(self.model.widths_c)[1:])) if len(self.model.widths_c) > 1 else 2.0,
            "tau_r": (self.model.rate_tau_s[1] / self.model.rate_tau_s[0]) ** (1 / (RATE_GRID_POINTS - 1)),
            "rate_sat": (self.model.rate_saturation_c_per_s[1] / self.model.rate_saturation_c_per_s[0]) ** (1 / (SATURATION_GRID_POINTS - 1)),
        }
        spacing |= {"tau_e2": spacing["tau_e"], "tau_w2": spacing["tau_w"], "width2": spacing["width"]}
        terms = {"tau_e": "thermal_lag", "tau_w": "warmup", "width": "hysteresis", "tau_r": "temp_rate", "tau_e2": "second_lag", "tau_w2": "second_warmup",
                 "rate_sat": "rate_saturation", "width2": "second_hysteresis"}
        m = self.model
        ranges = {"tau_e": m.lag_tau_s, "tau_w": m.warmup_tau_s, "width": (min(m.widths_c), max(m.widths_c)), "tau_r": m.rate_tau_s,
                  "tau_e2": m.lag_tau_s, "tau_w2": m.warmup_tau_s, "rate_sat": m.rate_saturation_c_per_s}
        ranges["width2"] = ranges["width"]
        without = {"tau_e": {"tau_e": 0.0, "tau_e2": 0.0, "series": False}, "tau_w": {"tau_w": 0.0, "tau_w2": 0.0}, "width": {"width": 0.0, "width2": 0.0},
                   "tau_r": {"rate_form": 0, "tau_r": 0.0, "rate_sat": 0.0}, "tau_e2": {"tau_e2": 0.0, "series": False}, "tau_w2": {"tau_w2": 0.0},
                   "rate_sat": {"rate_sat": 0.0}, "width2": {"width2": 0.0}}
        for _ in range(2):
            for key, factor in spacing.items():
                value = getattr(spec, key)
                if not value:
                    continue

                def deviance(log_value, key=key):
                    trial = dataclasses.replace(spec, **{key: float(np.exp(log_value))})
                    return self.deviance(self.design(trial)[0], noise)[0]

                lo, hi = ranges[key]
                bounds = (math.log(max(value / factor, lo)), math.log(min(value * factor, hi)))
                if bounds[1] - bounds[0] < 1e-9:
                    continue
                result = optimize.minimize_scalar(deviance, bounds=bounds, method="bounded", options={"xatol": 1e-3})
                trial = dataclasses.replace(spec, **{key: float(np.exp(result.x))})
                base = dataclasses.replace(spec, **without[key])
                if result.fun < deviance(math.log(value)) and self.identified(base, trial, terms[key]) is None:
                    spec = trial
        if spec.series and spec.tau_e and spec.tau_e2:
            spec = self._ridge(spec, noise, ("tau_e", "tau_e2"), "second_lag", {"tau_e2": 0.0, "series": False})
        if spec.on_element and spec.tau_e and spec.width:
            spec = self._ridge(spec, noise, ("tau_e", "width"), "hysteresis", {"width": 0.0, "width2": 0.0})
        return spec

    def _ridge(self, spec: Spec, noise, keys: tuple, term: str, without: dict) -> Spec:
        """Two parameters jointly (Nelder-Mead in their logarithms), where their deviance has a narrow ridge that a search
        of one at a time climbs only in small steps: two lags in series (along a constant sum), and a lag and the width
        of a hysteresis switching on ``T_e`` (a longer lag shrinks the swing of ``T_e``: a narrower width). Taken when
        it lowers the deviance and the runs still identify `term` at it."""
        m = self.model
        ranges = {"tau_e": m.lag_tau_s, "tau_e2": m.lag_tau_s, "width": (min(m.widths_c), max(m.widths_c))}
        lo, hi = np.log([ranges[k][0] for k in keys]), np.log([ranges[k][1] for k in keys])

        def at(logs) -> Spec:
            values = np.exp(np.clip(logs, lo, hi))
            if keys == ("tau_e", "tau_e2"):  # the first stage the shorter
                values = np.sort(values)
            return dataclasses.replace(spec, **{k: float(v) for k, v in zip(keys, values)})

        def deviance(logs):
            return self.deviance(self.design(at(logs))[0], noise)[0]

        start = np.log([getattr(spec, k) for k in keys])
        result = optimize.minimize(deviance, start, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 0.01, "maxiter": 200})
        trial = at(result.x)
        if result.fun < deviance(start) and self.identified(dataclasses.replace(spec, **without), trial, term) is None:
            return trial
        return spec

    def final(self, spec: Spec):
        blocks, _, names = self.design(spec)
        deviance, beta = self.deviance(blocks, self.noise)
        return beta, names, self.noise


def _pairs(first: str, second: str, grid: np.ndarray) -> list:
    """Both time constants (or widths) anew, the second the longer, on every other point of `grid`: a second one
    beside the first one held where one alone fitted best would settle at a local optimum (a mixture of the two)."""
    coarse = grid[::2]
    return [{first: float(a), second: float(b)} for i, a in enumerate(coarse) for b in coarse[i + 1 :]]


def _params(spec: Spec, term: str) -> dict:
    return {
        "thermal_lag": {"tau_s": spec.tau_e},
        "temp_rate": {"heating_cooling_apart": spec.rate_form == 2, "filter_tau_s": spec.tau_r},
        "hysteresis": {"width_c": spec.width, "operator": "relay" if spec.relay else "play", "input": "element" if spec.on_element and spec.tau_e else "temperature"},
        "warmup": {"tau_s": spec.tau_w},
        "second_lag": {"tau_s": spec.tau_e2, "path": "series" if spec.series else "parallel"},
        "second_warmup": {"tau_s": spec.tau_w2},
        "rate_saturation": {"saturation_c_per_s": spec.rate_sat},
        "second_hysteresis": {"width_c": spec.width2, "operator": "play"},
    }[term]


def _reverses(temperature_c, width_c) -> bool:
    """Whether the play of `width_c` changes branch after the first excursion beyond it (:func:`~gyrocomp.effects.shapes.hysteresis_branch`)."""
    first = first_excursion(temperature_c, width_c)
    branch = hysteresis_branch(np.arange(temperature_c.size, dtype=float), temperature_c, width_c)
    return bool(first < temperature_c.size and np.any(branch[first:] != branch[first]))
