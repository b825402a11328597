"""``train``: fit a config's learners and write everything ``compensate`` needs (``model.json``).

Two kinds of pipeline (``[pipeline] parallel``):

* **parallel** (the papers): the training run has been decomposed
  (``components.parquet``) and its components classified (``classes.json``).
  The *drift* segment is the sum of the components classed ``drift`` (the
  trend or residue among them); the *mixed* segment is the sum of the
  components classed ``mixed``, denoised as ``[denoise] mixed`` says (SG in
  Cao et al. 2021, short-window TFPF in Zhang et al. 2024). Each segment
  with a ``[model.<segment>]`` table gets its learner, fitted against
  (T, dT/dt): PE-LCD-ANFIS fits a 16-rule ANFIS on drift and a 4-rule ANFIS
  on the SG-smoothed mixed segment (Cao et al. 2021, section IV-B);
  ICEEMDAN-SE-TFPF + NSGA-II-ELM fits NSGA-II-ELM on the feature (drift)
  segment (Zhang et al. 2024, section 3.7, step 3).
* **direct** (the comparators BP, ELM, polynomial): the learner models the
  recorded rate itself against (T, dT/dt), with no decomposition. Any
  recording (or a components table, which carries ``time``, ``rate`` and
  ``temperature``) is a valid training input.

Inputs and normalisation: column 0 is the measured temperature [degC],
column 1 its rate [degC/s] from the centred estimator of
:mod:`gyrocomp.pipeline.rate`; "all the sequences are normalized" (Cao et
al. 2021, section IV-B): each input is mapped linearly so that its training
range becomes [-1, 1] (except for the polynomial, whose reference
temperature is in degC), and each target is centred on its mean and
divided by its standard deviation. Both maps are stored per segment in
``model.json``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Iterator

import numpy as np

from gyrocomp import artefacts, recordings
from gyrocomp.config import bind, settings_dict
from gyrocomp.errors import InputError
from gyrocomp.pipeline import rate as rate_estimator
from gyrocomp.pipeline.coverage import even_over_temperature
from gyrocomp.pipeline.settings import (
    model_settings,
    pipeline_settings,
    rate_settings,
)

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "MODEL_SCHEMA",
    "MODEL_VERSION",
    "INPUTS",
    "train_direct",
    "train_parallel",
    "parallel_targets",
    "fit_parallel",
    "train_parallel_segments",
    "segments",
    "class_sums",
    "model_file",
    "axis_models",
]

MODEL_SCHEMA = "gyrocomp.model"
MODEL_VERSION = "2.0"
"""``model.json`` version: 2 holds one model per sensor axis under ``axes``; 1 (one model, no axes) is still read."""
_HEADER_KEYS = ("schema", "gyrocomp_version", "inputs", "settings", "seed")
INPUTS = ("temperature_c", "temperature_rate_c_per_s")
"""Names of the learners' input columns, in order."""
TRAIN_ROWS = 1 << 16
"""Samples whose inputs training computes at once (whole blocks of the block means)."""


def train_direct(recording: recordings.Recording, config: dict, *, source: str = "config", seed: int | None = 0, bounds=None) -> dict:
    """Fit a direct pipeline's learner on a recording's rate.

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        One axis in ``rate``, with ``temperature``.
    config : dict
        A loaded pipeline config with ``[pipeline] parallel = false``.
    source : str
        The config's name, used in messages and recorded in the header.
    seed : int or None
        Seed of every learner that takes one.
    bounds : sequence of slice or None
        Row ranges sampled without a gap (``None``: one). Every sample of
        every range is used; the temperature rate is estimated within each
        range, never across a gap.

    Returns
    -------
    dict
        The model of one axis (schema ``gyrocomp.model``, no ``axes``;
        :func:`model_file` gathers the axes of a ``model.json``).
    """
    pipeline = pipeline_settings(config, source)
    if pipeline.parallel:
        raise InputError(f"{source}: [pipeline] parallel = true needs components and classes; use train_parallel")
    temperature = _temperature_of(recording.data, recording.name)
    rate = recording.data["rate"].to_numpy(dtype=float)
    settings = {"pipeline": settings_dict(pipeline)}
    return _fit(
        {"drift": rate},
        temperature,
        recording.fs_hz,
        config,
        source=source,
        seed=seed,
        settings=settings,
        inputs=[recording.input_record()],
        extra={"segments": {"drift": {"components": ["rate"]}}},
        bounds=bounds,
    )


