"""``compensate``: a recording and a ``model.json`` to ``compensated.parquet`` and its ``compensated.meta.json`` sidecar."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.artefacts import sidecar_path
from gyrocomp.commands import guarded
from gyrocomp.config import check_seed
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files", "streams", "stream_to_files", "compensate_files", "write"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp compensate`` (defaults: the command's).

    Attributes
    ----------
    mode : {"causal", "full"}
        ``causal``: rate - f(T, dT/dt) only (what firmware runs); ``full``: the
        paper's offline decompose + denoise + compensate.
    clamp : bool or None
        Clamp temperature and dT/dt to the training ranges (``None``: yes in
        causal mode, the model's ``clip_inputs`` in full mode); False extrapolates.
    seed : int or None
        Seed of the decomposition in full mode (``None``: the training run's).
    workers : int
        Processes for the decomposition in full mode.
    columns : gyrocomp.recordings.ColumnSpec
    resample : bool
        Interpolate a jittered time axis instead of refusing it.
    """

    mode: str = "causal"
    clamp: Optional[bool] = None
    plot: Optional[str | os.PathLike] = None
    seed: Optional[int] = None
    workers: int = 1
    columns: ColumnSpec = ColumnSpec()
    resample: bool = False

    def __post_init__(self):
        check_seed(self.seed)


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return ([out] if str(out) == "-" else [out, sidecar_path(out)]) + [options.plot]


