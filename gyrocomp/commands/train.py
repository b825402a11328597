"""``train``: components and classes (parallel pipelines) or a recording (direct pipelines) to ``model.json``."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.config import check_seed
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp train`` (defaults: the command's).

    Attributes
    ----------
    config : str
        Pipeline TOML or a name in ``configs/`` (``pe-lcd-anfis``,
        ``iceemdan-se-tfpf-nsga2elm``, ``bp``, ``elm``, ``polynomial``).
    seed : int
        Seed of every learner that draws random numbers.
    overrides : tuple of str
        ``table.key=value`` assignments to the config (``--set``).
    workers : int
        Processes training the axes of a direct pipeline side by side; the
        model does not depend on it.
    columns : gyrocomp.recordings.ColumnSpec
        Column names and units of a direct pipeline's recording; several
        axes (``rate="gx,gy,gz"``) give one model each.
    plot : path-like or None
        PNG of :func:`gyrocomp.plots.drift_figure` on the training run, one row per axis.
    even_temperature : bool
        Average the training block means within temperature bins of
        ``[coverage] bin_c`` before the fit (``[model] temperature_bin_c``;
        :func:`gyrocomp.pipeline.coverage.even_over_temperature`).
    """

    config: str = "pe-lcd-anfis"
    seed: int = 0
    overrides: tuple = ()
    workers: int = 1
    columns: ColumnSpec = ColumnSpec()
    plot: Optional[str | os.PathLike] = None
    even_temperature: bool = False

    def __post_init__(self):
        check_seed(self.seed)


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out, options.plot]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options()) -> dict:
    """Fit the drift models of a pipeline and write ``model.json``.

    Given a recording, a model is fitted per sensor axis (the streams of
    a flight log each on their own time stamps,
    :func:`gyrocomp.recordings.read_recordings`), each with the
    same seed, in ``options.workers`` processes, on every sample of every
    gap-free segment (the temperature rate never spans a gap): a direct
    pipeline on the rate; a parallel pipeline decomposes and classifies
    each axis first, as ``decompose`` and ``classify`` would, and with gaps
    each segment on its own
    (:func:`~gyrocomp.pipeline.train.train_parallel_segments`; a segment
    too short to decompose is refused, named). Given components and classes, a parallel pipeline fits
    every axis they were decomposed from (a several-axis components file and
    its classes: each axis as its one-axis chain would).

    Parameters
    ----------
    inputs : sequence of path-like
        ``[recording]`` (with temperature), or ``[components.parquet,
        classes.json]`` for a parallel pipeline (one axis, or several:
        :func:`gyrocomp.commands.decompose.write_axes`).
    out : path-like
        ``model.json`` to write (:func:`gyrocomp.pipeline.model_file.model_file`:
        a model per axis under ``axes``, named after the axes' columns).
    options : Options

    Returns
    -------
    dict
        The model as written.
    """
    from gyrocomp import artefacts, recordings
    from gyrocomp.config import PIPELINE_TABLES, apply_overrides, check_tables, load_config
    from gyrocomp.errors import InputError
    from gyrocomp.pipeline.settings import pipeline_settings, rate_settings
    from gyrocomp.artefacts import file_record
    from gyrocomp.pipeline.model_file import model_file
    from gyrocomp.pipeline.train import train_parallel

    from gyrocomp.pipeline import coverage

    checks = coverage.get_config()
    even = (f"model.temperature_bin_c={checks.bin_c!r}",) if options.even_temperature else ()
    cfg = check_tables(apply_overrides(load_config(options.config), (*even, *options.overrides)), PIPELINE_TABLES, options.config)
    pipeline = pipeline_settings(cfg, options.config)
    if options.even_temperature and pipeline.kind == "greybox":
        raise InputError(f"{options.config}: --even-temperature weights block means of a direct or parallel fit; a greybox model fits the runs' dynamics")
    window_s = rate_settings(cfg, options.config).window_s
    source, *rest = inputs
    sensors = {}  # by axis: what a flight log says about its sensor
    if pipeline.parallel and rest:
        (classes,) = rest
        frame, header = artefacts.read_table(source, "gyrocomp.components")
        labels = artefacts.read_json(classes, "gyrocomp.classes")
        records = [file_record(source), file_record(classes)]
        if "axes" in header:
            trained, units = _train_components_axes(frame, header, labels, cfg, source, classes, options, records)
        else:
            axis = str(header.get("axis", "rate"))
            trained = {axis: train_parallel(frame, header, labels, cfg, source=options.config, seed=options.seed, inputs=records)}
            units = {axis: str(header.get("unit", "deg/s"))}
    elif pipeline.kind == "greybox":  # every input a run of the same gyro
        from gyrocomp.pipeline.greybox import train_greybox

        runs = []
        for path in inputs:
            streams = recordings.read_recordings(path, options.columns, require_temperature=True, min_samples=16, allow_gaps=True)
            if len(streams) > 1:
                raise InputError(f"{path}: {len(streams)} streams on their own time bases; select one with --rate-col for a greybox model")
            runs.append(streams[0])
        trained, units = train_greybox(runs, cfg, source=options.config, seed=options.seed)
        for run in runs:  # once the fit stands: a refused run gets its one error line only
            coverage.check_run(Path(run.name).name, run.time_s, run.temperature_c, run.segments, window_s, checks)
    else:
        if rest:
            raise InputError(f"{options.config}: a direct pipeline ({pipeline.kind}) trains on the recording alone; drop {rest[0]}")
        streams = recordings.read_recordings(source, options.columns, require_temperature=True, min_samples=16, allow_gaps=True)
        trained, units = {}, {}
        for recording in streams:  # a flight log's streams, each on its own time base
            trained.update(train_axes(recording, cfg, source=options.config, seed=options.seed, workers=options.workers))
            coverage.check_run(Path(recording.name).name, recording.time_s, recording.temperature_c, recording.segments, window_s, checks)
            units.update({axis.name: axis.unit for axis in recording.axes})
            if "stream" in recording.metadata:  # what the log says about the sensor: export's instances and device ids
                sensors.update(dict.fromkeys(recording.axis_names, dict(recording.metadata)))
    model = model_file(trained, units, sensors)
    artefacts.write_json(out, model)
    if options.plot is not None:
        from gyrocomp.pipeline.compensate import load_models

        if pipeline.parallel and rest:  # the components file's rate columns
            rates = list(units) if "axes" in header else ["rate"]
            streams = [recordings.recording_from_frame(
                frame[["time", *rates, "temperature"]], name=Path(source).name, columns=ColumnSpec(rate=",".join(rates), rate_unit=",".join(units.values()))
            )]
        models = load_models(model, str(out))
        only = next(iter(models.values())) if len(models) == 1 else None  # one model: whatever its axis is called
        pairs = {name: models.get(name, only) for rec in streams for name in rec.axis_names if models.get(name, only) is not None}
        drift_plot(streams, pairs, options.plot, title=f"{pipeline.kind} trained on {Path(source).name}")
    return model


