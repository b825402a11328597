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
    detrend_temperature : bool
        Remove a least-squares cubic in temperature from each axis before
        the analysis (:func:`gyrocomp.allan.thermal.cubic_in_temperature`).
    segments : bool
        Write each gap-free segment's own series (``<file> segment <k>``)
        after the series pooled over them; the plot keeps one curve per axis.
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
    segments: bool = False
    detrend_temperature: bool = False

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
    or, for a CSV or Parquet file, read chunk by chunk, twice per series (a Parquet file's phase that fits in memory: once)
    (:func:`gyrocomp.streaming.read_chunks`, :func:`gyrocomp.allan.analyse_segment_chunks`),
    so that a recording bigger than memory is fine (standard input, flight
    logs, time units other than seconds and `resample` read it whole);
    the streams of a flight log that the columns select are analysed each
    on its own time stamps (:func:`gyrocomp.recordings.read_recordings`);
    each segment of a recording with gaps is analysed on its own (an Allan
    deviation never spans a gap, nothing is interpolated; a file read in
    chunks is not read again for it, and its gaps are noted once),
    segments of fewer than 3 samples left out, and the segments of an axis
    pooled into one series (:func:`gyrocomp.allan.pool_segments`; with
    ``options.segments`` each segment's series follows it as
    ``<file> segment <k>``); its ``column`` the axis' name, and every
    series written to `out` (``-`` is stdout) as
    :func:`gyrocomp.allan.allan_artefact` and the pooled ones drawn in one
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
    series, curves, records = [], [], []
    for path in inputs:
        usecols = ([] if column == "rate" else [column]) + list(options.columns.temperature_patterns)
        if str(path) != "-" and not options.resample and streaming.supports(path, options.columns):
            found, pooled, record = _streamed(path, options, settings, usecols)
            series += found
            curves += pooled
            records.append(record)
            continue
        streams = recordings.read_recordings(
            path, options.columns, min_samples=3, resample=options.resample, usecols=usecols, allow_gaps=not options.resample
        )
        for rec in streams:  # a flight log's streams, each on its own time base
            if column != "rate" and column not in rec.columns:
                raise InputError(f"{rec.name}: no column {column!r} to analyse; it has {', '.join(rec.columns)}")
            label = Path(rec.name).name
            parts = rec.split()
            kept = [(k, part) for k, part in enumerate(parts, start=1) if len(parts) == 1 or part.n_samples >= 3]
            axes = {axis.name: axis.unit for axis in rec.axes} if column == "rate" else {column: "deg/s"}
            for name, unit in axes.items():
                values = [(k, part.axis(name).rate_dps if column == "rate" else part.column(column), part.temperature_c) for k, part in kept]
                if options.detrend_temperature:
                    cubic = _cubic(lambda: iter(values), label, rec.temperature_c is not None)
                    values = [(k, y - cubic(t), t) for k, y, t in values]
                found = [
                    al.analyse(y, rec.fs_hz, taus=options.taus, name=label if len(parts) == 1 else f"{label} segment {k}", column=name, settings=settings)
                    for k, y, _ in values
                ]
                pooled = _pool(found, label, unit, settings)
                if rec.temperature_c is not None:
                    _judge(pooled, lambda: iter(values), settings, options.detrend_temperature)
                series += [pooled, *found] if options.segments and len(found) > 1 else [pooled]
                curves.append((pooled, unit))
        records.append(_input_record(streams))
        del streams, rec, parts, kept, values
    resolved = {**settings_dict(settings), "taus": options.taus or settings.taus, "column": column}
    artefacts.write_json(out, al.allan_artefact(series, inputs=records, settings=resolved))
    if options.plot is not None:
        from gyrocomp import plots

        units = ", ".join(dict.fromkeys(unit for _, unit in curves)) or "deg/s"
        plots.save(plots.allan_figure([s for s, _ in curves], unit=units), options.plot, dpi=120)
    return series


def _streamed(path, options: Options, settings, usecols: list) -> tuple[list, list, dict]:
    """The series of a CSV or Parquet file read chunk by chunk (:func:`gyrocomp.allan.analyse_segment_chunks`).

    A file with gaps is read the same way: each gap-free segment is
    analysed on its own, the pieces of a chunk cut at the gaps the reader
    finds (:attr:`gyrocomp.streaming.ChunkReader.breaks`), the segments
    pooled (:func:`_pool`), and the reader notes the gaps once. Returns
    the series to write, the pooled ones with their units (to draw), and
    the input record.
    """
    from gyrocomp import allan as al
    from gyrocomp import streaming
    from gyrocomp.errors import InputError

    column = options.column
    reader = streaming.read_chunks(path, options.columns, usecols=usecols, gaps=True, writable=False)  # the chunks are only read
    reading = iter(reader)
    head = next(reading)  # the axes and columns, from the first chunk of the first reading, which goes on
    if column == "rate":
        values = {axis.name: ((lambda chunk, name=axis.name: chunk.axis(name).rate_dps), axis.unit) for axis in head.axes}
    elif column in head.columns:
        values = {column: ((lambda chunk: chunk.column(column)), "deg/s")}
    else:
        raise InputError(f"{head.name}: no column {column!r} to analyse; it has {', '.join(head.columns)}")
    warm = head.temperature_c is not None
    first = [_resumed([head], reading)]
    del head  # its columns are views of the first row group, which the reading frees when it moves on

    def chunks():
        return first.pop() if first else iter(reader)
    series, curves = [], []
    label = Path(reader.name).name
    for name, (pick, unit) in values.items():
        if options.detrend_temperature:
            cubic = _cubic(lambda pick=pick: _with_temperature(reader, chunks(), pick), label, warm)
            pick = (lambda chunk, pick=pick, cubic=cubic: pick(chunk) - cubic(chunk.temperature_c))
        found = al.analyse_segment_chunks(
            lambda: _pieces(reader, chunks(), pick), lambda: reader.fs_hz, taus=options.taus, name=label, column=name, settings=settings,
            n_samples=reader.n_rows,
        )
        pooled = _pool(found, label, unit, settings)
        if warm:
            _judge(pooled, lambda pick=pick: _with_temperature(reader, chunks(), pick), settings, options.detrend_temperature)
        series += [pooled, *found] if options.segments and len(found) > 1 else [pooled]
        curves.append((pooled, unit))
    return series, curves, reader.input_record()


def _resumed(held: list, rest: Iterator) -> Iterator:
    """The chunk in `held`, then those of `rest`: a reading resumed after its first chunk, which is not kept once handed out."""
    yield held.pop()
    yield from rest


def _with_temperature(reader, chunks, pick) -> Iterator[tuple[int, "np.ndarray", "np.ndarray"]]:
    """``(segment, rate, temperature)`` of each piece of a reading of `reader` (:func:`_pieces`): what :mod:`gyrocomp.allan.thermal` reads."""
    import numpy as np

    for k, both in _pieces(reader, chunks, lambda chunk: np.column_stack([pick(chunk), chunk.temperature_c])):
        yield k, both[:, 0], both[:, 1]


def _cubic(pieces, label: str, warm: bool):
    """The cubic in T that ``--detrend-temperature`` removes (:func:`gyrocomp.allan.thermal.cubic_in_temperature`)."""
    from gyrocomp.allan import thermal

    if not warm:
        raise InputError(f"{label}: --detrend-temperature needs a temperature column; there is none (map it with --temp-col)")
    return thermal.cubic_in_temperature(pieces(), label)


def _judge(pooled, pieces, settings, detrended: bool) -> None:
    """Test whether `pooled`'s long-tau rise follows temperature and say so in one line (:func:`gyrocomp.allan.thermal.judge`)."""
    import warnings

    from gyrocomp.allan import thermal

    result = thermal.temperature_test(pieces, pooled, min_clusters=settings.min_clusters, alpha=settings.thermal_alpha)
    message = thermal.judge(pooled, result, detrended=detrended)
    if message:
        warnings.warn(message, stacklevel=3)


def _pool(found: list, label: str, unit: str, settings):
    """The series of one axis pooled over its segments (:func:`gyrocomp.allan.pool_segments`), every one relabelled for `unit`."""
    from gyrocomp import allan as al

    pooled = found[0] if len(found) == 1 else al.pool_segments(found, name=label, settings=settings)
    for one in {id(s): s for s in (pooled, *found)}.values():
        _relabel(one, unit)
    return pooled


def _pieces(reader, chunks, pick) -> Iterator[tuple[int, "np.ndarray"]]:
    """``(segment, samples)`` of each chunk of a reading `chunks` of `reader`, cut at its gaps: what :func:`gyrocomp.allan.analyse_segment_chunks` reads."""
    import bisect

    for chunk in chunks:
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
