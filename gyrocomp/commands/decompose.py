"""``decompose``: a recording to ``components.parquet`` and its ``components.json`` sidecar."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files", "write", "table"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp decompose`` (defaults: the command's).

    Attributes
    ----------
    method : str or None
        ``lcd``, ``iceemdan``, ``ceemdan`` or ``emd``; ``None`` takes the config's, else ``lcd``.
    ensemble : int or None
        Noise realisations of iceemdan / ceemdan; ``None`` takes the config's.
    seed : int
        Seed of the noise ensemble.
    workers : int
        Processes for the ensemble; the result does not depend on it.
    config : str or None
        Pipeline TOML (path or name in ``configs/``) whose ``[decompose]`` table is read.
    overrides : tuple of str
        ``key=value`` assignments to the ``[decompose]`` table (``--set``).
    columns : gyrocomp.recordings.ColumnSpec
    resample : bool
        Interpolate a jittered time axis instead of refusing it.
    """

    method: Optional[str] = None
    ensemble: Optional[int] = None
    seed: int = 0
    workers: int = 1
    config: Optional[str] = None
    overrides: tuple = ()
    columns: ColumnSpec = ColumnSpec()
    resample: bool = False
    plot: Optional[str | os.PathLike] = None

    def settings(self):
        """The :class:`~gyrocomp.decompose.DecomposeSettings`: the config's table, then ``--set``, then method and ensemble."""
        from gyrocomp import config as cfg
        from gyrocomp.decompose import DecomposeSettings

        table, source = {}, "[decompose]"
        if self.config is not None:
            whole = cfg.check_tables(cfg.load_config(self.config), cfg.PIPELINE_TABLES, self.config)
            table = dict(whole.get("decompose", {}))
            source = f"{self.config} [decompose]"
        table = cfg.apply_overrides({"decompose": table}, [f"decompose.{a}" for a in self.overrides])["decompose"]
        if self.method is not None:
            table["method"] = self.method
        if self.ensemble is not None:
            table["ensemble"] = self.ensemble
        return cfg.bind(DecomposeSettings, table, source)


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return ([out] if str(out) == "-" else [out, Path(out).with_suffix(".json")]) + [options.plot]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options(), *, progress: Callable[[int, int], None] | None = None):
    """Read a recording (``inputs = [recording]``), decompose its one axis and write the artefacts (:func:`write`).

    Returns
    -------
    decomposition : gyrocomp.decompose.Decomposition
    sidecar : dict
        The ``components.json`` object written.
    """
    from gyrocomp import recordings

    (path,) = inputs
    recording = recordings.read_recording(path, options.columns, min_samples=4, resample=options.resample).axis()
    result, sidecar = write(recording, options.settings(), out, seed=options.seed, workers=options.workers, progress=progress)
    if options.plot is not None:
        from gyrocomp import plots

        stack = [(name, values, None) for name, values in zip(result.names, result.components)]
        plots.save(plots.components_figure(recording.time_s, stack), options.plot)
    return result, sidecar


def write(recording, settings, out: str | os.PathLike, *, seed: int = 0, workers: int = 1, progress: Callable[[int, int], None] | None = None):
    """Decompose a recording's rate and write ``components.parquet`` with its ``components.json`` sidecar.

    The sequence ``gyrocomp decompose`` and the parallel pipelines
    (:func:`gyrocomp.commands.run.decompose_and_classify`) share.

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        One axis (:meth:`~gyrocomp.recordings.Recording.axis`).
    settings : gyrocomp.decompose.DecomposeSettings
    out : path-like
        ``components.parquet`` to write: ``time``, ``rate``,
        ``temperature`` (when the recording has it) and one column per
        component, fastest first; header schema ``gyrocomp.components``
        with ``components`` (the names), ``fs_hz``, and ``axis`` and
        ``unit`` (the axis' column name and unit, kept by ``train``). The sidecar
        (schema :data:`~gyrocomp.decompose.SIDECAR_SCHEMA`,
        :func:`~gyrocomp.decompose.component_stats`) goes beside it with
        suffix ``.json``.
    seed, workers, progress
        As :func:`gyrocomp.decompose.decompose` (`progress` is its `callback`).

    Returns
    -------
    decomposition : gyrocomp.decompose.Decomposition
    sidecar : dict
    """
    from gyrocomp import artefacts
    from gyrocomp.decompose import SIDECAR_SCHEMA, component_stats, decompose

    result = decompose(recording.rate_dps, settings, seed=seed, workers=workers, callback=progress)
    frame, header = table(recording, result, settings, seed)
    sidecar = artefacts.artefact_header(SIDECAR_SCHEMA, inputs=header["inputs"], settings=header["settings"], seed=seed)
    sidecar.update(method=settings.method, fs_hz=recording.fs_hz, **component_stats(result, recording.fs_hz))
    artefacts.write_table(out, frame, header)
    artefacts.write_json(Path(out).with_suffix(".json"), sidecar)
    return result, sidecar


def table(recording, result, settings, seed: int):
    """The ``components.parquet`` table of a decomposition and its header (see :func:`write`)."""
    import pandas as pd

    from gyrocomp import artefacts
    from gyrocomp.config import settings_dict

    frame = pd.DataFrame({"time": recording.time_s, "rate": recording.rate_dps})
    if recording.temperature_c is not None:
        frame["temperature"] = recording.temperature_c
    for name, values in zip(result.names, result.components):
        frame[name] = values
    header = artefacts.artefact_header("gyrocomp.components", inputs=[recording.input_record()], settings=settings_dict(settings), seed=seed)
    header.update(components=list(result.names), fs_hz=recording.fs_hz, axis=recording.axes[0].name, unit=recording.axes[0].unit)
    return frame, header