def _train_components_axes(frame, header: dict, labels: dict, cfg: dict, source, classes, options, records) -> tuple[dict, dict]:
    """Each axis of a several-axis components file and its classes, trained as its one-axis chain would be.

    Returns the models and the units, by axis name in the file's order.
    """
    from gyrocomp.commands.decompose import axis_view
    from gyrocomp.errors import InputError
    from gyrocomp.pipeline.train import train_parallel

    by_axis = labels.get("axes")
    if not isinstance(by_axis, dict) or list(by_axis) != list(header["axes"]):
        raise InputError(f"{classes}: classes of axes {list(by_axis or [])} do not match the components' axes {list(header['axes'])}; classify that file")
    trained, units = {}, {}
    for axis in header["axes"]:
        one, one_header = axis_view(frame, header, axis, str(source))
        entries = by_axis[axis].get("components") if isinstance(by_axis[axis], dict) else None
        if not isinstance(entries, list):
            raise InputError(f"{classes}: axis {axis!r} has no `components` list")
        prefix = f"{axis}_"
        unprefixed = [
            {**e, "name": e["name"][len(prefix) :]} if isinstance(e, dict) and str(e.get("name", "")).startswith(prefix) else e for e in entries
        ]
        one_labels = {**{k: v for k, v in labels.items() if k != "axes"}, "components": unprefixed}
        trained[axis] = train_parallel(one, one_header, one_labels, cfg, source=options.config, seed=options.seed, inputs=records)
        units[axis] = one_header["unit"]
    return trained, units