def train_parallel(
    components: "pd.DataFrame",
    components_header: dict,
    classes: dict,
    config: dict,
    *,
    source: str = "config",
    seed: int | None = 0,
    inputs: list[dict] | None = None,
) -> dict:
    """Fit a parallel pipeline's learners on the segments of a classified decomposition.

    Parameters
    ----------
    components : pandas.DataFrame
        ``components.parquet``: ``time``, ``rate``, ``temperature`` and one
        column per component named in ``components_header["components"]``.
    components_header : dict
        Its header (the decomposition settings and seed are copied into the
        model so that ``compensate --mode full`` decomposes alike).
    classes : dict
        ``classes.json``: ``components``, a list of ``{name, entropy, class}``.
    config : dict
        A loaded pipeline config with ``[pipeline] parallel = true``.
    source : str
        The config's name.
    seed : int or None
        Seed of every learner that takes one.
    inputs : list of dict
        Header ``inputs`` records of the components and classes files.

    Returns
    -------
    dict
        The ``model.json`` object.
    """
    prepared = parallel_targets(components, components_header, classes, config, source=source)
    return fit_parallel(prepared, config, source=source, seed=seed, inputs=inputs)


def parallel_targets(components: "pd.DataFrame", components_header: dict, classes: dict, config: dict, *, source: str = "config") -> dict:
    """The first half of :func:`train_parallel`: the class sums its learners fit, and what the model records.

    The result holds no reference to `components`' component columns: a
    caller that drops its own fits (:func:`fit_parallel`) without the
    decomposition in memory (``train`` on a recording).

    Returns
    -------
    dict
        ``targets`` (segment to class sum), ``temperature``, ``fs_hz``,
        ``settings`` and ``extra``, as :func:`fit_parallel` takes them.
    """
    from gyrocomp.denoise import DenoiseSettings

    pipeline = pipeline_settings(config, source)
    if not pipeline.parallel:
        raise InputError(f"{source}: [pipeline] parallel = false; train a direct pipeline on the recording itself")
    names = _component_names(components, components_header)
    labels = _class_labels(classes, names)
    temperature = _temperature_of(components, "components")
    fs_hz = _fs_of(components["time"].to_numpy(dtype=float))
    denoise = bind(DenoiseSettings, config.get("denoise"), f"{source} [denoise]")
    parts = segments([components[name].to_numpy(dtype=float) for name in names], labels, denoise)
    if not any(label == "drift" for label in labels):
        raise InputError(
            "classes: no component is classed drift; the drift segment (trend included) is what the model learns"
        )
    targets = {"drift": parts["drift"]}
    model_table = model_settings(config, source, parallel=True)
    if "mixed" in model_table.segments:
        targets["mixed"] = parts["mixed"]
    settings = {
        "pipeline": settings_dict(pipeline),
        "decompose": components_header.get("settings", {}),
        "decompose_seed": components_header.get("seed"),
        "classify": classes.get("settings", {}),
        "denoise": settings_dict(denoise),
    }
    members = {seg: [n for n, label in zip(names, labels) if label == seg] for seg in ("noise", "mixed", "drift")}
    extra = {
        "segments": {seg: {"components": members[seg]} for seg in targets},
        "training_classes": classes.get("components"),
    }
    return {"targets": targets, "temperature": temperature, "fs_hz": fs_hz, "settings": settings, "extra": extra}


