"""Diagnose the sim-to-real gap: where it lies, which effect causes it, how far it shrinks.

:func:`diagnose` calibrates the baseline simulator of DESIGN.md ("The
simulator and the sim-to-real gap": per-run offset, cubic polynomial in the
measured temperature, white noise) on a fit recording, then

1. **which** -- selects effects of the vocabulary stepwise by one
   criterion, the BIC of a block-mean Gaussian likelihood in which
   deterministic effects are regressors and flicker / random walk are
   covariance terms, on the *selection runs* only
   (:class:`gyrocomp.diagnose.select.Search`); a noise term must also show
   its own signature there (:func:`gyrocomp.diagnose.signature.check`);
2. **how far** -- measures the scalar gap of :mod:`gyrocomp.diagnose.gap`
   for the baseline, for every candidate alone and for the selected model,
   on the fit recording and on a holdout that took no part in the
   selection. The protocol (``gap.protocol``): with one holdout the
   selection sees the fit run only; with several (``--holdout A --holdout
   B``) it sees the fit run and all holdouts but the last, and the gap is
   reported on the last;
3. **where** -- breaks the residual down by regime, timescale and EMD
   component (:mod:`gyrocomp.diagnose.localize`);
4. **what it could have missed** -- for every candidate not selected, the
   weakest amplitude an ideal detector would find beside the selected model
   with probability ``detection_power``
   (:func:`gyrocomp.diagnose.detectability.detection_limit`);
5. **what it does not explain** -- the residual of the selected model on
   every run is tested for structure the model does not predict
   (:func:`gyrocomp.diagnose.unexplained.verdict`); when some is found the
   report's ``unexplained.present`` is true and the gap of the selected
   model is not called explained. The selected effects that only stand in
   for what the tests flag are then unlisted
   (:func:`gyrocomp.diagnose.confirm.confirm`, its named rules): a noise
   term without its own signature on all runs, an effect the holdout
   refutes at its fitted shape, an effect that gains nothing beside the
   structure the tests found on the fit run;
6. **what else it could be** -- every listed rate random walk or flicker
   is compared with one time-local event per run, a step (a mode hop) or
   a bump (a transient), each beside the other
   (:func:`gyrocomp.diagnose.competing.compare`), and a flicker with
   popcorn by its signature's test of Gaussian levels: the report names the
   alternative, where it lies and the evidence for each where the pair
   prefers the event or cannot tell them apart.

The gap and the localization compare each residual with the model's noise
terms, whose white level is the fit run's sample-level one
(:func:`gyrocomp.diagnose.select.sample_arw`): the likelihood's white term,
fitted on block means, also absorbs whatever drift a model leaves out (the
baseline's then reads a quarter of the real Allan deviation at short tau),
which would hide that drift from the gap.

Every recording is averaged to at most ``max_rate_hz`` at entry
(:func:`reduce_recording`), before anything else: the likelihood works on
block means of 10 s or more and the gap on Allan taus from 1 s, so the
cost does not grow with the sample rate. The sample-level white level of
the full-rate recording is kept beside it (``blocks.arw_sample``).

A recording without temperature (a static run) is diagnosed on its
stochastic part and time effects only; the temperature effects are listed
as skipped with the reason.

:func:`diagnose` is these steps, one call each; the runs are prepared in
:mod:`gyrocomp.diagnose.runs` and every number is in the one settings tree
of :mod:`gyrocomp.diagnose.settings` (``configs/diagnose.toml``).
"""

from __future__ import annotations

import dataclasses
import math
import os

from gyrocomp.config import settings_dict
from gyrocomp.diagnose import competing as _competing
from gyrocomp.diagnose import confirm as _confirm
from gyrocomp.diagnose import gap as _gap
from gyrocomp.diagnose import localize
from gyrocomp.diagnose import signature as _signature
from gyrocomp.diagnose.detectability import detection_limit
from gyrocomp.diagnose.effects import EFFECTS, effect_params
from gyrocomp.diagnose.error_rate import error_rate
from gyrocomp.diagnose.identify import holdout_needs, unidentifiable
from gyrocomp.diagnose.runs import Runs, _as_list, problems, reduce_recording, segment_lengths
from gyrocomp.diagnose.select import Fitted, Problem, Search, extend, fit_baseline, holdout_fit, residual_of
from gyrocomp.diagnose.settings import DiagnoseSettings, get_config
from gyrocomp.diagnose.uncertainty import uncertainties
from gyrocomp.errors import InputError

