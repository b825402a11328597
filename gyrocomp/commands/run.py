"""``run``: the whole chain for several pipelines on one training and one held-out run, scored side by side.

For each method of the run config (``configs/compare.toml``):

1. parallel pipelines: decompose the training run, classify its
   components, train the segment learners; direct pipelines: train on the
   recording itself;
2. compensate the test run, and the test run with a known angular rate
   added (:func:`gyrocomp.pipeline.evaluate.injected_signal`), in each mode;
3. score: ARW and bias instability, residual temperature drift of the
   100 s means, signal preservation, training and per-stage times.

Several axes (``--rate-col gx,gy,gz``) run every method on each axis
alone, with the same seed and the same injected rate, as ``run`` on that
column would; their artefacts go under ``DIR/<axis>/<method>/`` and every
report row and method entry names its ``axis``.

Every artefact is kept under ``DIR/<method>/``; the scores go to
``report.json``, ``report.md`` and ``report.png``
(:mod:`gyrocomp.pipeline.report`). Without a test run the training run is
scored and the report says that nothing was held out.
"""

from __future__ import annotations

import dataclasses
import os
import time
import warnings
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from gyrocomp import artefacts, recordings
from gyrocomp.commands import Folder, guarded
from gyrocomp.errors import InputError
from gyrocomp.config import PIPELINE_TABLES, apply_overrides, bind, check_seed, check_tables, load_config, settings_dict
from gyrocomp.pipeline import evaluate
from gyrocomp.pipeline.compensate import compensate, load_model
from gyrocomp.pipeline.settings import EvaluateSettings, RunSettings, SignalSettings, pipeline_settings
from gyrocomp.artefacts import file_record
from gyrocomp.pipeline.model_file import model_file
from gyrocomp.pipeline.train import train_direct, train_parallel

__all__ = ["REPORT_SCHEMA", "Options", "to_files", "load_run_config", "decompose_and_classify"]

REPORT_SCHEMA = "gyrocomp.report"

Progress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: the stage's description and its progress."""