def fit_parallel(prepared: dict, config: dict, *, source: str = "config", seed: int | None = 0, inputs: list[dict] | None = None) -> dict:
    """The second half of :func:`train_parallel`: fit the learners on :func:`parallel_targets`' class sums."""
    return _fit(
        prepared["targets"],
        prepared["temperature"],
        prepared["fs_hz"],
        config,
        source=source,
        seed=seed,
        settings=prepared["settings"],
        inputs=inputs or [],
        extra=prepared["extra"],
    )


def train_parallel_segments(
    recording: recordings.Recording,
    config: dict,
    *,
    source: str = "config",
    seed: int | None = 0,
    bounds,
    workers: int = 1,
    callback=None,
) -> dict:
    """Fit a parallel pipeline on a recording with gaps: each gap-free segment decomposed on its own.

    Each row range of `bounds` is decomposed, classified and denoised by
    itself (:func:`class_sums`: nothing spans a gap, nothing is
    interpolated, no sample is left out); the class sums of the ranges,
    end to end, are the learners' targets, against (T, dT/dt) estimated
    within each range, as :func:`train_direct` does.

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        One axis in ``rate``, with ``temperature``.
    config : dict
        A loaded pipeline config with ``[pipeline] parallel = true``.
    source : str
        The config's name.
    seed : int or None
        Seed of the decomposition of every range and of every learner.
    bounds : sequence of slice
        The recording's gap-free row ranges (:attr:`~gyrocomp.recordings.Recording.segments`).
    workers : int
        Processes for each decomposition's ensemble.
    callback : callable(done, total) or None
        Progress, one step per range.

    Returns
    -------
    dict
        The model of one axis, as :func:`train_parallel` (``decompose_seed``
        the seed of every range); ``training.segment_classes`` holds the
        classes found in each range.

    Raises
    ------
    InputError
        A range too short to decompose (named, :func:`class_sums`), or no
        component of any range classed drift.
    """
    from gyrocomp.classify import ClassifySettings
    from gyrocomp.decompose import DecomposeSettings
    from gyrocomp.denoise import DenoiseSettings

    pipeline = pipeline_settings(config, source)
    if not pipeline.parallel:
        raise InputError(f"{source}: [pipeline] parallel = false; train a direct pipeline with train_direct")
    decompose_cfg = bind(DecomposeSettings, config.get("decompose"), f"{source} [decompose]")
    classify_cfg = bind(ClassifySettings, config.get("classify"), f"{source} [classify]")
    denoise_cfg = bind(DenoiseSettings, config.get("denoise"), f"{source} [denoise]")
    temperature = _temperature_of(recording.data, recording.name)
    parts, classes = class_sums(
        recording.rate_dps, bounds, decompose_cfg, classify_cfg, denoise_cfg,
        seed=seed, time_s=recording.time_s, name=recording.name, workers=workers, callback=callback,
    )
    found = [entry for entries in classes for entry in entries]
    if not any(entry["class"] == "drift" for entry in found):
        raise InputError(f"{recording.name}: no component of any segment is classed drift; the drift segment is what the model learns")
    targets = {"drift": parts["drift"]}
    if "mixed" in model_settings(config, source, parallel=True).segments:
        targets["mixed"] = parts["mixed"]
    settings = {
        "pipeline": settings_dict(pipeline),
        "decompose": settings_dict(decompose_cfg),
        "decompose_seed": seed,
        "classify": settings_dict(classify_cfg),
        "denoise": settings_dict(denoise_cfg),
    }
    members = {seg: list(dict.fromkeys(e["name"] for e in found if e["class"] == seg)) for seg in targets}
    extra = {"segments": {seg: {"components": members[seg]} for seg in targets}, "segment_classes": classes}
    return _fit(
        targets, temperature, recording.fs_hz, config, source=source, seed=seed,
        settings=settings, inputs=[recording.input_record()], extra=extra, bounds=bounds,
    )


