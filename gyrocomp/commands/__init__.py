"""The stages as file-to-file functions: what ``gyrocomp <stage>`` and ``gyrocomp batch <stage>`` both run.

Each stage module holds an ``Options`` dataclass (every setting of the
stage, with the command line's defaults; the column spec of the recordings
among them) and ``to_files(inputs, out, options)``: read the input files
(the command's positional arguments, in order), run the library, write the
artefacts atomically and return what was computed. The command line builds
the options from its parameters (:func:`from_params`); a batch does the
same from the options it was given and stores them in every manifest
(:func:`to_settings`, :func:`from_settings`), so neither restates a stage's
options or defaults.

Stages
------
``decompose``, ``classify``, ``train``, ``compensate``, ``allan``,
``simulate``, ``diagnose``, ``run`` (:data:`STAGES`).
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import threading
from pathlib import PurePath
from types import ModuleType
from typing import Any, Mapping

__all__ = ["STAGES", "stage", "from_params", "param_names", "column_spec", "to_settings", "from_settings", "PLOT_LOCK"]

STAGES = ("decompose", "classify", "train", "compensate", "allan", "simulate", "diagnose", "run")
"""The stage modules of this package, in pipeline order."""

COLUMN_PARAMS = {"time_col": "time", "rate_col": "rate", "temp_col": "temperature", "temp_unit": "temperature_unit"}
"""Command-line parameter names of the :class:`~gyrocomp.recordings.ColumnSpec` fields whose names differ.

Every other field of the column spec is read from the parameter of its own name."""

PLOT_LOCK = threading.RLock()
"""Matplotlib is not thread-safe (its mathtext parser is shared): a Dask worker
runs several inputs as threads of one process, so figures are drawn one at a time."""


def stage(name: str) -> ModuleType:
    """The module of a stage (``Options`` and ``to_files``); :class:`~gyrocomp.errors.InputError` names the choices."""
    from gyrocomp.errors import InputError

    if name not in STAGES:
        raise InputError(f"unknown stage {name!r}; choose one of {', '.join(STAGES)}")
    return importlib.import_module(f"{__name__}.{name}")


def column_spec(params: Mapping[str, Any]):
    """The :class:`~gyrocomp.recordings.ColumnSpec` of command-line parameters (``time_col``, ``rate_col``, ...).

    A parameter that is absent keeps the column spec's default.
    """
    from gyrocomp.recordings import ColumnSpec

    given = {}
    for field in dataclasses.fields(ColumnSpec):
        name = _column_param(field.name)
        if name in params:
            value = params[name]
            given[field.name] = tuple(value) if isinstance(value, list) else value
    return ColumnSpec(**given)


def param_names(cls) -> tuple[str, ...]:
    """Command-line parameter names that :func:`from_params` reads for an ``Options`` class."""
    from gyrocomp.recordings import ColumnSpec

    names = []
    for field in dataclasses.fields(cls):
        if field.name == "columns":
            names += [_column_param(f.name) for f in dataclasses.fields(ColumnSpec)]
        else:
            names.append(field.name)
    return tuple(names)


def from_params(cls, params: Mapping[str, Any]):
    """Build a stage's options from command-line parameters (Python names); absent ones keep their defaults.

    Parameters named as a field of `cls` set it (a list becomes a tuple,
    ``None`` for a repeatable option keeps ``()``); the column parameters
    make its ``columns`` (:func:`column_spec`).
    Other parameters (``out``, the inputs) are ignored.
    """
    given = {}
    for field in dataclasses.fields(cls):
        if field.name == "columns":
            given["columns"] = column_spec(params)
        elif field.name in params:
            value = params[field.name]
            if value is None and isinstance(field.default, tuple):
                continue  # a repeatable option given no times
            given[field.name] = tuple(value) if isinstance(value, list) else value
    return cls(**given)


def to_settings(options) -> dict:
    """The options as a JSON-able dict (paths as strings, tuples as lists); :func:`from_settings` inverts it."""
    return _jsonable(dataclasses.asdict(options))


def from_settings(cls, settings: Mapping[str, Any]):
    """The options of :func:`to_settings`."""
    from gyrocomp.recordings import ColumnSpec

    given = {}
    for field in dataclasses.fields(cls):
        if field.name not in settings:
            continue
        value = settings[field.name]
        if field.name == "columns":
            value = ColumnSpec(**{k: tuple(v) if isinstance(v, list) else v for k, v in value.items()})
        elif isinstance(value, list):
            value = tuple(value)
        given[field.name] = value
    return cls(**given)


def _column_param(field: str) -> str:
    for param, name in COLUMN_PARAMS.items():
        if name == field:
            return param
    return field


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (PurePath, os.PathLike)):
        return os.fspath(value)
    return value
