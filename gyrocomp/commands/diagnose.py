"""``diagnose``: a fit recording (and a held-out one) to ``report.json``, ``report.md`` and ``gap.png``."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp diagnose`` (defaults: the command's).

    Attributes
    ----------
    holdout : path-like or None
        A second run of the same gyro: checks each effect and gives the held-out gap.
    sim : path-like or None
        A simulator config whose enabled effects join the baseline (refitted).
    config : str
        TOML with a ``[diagnose]`` table (path or name in ``configs/``).
    plot : path-like or None
        ``gap.png`` to write: gap by regime and timescale, before and after.
    markdown : path-like or None
        ``report.md`` to write.
    columns : gyrocomp.recordings.ColumnSpec
    resample : bool
        Interpolate a jittered time axis instead of refusing it.
    """

    holdout: Optional[str | os.PathLike] = None
    sim: Optional[str | os.PathLike] = None
    config: str = "diagnose"
    plot: Optional[str | os.PathLike] = None
    markdown: Optional[str | os.PathLike] = None
    columns: ColumnSpec = ColumnSpec()
    resample: bool = False


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out, options.markdown, options.plot]


@guarded(written)
def to_files(
    inputs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: Options = Options(),
    *,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Read the recordings (``inputs = [fit]``), diagnose them and write ``report.json`` (``-``: stdout), ``report.md`` and the plot.

    Returns
    -------
    dict
        The report as written (:func:`gyrocomp.diagnose.report.to_json`).
    """
    from gyrocomp import artefacts, recordings
    from gyrocomp.commands import PLOT_LOCK
    from gyrocomp.config import settings_dict
    from gyrocomp.diagnose import diagnose, get_config
    from gyrocomp.diagnose.report import plot_gap, to_json, to_markdown

    (fit,) = inputs
    settings = get_config(options.config)
    fit_rec = recordings.read_recording(fit, options.columns, resample=options.resample, min_samples=64).axis()
    hold_rec = recordings.read_recording(options.holdout, options.columns, resample=options.resample, min_samples=64).axis() if options.holdout else None
    start = ()
    if options.sim is not None:
        from gyrocomp.sim.model import load_sim_config

        start = tuple(load_sim_config(options.sim).gyro.active_effects())
    body = diagnose(fit_rec, hold_rec, settings, start_effects=start, callback=progress)
    records = [fit_rec.input_record()] + ([hold_rec.input_record()] if hold_rec else [])
    report = to_json(body, inputs=records, settings=settings_dict(settings))
    artefacts.write_json(out, report)
    if options.markdown is not None:
        with artefacts.atomic_path(options.markdown) as tmp:
            Path(tmp).write_text(to_markdown(report), encoding="utf-8")
    if options.plot is not None:
        with PLOT_LOCK:
            plot_gap(report, options.plot)
    return report