def class_sums(
    rate,
    bounds,
    decompose_settings,
    classify_settings,
    denoise_settings,
    *,
    seed: int | None,
    time_s=None,
    name: str = "recording",
    workers: int = 1,
    callback=None,
) -> tuple[dict, list]:
    """Decompose, classify and denoise each gap-free row range on its own; the class sums end to end.

    A parallel pipeline's signal path (Cao et al. 2021, Fig. 5; Zhang et
    al. 2024, section 3.7) run on each range of `bounds` alone, so that no
    component, entropy or filter window spans a gap, and no sample is
    interpolated or dropped.

    Parameters
    ----------
    rate : array_like, shape (n_samples,)
        The axis' values [deg/s, or the axis' unit].
    bounds : sequence of slice or None
        Row ranges sampled without a gap, covering the rows (``None``: one).
    decompose_settings, classify_settings, denoise_settings
        :class:`~gyrocomp.decompose.DecomposeSettings`,
        :class:`~gyrocomp.classify.ClassifySettings`,
        :class:`~gyrocomp.denoise.DenoiseSettings`.
    seed : int or None
        Seed of every range's decomposition.
    time_s : array_like or None
        Time stamps [s], to name a range in messages.
    name : str
        The recording's name, for messages.
    workers : int
        Processes for the decomposition's ensemble.
    callback : callable(done, total) or None
        Progress: the decomposition's own for one range, else one step per range.

    Returns
    -------
    parts : dict of str to ndarray
        ``noise``, ``mixed``, ``drift`` as :func:`segments`, each range's in its rows.
    classes : list of list of dict
        The classes of each range's components (:func:`gyrocomp.classify.classify`).

    Raises
    ------
    InputError
        A range shorter than the decomposition, the entropy or a class's
        denoiser needs, naming the range, its time span, its length and
        the setting; such a range is never dropped silently.
    """
    from gyrocomp.classify import classify
    from gyrocomp.decompose import MIN_SAMPLES, decompose

    rate = np.asarray(rate, dtype=float)
    bounds = [slice(0, rate.size)] if bounds is None else list(bounds)
    need, why = max((MIN_SAMPLES, "the decomposition"), classify_settings.min_samples(), denoise_settings.min_samples(), key=lambda p: p[0])
    for k, rows in enumerate(bounds):
        n = rows.stop - rows.start
        if n < need:
            where = "" if time_s is None else f", t = {time_s[rows.start]:.6g}..{time_s[rows.stop - 1]:.6g} s"
            raise InputError(
                f"{name}: segment {k + 1} of {len(bounds)} (samples {rows.start}..{rows.stop - 1}{where}) has {n} samples, "
                f"fewer than the {need} that {why} needs; a decomposition pipeline decomposes each gap-free segment "
                "on its own and drops none: remove that segment's rows, or train a direct pipeline (bp, elm, polynomial)"
            )
    parts = {cls: np.empty(rate.size) for cls in ("noise", "mixed", "drift")}
    classes = []
    for k, rows in enumerate(bounds):
        step = callback if len(bounds) == 1 else None
        result = decompose(rate[rows], decompose_settings, seed=seed, workers=workers, callback=step)
        entries = classify(result.components, result.names, classify_settings)
        for cls, values in segments(np.asarray(result.components), [e["class"] for e in entries], denoise_settings).items():
            parts[cls][rows] = values
        classes.append(entries)
        if callback is not None and len(bounds) > 1:
            callback(k + 1, len(bounds))
    return parts, classes


def segments(stack, labels, denoise_settings) -> dict:
    """Denoise each component as ``[denoise]`` says for its class, then sum each class.

    Parameters
    ----------
    stack : ndarray, shape (n_components, n_samples), or sequence of 1-D arrays
        The components, fastest first (the columns of ``components.parquet``
        need not be copied into one array).
    labels : sequence of {"noise", "mixed", "drift"}
        One class per component.
    denoise_settings : gyrocomp.denoise.DenoiseSettings

    Returns
    -------
    dict of str to ndarray
        ``noise``, ``mixed``, ``drift``: the sums of the denoised components
        of each class [deg/s] (zeros for a class without components or one
        that is dropped).

    Notes
    -----
    One component is denoised at a time and added to its class's sum in
    component order: the same bytes as summing the rows of
    :func:`gyrocomp.denoise.apply`'s output over the first axis, in memory
    for one processed component instead of all of them.
    """
    from gyrocomp import denoise

    labels = list(labels)
    if len(labels) != len(stack):
        raise InputError(f"denoise: {len(labels)} classes for {len(stack)} components")
    n = len(stack[0]) if len(stack) else 0
    sums = {}
    for component, label in zip(stack, labels):
        processed = denoise.apply(np.asarray(component, dtype=float)[None], [label], denoise_settings)[0]
        if label in sums:
            sums[label] += processed
        else:
            sums[label] = processed
    return {cls: sums[cls] if cls in sums else np.zeros(n) for cls in ("noise", "mixed", "drift")}


