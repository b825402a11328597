"""``diagnose``: a fit recording (and a held-out one) to ``report.json``, ``report.md`` and ``gap.png``."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files", "greybox_of"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp diagnose`` (defaults: the command's).

    Attributes
    ----------
    holdout : sequence of path-like
        Other runs of the same gyro. The last one takes no part in the
        selection and gives the held-out gap; the ones before it join the
        fit run in the selection (:func:`gyrocomp.diagnose.diagnose`).
    sim : path-like or None
        A simulator config whose enabled effects join the baseline (refitted).
    config : str
        TOML with a ``[diagnose]`` table (path or name in ``configs/``).
    plot : path-like or None
        ``gap.png`` to write: gap by regime and timescale, before and after.
    markdown : path-like or None
        ``report.md`` to write.
    model_out : path-like or None
        ``model.json`` to write: the ``greybox`` model of the selected
        effects it can hold, fitted on the selection runs (:func:`greybox_of`).
    columns : gyrocomp.recordings.ColumnSpec
    resample : bool
        Interpolate a jittered time axis instead of refusing it.
    """

    holdout: Sequence[str | os.PathLike] = ()
    sim: Optional[str | os.PathLike] = None
    config: str = "diagnose"
    plot: Optional[str | os.PathLike] = None
    markdown: Optional[str | os.PathLike] = None
    model_out: Optional[str | os.PathLike] = None
    columns: ColumnSpec = ColumnSpec()
    resample: bool = False


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out, options.markdown, options.plot, options.model_out]


@guarded(written)
def to_files(
    inputs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: Options = Options(),
    *,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Read the recordings (``inputs = [fit]``), diagnose each axis and write ``report.json`` (``-``: stdout), ``report.md`` and the plot.

    Each axis is diagnosed alone, against the axis of the same name in the
    held-out recording. One axis gives the report of
    :func:`gyrocomp.diagnose.report.to_json` (with ``axis``, its name);
    several give the header and ``axes``, a verdict per axis name, one
    ``report.md`` with a section per axis and one plot per axis
    (``gap_<axis>.png`` beside the ``--plot`` path).

    Returns
    -------
    dict
        The report as written.
    """
    from gyrocomp import artefacts, recordings
    from gyrocomp import plots
    from gyrocomp.config import settings_dict
    from gyrocomp.diagnose import diagnose, get_config
    from gyrocomp.diagnose.report import to_json, to_markdown

    (fit,) = inputs
    settings = get_config(options.config)

    def read(path):
        # A recording with gaps is diagnosed by segments (gyrocomp.diagnose.problems), never interpolated.
        return recordings.read_recording(
            path, options.columns, resample=options.resample, allow_gaps=not options.resample, min_samples=64
        )

    fit_rec = read(fit)
    if options.plot is not None and len(fit_rec.axes) > 1:  # one plot per axis, named by it: checked before anything is written
        for axis in fit_rec.axis_names:
            artefacts.name_part(axis, f"{fit}: axis")
    holdouts = [options.holdout] if isinstance(options.holdout, (str, os.PathLike)) else list(options.holdout or ())
    hold_recs = [read(path) for path in holdouts]
    recordings.check_distinct([fit_rec, *hold_recs])
    start = ()
    if options.sim is not None:
        from gyrocomp.sim.model import load_sim_config

        start = tuple(load_sim_config(options.sim).gyro.active_effects())
    bodies = {}
    for axis in fit_rec.axis_names:
        held = [rec.axis(axis if len(fit_rec.axes) > 1 else None) for rec in hold_recs]
        bodies[axis] = diagnose(
            fit_rec.axis(axis), held, settings, start_effects=start, callback=progress
        )
    if options.model_out is not None:
        models, units, left_out = {}, {}, {}
        for axis, body in bodies.items():
            runs = [rec.axis(axis if len(fit_rec.axes) > 1 else None) for rec in [fit_rec] + hold_recs[:-1]]
            trained, unit, left_out[axis] = greybox_of(body, runs)
            models.update(trained), units.update(unit)
        from gyrocomp.pipeline.model_file import model_file

        artefacts.write_json(options.model_out, model_file(models, units))
        for axis, body in bodies.items():
            body["model_out"] = {"path": str(options.model_out), **left_out[axis]}
    records = [rec.input_record() for rec in [fit_rec] + hold_recs]
    report = to_json({}, inputs=records, settings=settings_dict(settings))
    verdicts = {axis: {**report, **to_json(body, inputs=records, settings=report["settings"]), "axis": axis} for axis, body in bodies.items()}
    if len(verdicts) == 1:
        report = next(iter(verdicts.values()))
    else:
        report["axes"] = {axis: {k: v for k, v in verdict.items() if k not in report} for axis, verdict in verdicts.items()}
    artefacts.write_json(out, report)
    if options.markdown is not None:
        text = "\n".join((f"# Axis `{axis}`\n\n" if len(verdicts) > 1 else "") + to_markdown(v) for axis, v in verdicts.items())
        with artefacts.atomic_path(options.markdown) as tmp:
            Path(tmp).write_text(text, encoding="utf-8")
    if options.plot is not None:
        plot = Path(options.plot)
        for axis, verdict in verdicts.items():
            plots.save(plots.gap_figure(verdict), plot if len(verdicts) == 1 else plot.with_name(f"{plot.stem}_{axis}{plot.suffix}"), dpi=100)
    return report


def greybox_of(body: dict, runs: list) -> tuple[dict, dict, dict]:
    """The ``greybox`` model of the effects a diagnosis selected, fitted on its selection runs.

    Parameters
    ----------
    body : dict
        The diagnosis of one axis (:func:`gyrocomp.diagnose.diagnose`).
    runs : list of gyrocomp.recordings.Recording
        That axis of the fit run and of the holdouts that took part in the
        selection (every holdout but the last).

    Returns
    -------
    models, units : dict
        As :func:`gyrocomp.pipeline.greybox.train_greybox`.
    left_out : dict
        ``terms`` fitted, and what the model leaves out: the selected
        effects it cannot hold (noise terms, a periodic or a ramp), the terms
        the runs could not identify, and whether the residual tests found
        structure no effect explains.
    """
    from gyrocomp.config import apply_overrides, load_config
    from gyrocomp.models.greybox import TERMS
    from gyrocomp.pipeline.greybox import train_greybox

    selected = list(body["selected_effects"])
    warmup = body["models"]["selected"]["params"].get("warmup", {})
    joined = ["second_warmup"] if "slow_tau_s" in warmup else []  # a warm-up of two time constants
    terms = [t for t in TERMS if t in selected + joined]
    config = apply_overrides(load_config("greybox"), [f"greybox.terms={terms!r}".replace("'", '"'), 'greybox.selection="all"'])
    models, units = train_greybox(runs, config, source="diagnose --model-out")
    not_fitted = [r for m in models.values() for r in m["not_fitted"]]
    unexplained = body.get("unexplained", {}) or {}
    left_out = {
        "terms": terms,
        "not_held": [e for e in selected if e not in TERMS],
        "not_fitted": not_fitted,
        "unexplained_structure": bool(unexplained.get("present")),
    }
    return models, units, left_out

