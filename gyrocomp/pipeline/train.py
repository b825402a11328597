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

from typing import TYPE_CHECKING

import numpy as np

from gyrocomp import recordings
from gyrocomp.config import bind, settings_dict
from gyrocomp.errors import InputError
from gyrocomp.pipeline import rate as rate_estimator
from gyrocomp.pipeline.block_fit import fit_block_means
from gyrocomp.pipeline.signal_path import class_sums, segments
from gyrocomp.pipeline.settings import model_settings, pipeline_settings

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "train_direct",
    "train_parallel",
    "parallel_targets",
    "fit_parallel",
    "train_parallel_on_disk",
    "train_parallel_segments",
]



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
        :func:`gyrocomp.pipeline.model_file.model_file` gathers the axes of a ``model.json``).
    """
    pipeline = pipeline_settings(config, source)
    if pipeline.parallel:
        raise InputError(f"{source}: [pipeline] parallel = true needs components and classes; use train_parallel")
    temperature = _temperature_of(recording.data, recording.name)
    rate = recording.data["rate"].to_numpy(dtype=float)
    settings = {"pipeline": settings_dict(pipeline)}
    return fit_block_means(
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
    decomposed = (components_header.get("settings", {}), components_header.get("seed"))
    return _prepared(parts, names, labels, classes, decomposed, temperature, fs_hz, denoise, config, source)


def _prepared(parts: dict, names, labels, classes: dict, decomposed: tuple, temperature, fs_hz, denoise, config, source) -> dict:
    """:func:`parallel_targets`' result from the class sums `parts` of the components `names` classed `labels`."""
    pipeline = pipeline_settings(config, source)
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
        "decompose": decomposed[0],
        "decompose_seed": decomposed[1],
        "classify": classes.get("settings", {}),
        "denoise": settings_dict(denoise),
    }
    members = {seg: [n for n, label in zip(names, labels) if label == seg] for seg in ("noise", "mixed", "drift")}
    extra = {
        "segments": {seg: {"components": members[seg]} for seg in targets},
        "training_classes": classes.get("components"),
    }
    return {"targets": targets, "temperature": temperature, "fs_hz": fs_hz, "settings": settings, "extra": extra}


def train_parallel_on_disk(recording: recordings.Recording, config: dict, directory, *, source: str = "config", seed: int | None = 0) -> dict:
    """:func:`train_parallel` of a gap-free recording decomposed by LCD a block at a time, its components on disk.

    The signal path is :func:`~gyrocomp.pipeline.signal_path.class_sums_on_disk`
    and the learners read their targets from `directory` a run at a time
    (:func:`~gyrocomp.pipeline.block_fit.fit_block_means`), so memory holds the recording's columns and blocks, not
    its decomposition. The model equals the one of ``decompose``,
    ``classify`` and :func:`train_parallel` on the same recording wherever
    the decomposition does (:mod:`gyrocomp.decompose.lcd_blocks`; tested
    equal, and measured equal on 12 min at 1 kHz: ``docs/performance.md``).

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        One axis in ``rate``, with ``temperature``, without gaps.
    config : dict
        A parallel pipeline config whose ``[decompose] method`` is ``lcd``.
    directory : path-like
        A temporary directory for the components (about 140 bytes a sample).
    source, seed
        As :func:`train_parallel`; `seed` is recorded as the decomposition's.
    """
    from gyrocomp.pipeline.signal_path import class_sums_on_disk

    decompose_cfg, classify_cfg, denoise_cfg = _signal_settings(config, source)
    temperature = _temperature_of(recording.data, recording.name)
    fs_hz = _fs_of(recording.time_s)
    parts, entries = class_sums_on_disk(recording.rate_dps, decompose_cfg, classify_cfg, denoise_cfg, directory)
    classes = {"settings": settings_dict(classify_cfg), "components": entries}
    labels = [entry["class"] for entry in entries]
    prepared = _prepared(
        parts, [e["name"] for e in entries], labels, classes, (settings_dict(decompose_cfg), seed), temperature, fs_hz, denoise_cfg, config, source
    )
    try:
        return fit_parallel(prepared, config, source=source, seed=seed, inputs=[recording.input_record()])
    finally:
        parts["drift"].store.close()


def fit_parallel(prepared: dict, config: dict, *, source: str = "config", seed: int | None = 0, inputs: list[dict] | None = None) -> dict:
    """The second half of :func:`train_parallel`: fit the learners on :func:`parallel_targets`' class sums."""
    return fit_block_means(
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
    itself (:func:`~gyrocomp.pipeline.signal_path.class_sums`: nothing spans a gap, nothing is
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
        A range too short to decompose (named, :func:`~gyrocomp.pipeline.signal_path.class_sums`), or no
        component of any range classed drift.
    """
    pipeline = pipeline_settings(config, source)
    decompose_cfg, classify_cfg, denoise_cfg = _signal_settings(config, source)
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
    return fit_block_means(
        targets, temperature, recording.fs_hz, config, source=source, seed=seed,
        settings=settings, inputs=[recording.input_record()], extra=extra, bounds=bounds,
    )


def _signal_settings(config: dict, source: str) -> tuple:
    """The ``[decompose]``, ``[classify]`` and ``[denoise]`` settings of a parallel pipeline config (else InputError)."""
    from gyrocomp.classify import ClassifySettings
    from gyrocomp.decompose import DecomposeSettings
    from gyrocomp.denoise import DenoiseSettings

    if not pipeline_settings(config, source).parallel:
        raise InputError(f"{source}: [pipeline] parallel = false; train a direct pipeline with train_direct")
    return (
        bind(DecomposeSettings, config.get("decompose"), f"{source} [decompose]"),
        bind(ClassifySettings, config.get("classify"), f"{source} [classify]"),
        bind(DenoiseSettings, config.get("denoise"), f"{source} [denoise]"),
    )


def segment_inputs(temperature, fs_hz: float, settings, bounds=None, *, causal: bool = False) -> np.ndarray:
    """The learners' inputs (:func:`gyrocomp.pipeline.rate.model_inputs`) of each gap-free row range, stacked.

    The temperature rate restarts in each range (its window shrinks to fit
    a short one), so no estimate spans a gap. `bounds` ``None`` is one range.
    """
    temperature = np.asarray(temperature, dtype=float)
    if bounds is None or len(bounds) == 1:
        return rate_estimator.model_inputs(temperature, fs_hz, settings, causal=causal)
    return np.concatenate([rate_estimator.model_inputs(temperature[b], fs_hz, settings, causal=causal) for b in bounds])


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
    """1 / the median interval of the time stamps, as ``np.median(np.diff(time_s))``, without the array of intervals (:func:`gyrocomp.recordings.median_interval`)."""
    if time_s.size < 2:
        raise InputError("components: fewer than 2 samples")
    return 1.0 / recordings.median_interval(time_s)
