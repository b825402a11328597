"""``decompose``: a recording to ``components.parquet`` and its ``components.meta.json`` sidecar."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.artefacts import sidecar_path
from gyrocomp.commands import guarded
from gyrocomp.config import check_seed
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files", "write", "write_axes", "table", "axis_view"]


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

    def __post_init__(self):
        check_seed(self.seed)

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
    return ([out] if str(out) == "-" else [out, sidecar_path(out)]) + [options.plot]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options(), *, progress: Callable[[int, int], None] | None = None):
    """Read a recording (``inputs = [recording]``), decompose every axis and write the artefacts.

    One axis: :func:`write` (columns ``rate`` and the component names).
    Several axes (``--rate-col gx,gy,gz``): :func:`write_axes` (columns
    prefixed by the axis, ``gx_isc1 ... gx_trend``).

    Returns
    -------
    decomposition : gyrocomp.decompose.Decomposition, or dict of str to it (several axes)
    sidecar : dict
        The ``components.meta.json`` object written.
    """
    from gyrocomp import recordings

    (path,) = inputs
    recording = recordings.read_recording(path, options.columns, min_samples=4, resample=options.resample)
    if len(recording.axes) == 1:
        recording = recording.axis()
        result, sidecar = write(recording, options.settings(), out, seed=options.seed, workers=options.workers, progress=progress)
        stack = [(name, values, None) for name, values in zip(result.names, result.components)]
    else:
        result, sidecar = write_axes(recording, options.settings(), out, seed=options.seed, workers=options.workers, progress=progress)
        stack = [(f"{axis}_{name}", values, None) for axis, one in result.items() for name, values in zip(one.names, one.components)]
    if options.plot is not None:
        from gyrocomp import plots

        plots.save(plots.components_figure(recording.time_s, stack), options.plot)
    return result, sidecar


def write(recording, settings, out: str | os.PathLike, *, seed: int = 0, workers: int = 1, progress: Callable[[int, int], None] | None = None):
    """Decompose a recording's rate and write ``components.parquet`` with its ``components.meta.json`` sidecar.

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
    frame, header = _columns(recording, result, settings, seed)
    sidecar = artefacts.artefact_header(SIDECAR_SCHEMA, inputs=header["inputs"], settings=header["settings"], seed=seed)
    sidecar.update(method=settings.method, fs_hz=recording.fs_hz, **component_stats(result, recording.fs_hz))
    artefacts.write_table(out, frame, header)
    artefacts.write_json(artefacts.sidecar_path(out), sidecar)
    return result, sidecar


def table(recording, result, settings, seed: int):
    """The ``components.parquet`` table of a decomposition (a DataFrame) and its header (see :func:`write`)."""
    import pandas as pd

    columns, header = _columns(recording, result, settings, seed)
    return pd.DataFrame(columns, copy=False), header  # the columns are views of the decomposition's rows


def _columns(recording, result, settings, seed: int):
    """The columns of :func:`table` by name, in order, and its header (no pandas: :func:`write` stays light)."""
    from gyrocomp import artefacts
    from gyrocomp.config import settings_dict

    columns = {"time": recording.time_s, "rate": recording.rate_dps}
    if recording.temperature_c is not None:
        columns["temperature"] = recording.temperature_c
    columns.update(zip(result.names, result.components))
    header = artefacts.artefact_header("gyrocomp.components", inputs=[recording.input_record()], settings=settings_dict(settings), seed=seed)
    header.update(components=list(result.names), fs_hz=recording.fs_hz, axis=recording.axes[0].name, unit=recording.axes[0].unit)
    return columns, header


