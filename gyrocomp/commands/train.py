"""``train``: components and classes (parallel pipelines) or a recording (direct pipelines) to ``model.json``."""

from __future__ import annotations

import dataclasses
import os
from typing import Sequence

from gyrocomp.commands import guarded
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
    columns : gyrocomp.recordings.ColumnSpec
        Column names and units of a direct pipeline's recording.
    """

    config: str = "pe-lcd-anfis"
    seed: int = 0
    overrides: tuple = ()
    columns: ColumnSpec = ColumnSpec()


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options()) -> dict:
    """Fit the drift models of a pipeline and write ``model.json``.

    Parameters
    ----------
    inputs : sequence of path-like
        ``[components.parquet, classes.json]`` for a parallel pipeline,
        ``[recording]`` (with temperature) for a direct one.
    out : path-like
        ``model.json`` to write.
    options : Options

    Returns
    -------
    dict
        The model as written.
    """
    from gyrocomp import artefacts, recordings
    from gyrocomp.config import PIPELINE_TABLES, apply_overrides, check_tables, load_config
    from gyrocomp.errors import InputError
    from gyrocomp.pipeline.settings import pipeline_settings
    from gyrocomp.artefacts import file_record
    from gyrocomp.pipeline.train import train_direct, train_parallel

    cfg = check_tables(apply_overrides(load_config(options.config), options.overrides), PIPELINE_TABLES, options.config)
    pipeline = pipeline_settings(cfg, options.config)
    source, *rest = inputs
    if pipeline.parallel:
        if not rest:
            raise InputError(f"{options.config}: a parallel pipeline needs CLASSES (classes.json from `gyrocomp classify`)")
        (classes,) = rest
        frame, header = artefacts.read_table(source, "gyrocomp.components")
        labels = artefacts.read_json(classes, "gyrocomp.classes")
        records = [file_record(source), file_record(classes)]
        model = train_parallel(frame, header, labels, cfg, source=options.config, seed=options.seed, inputs=records)
    else:
        if rest:
            raise InputError(f"{options.config}: a direct pipeline ({pipeline.kind}) trains on the recording alone; drop {rest[0]}")
        recording = recordings.read_recording(source, options.columns, require_temperature=True, min_samples=16).axis()
        model = train_direct(recording, cfg, source=options.config, seed=options.seed)
    artefacts.write_json(out, model)
    return model
