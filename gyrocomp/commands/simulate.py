"""``simulate``: a simulator config (and a profile) to a recording."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Optional, Sequence

from gyrocomp.commands import guarded
from gyrocomp.config import check_seed
from gyrocomp.recordings import ColumnSpec

__all__ = ["Options", "to_files"]

_RECORDING_SUFFIXES = (".csv", ".parquet", ".pq")
"""A ``profile`` with one of these suffixes is a recording whose measured temperature drives the run."""


@dataclasses.dataclass(frozen=True)
class Options:
    """Settings of ``gyrocomp simulate`` (defaults: the command's; ``None`` keeps the config's).

    Attributes
    ----------
    profile : str or None
        Profile TOML (path or name in ``configs/profiles/``), or a recording
        whose measured temperature drives the run.
    seed : int or None
        Seed of every random draw (beats ``run.seed``).
    fs : float or None
        Sample rate [Hz] (beats ``run.fs_hz``).
    overrides : tuple of str
        ``table.key=value`` assignments (``--set``).
    truth_columns : bool or None
        Add a ``truth_*`` column per contribution.
    columns : gyrocomp.recordings.ColumnSpec
        Columns of a `profile` recording (its temperature column is the one used).
    """

    profile: Optional[str] = None
    seed: Optional[int] = None
    fs: Optional[float] = None
    overrides: tuple = ()
    truth_columns: Optional[bool] = None
    columns: ColumnSpec = ColumnSpec()

    def __post_init__(self):
        check_seed(self.seed)


def written(out, options) -> list:
    """The paths :func:`to_files` writes (checked against its inputs by :func:`~gyrocomp.commands.guarded`)."""
    return [out]


@guarded(written)
def to_files(
    inputs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: Options = Options(),
    *,
    progress: Callable[[int, int], None] | None = None,
):
    """Simulate a recording and write it (``.parquet`` with the truth in its metadata, ``.csv``, ``-`` for stdout).

    Parameters
    ----------
    inputs : sequence of path-like
        ``[config]`` (a simulation TOML or a name in ``configs/sample/``),
        or ``[]`` for the papers' oven test on ``configs/gyro/default.toml``.

    Returns
    -------
    frame : pandas.DataFrame
    header : dict
        With ``truth`` (what was simulated).
    config : gyrocomp.sim.SimConfig
        The resolved config.
    """
    from gyrocomp import artefacts, recordings, sim

    (config,) = inputs or (None,)
    recording, profile = None, options.profile
    if profile is not None and Path(profile).suffix.lower() in _RECORDING_SUFFIXES:
        spec = dataclasses.replace(ColumnSpec(), temperature=options.columns.temperature)
        recording = recordings.read_recording(profile, spec, require_temperature=True, resample=True).axis()
        profile = None
    cfg = sim.load_sim_config(
        config,
        profile=profile,
        overrides=options.overrides,
        seed=options.seed,
        fs_hz=options.fs,
        truth_columns=options.truth_columns,
    )
    frame, header = sim.run(cfg, temperature_from=recording, progress=progress)
    artefacts.write_table(out, frame, header)
    return frame, header, cfg