def load_run_config(path: str | os.PathLike, overrides=()) -> tuple[RunSettings, EvaluateSettings, SignalSettings, dict]:
    """Read a run config: its ``[run]``, ``[evaluate]`` and ``[signal]`` tables."""
    source = str(path)
    config = check_tables(apply_overrides(load_config(path), overrides), ("run", "evaluate", "signal"), source)
    return (
        bind(RunSettings, config.get("run"), f"{source} [run]"),
        bind(EvaluateSettings, config.get("evaluate"), f"{source} [evaluate]"),
        bind(SignalSettings, config.get("signal"), f"{source} [signal]"),
        config,
    )


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp run`` (defaults: the command's).

    Attributes
    ----------
    test : path-like or None
        Held-out recording to score on; ``None`` scores the training run (and the report says so).
    seed : int
        Seed of every random step (decompositions, learners).
    workers : int
        Processes for the decompositions.
    overrides : tuple of str
        ``table.key=value`` assignments to the run config (``--set``).
    columns : gyrocomp.recordings.ColumnSpec
        Column names and units of the recordings.
    """

    test: Optional[str | os.PathLike] = None
    seed: int = 0
    workers: int = 1
    overrides: tuple = ()
    columns: recordings.ColumnSpec = recordings.ColumnSpec()

    def __post_init__(self):
        check_seed(self.seed)


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [Folder(out)]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out_dir: str | os.PathLike, options: Options = Options(), *, progress: Progress | None = None) -> dict:
    """Train, compensate and score every method of a run config.

    Parameters
    ----------
    inputs : sequence of path-like
        ``[run config, training recording]``: the run config
        (``configs/compare.toml``, or a name in ``configs/``) and a
        recording with temperature (one axis or several, ``options.columns``);
        ``options.test`` is held out from training and must have the same axes.
    out_dir : path-like
        Folder for every artefact and the report.
    options : Options
    progress : callable(stage, done, total) or None

    Returns
    -------
    dict
        The report (also written as ``report.json``).
    """
    from gyrocomp.pipeline import report

    started = time.perf_counter()
    step = progress or (lambda stage, done, total: None)
    config_path, train_path = inputs
    seed, workers, columns = options.seed, options.workers, options.columns
    run_settings, eval_settings, signal_settings, _ = load_run_config(config_path, options.overrides)
    out = Path(out_dir)
    train_all = recordings.read_recording(train_path, columns, require_temperature=True, min_samples=16)
    held_out = options.test is not None
    test_all = recordings.read_recording(options.test, columns, require_temperature=True, min_samples=16) if held_out else train_all
    names = train_all.axis_names
    if held_out:
        recordings.check_distinct([train_all, test_all])
    if held_out and test_all.axis_names != names:
        raise InputError(f"{options.test}: axes {', '.join(test_all.axis_names)} differ from the training run's ({', '.join(names)})")
    several = len(names) > 1
    if several:  # each axis gets a folder of its name: refuse one that would lie elsewhere, before anything is written
        for axis in names:
            artefacts.name_part(axis, f"{train_path}: axis")
    first = test_all.axis(names[0])
    signal, parts = evaluate.injected_signal(first.time_s, first.fs_hz, signal_settings)

    rows, methods = [], []
    for axis in names:
        train_rec, test_rec = train_all.axis(axis), test_all.axis(axis)
        where = out / axis if several else out
        tag = f"{axis}: " if several else ""
        axis_rows, axis_methods = _run_axis(
            run_settings, eval_settings, train_rec, test_rec, _with_signal(test_rec, signal), parts, out, where,
            seed=seed, workers=workers, step=lambda stage, done, total, tag=tag: step(tag + stage, done, total),
        )
        rows += [{"axis": axis, **row} for row in axis_rows]
        methods += [{"axis": axis, **info} for info in axis_methods]
    train_rec, test_rec = train_all.axis(names[0]), first
    result = {
        **artefacts.artefact_header(
            REPORT_SCHEMA,
            inputs=[train_all.input_record()] + ([test_all.input_record()] if held_out else []),
            settings={
                "run": settings_dict(run_settings),
                "evaluate": settings_dict(eval_settings),
                "signal": settings_dict(signal_settings),
                "config": str(config_path),
                "workers": workers,
            },
            seed=seed,
        ),
        "train": _describe(train_rec),
        "test": {**_describe(test_rec), "held_out": held_out},
        "axes": list(names),
        "signal": {"rms_dps": float(np.sqrt(np.mean((signal - signal.mean()) ** 2))), "parts": list(parts)},
        "methods": methods,
        "rows": rows,
    }
    result["findings"] = report.findings(result)
    result["total_time_s"] = time.perf_counter() - started
    step("report", 0, 1)
    report.write(out, result)
    return result


def _run_axis(run_settings, eval_settings, train_rec, test_rec, signal_rec, parts, out: Path, where: Path, *, seed, workers, step) -> tuple[list, list]:
    """Every method of the run config on one axis: its report rows (raw first) and method entries; artefacts under ``where/<method>/``."""
    from gyrocomp.commands.compensate import write as write_compensation

    rows = [_score("raw", None, test_rec.rate_dps, None, test_rec.fs_hz, eval_settings)]
    methods = []
    for method in run_settings.methods:
        config, source, name = _method_config(method, run_settings.overrides)
        folder = where / name
        info, models = _train_method(config, source, name, train_rec, folder, seed, workers, step, out)
        info["overrides"] = [o.partition(":")[2] for o in run_settings.overrides if o.partition(":")[0] == method]
        modes = run_settings.modes if info["parallel"] else ("causal",)
        for mode in modes:
            outputs = {}
            for label, rec in (("test", test_rec), ("test_signal", signal_rec)):
                step(f"{name}: compensate {label} ({mode})", 0, 1)
                t0 = time.perf_counter()
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    frame, summary = compensate(
                        rec, models, mode, seed=seed, workers=workers, callback=lambda d, t, s=f"{name}: decompose {label}": step(s, d, t)
                    )
                info["stage_times_s"][f"compensate_{mode}_{label}"] = time.perf_counter() - t0
                summary["warnings"] = sorted({str(w.message) for w in caught} | set(summary["warnings"]))
                path = folder / f"compensated_{mode}_{label}.parquet"
                write_compensation(path, frame, {"rate": summary}, rec, folder / "model.json", mode, seed)
                info["artefacts"][f"compensated_{mode}_{label}"] = str(path.relative_to(out))
                outputs[label] = frame["compensated"].to_numpy()
                if label == "test":
                    info.setdefault("warnings", []).extend(summary["warnings"])
            step(f"{name}: score ({mode})", 0, 1)
            kept = evaluate.signal_preservation(outputs["test_signal"], outputs["test"], parts)
            rows.append(_score(name, mode, outputs["test"], kept, test_rec.fs_hz, eval_settings, info))
        methods.append(info)
    return rows, methods


def decompose_and_classify(recording: recordings.Recording, config: dict, source: str, folder: Path, *, seed: int, workers: int, callback=None) -> tuple[dict, dict]:
    """Decompose a recording and classify its components as ``gyrocomp decompose`` and ``classify`` do.

    Writes ``components.parquet`` (+ the ``components.meta.json`` sidecar,
    :func:`gyrocomp.commands.decompose.write`) and ``classes.json``
    (:func:`gyrocomp.commands.classify.write`) into `folder`.

    Returns
    -------
    times : dict
        Seconds spent in ``decompose`` and ``classify``.
    paths : dict
        ``components`` and ``classes``.
    """
    from gyrocomp.classify import ClassifySettings
    from gyrocomp.commands import classify, decompose
    from gyrocomp.decompose import DecomposeSettings

    settings = bind(DecomposeSettings, config.get("decompose"), f"{source} [decompose]")
    classify_settings = bind(ClassifySettings, config.get("classify"), f"{source} [classify]")
    paths = {"components": folder / "components.parquet", "classes": folder / "classes.json"}
    t0 = time.perf_counter()
    decompose.write(recording, settings, paths["components"], seed=seed, workers=workers, progress=callback)
    t1 = time.perf_counter()
    classify.write(paths["components"], classify_settings, paths["classes"])
    times = {"decompose": t1 - t0, "classify": time.perf_counter() - t1}
    return times, paths


def _train_method(config, source, name, train_rec, folder: Path, seed, workers, step, out: Path):
    pipeline = pipeline_settings(config, source)
    info = {
        "name": name,
        "kind": pipeline.kind,
        "config": source,
        "parallel": pipeline.parallel,
        "stage_times_s": {},
        "artefacts": {},
    }
    model_path = folder / "model.json"
    t_train = time.perf_counter()
    if pipeline.parallel:
        times, paths = decompose_and_classify(
            train_rec, config, source, folder, seed=seed, workers=workers,
            callback=lambda d, t: step(f"{name}: decompose training run", d, t),
        )
        info["stage_times_s"].update(times)
        step(f"{name}: train", 0, 1)
        t0 = time.perf_counter()
        components, header = artefacts.read_table(paths["components"], "gyrocomp.components")
        classes = artefacts.read_json(paths["classes"], "gyrocomp.classes")
        model = train_parallel(
            components, header, classes, config, source=source, seed=seed,
            inputs=[file_record(paths["components"]), file_record(paths["classes"])],
        )
        info["stage_times_s"]["train"] = time.perf_counter() - t0
        info["artefacts"].update({k: str(p.relative_to(out)) for k, p in paths.items()})
    else:
        step(f"{name}: train", 0, 1)
        t0 = time.perf_counter()
        if pipeline.kind == "greybox":
            from gyrocomp.pipeline.greybox import train_greybox

            model = next(iter(train_greybox([train_rec], config, source=source, seed=seed)[0].values()))
        else:
            model = train_direct(train_rec, config, source=source, seed=seed)
        info["stage_times_s"]["train"] = time.perf_counter() - t0
    info["train_time_s"] = time.perf_counter() - t_train
    artefacts.write_json(model_path, model_file({"rate": model}))
    info["artefacts"]["model"] = str(model_path.relative_to(out))
    return info, load_model(artefacts.read_json(model_path), str(model_path))


def _method_config(method: str, overrides) -> tuple[dict, str, str]:
    mine = [o.partition(":")[2] for o in overrides if o.partition(":")[0] == method]
    config = check_tables(apply_overrides(load_config(method), mine), PIPELINE_TABLES, method)
    name = Path(method).stem
    return config, method, name


def _score(name, mode, output, kept, fs_hz, settings: EvaluateSettings, info: dict | None = None) -> dict:
    terms = evaluate.allan_terms(output, fs_hz, settings)
    return {
        "method": name,
        "mode": mode,
        "arw": terms["arw"],
        "bias_instability": terms["bias_instability"],
        "allan": {"tau_s": terms["tau_s"], "adev": terms["adev"]},
        "residual_drift": evaluate.residual_drift(output, fs_hz, settings),
        "means_dph": (evaluate.block_means(output, fs_hz, settings.block_s) * evaluate.DPS_TO_DPH).tolist(),
        "signal": kept,
        "train_time_s": None if info is None else info["train_time_s"],
    }


def _with_signal(recording: recordings.Recording, signal: np.ndarray) -> recordings.Recording:
    """The test run with the injected rate added; its hash covers the file's hash and the signal."""
    import hashlib

    data = recording.data.copy()
    data["rate"] = data["rate"].to_numpy() + signal
    digest = hashlib.sha256(recording.sha256.encode() + np.ascontiguousarray(signal).tobytes()).hexdigest()
    return recordings.Recording(
        data=data,
        name=f"{recording.name}+signal",
        sha256=digest,
        fs_hz=recording.fs_hz,
        metadata=recording.metadata,
    )


def _describe(recording: recordings.Recording) -> dict:
    temperature = recording.temperature_c
    return {
        "name": Path(recording.name).name,
        "sha256": recording.sha256,
        "n_samples": int(len(recording.data)),
        "fs_hz": float(recording.fs_hz),
        "duration_s": float(len(recording.data) / recording.fs_hz),
        "temperature_c": [float(temperature.min()), float(temperature.max())],
    }