def write_axes(recording, settings, out: str | os.PathLike, *, seed: int = 0, workers: int = 1, progress: Callable[..., None] | None = None):
    """Decompose every axis of a recording and write them into one ``components.parquet`` and its sidecar.

    Each axis is decomposed alone, with the same `seed` (the seed of axis
    ``k`` does not depend on `k` nor on `workers`, which only spreads each
    ensemble), so an axis' components equal those of ``decompose
    --rate-col <axis>`` and of ``train``'s per-axis decomposition
    (:func:`gyrocomp.commands.train.train_axes`).

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        Several axes.
    settings : gyrocomp.decompose.DecomposeSettings
    out : path-like
        ``components.parquet`` to write: ``time``, ``temperature`` (when the
        recording has it), each axis' values under its column name, and each
        component as ``<axis>_<component>`` (``gx_isc1 ... gx_trend``),
        axis after axis, fastest first. Header schema
        ``gyrocomp.components`` with ``components`` (every component
        column), ``fs_hz`` and ``axes``: per axis its ``unit`` and
        ``components`` (its columns). The sidecar lists per axis (``axes``)
        the :func:`~gyrocomp.decompose.component_stats` of its components.
    seed, workers
        As :func:`gyrocomp.decompose.decompose`.
    progress : callable(done, total, description=None), optional
        The axes counted as one whole (:mod:`gyrocomp.progress`), then a
        ``writing`` stage.

    Returns
    -------
    decompositions : dict of str to gyrocomp.decompose.Decomposition
        By axis name, in the recording's order.
    sidecar : dict
    """
    from gyrocomp import artefacts
    from gyrocomp.config import settings_dict
    from gyrocomp.decompose import SIDECAR_SCHEMA, component_stats, decompose

    columns = {"time": recording.time_s}
    if recording.temperature_c is not None:
        columns["temperature"] = recording.temperature_c
    from gyrocomp.progress import part, stage

    results, axes, stats = {}, {}, {}
    n_axes = len(recording.axes)
    for index, axis in enumerate(recording.axes):
        one = recording.axis(axis.name)
        result = decompose(one.rate_dps, settings, seed=seed, workers=workers, callback=part(progress, index, n_axes, f"decompose {axis.name}"))
        names = [f"{axis.name}_{name}" for name in result.names]
        columns[axis.name] = one.rate_dps
        columns.update(zip(names, result.components))
        results[axis.name] = result
        axes[axis.name] = {"unit": axis.unit, "components": names}
        stats[axis.name] = component_stats(result, recording.fs_hz)
        for entry, name in zip(stats[axis.name]["components"], names):
            entry["name"] = name
    header = artefacts.artefact_header("gyrocomp.components", inputs=[recording.input_record()], settings=settings_dict(settings), seed=seed)
    header.update(components=[n for a in axes.values() for n in a["components"]], fs_hz=recording.fs_hz, axes=axes)
    sidecar = artefacts.artefact_header(SIDECAR_SCHEMA, inputs=header["inputs"], settings=header["settings"], seed=seed)
    sidecar.update(method=settings.method, fs_hz=recording.fs_hz, axes=stats)
    stage(progress, n_axes, f"writing {Path(out).name}")
    artefacts.write_table(out, columns, header)
    artefacts.write_json(artefacts.sidecar_path(out), sidecar)
    return results, sidecar


def axis_view(frame, header: dict, axis: str, source: str = "components.parquet"):
    """One axis of a several-axis ``components.parquet`` as a one-axis table and header (as :func:`write` lays it out).

    Columns ``time``, ``rate``, ``temperature`` (when present) and the
    axis' components without their ``<axis>_`` prefix; the header's
    ``components``, ``axis`` and ``unit`` are the axis'. `source` names
    the file in error messages.

    Raises
    ------
    InputError
        The header has no such axis, or a listed column is missing.
    """
    import pandas as pd

    from gyrocomp.errors import InputError

    entry = (header.get("axes") or {}).get(axis)
    if not isinstance(entry, dict) or not isinstance(entry.get("components"), list):
        raise InputError(f"{source}: header has no axis {axis!r} with a `components` list")
    listed = [axis, *entry["components"]]
    missing = [c for c in listed if c not in frame.columns]
    if missing:
        raise InputError(f"{source}: column {missing[0]!r} of axis {axis!r} listed in the header is missing")
    names = [c[len(axis) + 1 :] for c in entry["components"]]
    table = {"time": frame["time"].to_numpy(), "rate": frame[axis].to_numpy()}
    if "temperature" in frame.columns:
        table["temperature"] = frame["temperature"].to_numpy()
    table.update({name: frame[column].to_numpy() for name, column in zip(names, entry["components"])})
    one = {k: v for k, v in header.items() if k != "axes"}
    one.update(components=names, axis=axis, unit=str(entry.get("unit", "deg/s")))
    return pd.DataFrame(table), one