__all__ = ["DiagnoseSettings", "get_config", "diagnose", "problems", "reduce_recording", "Runs", "SCHEMA", "EFFECTS"]

SCHEMA = "gyrocomp.diagnosis"


def diagnose(fit, holdout=None, settings: DiagnoseSettings = DiagnoseSettings(), *, start_effects=(), callback=None) -> dict:
    """Diagnose the gap between recordings and the calibrated baseline simulator (the steps of the module docstring).

    Parameters
    ----------
    fit : gyrocomp.recordings.Recording
        The recording the model is calibrated on.
    holdout : gyrocomp.recordings.Recording or sequence of them, optional
        Other runs of the same gyro. The last one takes no part in the
        selection and gives the held-out gap; the ones before it join the
        fit run in the selection (:class:`gyrocomp.diagnose.select.Search`).
    settings : DiagnoseSettings
        The whole tree (:mod:`gyrocomp.diagnose.settings`).
    start_effects : sequence of str
        Effects the starting simulator already has (``--sim``): fitted as
        part of the baseline, not candidates.
    callback : callable(done, total), optional
        Progress over candidate fits.

    Returns
    -------
    dict
        The report body (see :func:`gyrocomp.diagnose.report.to_json`):
        ``selected_effects``, ``gap`` (with its ``protocol``),
        ``candidates``, ``localization``, ``skipped``, ``models``,
        ``unexplained``.

    Raises
    ------
    InputError
        A start effect not in the vocabulary, a recording too short for the
        likelihood, or a holdout whose temperature presence differs from the fit's.
    """
    from threadpoolctl import threadpool_limits

    holdouts = _checked(fit, holdout, start_effects)
    fit_p, extra_p, skipped = problems(fit, holdouts, settings)
    candidates = [e for e in EFFECTS if e not in skipped and e not in start_effects]
    with threadpool_limits(limits=1, user_api="blas"):
        runs = Runs.of(fit_p, extra_p)
        search = _search(runs, candidates, start_effects, settings, callback)
        listed = search.run()  # 1. which
        gaps = {"baseline": _gaps(runs, search.baseline)}
        # 5. what it does not explain, and which of the listed effects only stand in for that
        selected, verdict = _confirm.confirm(search, runs.labelled, listed, settings, runs.residuals(gaps["baseline"]))
        gaps["selected"] = _gaps(runs, selected)  # 2. how far
        cand = _candidates(runs, search, selected, settings)  # 4. what it could have missed
        local = _localization(runs, {"baseline": search.baseline, "selected": selected}, gaps, settings)  # 3. where
        listed = [e for e in selected.order if e not in start_effects]
        rivals = _competing.competing(runs.labelled, selected, listed, verdict["signatures"], settings)  # 6. what else it could be
    return {
        "selected_effects": listed,
        "start_effects": list(start_effects),
        "gap": {**_gap_summary(gaps, runs, verdict), "protocol": _protocol(runs.selection, runs.holdout, verdict["unlisted"])},
        "unexplained": verdict,
        "competing": rivals,
        **({"gap_note": GAP_NOTE} if runs.gapped else {}),
        "candidates": cand,
        "selection": {"error_rate": error_rate(candidates, search.first_step, sum(p.y.size for p in runs.selection),
                                               settings.bic_margin, settings.unexplained.family_alpha, settings.signature.refusal_alpha)},
        "selection_steps": search.steps + _confirm_step(verdict),
        "skipped": skipped,
        "models": {"baseline": _model_dict(search.baseline), "selected": _model_dict(selected, runs.fit)},
        "localization": local,
        "blocks": _blocks(fit, holdouts, runs),
        "settings": settings_dict(settings),
    }


GAP_NOTE = (
    "recording in segments with gaps: the scalar gap and the localization need a contiguous record "
    "(100 s means, Allan taus) and are not computed; selection and the unexplained tests use block means within segments"
)
"""The report's ``gap_note`` on a recording with gaps."""


def _checked(fit, holdout, start_effects) -> list:
    """The holdouts as a list, after checking the start effects and that every run has a temperature or none has."""
    unknown = [e for e in start_effects if e not in EFFECTS]
    if unknown:
        raise InputError(f"start effects {unknown}: not in the vocabulary {', '.join(EFFECTS)}")
    holdouts = _as_list(holdout)
    for rec in holdouts:
        if (fit.temperature_c is None) != (rec.temperature_c is None):
            raise InputError(f"{rec.name}: temperature column present in only one of the fit and holdout recordings")
    return holdouts


