"""Competing explanations: a listed noise term against one time-local event per run.

A rate random walk or a flicker can take the place of a single event that
the vocabulary does not name: a mode hop (one bias step per run, at a
different time in each) or a transient (one bump per run). A signature that
passes does not say which it is -- on one fit run and one holdout the two
are often inseparable (``benchmarks/oov_separability.py``). So for every
listed noise term ``T`` and every event kind of :data:`EVENTS`, the report
names the alternative, where each run's event lies, and the evidence for
each, by four maximum-likelihood fits over all runs (the noise levels shared,
as in the selection; each run its own coefficients; each run on at most
``checks.agreement_max_blocks`` merged block means):

* ``D_0``, the selected model without ``T``;
* ``D_T``, the selected model;
* ``D_E``, the model without ``T`` beside each run's most likely event: the
  event column of largest score (:func:`gyrocomp.diagnose.checks._linear.column_scores`)
  under the levels of ``D_0``;
* ``D_TE``, the selected model beside the same events.

The BIC gain of adding ``A`` to a model ``M`` is ``D(M) - D(M + A) - k ln n``
(``n`` the merged blocks of all runs), with ``k = 1`` for ``T``'s level and,
per run, 2 for a step (its time and size) and 3 for a bump (centre, width,
size): what the scan chose is charged as a parameter. The verdict is the
encompassing comparison, each explanation beside the other, at the
selection's ``bic_margin``:

=================  =================  ===============================================
``T`` beside E     E beside ``T``     verdict
=================  =================  ===============================================
gains              does not gain      ``noise``: the events do not replace the term
does not gain      gains              ``event``: the pair prefers one event per run
gains              gains              ``both``: the term and the events
does not gain      does not gain      ``inseparable`` when the events alone gain, else ``noise``
=================  =================  ===============================================

A listed flicker is also compared with popcorn, a noise switching between
two levels (``event`` ``two_levels``), by its signature's own test of
Gaussian levels (:mod:`gyrocomp.diagnose.checks.levels`: the kurtosis of its
levels, and the likelihood ratio of two levels to a Gauss-Markov wander
against Gaussian draws): ``event`` below the test's Bonferroni share in the
signature, ``inseparable`` below the signature's ``refusal_alpha`` (the
evidence of one test at the level the term is judged at, which the
family's share does not reach), else ``noise``.

Only the report reads the verdict; the selection and the unlisting rules
(:mod:`gyrocomp.diagnose.confirm`) do not. It is evidence, not a test at a
stated level: the margin is the selection's, and the levels are maximum
likelihood, which reads a weak walk low beside the baseline. On constructed
8 h pairs (``tests/diagnose/test_signature.py``'s oven runs, seeds 200-219)
a true walk of 1 deg/h/sqrt(h) beside 2.8 deg/h of white noise per block
against one step per run is ``inseparable`` in 13 of 20, ``noise`` in 4 and
``event`` in 3; at 3 deg/h/sqrt(h) ``noise`` in 19 and ``inseparable`` in 1;
a true flicker of 3 deg/h is ``noise`` against the steps in 20 of 20.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.diagnose.checks._linear import column_scores, innovations
from gyrocomp.diagnose.checks.step import step_positions
from gyrocomp.diagnose.settings import DiagnoseSettings
from gyrocomp.diagnose.signature import TERMS
from gyrocomp.effects.likelihood import fit_noise_runs, merge_blocks

__all__ = ["EVENTS", "VERDICTS", "step_columns", "bump_columns", "compare", "two_levels", "competing", "sentence"]

EVENTS = {"step": 2, "bump": 3}
"""The event kinds, and the parameters each event charges per run (time and size; centre, width and size)."""
VERDICTS = ("noise", "event", "both", "inseparable")
"""The verdicts of :func:`compare` (the module docstring's table)."""


def step_columns(n, min_blocks):
    """``1[i >= j]`` for every ``j`` of the step scan (:func:`gyrocomp.diagnose.checks.step.step_positions`), and the ``j``.

    Examples
    --------
    >>> G, where = step_columns(6, 2)
    >>> G.T.astype(int).tolist(), where["block"].tolist()
    ([[0, 0, 1, 1, 1, 1], [0, 0, 0, 1, 1, 1], [0, 0, 0, 0, 1, 1]], [2, 3, 4])
    """
    pos = step_positions(n, min_blocks)
    return (np.arange(n)[:, None] >= pos[None, :]).astype(float), {"block": pos}


def bump_columns(n, min_blocks, widths):
    """Raised-cosine bumps ``(1 + cos(pi (i - c) / w)) / 2`` on ``|i - c| < w``, and their ``c`` and ``w`` [blocks].

    ``w`` (the full width at half height) takes `widths` log-spaced values
    from `min_blocks` to ``n / 2``; the centres ``c`` lie ``w / 4`` apart over
    the run. A bump with fewer than `min_blocks` blocks inside the run is left out.

    Examples
    --------
    >>> G, where = bump_columns(40, 4, 3)
    >>> G.shape, sorted(set(np.round(where["width"], 2).tolist()))
    ((40, 68), [4.0, 8.94, 20.0])
    """
    i = np.arange(n)
    cols, centre, width = [], [], []
    for w in np.geomspace(min_blocks, n / 2.0, widths):
        for c in np.arange(0.0, n + 1.0, max(1.0, w / 4.0)):
            x = (i - c) / w
            g = np.where(np.abs(x) < 1.0, 0.5 * (1.0 + np.cos(np.pi * x)), 0.0)
            if np.count_nonzero(g) >= min_blocks:
                cols.append(g)
                centre.append(c)
                width.append(w)
    return np.array(cols).T, {"centre": np.array(centre), "width": np.array(width)}


def _columns(event, n, settings: DiagnoseSettings):
    if event == "step":
        return step_columns(n, settings.checks.min_step_blocks)
    return bump_columns(n, settings.checks.min_step_blocks, settings.competing.bump_widths)


def compare(runs, model, term, events=tuple(EVENTS), settings: DiagnoseSettings = DiagnoseSettings()) -> dict:
    """Noise term `term` of `model` against one event per run, for each kind of `events` (module docstring).

    The fits without an event (``D_0``, ``D_T``) are made once for all kinds.

    Parameters
    ----------
    runs : sequence of (str, gyrocomp.diagnose.select.Problem)
        The labelled runs (fit, holdout).
    model : gyrocomp.diagnose.select.Fitted
        A model with `term` in its noise.
    term : {"rate_random_walk", "bias_instability"}
    events : sequence of {"step", "bump"}
    settings : DiagnoseSettings
        ``bic_margin``, ``checks.agreement_max_blocks``, ``checks.min_step_blocks``
        and ``competing.bump_widths``.

    Returns
    -------
    dict
        Per event kind, None when a run is too short for one event at least
        ``checks.min_step_blocks`` merged blocks from either end. Else
        ``term``, ``event``, ``verdict`` (module docstring), ``gain``: the
        BIC gains ``noise`` (``T`` over neither), ``event`` (the events over
        neither), ``noise_beside_event`` and ``event_beside_noise``;
        ``runs``: per run its ``run`` label, the event's ``time_s`` (a step's
        time, a bump's centre, from the run's first sample, gaps of a run in
        segments counted), ``width_s`` (a bump's full width at half height)
        and ``size_deg_h`` (fitted beside the other terms, without ``T``).
    """
    noise = model.noise
    free = ("arw",) + tuple(t for t in TERMS if getattr(noise, t) > 0.0)
    less = tuple(f for f in free if f != term)
    without = dataclasses.replace(noise, **{term: 0.0})
    max_blocks = settings.checks.agreement_max_blocks
    merged = [merge_blocks(p.y, p.design_blocks(model.spec)[0], p.basis, max_blocks) for _, p in runs]
    columns = {event: [_columns(event, y.size, settings) for y, _, _ in merged] for event in events}
    held = [event for event in events if all(G.shape[1] for G, _ in columns[event])]
    if not held:
        return dict.fromkeys(events)
    bare, d_0, _ = fit_noise_runs(merged, without, less)
    d_t = fit_noise_runs(merged, noise, free)[1]
    innov = [innovations(y, X, basis.covariance(bare)) for y, X, basis in merged]
    log_n = np.log(sum(y.size for y, _, _ in merged))
    out = dict.fromkeys(events)
    for event in held:
        with_event, found = [], []
        for (_, p), (y, X, basis), (e, Xw, lower), (G, where) in zip(runs, merged, innov, columns[event]):
            j = int(np.argmax(np.abs(column_scores(e, Xw, lower, G)[0])))
            with_event.append((y, np.column_stack([X, G[:, j]]), basis))
            found.append(_place(where, j, _merged_starts(p, basis), basis.block_s))
        _, d_e, betas = fit_noise_runs(with_event, without, less)
        d_te = fit_noise_runs(with_event, noise, free)[1]
        k_event = EVENTS[event] * len(merged)
        gain = {
            "noise": d_0 - d_t - log_n,
            "event": d_0 - d_e - k_event * log_n,
            "noise_beside_event": d_e - d_te - log_n,
            "event_beside_noise": d_t - d_te - k_event * log_n,
        }
        out[event] = {
            "term": term,
            "event": event,
            "verdict": _verdict(gain, settings.bic_margin),
            "gain": {k: float(v) for k, v in gain.items()},
            "runs": [_event_entry(label, at, beta[-1]) for (label, _), at, beta in zip(runs, found, betas)],
        }
    return out


def _verdict(gain, margin):
    """The encompassing comparison's verdict (the module docstring's table).

    Examples
    --------
    >>> _verdict({"noise": 50, "event": 45, "noise_beside_event": 2, "event_beside_noise": -3}, 10)
    'inseparable'
    >>> _verdict({"noise": 50, "event": 80, "noise_beside_event": -5, "event_beside_noise": 25}, 10)
    'event'
    """
    noise, event = gain["noise_beside_event"] > margin, gain["event_beside_noise"] > margin
    if noise and event:
        return "both"
    if event:
        return "event"
    if noise or not gain["event"] > margin:
        return "noise"
    return "inseparable"


def _merged_starts(problem, merged):
    """The start of each block of `merged` (:func:`~gyrocomp.effects.likelihood.merge_blocks`' basis of `problem`'s blocks)
    [s from the run's first sample]: across a gap of a run in segments too."""
    run = problem.run
    starts = run.block_start_s if run.block_start_s is not None else np.arange(run.n_blocks) * run.block_s
    return starts[:: round(merged.block_s / problem.basis.block_s)][: merged.n_blocks]


def _place(where, j, starts, block_s):
    """Column `j`'s event in seconds from the run's first sample: a step's time, a bump's centre and full width
    (merged block ``i`` spans ``[starts[i], starts[i] + block_s)``)."""
    if "block" in where:
        return {"time_s": float(starts[where["block"][j]])}
    c = float(where["centre"][j])
    i = min(int(c), starts.size - 1)
    return {"time_s": float(starts[i]) + (c - i + 0.5) * block_s, "width_s": float(where["width"][j]) * block_s}


def _event_entry(label, at, size_dps):
    """One run's event: where, how wide and how large [deg/h]."""
    return {"run": label, **at, "size_deg_h": float(size_dps) * 3600.0}


def two_levels(signature, refusal_alpha) -> dict | None:
    """A listed flicker against popcorn, from its signature in the verdict (``unexplained.signatures``; module docstring).

    Examples
    --------
    >>> sig = {"alpha": 0.0005, "levels": {"p": 0.004, "by": "two_levels", "two_levels_z": 2.9, "two_levels_gain": 14.0}}
    >>> two_levels(sig, 0.01)["verdict"]
    'inseparable'
    """
    levels = (signature or {}).get("levels")
    if levels is None:
        return None
    p = levels["p"]
    verdict = "event" if p < signature["alpha"] else "inseparable" if p < refusal_alpha else "noise"
    return {"term": "bias_instability", "event": "two_levels", "verdict": verdict, "levels": levels,
            "alpha": signature["alpha"], "refusal_alpha": refusal_alpha}


def competing(runs, model, listed, signatures, settings: DiagnoseSettings = DiagnoseSettings()) -> list:
    """:func:`compare` for every noise term of `listed` in `model` and every event kind of :data:`EVENTS` (the runs
    can hold), and :func:`two_levels` for a listed flicker from its entry in `signatures` (``unexplained.signatures``)."""
    found = [entry for term in TERMS if term in listed and getattr(model.noise, term) > 0.0
             for entry in compare(runs, model, term, tuple(EVENTS), settings).values()]
    if "bias_instability" in listed:
        found.append(two_levels(signatures.get("bias_instability"), settings.signature.refusal_alpha))
    return [entry for entry in found if entry is not None]


_WORDS = {"step": "one step per run", "bump": "one bump per run"}


def sentence(entry) -> str:
    """The report's sentence for one :func:`compare` or :func:`two_levels` result whose verdict is not ``noise``."""
    if entry["event"] == "two_levels":
        return _two_levels_sentence(entry)
    term, g = entry["term"], entry["gain"]
    where = "; ".join(_where(r, entry["event"]) for r in entry["runs"])
    alt = f"{_WORDS[entry['event']]} ({where})"
    if entry["verdict"] == "event":
        return (f"the pair prefers {alt} to {term}: beside the events {term} gains {g['noise_beside_event']:.1f} in BIC, "
                f"the events beside {term} {g['event_beside_noise']:.1f}")
    if entry["verdict"] == "both":
        return (f"{term} and {alt} both: each gains beside the other ({g['noise_beside_event']:.1f} and "
                f"{g['event_beside_noise']:.1f} in BIC)")
    return (f"{term} or {alt}: alone they gain {g['noise']:.1f} and {g['event']:.1f} in BIC, beside each other "
            f"{g['noise_beside_event']:.1f} and {g['event_beside_noise']:.1f}; this pair cannot tell them apart "
            "(a longer run or another holdout can)")


def _where(run, event):
    """``fit: at 3.42 h, -8.7 deg/h`` (a bump: its full width too)."""
    width = f", {run['width_s'] / 3600.0:.2f} h wide" if event == "bump" else ""
    return f"{run['run']}: at {run['time_s'] / 3600.0:.2f} h{width}, {run['size_deg_h']:+.1f} deg/h"


def _two_levels_sentence(entry):
    lv = entry["levels"]
    lead = ("the pair prefers popcorn (a noise switching between two levels) to bias_instability" if entry["verdict"] == "event"
            else "bias_instability or popcorn (a noise switching between two levels)")
    return (f"{lead}: two levels gain {lv['two_levels_gain']:.1f} in log-likelihood over a Gauss-Markov wander, z = "
            f"{lv['two_levels_z']:.1f} against Gaussian draws; Gaussian-levels test p = {lv['p']:.2g} (the signature refuses below "
            f"{entry['alpha']:.2g}, the term's rate is {entry['refusal_alpha']:g})")