@guarded(written)
def to_files(
    inputs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: Options = Options(),
    *,
    progress: Callable[[int, int], None] | None = None,
) -> tuple:
    """Read a recording and a model (``inputs = [recording, model.json]``), compensate every axis, write the artefacts.

    Each axis of the recording is compensated by the model of the same name
    (a one-axis model applies to a one-axis recording whatever their
    names), over every sample of every gap-free segment: the temperature
    rate is estimated within each segment, never across a gap. `out` ``-``
    writes the table as CSV to stdout, without sidecar.

    The streams of a flight log that the columns select (ULog's
    ``sensor_gyro`` and ``sensor_accel``: their own time stamps,
    :func:`gyrocomp.recordings.read_recordings`) are compensated each on
    its own time base and written each to its own table, `out` with
    ``_<stream>`` before the suffix (``c_sensor_gyro_0.parquet`` and its
    sidecar; the plot likewise): no stream is interpolated onto another's
    time stamps.

    Returns
    -------
    groups : list of (path, pandas.DataFrame, gyrocomp.recordings.Recording)
        Per time base (one, but for several streams of a log), the table
        written, where, and its recording. A table has ``time``, each axis,
        ``temperature``, then ``<axis>_drift_model`` and
        ``<axis>_compensated`` per axis; a single axis named ``rate`` gives
        the columns ``time``, ``rate``, ``temperature``, ``drift_model``,
        ``compensated``.
    summaries : dict of str to dict
        Per axis, from :func:`~gyrocomp.pipeline.compensate.compensate`.
    caught : list of warnings.WarningMessage
        The warnings compensating raised (e.g. leaving the training temperature range).
    """
    import warnings

    from gyrocomp import artefacts, recordings
    from gyrocomp.errors import InputError
    from gyrocomp.pipeline.compensate import load_models

    recording_path, model_path = inputs
    models = load_models(artefacts.read_json(model_path), str(model_path))
    streams = recordings.read_recordings(recording_path, options.columns, require_temperature=True, min_samples=2, resample=options.resample, allow_gaps=True)
    if len(streams) > 1 and str(out) == "-":
        keys = ", ".join(rec.metadata["stream"] for rec in streams)
        raise InputError(f"{recording_path}: {keys} have their own time stamps, one table each; give --out a file, not -")
    if len(streams) > 1:  # one table, sidecar and plot per stream: what is written is known only now
        from gyrocomp.commands import check_paths

        outputs = []
        for rec in streams:
            table = stream_path(out, rec.metadata["stream"])
            outputs += [table, artefacts.sidecar_path(table), None if options.plot is None else stream_path(options.plot, rec.metadata["stream"])]
        check_paths(inputs, options, outputs)
    groups, summaries = [], {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for recording in streams:
            path, plot = out, options.plot
            if len(streams) > 1:
                path, plot = (None if p is None else stream_path(p, recording.metadata["stream"]) for p in (out, options.plot))
            pairs = _pair_axes(recording, models, str(model_path), alone=len(streams) == 1)
            table, found = _compensate_stream(recording, pairs, models, path, plot, Path(model_path), options, progress)
            groups.append((path, table, recording))
            summaries.update(found)
    return groups, summaries, list(caught)


def stream_path(path: str | os.PathLike, stream: str) -> Path:
    """The output of one stream of a flight log: `path` with ``_<stream>`` before its suffix."""
    from gyrocomp.artefacts import name_part

    path = Path(path)
    return path.with_name(f"{path.stem}_{name_part(stream, f'{path}: stream')}{path.suffix}")


def _compensate_stream(recording, pairs: dict, models: dict, out, plot, model_path: Path, options: Options, progress) -> tuple:
    """Compensate the axes of one recording (one time base) and write its table, sidecar and plot; the table and the summaries."""
    import pandas as pd

    from gyrocomp import artefacts
    from gyrocomp.pipeline.compensate import compensate

    columns = {"time": recording.time_s, **{name: recording.axis(name).rate_dps for name in pairs}, "temperature": recording.temperature_c}
    drift, compensated, summaries = {}, {}, {}
    for name, model in pairs.items():
        frame, summary = compensate(
            recording.axis(name), model, options.mode, clamp=options.clamp, seed=options.seed, workers=options.workers, callback=progress, bounds=list(recording.segments)
        )
        drift[name], compensated[name] = frame["drift_model"].to_numpy(), frame["compensated"].to_numpy()
        summaries[name] = {**summary, "model_axis": _model_axis(models, model), "unit": recording.axis(name).axes[0].unit}
    for name in pairs:
        columns[output_name(name, "drift_model")] = drift[name]
    for name in pairs:
        columns[output_name(name, "compensated")] = compensated[name]
    table = pd.DataFrame(columns)
    if str(out) == "-":
        artefacts.write_table(out, table, {})
    else:
        write(Path(out), table, summaries, recording, model_path, options.mode, options.seed)
    if plot is not None:
        from gyrocomp.commands.train import drift_plot

        drift_plot([recording], pairs, plot, title=f"{recording.name} compensated ({options.mode})", compensated=compensated)
    return table, summaries


def streams(inputs: Sequence[str | os.PathLike], options: Options = Options()) -> bool:
    """Whether :func:`stream_to_files` can take these: causal mode, no resampling, CSV or Parquet in seconds."""
    from gyrocomp import streaming

    return options.mode == "causal" and not options.resample and streaming.supports(inputs[0], options.columns)


@guarded(written)
def stream_to_files(
    inputs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: Options = Options(),
    *,
    rows: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple:
    """:func:`to_files` in causal mode, in constant memory: read, compensate and write chunk by chunk.

    The recording (a file, or CSV on standard input for ``-``) is read in
    chunks of `rows` samples (:func:`gyrocomp.streaming.read_chunks`; default
    ``CHUNK_ROWS``, and ``FILE_CHUNK_ROWS`` after the first chunk of a Parquet
    file), every
    axis of each chunk compensated by its
    :class:`~gyrocomp.pipeline.compensate.CausalCompensation` and the chunk
    written at once (``-``: CSV on standard output, flushed after each
    chunk); the plot is drawn from 60 s block means kept while streaming
    (:class:`gyrocomp.plots.BlockMeans`). The table's bytes are those of :func:`to_files` for a gap-free
    recording longer than the rate window, the sample rate being the first
    chunk's. A gap raises :class:`gyrocomp.streaming.GapError` (a file with
    gaps goes to :func:`to_files`, which compensates it by segments).
    ``compensated.meta.json`` goes beside a file `out`, with the figures of
    :func:`write` merged chunk by chunk.

    Returns
    -------
    n_samples : int
    summaries : dict of str to dict
        Per axis, from :meth:`~gyrocomp.pipeline.compensate.CausalCompensation.summary`, with ``figures``.
    caught : list of warnings.WarningMessage
    """
    import warnings

    from gyrocomp import artefacts, recordings, streaming
    from gyrocomp.pipeline.compensate import COMPENSATION_SCHEMA, CausalCompensation, load_models

    recording_path, model_path = inputs
    models = load_models(artefacts.read_json(model_path), str(model_path))
    parquet = str(recording_path) != "-" and recordings._kind(str(recording_path)) == "parquet"
    chunks = streaming.read_chunks(
        recording_path, options.columns, rows=rows or (streaming.FILE_CHUNK_ROWS if parquet else streaming.CHUNK_ROWS),
        first_rows=None if rows else streaming.CHUNK_ROWS, require_temperature=True, usecols=[options.columns.temperature],
    )

    def header() -> dict:
        records = [chunks.input_record(), artefacts.file_record(model_path)]
        return artefacts.artefact_header(COMPENSATION_SCHEMA, inputs=records, settings={"mode": "causal"}, seed=options.seed)

    from gyrocomp import plots

    streams, figures, pairs, means = {}, {}, None, {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with streaming.TableWriter(out, header, header_known_first=str(recording_path) != "-") as writer:
            for chunk in chunks:
                if pairs is None:
                    pairs = _pair_axes(chunk, models, str(model_path))
                    clamp = True if options.clamp is None else options.clamp
                    streams = {name: CausalCompensation(model, chunk.fs_hz, chunks.name, clamp=clamp) for name, model in pairs.items()}
                    figures = {name: _RunningFigures() for name in pairs}
                    if options.plot is not None:
                        means = {name: plots.BlockMeans(max(1, int(round(plots.DRIFT_BLOCK_S * chunk.fs_hz)))) for name in pairs}
                columns = {"time": chunk.time_s, **{name: chunk.axis(name).rate_dps for name in pairs}, "temperature": chunk.temperature_c}
                results = {name: streams[name](columns[name], columns["temperature"], chunk.time_s) for name in pairs}
                for name in pairs:
                    columns[output_name(name, "drift_model")] = results[name][0]
                for name in pairs:
                    columns[output_name(name, "compensated")] = results[name][1]
                    figures[name].add(columns[name], *results[name])
                for name, kept in means.items():
                    kept.add({"time": chunk.time_s, "temperature": columns["temperature"], "rate": columns[name], "compensated": results[name][1]})
                writer.write(columns)
                if progress is not None:
                    progress(chunks.n_samples, None)
        summaries = {}
        for name, model in pairs.items():
            summary = {**streams[name].summary(), "model_axis": _model_axis(models, model), "unit": chunk.axis(name).axes[0].unit}
            summaries[name] = {**summary, "figures": {"n_samples": chunks.n_samples, "n_segments": 1, "fs_hz": float(chunks.fs_hz), **figures[name].figures()}}
    if str(out) != "-":
        artefacts.write_json(artefacts.sidecar_path(out), {**header(), "mode": "causal", "axes": summaries})
    if means:
        axes = [plots.drift_axis_from_means(name, [kept.means()], pairs[name]) for name, kept in means.items()]
        plots.save(plots.drift_figure(axes, title=f"{chunks.name} compensated (causal)"), options.plot)
    return chunks.n_samples, summaries, list(caught)


class _RunningFigures:
    """RMS of the drift model, standard deviations of the rate and the compensated rate, merged chunk by chunk (Chan et al. 1979)."""

    def __init__(self):
        self.n = 0
        self.drift_sq = 0.0
        self.moments = [(0.0, 0.0), (0.0, 0.0)]

    def add(self, rate, drift, compensated) -> None:
        import numpy as np

        k = len(rate)
        self.drift_sq += float(np.dot(drift, drift))
        for i, x in enumerate((rate, compensated)):
            mean, m2 = self.moments[i]
            mean_k = float(x.mean())
            m2_k = float(np.sum((x - mean_k) ** 2))
            delta = mean_k - mean
            total = self.n + k
            self.moments[i] = (mean + delta * k / total, m2 + m2_k + delta * delta * self.n * k / total)
        self.n += k

    def figures(self) -> dict:
        import math

        return {
            "drift_model_rms": math.sqrt(self.drift_sq / self.n),
            "rate_std": math.sqrt(self.moments[0][1] / self.n),
            "compensated_std": math.sqrt(self.moments[1][1] / self.n),
        }


def compensate_files(inputs, out, options: Options = Options(), *, progress=None) -> tuple:
    """What ``gyrocomp compensate`` runs: :func:`stream_to_files` where :func:`streams` allows, else :func:`to_files`.

    A file with gaps found while streaming is compensated whole, by
    segments (the streamed output, written under a temporary name, is
    dropped); standard input with a gap is refused.

    Returns
    -------
    n_samples : int
    summaries : dict of str to dict
        Per axis, with ``figures`` (``n_samples``, ``rate_std``,
        ``compensated_std``, ...) and, from :func:`to_files`, ``output``
        (the table it is in: one per stream of a flight log).
    caught : list of warnings.WarningMessage
    """
    import numpy as np

    from gyrocomp.streaming import GapError

    if streams(inputs, options):
        try:
            return stream_to_files(inputs, out, options, progress=progress)
        except GapError:
            if str(inputs[0]) == "-":
                raise
    groups, summaries, caught = to_files(inputs, out, options, progress=progress)
    for path, frame, recording in groups:
        for axis in recording.axis_names:
            summaries[axis]["output"] = str(path)
            summaries[axis]["figures"] = {
                "n_samples": len(frame),
                "rate_std": float(np.std(frame[axis])),
                "compensated_std": float(np.std(frame[output_name(axis, "compensated")])),
            }
    return sum(len(frame) for _, frame, _ in groups), summaries, caught


def output_name(axis: str, what: str) -> str:
    """Column of an axis' ``drift_model`` or ``compensated`` values: ``<axis>_<what>``, or `what` for the axis ``rate``."""
    return what if axis == "rate" else f"{axis}_{what}"


def write(path: Path, frame, summaries: dict, recording, model_path: Path, mode: str, seed) -> dict:
    """Write ``compensated.parquet`` and its ``compensated.meta.json`` sidecar (same stem).

    The sidecar holds the header (inputs: the recording and the model
    file), ``mode``, and per axis (``axes``) the summary of
    :func:`~gyrocomp.pipeline.compensate.compensate` with the RMS of the
    drift model and the standard deviations before and after.
    """
    import numpy as np

    from gyrocomp import artefacts
    from gyrocomp.pipeline.compensate import COMPENSATION_SCHEMA

    header = artefacts.artefact_header(
        COMPENSATION_SCHEMA,
        inputs=[recording.input_record(), artefacts.file_record(model_path)],
        settings={"mode": mode},
        seed=seed,
    )
    artefacts.write_table(path, frame, header)
    axes = {}
    for name, summary in summaries.items():
        drift, out = frame[output_name(name, "drift_model")].to_numpy(), frame[output_name(name, "compensated")].to_numpy()
        figures = {
            "n_samples": int(len(frame)),
            "n_segments": len(recording.segments),
            "fs_hz": float(recording.fs_hz),
            "drift_model_rms": float(np.sqrt(np.mean(drift**2))),
            "rate_std": float(np.std(frame[name].to_numpy())),
            "compensated_std": float(np.std(out)),
        }
        axes[name] = {**summary, "figures": figures}
    sidecar = {**header, "mode": mode, "axes": axes}
    artefacts.write_json(artefacts.sidecar_path(path), sidecar)
    return sidecar


def _pair_axes(recording, models: dict, name: str, *, alone: bool = True) -> dict:
    """The model of each axis of the recording: same name, or the one model of a one-axis file for a one-axis recording `alone` in its file.

    Each model must be in its axis' unit (:func:`gyrocomp.units.check_compensates`).
    """
    from gyrocomp import units
    from gyrocomp.errors import InputError

    if alone and len(models) == 1 and len(recording.axes) == 1:
        pairs = {recording.axis_names[0]: next(iter(models.values()))}
    else:
        missing = [axis for axis in recording.axis_names if axis not in models]
        if missing:
            have = ", ".join(str(a) for a in models)
            raise InputError(f"{name}: no model for axis {', '.join(missing)} of {recording.name} (it has {have}); pick the axes with --rate-col")
        pairs = {axis: models[axis] for axis in recording.axis_names}
    for axis, model in pairs.items():
        units.check_compensates(model, recording.axis(axis).axes[0].unit, recording.name, axis)
    _check_output_names(recording, list(pairs))
    return pairs


def _check_output_names(recording, axes: list) -> None:
    """Refuse axes whose output columns (:func:`output_name`) would take the name of another column of the table.

    ``gx`` beside ``gx_compensated`` (``--rate-col 'gx*'``) would write the
    first axis' compensated values over the second axis' raw ones.
    """
    from gyrocomp.errors import InputError

    taken = {"time": "the time", "temperature": "the temperature", **{axis: f"axis {axis}" for axis in axes}}
    for axis in axes:
        for what in ("drift_model", "compensated"):
            column = output_name(axis, what)
            if column in taken:
                raise InputError(
                    f"{recording.name}: the {what} column of axis {axis} would be `{column}`, which is {taken[column]}; "
                    "rename the column or leave it out of --rate-col"
                )
            taken[column] = f"the {what} column of axis {axis}"


def _model_axis(models: dict, model):
    return next(axis for axis, m in models.items() if m is model)
