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

Outputs never overwrite inputs
------------------------------
Each stage's ``to_files`` is wrapped by :func:`guarded` with a function
that lists the paths it writes (the artefact, its sidecar, the plot) and
the folders it fills. Before anything is read or written,
:func:`check_paths` compares them, resolved and following links (hard
links too), with every file the stage reads: its positional inputs and
every option naming an existing file (a holdout, a model, a config). A
clash exits 2 naming both paths; an output named twice does too.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import importlib
import inspect
import os
from pathlib import PurePath
from types import ModuleType
from typing import Any, Callable, Iterator, Mapping, Sequence

__all__ = [
    "STAGES",
    "stage",
    "from_params",
    "param_names",
    "column_spec",
    "to_settings",
    "from_settings",
    "Folder",
    "guarded",
    "check_paths",
]

STAGES = ("decompose", "classify", "train", "compensate", "allan", "simulate", "diagnose", "run")
"""The stage modules of this package, in pipeline order."""

COLUMN_PARAMS = {"time_col": "time", "rate_col": "rate", "temp_col": "temperature", "temp_unit": "temperature_unit"}
"""Command-line parameter names of the :class:`~gyrocomp.recordings.ColumnSpec` fields whose names differ.

Every other field of the column spec is read from the parameter of its own name."""

def stage(name: str) -> ModuleType:
    """The module of a stage (``Options`` and ``to_files``); :class:`~gyrocomp.errors.InputError` names the choices."""
    from gyrocomp.errors import InputError

    if name not in STAGES:
        raise InputError(f"unknown stage {name!r}; choose one of {', '.join(STAGES)}")
    return importlib.import_module(f"{__name__}.{name}")


class Folder(str):
    """A folder a stage fills (``run --out DIR``): no input may lie inside it."""


def guarded(written: Callable[[Any, Any], Sequence[Any]]):
    """Wrap a stage's ``to_files`` so that :func:`check_paths` runs first and every error names a file.

    A library error about a file's content that names no file (``savgol:
    20 samples ...``, ``classes: ...``) is prefixed with the inputs
    (:func:`name_inputs`).

    Parameters
    ----------
    written : callable(out, options) -> sequence of path-like, Folder or None
        Every path the stage writes for these arguments (``None`` and ``-``
        are skipped), and every :class:`Folder` it fills.
    """

    def decorate(to_files):
        default = inspect.signature(to_files).parameters["options"].default

        @functools.wraps(to_files)
        def run(inputs, out, options=default, **kwargs):
            check_paths(inputs, options, written(out, options))
            with name_inputs(inputs, options):
                return to_files(inputs, out, options, **kwargs)

        run.written = written
        return run

    return decorate


@contextlib.contextmanager
def name_inputs(inputs: Sequence[Any], options: Any) -> Iterator[None]:
    """Prefix an :class:`~gyrocomp.errors.InputError` that names none of the files with the inputs' names.

    A message already naming an input or a file-valued option (the config,
    the holdout, the model) is left as it is.
    """
    from gyrocomp.errors import InputError

    names = [os.fspath(p) for p in inputs if str(p) not in ("", "-")]
    try:
        yield
    except InputError as err:
        message = str(err)
        files = [v for f in dataclasses.fields(options) for v in _paths_in(getattr(options, f.name)) if f.name == "config" or os.path.exists(v)]
        known = names + files
        if not names or any(k in message for k in known):
            raise
        raise type(err)(f"{', '.join(names)}: {message}") from err


def check_paths(inputs: Sequence[Any], options: Any, outputs: Sequence[Any]) -> None:
    """Refuse outputs that are inputs, or that are named twice, before anything is written.

    Raises
    ------
    InputError
        Naming the output and the input it would overwrite (exit 2).
    """
    from gyrocomp.errors import InputError

    written = [p for p in outputs if p is not None and str(p) != "-"]
    reads = [p for p in inputs if str(p) != "-"]
    for field in dataclasses.fields(options):
        option = getattr(options, field.name)
        if any(option is p for p in outputs):  # an output option (a --plot there already) is no input
            continue
        for value in _paths_in(option):
            if os.path.isfile(value):
                reads.append(value)
    seen: dict = {}
    for path in written:
        key = _identity(path)
        if key in seen:
            raise InputError(f"{path}: named as two outputs ({seen[key]} too); choose another path for one of them")
        seen[key] = path
    folders = [os.path.realpath(p) for p in written if isinstance(p, Folder)]
    for path in reads:
        clash = seen.get(_identity(path))
        if clash is None:
            real = os.path.realpath(path)
            clash = next((f for f in folders if os.path.commonpath([f, real]) == f), None)
        if clash is not None:
            raise InputError(f"{clash}: the output would overwrite the input {path}; choose another output path")


def _paths_in(value) -> list:
    """The path-like strings in an option value (a path, or a tuple of them)."""
    values = value if isinstance(value, (tuple, list)) else (value,)
    return [os.fspath(v) for v in values if isinstance(v, (str, os.PathLike)) and str(v) not in ("", "-")]


def _identity(path) -> tuple:
    """What makes two paths one file: device and inode when it exists (links followed), else the resolved path."""
    try:
        stat = os.stat(path)
    except OSError:
        return ("path", os.path.realpath(path))
    return ("inode", stat.st_dev, stat.st_ino)


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
