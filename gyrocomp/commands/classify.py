"""``classify``: ``components.parquet`` to ``classes.json`` (and the entropy bar chart)."""

from __future__ import annotations

import dataclasses
import os
from typing import Optional, Sequence

from gyrocomp.commands import guarded

__all__ = ["Options", "to_files"]


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp classify`` (defaults: the command's).

    Attributes
    ----------
    entropy : str or None
        ``permutation`` (Cao et al. 2021) or ``sample`` (Zhang et al. 2024); ``None`` takes the config's.
    config : str or None
        Pipeline TOML (path or name in ``configs/``) whose ``[classify]`` table is read;
        ``None``: the PE-LCD-ANFIS defaults.
    overrides : tuple of str
        ``table.key=value`` assignments to the config (``--set``).
    plot : path-like or None
        PNG bar chart of the entropy per component (the papers' Fig. 10).
    """

    entropy: Optional[str] = None
    config: Optional[str] = None
    overrides: tuple = ()
    plot: Optional[str | os.PathLike] = None

    def settings(self):
        """The :class:`~gyrocomp.classify.ClassifySettings`: defaults, the config's table, ``--set``, then ``--entropy``."""
        from gyrocomp import config as cfg
        from gyrocomp.classify import ClassifySettings

        table, source = {}, "defaults [classify]"
        if self.config is not None or self.overrides:
            whole = cfg.load_config(self.config) if self.config is not None else {}
            whole = cfg.check_tables(cfg.apply_overrides(whole, self.overrides), cfg.PIPELINE_TABLES, self.config or "--set")
            table, source = dict(whole.get("classify", {})), f"{self.config or '--set'} [classify]"
        if self.entropy is not None:
            table, source = {**table, "entropy": self.entropy}, f"--entropy {self.entropy}"
        return cfg.bind(ClassifySettings, table, source)


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out, options.plot]


@guarded(written)
def to_files(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, options: Options = Options()) -> list[dict]:
    """Classify the components of ``inputs = [components.parquet]`` and write ``classes.json`` (:func:`write`)."""
    (components,) = inputs
    return write(components, options.settings(), out, plot=options.plot)


def write(components: str | os.PathLike, settings, out: str | os.PathLike, *, plot: str | os.PathLike | None = None) -> list[dict]:
    """Read ``components.parquet``, classify its components and write ``classes.json``.

    The sequence ``gyrocomp classify`` and the parallel pipelines
    (:func:`gyrocomp.commands.run.decompose_and_classify`) share.

    Parameters
    ----------
    components : path-like
        ``components.parquet`` (schema ``gyrocomp.components``) whose header
        lists the component columns.
    settings : gyrocomp.classify.ClassifySettings
    out : path-like
        ``classes.json`` to write (``-``: stdout): the header (input: the
        components file's name and SHA-256), ``entropy`` (kind and its
        settings), ``thresholds`` and ``components``
        (:func:`gyrocomp.classify.classify`); a several-axis components file
        (header ``axes``, :func:`gyrocomp.commands.decompose.write_axes`)
        gives ``axes`` in place of ``components``: per axis its
        ``components``, named by their columns (``gx_isc1``), each axis
        classified alone as its one-axis file would be.
    plot : path-like or None
        PNG of :func:`gyrocomp.plots.classes_figure` (entropies and the components labelled by class) to write as well.

    Returns
    -------
    list of dict
        The entries of :func:`gyrocomp.classify.classify`, axis after axis.

    Raises
    ------
    InputError
        The header lists no components, or a listed column is missing.
    """
    from gyrocomp import artefacts
    from gyrocomp import plots
    from gyrocomp.classify import CLASSES_SCHEMA, classify
    from gyrocomp.config import settings_dict
    from gyrocomp.errors import InputError

    frame, header = artefacts.read_table(components, "gyrocomp.components")
    names = header.get("components")
    if not isinstance(names, list) or not names:
        raise InputError(f"{components}: header lists no `components`")
    missing = [n for n in names if n not in frame.columns]
    if missing:
        raise InputError(f"{components}: component column {missing[0]!r} listed in the header is missing")
    result = artefacts.artefact_header(CLASSES_SCHEMA, inputs=[artefacts.file_record(components)], settings=settings_dict(settings))
    result["entropy"] = {"kind": settings.entropy, **dataclasses.asdict(settings.active)}
    result["thresholds"] = {"noise_above": settings.noise_above, "drift_below": settings.drift_below}
    if "axes" in header:
        from gyrocomp.commands.decompose import axis_view

        result["axes"] = {}
        for axis in header["axes"]:
            one, one_header = axis_view(frame, header, axis, str(components))
            entries = classify(one[one_header["components"]].to_numpy(dtype=float).T, one_header["components"], settings)
            result["axes"][axis] = {"components": [{**e, "name": f"{axis}_{e['name']}"} for e in entries]}
        entries = [e for axis in result["axes"].values() for e in axis["components"]]
    else:
        entries = classify(frame[names].to_numpy(dtype=float).T, names, settings)
        result["components"] = entries
    artefacts.write_json(out, result)
    if plot is not None:
        stack = [(e["name"], frame[e["name"]].to_numpy(dtype=float), e["class"]) for e in entries]
        plots.save(plots.classes_figure(frame["time"].to_numpy(dtype=float), stack, entries, settings), plot, dpi=110)
    return entries