def _search(runs: Runs, candidates, start_effects, s: DiagnoseSettings, callback) -> Search:
    """The stepwise search over `candidates` on the selection runs, from the baseline with `start_effects`.

    A noise term is admitted only when it shows its own signature there
    (:func:`gyrocomp.diagnose.signature.check`).
    """

    checked = {}

    def admissible(problems, model, effect):
        # A later move asks again about a trial model already judged (forward, then backward): judge it once.
        key = (effect, model.key, model.noise)
        if key not in checked:
            checked[key] = _signature.check(effect, problems, model, s).ok
        return checked[key]

    start = _start_model(runs.fit, start_effects)
    return Search(runs.selection, candidates, start=start, admissible=admissible, callback=callback)


def _candidates(runs: Runs, search: Search, selected: Fitted, s: DiagnoseSettings) -> dict:
    """Every candidate alone: its parameters, gaps and BIC change; whether the selection runs identify it; its detection limit.

    A candidate selected, or not identifiable from the selection runs
    (:func:`gyrocomp.diagnose.identify.unidentifiable`), gets no detection
    limit; of the latter, one the holdout needs gets ``holdout_needs``
    (:func:`gyrocomp.diagnose.identify.holdout_needs`: its p-value there and
    the holdout's name), else None.
    """
    cand = {}
    for effect, model in search.first_step.items():
        g = _gaps(runs, model)
        cand[effect] = {
            "params": effect_params(effect, model.spec, model.beta, model.names, model.noise),
            "gap_fit": g["fit"]["total"],
            "gap_holdout": g["holdout"]["total"] if runs.holdout is not None else None,
            "delta_bic": search.score(model) - search.score(search.baseline),
        }
    for effect, c in cand.items():
        alone = search.first_step[effect]
        c["not_identifiable"] = unidentifiable(runs.selection, search.baseline, alone, effect, s.identifiable_min_unique)
        c["holdout_needs"] = _holdout_needs(runs, selected, effect, s) if c["not_identifiable"] else None
        c["detection_limit"] = (
            None
            if effect in selected.order or c["not_identifiable"]
            else detection_limit(runs.selection, selected, effect, alone.spec.get(effect, {}), s.bic_margin, s.detection_power)
        )
    return cand


def _holdout_needs(runs: Runs, selected: Fitted, effect, s: DiagnoseSettings):
    """``{"p", "holdout"}`` when the held-out run needs `effect`, which the selection runs cannot identify; else None."""
    if runs.holdout is None:
        return None
    p = holdout_needs(runs.fit, runs.holdout, selected, effect, s.confirm.replication_alpha, s.identifiable_min_unique)
    return None if p is None else {"p": p, "holdout": runs.holdout.run.name}


def _gap_summary(gaps, runs: Runs, verdict) -> dict:
    """The report's ``gap``: per model, the total on each run and its parts; the selected model's is explained unless the verdict is present."""
    return {
        name: {
            "fit": g["fit"]["total"],
            "holdout": g["holdout"]["total"] if runs.holdout is not None else None,
            "parts": {
                run: {k: g[run][k] for k in ("deterministic", "stochastic", "noise_floor", "noise_level")}
                for run in ("fit", "holdout")
                if g[run] is not None
            },
            **({"explained": not verdict["present"]} if name == "selected" else {}),
        }
        for name, g in gaps.items()
    }


def _confirm_step(verdict) -> list:
    """The selection step of the effects :func:`gyrocomp.diagnose.confirm.confirm` unlisted (none: no step)."""
    if not verdict["unlisted"]:
        return []
    return [{"move": "confirm", "accepted": None, "dropped": [u["effect"] for u in verdict["unlisted"]]}]


def _blocks(fit, holdouts, runs: Runs) -> dict:
    """The report's ``blocks``: block length and counts, segments, sample rates and sample-level white levels."""
    hold_p = runs.holdout
    return {
        "block_s": runs.fit.run.block_s,
        "n_fit": runs.fit.y.size,
        "n_holdout": hold_p.y.size if hold_p else None,
        "segments": {"fit": len(segment_lengths(fit)), "holdout": len(segment_lengths(holdouts[-1])) if holdouts else None},
        "fs_hz": fit.fs_hz,
        "reduced_fs_hz": runs.fit.run.fs_hz,
        "arw_sample": {"fit": runs.fit.run.arw_sample, "holdout": hold_p.run.arw_sample if hold_p else None},
    }


