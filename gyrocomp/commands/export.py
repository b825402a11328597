"""``export``: a ``model.json`` to PX4 / ArduPilot parameters, a C99 header or plain JSON."""

from __future__ import annotations

import dataclasses
import os
import sys
from pathlib import Path
from typing import Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp export`` (see :class:`gyrocomp.export.ExportOptions`).

    Attributes
    ----------
    fmt : {"px4", "ardupilot", "c", "json-plain"}
    fit_polynomial, axis, instance, device_id, n_vectors, prefix, static_part
        As :class:`gyrocomp.export.ExportOptions`.
    vectors : path or None
        c: recording whose first `n_vectors` samples become the test vectors.
    columns : gyrocomp.recordings.ColumnSpec
        Columns of `vectors`.
    """

    fmt: str = "c"
    fit_polynomial: bool = False
    axis: str = "x"
    instance: Optional[int] = None
    device_id: int = 0
    vectors: Optional[str] = None
    n_vectors: int = 2048
    prefix: str = "gyrocomp"
    columns: ColumnSpec = ColumnSpec()
    static_part: bool = False


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options()) -> tuple:
    """Read a model (``inputs = [model.json]``), write it in ``options.fmt`` atomically (``-``: stdout).

    Returns
    -------
    models : dict of str to gyrocomp.pipeline.compensate.DriftModel
        By axis (``None`` for a version-1 model).
    summary : dict
        From :func:`gyrocomp.export.export_model`.
    """
    from gyrocomp import artefacts, recordings
    from gyrocomp.export import ExportOptions, export_model
    from gyrocomp.pipeline.compensate import load_models

    (model_path,) = inputs
    drift = load_models(artefacts.read_json(model_path), str(model_path))  # checks the header (model.json 1.x and 2.x)
    recording = None
    if options.vectors is not None:
        columns = options.columns
        if columns.rate == "rate" and None not in drift:  # the model's own axis names, unless told otherwise
            columns = dataclasses.replace(columns, rate=",".join(drift))
        recording = recordings.read_recording(options.vectors, columns, require_temperature=True, min_samples=2)
    export_options = ExportOptions(
        options.fit_polynomial, options.axis.lower(), options.instance, options.device_id, recording, options.n_vectors, options.prefix,
        static_part=options.static_part,
    )
    text, summary = export_model(drift, options.fmt, export_options)
    if str(out) == "-":
        sys.stdout.write(text)
    else:
        with artefacts.atomic_path(out) as tmp:
            Path(tmp).write_text(text, encoding="utf-8")
    return drift, summary