def drift_plot(streams, models: dict, path, *, title: str = "", compensated: dict | None = None) -> None:
    """:func:`gyrocomp.plots.drift_figure` of a run, one row per axis, with the model of each axis.

    The figure draws means of 60 s blocks within each segment, so they are
    all that is kept (:class:`gyrocomp.plots.BlockMeans`): the run is read
    `_PLOT_ROWS` samples at a time and, unless given, compensated in causal
    mode chunk by chunk (:class:`~gyrocomp.pipeline.compensate.CausalCompensation`),
    so that ``--plot`` adds memory of a chunk, not of the run
    (``benchmarks/bench_long.py plot``).

    Parameters
    ----------
    streams : sequence of gyrocomp.recordings.Recording
        The run's recordings (a flight log's streams: each axis on its own time base).
    models : dict of str to DriftModel
        By the recordings' axis names.
    compensated : dict of str to ndarray or None
        Each axis compensated already; by default compensated here in causal mode.
    """
    import warnings

    from gyrocomp import plots
    from gyrocomp.pipeline.compensate import CausalCompensation

    axes = []
    owner = {name: rec for rec in streams for name in rec.axis_names}
    for name, model in models.items():
        one = owner[name].axis(name)
        time, temperature, rate = one.time_s, one.temperature_c, one.rate_dps
        parts = []
        for seg in one.segments:
            means = plots.BlockMeans(max(1, int(round(plots.DRIFT_BLOCK_S * one.fs_hz))))
            causal = None if compensated is not None else CausalCompensation(model, one.fs_hz, one.name)
            for start in range(seg.start, seg.stop, _PLOT_ROWS):
                rows = slice(start, min(start + _PLOT_ROWS, seg.stop))
                if causal is None:
                    values = compensated[name][rows]
                else:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")  # the training run's own ranges; compensate reports leaving them, the plot need not
                        values = causal(rate[rows], temperature[rows], time[rows])[1]
                means.add({"time": time[rows], "temperature": temperature[rows], "rate": rate[rows], "compensated": values})
            parts.append(means.means())
        axes.append(plots.drift_axis_from_means(name, parts, model))
    plots.save(plots.drift_figure(axes, title=title), path)


_PLOT_ROWS = 1 << 18
"""Samples :func:`drift_plot` reads and compensates at a time (8 MB a column)."""


def train_axes(recording, config: dict, *, source: str, seed: int | None, workers: int = 1) -> dict:
    """A pipeline's model of every axis of a recording, by axis name in the recording's order.

    Each axis is trained alone (:meth:`~gyrocomp.recordings.Recording.axis`;
    :func:`gyrocomp.pipeline.train.train_direct` over its gap-free segments,
    or decomposed, classified and :func:`~gyrocomp.pipeline.train.train_parallel`,
    by segments :func:`~gyrocomp.pipeline.train.train_parallel_segments`)
    with the same seed, so the models do not depend on `workers`. A gap-free
    LCD axis longer than :data:`gyrocomp.decompose.lcd_blocks.BLOCK` samples
    is decomposed on disk in a temporary directory
    (:func:`~gyrocomp.pipeline.train.train_parallel_on_disk`), the same model
    in memory that does not grow with the log.
    """
    from gyrocomp.workers import run_local

    tasks = [
        {"axis": name, "recording": recording.axis(name), "config": config, "source": source, "seed": seed, "bounds": list(recording.segments)}
        for name in recording.axis_names
    ]
    done = {task["axis"]: result for task, result in run_local(_train_axis, tasks, workers=workers)}
    for name in recording.axis_names:
        if isinstance(done[name], BaseException):
            raise done[name]
    return {name: done[name] for name in recording.axis_names}


def _train_axis(task: dict) -> dict:
    import tempfile

    from gyrocomp.classify import ClassifySettings, classify
    from gyrocomp.commands.decompose import table
    from gyrocomp.config import bind, settings_dict
    from gyrocomp.decompose import DecomposeSettings, decompose
    from gyrocomp.decompose.lcd_blocks import BLOCK
    from gyrocomp.pipeline.settings import pipeline_settings
    from gyrocomp.pipeline.train import fit_parallel, parallel_targets, train_direct, train_parallel_on_disk, train_parallel_segments

    recording, config, source, seed = task["recording"], task["config"], task["source"], task["seed"]
    if not pipeline_settings(config, source).parallel:
        return train_direct(recording, config, source=source, seed=seed, bounds=task["bounds"])
    if len(task["bounds"]) > 1:
        return train_parallel_segments(recording, config, source=source, seed=seed, bounds=task["bounds"])
    settings = bind(DecomposeSettings, config.get("decompose"), f"{source} [decompose]")
    if settings.method == "lcd" and len(recording.rate_dps) > BLOCK:  # a long record: its decomposition on disk
        with tempfile.TemporaryDirectory(prefix="gyrocomp-train-") as directory:
            return train_parallel_on_disk(recording, config, directory, source=source, seed=seed)
    classify_settings = bind(ClassifySettings, config.get("classify"), f"{source} [classify]")
    result = decompose(recording.rate_dps, settings, seed=seed)
    classes = {"settings": settings_dict(classify_settings), "components": classify(result.components, result.names, classify_settings)}
    frame, header = table(recording, result, settings, seed)
    del result
    prepared = parallel_targets(frame, header, classes, config, source=source)
    del frame  # the learners are fitted without the decomposition in memory
    return fit_parallel(prepared, config, source=source, seed=seed, inputs=[recording.input_record()])