def _protocol(selection, hold_p, unlisted=()) -> dict:
    """Which runs selected the effects, which one the held-out gap comes from, and whether it unlisted any.

    An effect unlisted for its signature or refuted on the holdout
    (:data:`gyrocomp.diagnose.confirm.RULES`, rules 1 to 3) was
    judged on the holdout too: the holdout then took part in what is
    listed, never in what was added.
    """
    names = [os.path.basename(p.run.name) for p in selection]
    held = os.path.basename(hold_p.run.name) if hold_p is not None else None
    if hold_p is None:
        text = "no holdout: effects selected on the fit run; no held-out gap"
    elif len(selection) == 1:
        text = f"effects selected on the fit run only; the held-out gap is from {held}, which took no part in the selection"
    else:
        text = f"effects selected on {' + '.join(names)}; the held-out gap is from {held}, which took no part in the selection"
    read = [u["effect"] for u in unlisted if u["holdout"]]
    if read and held is not None:
        text += f"; {', '.join(read)} unlisted on evidence that includes {held} (its signature or its replication there)"
    return {"selection_runs": names, "holdout_run": held, "description": text}


def _start_model(problem: Problem, start_effects) -> Fitted:
    model = fit_baseline(problem)
    for effect in start_effects:
        model = extend(problem, model, effect)
    return model


def _gap_noise(model: Fitted, white: float):
    """The model's noise terms with the sample-level white level `white` [deg/s/sqrt(Hz)]."""
    return dataclasses.replace(model.noise, arw=white)


def _gaps(runs: Runs, model: Fitted) -> dict:
    """The scalar gap of `model` on each run; on a recording with gaps, None (its 100 s means and Allan taus need a contiguous record)."""
    fit_p, hold_p = runs.fit, runs.holdout
    if runs.gapped:
        empty = {"total": None, "deterministic": None, "stochastic": None, "noise_floor": None, "noise_level": None}
        return {"fit": empty, "holdout": dict(empty) if hold_p is not None else None}
    s = fit_p.settings
    noise = _gap_noise(model, runs.white)
    r_fit = residual_of(fit_p, model)
    out = {"fit": _gap.gap(r_fit, fit_p.run.fs_hz, noise, len(model.names), s.gap_block_s, s.gap_min_windows)}
    out["fit"]["residual"] = r_fit
    out["holdout"] = None
    if hold_p is not None:
        _, r_hold, n_free = holdout_fit(hold_p, model)
        out["holdout"] = _gap.gap(r_hold, hold_p.run.fs_hz, noise, n_free, s.gap_block_s, s.gap_min_windows)
        out["holdout"]["residual"] = r_hold
    return out


def _localization(runs: Runs, models, gaps, s: DiagnoseSettings) -> dict:
    """The residual of each model in `models` by regime, timescale and EMD component, on each run (none on a recording with gaps)."""
    if runs.gapped:
        return {}
    out = {}
    for run_name, problem in runs.labelled:
        run = problem.run
        per_model = {}
        for name, model in models.items():
            g = gaps[name][run_name]
            r = g["residual"]
            noise = _gap_noise(model, runs.white)
            per_model[name] = {
                "regime": localize.regimes(run.time_s, run.temperature_c, r, run.fs_hz, noise, s),
                "timescale": localize.timescales(r, run.fs_hz, noise, g["timescale"]),
                "component": localize.components(r, run.fs_hz, s),
            }
        out[run_name] = per_model
    return out


def _model_dict(model: Fitted, problem=None) -> dict:
    """`model` for the report; with `problem` (the run it was fitted on), each numeric parameter's 1-sigma ``uncertainty``."""
    params = {e: effect_params(e, model.spec, model.beta, model.names, model.noise) for e in model.order}
    if problem is not None:
        for effect, sigmas in uncertainties(problem, model).items():
            for name, sigma in sigmas.items():
                params[effect][name]["uncertainty"] = sigma
    return {
        "effects": list(model.order),
        "params": params,
        "noise": model.noise.datasheet_units(),
        "coefficients": dict(zip(model.names, model.beta.tolist())),
        "deviance": model.deviance,
        "n_params": model.n_params,
        "bic": model.bic if math.isfinite(model.bic) else None,
    }
