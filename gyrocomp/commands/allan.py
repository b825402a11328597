"""``allan``: recordings to ``allan.json`` (and ``allan.png``); the CI bounds on its read-offs."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files", "check"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp allan`` (defaults: the command's).

    Attributes
    ----------
    column : str
        Column to analyse, after mapping (``rate``, or e.g. ``compensated``).
    taus : str or None
        ``octave``, ``decade``, ``all`` or comma-separated seconds; ``None`` takes the config's.
    config : str
        TOML with an ``[allan]`` table (path or name in ``configs/``).
    plot : path-like or None
        PNG of the curves, bands and fitted terms to write as well.
    max_arw, max_bias_instability, max_rrw : float or None
        CI bounds on the read-offs [deg/sqrt(h), deg/h, deg/h/sqrt(h)] (:func:`check`).
    columns : gyrocomp.recordings.ColumnSpec
        Column names and units of the recordings.
    resample : bool
        Interpolate a jittered time axis instead of refusing it.
    """

    column: str = "rate"
    taus: Optional[str] = None
    config: str = "allan"
    plot: Optional[str | os.PathLike] = None
    max_arw: Optional[float] = None
    max_bias_instability: Optional[float] = None
    max_rrw: Optional[float] = None
    columns: ColumnSpec = ColumnSpec()
    resample: bool = False


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out, options.plot]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options()) -> list:
    """Read recordings, analyse one column of each and write ``allan.json`` (and the plot).

    Each recording is read (:func:`gyrocomp.recordings.read_recording`), its column
    analysed (:func:`gyrocomp.allan.analyse`), and every series written to
    `out` (``-`` is stdout) as :func:`gyrocomp.allan.allan_artefact`. The
    bounds are left to :func:`check`, so that the artefacts exist when one
    is crossed.

    Parameters
    ----------
    inputs : sequence of path-like
        CSV or Parquet recordings (``-`` reads CSV from stdin).
    out : path-like
        ``allan.json`` to write.
    options : Options

    Returns
    -------
    list of gyrocomp.allan.AllanSeries
    """
    from gyrocomp import allan as al
    from gyrocomp import artefacts, recordings
    from gyrocomp.commands import PLOT_LOCK
    from gyrocomp.config import settings_dict
    from gyrocomp.errors import InputError

    settings = al.get_config(options.config)
    spec, column = options.columns, options.column
    series, records = [], []
    for path in inputs:
        rec = recordings.read_recording(path, spec, min_samples=3, resample=options.resample, usecols=[column]).axis()
        if column not in rec.columns:
            raise InputError(f"{rec.name}: no column {column!r} to analyse; it has {', '.join(rec.columns)}")
        series.append(al.analyse(rec.column(column), rec.fs_hz, taus=options.taus, name=Path(rec.name).name, column=column, settings=settings))
        records.append(rec.input_record())
        del rec
    resolved = {**settings_dict(settings), "taus": options.taus or settings.taus, "column": column}
    artefacts.write_json(out, al.allan_artefact(series, inputs=records, settings=resolved))
    if options.plot is not None:
        with PLOT_LOCK:
            al.plot_allan(series, options.plot)
    return series


def check(series: Sequence, options: Options) -> None:
    """Raise :class:`~gyrocomp.errors.ThresholdError` when a read-off exceeds its ``--max-*`` bound."""
    from gyrocomp.allan import check_thresholds

    check_thresholds(series, max_arw=options.max_arw, max_bias_instability=options.max_bias_instability, max_rrw=options.max_rrw)