def segment_inputs(temperature, fs_hz: float, settings, bounds=None, *, causal: bool = False) -> np.ndarray:
    """The learners' inputs (:func:`gyrocomp.pipeline.rate.model_inputs`) of each gap-free row range, stacked.

    The temperature rate restarts in each range (its window shrinks to fit
    a short one), so no estimate spans a gap. `bounds` ``None`` is one range.
    """
    temperature = np.asarray(temperature, dtype=float)
    if bounds is None or len(bounds) == 1:
        return rate_estimator.model_inputs(temperature, fs_hz, settings, causal=causal)
    return np.concatenate([rate_estimator.model_inputs(temperature[b], fs_hz, settings, causal=causal) for b in bounds])


def model_file(axes: dict, units: dict | None = None, sensors: dict | None = None) -> dict:
    """The ``model.json`` object (version :data:`MODEL_VERSION`) of one model per sensor axis.

    Parameters
    ----------
    axes : dict of str to dict
        Axis name (the recording's column) to its model from
        :func:`train_direct` or :func:`train_parallel`, in output order.
        They share one header (inputs, settings, seed): the first's.
    units : dict of str to str, optional
        Unit of each axis' values and drift model (``deg/s``, ``m/s^2``).
    sensors : dict of str to dict, optional
        For an axis of a flight log, what the log says about its sensor
        (``stream``, ``autopilot``, ``instance``, PX4's ``device_id``:
        :func:`gyrocomp.flightlogs.read_logs`); ``export`` writes every
        instance with its own id.

    Returns
    -------
    dict
        The header and ``axes``: per axis its model without the header,
        ``unit``, and ``sensor`` when given.
    """
    first = next(iter(axes.values()))
    header = {key: first[key] for key in _HEADER_KEYS if key in first}
    header["schema"] = {"name": MODEL_SCHEMA, "version": MODEL_VERSION}
    body = {}
    for name, model in axes.items():
        body[name] = {key: value for key, value in model.items() if key not in _HEADER_KEYS}
        body[name]["unit"] = (units or {}).get(name, "deg/s")
        if name in (sensors or {}):
            body[name]["sensor"] = sensors[name]
    return {**header, "axes": body}


def axis_models(obj: dict, name: str = "model.json") -> dict:
    """Each axis' model of a ``model.json`` as a one-axis object with the header (:func:`train_direct`'s shape).

    A version-1 file (one model, no ``axes``) gives ``{None: obj}``: one axis, unnamed.

    Raises
    ------
    SchemaError
        Not a ``gyrocomp.model``, or of a newer major version.
    InputError
        Version 2 without ``axes``.
    """
    artefacts.check_header(obj, MODEL_SCHEMA, name, supported_major=int(MODEL_VERSION.split(".")[0]))
    if int(str(obj["schema"]["version"]).split(".")[0]) < 2:
        return {None: obj}
    axes = obj.get("axes")
    if not isinstance(axes, dict) or not axes or not all(isinstance(v, dict) for v in axes.values()):
        raise InputError(f"{name}: no `axes` (one model per sensor axis)")
    header = {key: obj[key] for key in _HEADER_KEYS if key in obj}
    return {axis: {**header, **entry} for axis, entry in axes.items()}


