"""``allan``: recordings to ``allan.json`` (and ``allan.png``); the CI bounds on its read-offs."""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Iterator, Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.errors import InputError
from gyrocomp.recordings import ColumnSpec

if TYPE_CHECKING:
    import numpy as np

__all__ = ["Options", "to_files", "check"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp allan`` (defaults: the command's).

    Attributes
    ----------
    column : str
        Column to analyse, after mapping: ``rate`` analyses every axis of
        ``columns.rate``; any other name (e.g. ``compensated``) that column.
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

    def __post_init__(self):
        for name in ("max_arw", "max_bias_instability", "max_rrw"):
            bound = getattr(self, name)
            if bound is not None and not (math.isfinite(bound) and bound >= 0):
                raise InputError(f"--{name.replace('_', '-')} {bound!r}: must be a finite number >= 0 (a NaN bound never fires)")


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out, options.plot]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options()) -> list:
    """Read recordings, analyse one column of each and write ``allan.json`` (and the plot).

    Each recording is read (:func:`gyrocomp.recordings.read_recording`),
    each of its axes (or ``options.column``) analysed
    (:func:`gyrocomp.allan.analyse`) as one series named after the file,
    or, for a CSV or Parquet file, read chunk by chunk, twice per series
    (:func:`gyrocomp.streaming.read_chunks`, :func:`gyrocomp.allan.analyse_segment_chunks`),
    so that a recording bigger than memory is fine (standard input, flight
    logs, time units other than seconds and `resample` read it whole);
    the streams of a flight log that the columns select are analysed each
    on its own time stamps (:func:`gyrocomp.recordings.read_recordings`);
    each segment of a recording with gaps is analysed as a series of its
    own (``<file> segment <k>``: an Allan deviation never spans a gap,
    nothing is interpolated; a file read in chunks is not read again for
    it, and its gaps are noted once), segments of fewer than 3 samples
    left out; its ``column`` the axis' name, and every series written to `out` (``-``
    is stdout) as :func:`gyrocomp.allan.allan_artefact` and drawn in one
    plot. The bounds are left to :func:`check`, so that the artefacts exist
    when one is crossed.

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
    from gyrocomp import artefacts, recordings, streaming
    from gyrocomp.config import settings_dict
    from gyrocomp.errors import InputError

    settings = al.get_config(options.config)
    column = options.column
    series, records, units = [], [], []
    for path in inputs:
        usecols = [] if column == "rate" else [column]
        if str(path) != "-" and not options.resample and streaming.supports(path, options.columns):
            found, record, found_units = _streamed(path, options, settings, usecols)
            series += found
            units += found_units
            records.append(record)
            continue
        streams = recordings.read_recordings(
            path, options.columns, min_samples=3, resample=options.resample, usecols=usecols, allow_gaps=not options.resample
        )
        for rec in streams:  # a flight log's streams, each on its own time base
            if column != "rate" and column not in rec.columns:
                raise InputError(f"{rec.name}: no column {column!r} to analyse; it has {', '.join(rec.columns)}")
            parts = rec.split()
            for k, part in enumerate(parts, start=1):
                label = Path(rec.name).name if len(parts) == 1 else f"{Path(rec.name).name} segment {k}"
                if len(parts) > 1 and part.n_samples < 3:
                    continue
                if column == "rate":
                    values = {axis.name: (part.axis(axis.name).rate_dps, axis.unit) for axis in part.axes}
                else:
                    values = {column: (part.column(column), "deg/s")}
                for name, (x, unit) in values.items():
                    one = al.analyse(x, rec.fs_hz, taus=options.taus, name=label, column=name, settings=settings)
                    _relabel(one, unit)
                    series.append(one)
                    units.append(unit)
        records.append(_input_record(streams))
        del streams, rec, parts
    resolved = {**settings_dict(settings), "taus": options.taus or settings.taus, "column": column}
    artefacts.write_json(out, al.allan_artefact(series, inputs=records, settings=resolved))
    if options.plot is not None:
        from gyrocomp import plots

        plots.save(plots.allan_figure(series, unit=", ".join(dict.fromkeys(units)) or "deg/s"), options.plot, dpi=120)
    return series


def _streamed(path, options: Options, settings, usecols: list) -> tuple[list, dict, list]:
    """The series of a CSV or Parquet file read chunk by chunk (:func:`gyrocomp.allan.analyse_segment_chunks`).

    A file with gaps is read the same way: each gap-free segment is a
    series of its own (``<file> segment <k>``), the pieces of a chunk cut
    at the gaps the reader finds (:attr:`gyrocomp.streaming.ChunkReader.breaks`),
    and the reader notes the gaps once.
    """
    from gyrocomp import allan as al
    from gyrocomp import streaming
    from gyrocomp.errors import InputError

    column = options.column
    reader = streaming.read_chunks(path, options.columns, usecols=usecols, gaps=True)
    head = next(iter(reader))  # the axes and columns, from the first chunk
    if column == "rate":
        values = {axis.name: ((lambda chunk, name=axis.name: chunk.axis(name).rate_dps), axis.unit) for axis in head.axes}
    elif column in head.columns:
        values = {column: ((lambda chunk: chunk.column(column)), "deg/s")}
    else:
        raise InputError(f"{head.name}: no column {column!r} to analyse; it has {', '.join(head.columns)}")
    series, units = [], []
    for name, (pick, unit) in values.items():
        found = al.analyse_segment_chunks(
            lambda: _pieces(reader, pick), lambda: reader.fs_hz,
            taus=options.taus, name=Path(reader.name).name, column=name, settings=settings,
        )
        for one in found:
            _relabel(one, unit)
            series.append(one)
            units.append(unit)
    return series, reader.input_record(), units


def _pieces(reader, pick) -> Iterator[tuple[int, "np.ndarray"]]:
    """``(segment, samples)`` of each chunk of `reader`, cut at its gaps: what :func:`gyrocomp.allan.analyse_segment_chunks` reads."""
    import bisect

    for chunk in reader:
        y = pick(chunk)
        stop = reader.n_samples
        start = stop - len(y)
        edges = [start, *(b for b in reader.breaks if start < b < stop), stop]
        for a, b in zip(edges[:-1], edges[1:]):
            yield bisect.bisect_right(reader.breaks, a), y[a - start : b - start]


def _input_record(streams: Sequence) -> dict:
    """The ``inputs`` entry of a file read as one recording or as several streams: one entry, every stream's notes."""
    record = streams[0].input_record()
    notes = [note for rec in streams for note in rec.notes]
    if notes:
        record["notes"] = notes
    return record


def check(series: Sequence, options: Options) -> None:
    """Raise :class:`~gyrocomp.errors.ThresholdError` when a read-off exceeds its ``--max-*`` bound."""
    from gyrocomp.allan import check_thresholds

    check_thresholds(series, max_arw=options.max_arw, max_bias_instability=options.max_bias_instability, max_rrw=options.max_rrw)


_INTEGRATED = {"deg/s": "deg", "m/s^2": "m/s"}
"""The integral over time of each quantity's unit: what the IEEE 952 term units are built on."""


def _relabel(series, unit: str) -> None:
    """Give the terms of an axis in `unit` (an acceleration) their units, in place.

    The terms are computed for deg/s with factors that only turn seconds
    into hours (:data:`gyrocomp.allan.ieee952.FACTORS`), so for an axis in m/s^2
    the same values hold with ``m/s`` in place of ``deg``: velocity random
    walk [m/s/sqrt(h)], bias instability [m/s/h], acceleration random walk
    [m/s/h/sqrt(h)] (IEEE Std 1293, Annex C).
    """
    if unit != "deg/s":
        for term in series.terms.values():
            term["unit"] = term["unit"].replace("deg", _INTEGRATED[unit], 1)
