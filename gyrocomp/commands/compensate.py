"""``compensate``: a recording and a ``model.json`` to ``compensated.parquet`` and its ``compensated.json`` sidecar."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files", "write"]


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
    seed: Optional[int] = None
    workers: int = 1
    columns: ColumnSpec = ColumnSpec()
    resample: bool = False


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out] if str(out) == "-" else [out, Path(out).with_suffix(".json")]


@guarded(written)
def to_files(
    inputs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: Options = Options(),
    *,
    progress: Callable[[int, int], None] | None = None,
) -> tuple:
    """Read a recording and a model (``inputs = [recording, model.json]``), compensate, write the artefacts.

    `out` ``-`` writes the table as CSV to stdout, without sidecar.

    Returns
    -------
    frame : pandas.DataFrame
        ``time``, ``rate``, ``temperature``, ``drift_model``, ``compensated``.
    summary : dict
        From :func:`~gyrocomp.pipeline.compensate.compensate`.
    recording : gyrocomp.recordings.Recording
    caught : list of warnings.WarningMessage
        The warnings compensating raised (e.g. leaving the training temperature range).
    """
    import warnings

    from gyrocomp import artefacts, recordings
    from gyrocomp.pipeline.compensate import compensate, load_model

    recording_path, model_path = inputs
    drift = load_model(artefacts.read_json(model_path, "gyrocomp.model"), str(model_path))
    recording = recordings.read_recording(recording_path, options.columns, require_temperature=True, min_samples=2, resample=options.resample).axis()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        frame, summary = compensate(recording, drift, options.mode, clamp=options.clamp, seed=options.seed, workers=options.workers, callback=progress)
    if str(out) == "-":
        artefacts.write_table(out, frame, {})
    else:
        write(Path(out), frame, summary, recording, Path(model_path), options.mode, options.seed)
    return frame, summary, recording, list(caught)


def write(path: Path, frame, summary: dict, recording, model_path: Path, mode: str, seed) -> dict:
    """Write ``compensated.parquet`` and its ``compensated.json`` sidecar (same stem).

    The sidecar holds the header (inputs: the recording and the model file),
    the summary of :func:`~gyrocomp.pipeline.compensate.compensate`, and the
    RMS of the drift model and of the compensated rate.
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
    figures = {
        "n_samples": int(len(frame)),
        "fs_hz": float(recording.fs_hz),
        "drift_model_rms_dps": float(np.sqrt(np.mean(frame["drift_model"].to_numpy() ** 2))),
        "rate_std_dps": float(np.std(frame["rate"].to_numpy())),
        "compensated_std_dps": float(np.std(frame["compensated"].to_numpy())),
    }
    sidecar = {**header, **summary, "figures": figures}
    artefacts.write_json(path.with_suffix(".json"), sidecar)
    return sidecar