def _fit(targets: dict, temperature, fs_hz, config, *, source, seed, settings, inputs, extra, bounds=None) -> dict:
    """Fit each segment's learner on block means of (T, dT/dt) and its target, in bounded memory.

    The inputs are computed a run of whole blocks at a time (:func:`_runs`,
    :func:`_inputs_of`), three times: for their ranges, the block means and
    the training RMSE. Beside the recording's own columns, memory holds one
    run's inputs and the block means (at most ``max_samples`` a segment),
    whatever the recording's length; the figures equal those of the whole
    arrays at once bit for bit on a recording of one run.
    """
    rate_cfg = rate_settings(config, source)
    pipeline = pipeline_settings(config, source)
    model_table = model_settings(config, source, parallel=pipeline.parallel)
    temperature = np.asarray(temperature, dtype=float)
    n = len(temperature)
    duration = n / fs_hz
    if rate_cfg.window_s > duration:
        raise InputError(
            f"{', '.join(record['name'] for record in inputs) or source}: [rate] window_s = {rate_cfg.window_s:g} s "
            f"is longer than the recording ({duration:g} s); the temperature rate needs a window within it"
        )
    ranges = [(0, n)] if bounds is None else [b.indices(n)[:2] for b in bounds]
    for lo, hi in ranges:
        rate_estimator.check_temperature(temperature[lo:hi], minimum=2)
    size = 1 if model_table.max_samples == 0 or n <= model_table.max_samples else -(-n // model_table.max_samples)
    runs = _runs(ranges, np.concatenate([np.arange(lo, hi, size) for lo, hi in ranges]), TRAIN_ROWS)

    def input_runs():
        return _inputs_of(temperature, fs_hz, rate_cfg, runs)

    extremes = [(X.min(axis=0), X.max(axis=0)) for _, X, _ in input_runs()]
    lo, hi = np.min([e[0] for e in extremes], axis=0), np.max([e[1] for e in extremes], axis=0)
    _check_rank(lo, hi, model_table, ", ".join(record["name"] for record in inputs) or source)
    maps = {}
    for segment, y in targets.items():
        spec = model_table.segments[segment]
        if spec.normalise_inputs:
            offset, scale = (hi + lo) / 2, np.where(hi > lo, (hi - lo) / 2, 1.0)
        else:
            offset, scale = np.zeros(2), np.ones(2)
        y = np.asarray(y, dtype=float)
        y_offset = float(np.mean(y))
        y_scale = math.sqrt(sum(float(np.sum((y[run[0] : run[1]] - y_offset) ** 2)) for run in runs) / n) or 1.0
        maps[segment] = (y, offset, scale, y_offset, y_scale)
    means = {segment: ([], []) for segment in targets}
    for rows, X, local_starts in input_runs():
        counts = np.diff(np.append(local_starts, len(X)))
        for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
            means[segment][0].append(np.add.reduceat((X - offset) / scale, local_starts, axis=0) / counts[:, None])
            means[segment][1].append(np.add.reduceat((y[rows] - y_offset) / y_scale, local_starts) / counts)
    learners, not_fitted = {}, {}
    for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
        Xb, yb = np.concatenate(means[segment][0]), np.concatenate(means[segment][1])
        if model_table.temperature_bin_c:
            Xb, yb = even_over_temperature(Xb, yb, Xb[:, 0] * scale[0] + offset[0], model_table.temperature_bin_c)
        learner, not_fitted[segment] = _identifiable(model_table.segments[segment], Xb * scale + offset, model_table.min_unique_variance, seed)
        learners[segment] = (learner.fit(Xb, yb), float(np.min(yb)), float(np.max(yb)))
    squares = dict.fromkeys(targets, 0.0)
    for rows, X, _ in input_runs():
        for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
            error = learners[segment][0].predict((X - offset) / scale) * y_scale + y_offset - y[rows]
            squares[segment] += float(np.sum(error**2))
    fitted = {}
    for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
        learner, low, high = learners[segment]
        fitted[segment] = {
            **extra["segments"][segment],
            "not_fitted": [refusal.to_dict() for refusal in not_fitted[segment]],
            "input_offset": offset.tolist(),
            "input_scale": scale.tolist(),
            "output_offset": y_offset,
            "output_scale": y_scale,
            "output_min": low * y_scale + y_offset,
            "output_max": high * y_scale + y_offset,
            "train_rmse_dps": math.sqrt(squares[segment] / n),
            "learner": learner.to_dict(),
        }
    settings = {**settings, "rate": settings_dict(rate_cfg), "model": model_table.to_dict()}
    header = artefacts.artefact_header(MODEL_SCHEMA, inputs=inputs, settings=settings, seed=seed)
    body = {
        "kind": pipeline.kind,
        "parallel": pipeline.parallel,
        "fs_hz": float(fs_hz),
        "input_columns": list(INPUTS),
        "rate_estimator": rate_estimator.describe(rate_cfg, fs_hz),
        "clip_inputs": model_table.clip_inputs,
        "clip_output": model_table.clip_output,
        "formula": (
            "per segment: y = learner((x - input_offset) / input_scale) * output_scale + output_offset, "
            "x = [temperature, temperature rate] held inside the training ranges when clip_inputs, "
            "y held inside [output_min, output_max] when clip_output; drift_model = sum over segments"
        ),
        "segments": fitted,
        "training": {
            "temperature_c": {"min": float(lo[0]), "max": float(hi[0])},
            "temperature_rate_c_per_s": {"min": float(lo[1]), "max": float(hi[1])},
            "temperature_rate_causal_c_per_s": dict(zip(("min", "max"), _causal_rate_range(temperature, fs_hz, rate_cfg, bounds))),
            "n_samples": n,
            "duration_s": float(n / fs_hz),
            "n_segments": 1 if bounds is None else len(bounds),
        },
    }
    if extra.get("training_classes") is not None:
        body["training"]["classes"] = extra["training_classes"]
    if extra.get("segment_classes") is not None:
        body["training"]["segment_classes"] = extra["segment_classes"]
    return {**header, **body}


def _causal_rate_range(temperature, fs_hz: float, rate_cfg, bounds) -> tuple[float, float]:
    """dT/dt range of the training run by the causal estimator, the one ``compensate --mode causal`` judges a recording's against."""
    rate = segment_inputs(temperature, fs_hz, rate_cfg, bounds, causal=True)[:, 1]
    return float(rate.min()), float(rate.max())


def _identifiable(spec, X: np.ndarray, min_unique: float, seed) -> tuple:
    """An unfitted learner of `spec` with only the terms the training inputs identify, and the terms it leaves out.

    A polynomial drops each power of T and its dT/dt term that the block
    means `X` (physical units: degC, degC/s) cannot tell from the terms
    before it (:func:`gyrocomp.identifiability.polynomial_terms`). A learned
    map of (T, dT/dt) keeps both inputs, but when dT/dt follows T on the
    training runs the refusal is recorded all the same: what it learns of
    dT/dt is then a guess (:mod:`gyrocomp.identifiability`).
    """
    from gyrocomp.identifiability import polynomial_terms

    if spec.learner == "polynomial":
        asked = spec.build(seed)
        degree, rate_term, refused = polynomial_terms(X[:, 0], X[:, 1], asked.degree, asked.rate_term, min_unique)
        return asked.set_params(degree=degree, rate_term=rate_term), refused
    _, _, refused = polynomial_terms(X[:, 0], X[:, 1], 3, True, min_unique)
    refused = [
        dataclasses.replace(r, reason=f"{r.reason} (the {spec.learner} learner keeps its dT/dt input; what it learns of it is not identified)")
        for r in refused
        if r.term == "dT/dt"
    ]
    return spec.build(seed), refused


def _check_rank(lo: np.ndarray, hi: np.ndarray, model_table, name: str) -> None:
    """Refuse inputs that leave the drift model rank-deficient (see :class:`ModelSettings`).

    The temperature-rate span is not checked for a polynomial alone: its
    dT/dt term is judged with its powers of T (:func:`_identifiable`) and
    left out, not refused, on a run that ramps at one rate.
    """
    limits = (("temperature", "degC", model_table.min_temperature_span_c, "min_temperature_span_c"),)
    if any(spec.learner != "polynomial" for spec in model_table.segments.values()):
        limits += (("temperature rate", "degC/s", model_table.min_temperature_rate_span_c_per_s, "min_temperature_rate_span_c_per_s"),)
    for (what, unit, limit, key), low, high in zip(limits, lo, hi):
        if high - low < limit:
            raise InputError(
                f"{name}: the training {what} spans only {high - low:.3g} {unit} ({low:.6g} to {high:.6g}); "
                f"a drift model needs at least {limit:g} ([model] {key}): train on a run that heats and cools"
            )


def _runs(ranges: list, starts: np.ndarray, rows: int) -> list:
    """Runs of whole blocks, about `rows` samples each, within each gap-free range.

    Returns
    -------
    list of (first, stop, range_lo, range_hi, block_starts)
        Samples ``first .. stop - 1`` of the range ``range_lo .. range_hi - 1``,
        and the first samples of the run's blocks counted from `first`
        (`starts`: every block of every range, :func:`_fit`), so a block
        never spans a gap or two runs.
    """
    runs = []
    for lo, hi in ranges:
        first = starts[(starts >= lo) & (starts < hi)]
        step = max(1, rows // (int(first[1] - first[0]) if len(first) > 1 else hi - lo))
        for k in range(0, len(first), step):
            stop = int(first[k + step]) if k + step < len(first) else hi
            runs.append((int(first[k]), stop, lo, hi, first[k : k + step] - first[k]))
    return runs


def _inputs_of(temperature: np.ndarray, fs_hz: float, settings, runs: list) -> Iterator[tuple]:
    """(rows, X, block starts) of each run: X = [T, centred dT/dt] of its samples, the rate of its range's whole series, bit for bit."""
    estimators = {}
    for first, stop, lo, hi, block_starts in runs:
        if (lo, hi) not in estimators:
            estimators = {(lo, hi): rate_estimator.CentredRate(temperature[lo:hi], fs_hz, settings)}
        rate = estimators[(lo, hi)].rows(first - lo, stop - lo)
        yield slice(first, stop), np.column_stack([temperature[first:stop], rate]), block_starts


def _component_names(frame, header: dict) -> list[str]:
    names = header.get("components")
    if not isinstance(names, list) or not names:
        raise InputError("components: header lists no `components`; write it with `gyrocomp decompose`")
    missing = [n for n in names if n not in frame.columns]
    if missing:
        raise InputError(f"components: header names column(s) {', '.join(missing)} that the table lacks")
    return [str(n) for n in names]


def _class_labels(classes: dict, names: list[str]) -> list[str]:
    entries = classes.get("components")
    if not isinstance(entries, list):
        raise InputError("classes: no `components` list")
    by_name = {}
    for entry in entries:
        if not isinstance(entry, dict) or entry.get("class") not in ("noise", "mixed", "drift"):
            raise InputError(f"classes: bad entry {entry!r}; each needs a `name` and a `class` of noise, mixed or drift")
        by_name[str(entry.get("name"))] = entry["class"]
    missing = [n for n in names if n not in by_name]
    extra = [n for n in by_name if n not in names]
    if missing or extra:
        raise InputError(
            f"classes: does not match the components (missing {missing or 'none'}, unknown {extra or 'none'}); "
            "classify the same components.parquet"
        )
    return [by_name[n] for n in names]


def _temperature_of(frame, name: str) -> np.ndarray:
    if "temperature" not in frame.columns:
        raise InputError(f"{name}: no `temperature` column; the drift model needs the temperature")
    return frame["temperature"].to_numpy(dtype=float)


def _fs_of(time_s: np.ndarray) -> float:
    if time_s.size < 2:
        raise InputError("components: fewer than 2 samples")
    return 1.0 / float(np.median(np.diff(time_s)))
