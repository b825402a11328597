"""Settings from TOML: load, override, and bind to frozen dataclasses.

Every number of a paper lives in ``configs/*.toml`` with its source beside
it. A stage keeps its settings in a frozen dataclass whose defaults equal
the shipped TOML (a test checks it); :func:`bind` builds that dataclass from
a table and refuses unknown keys, naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import numbers
import os
import tomllib
from pathlib import Path
from typing import Any, Iterable, TypeVar

from gyrocomp.errors import InputError

__all__ = ["CONFIG_DIR", "PIPELINE_TABLES", "SEED_MAX", "load_config", "apply_overrides", "check_tables", "bind", "settings_dict", "check_seed"]

def _config_dir() -> Path:
    """``configs/`` of the source checkout this package runs from, else the installed package data."""
    root = Path(__file__).resolve().parent.parent
    if (root / "pyproject.toml").is_file() and (root / "configs").is_dir():
        return root / "configs"
    return Path(str(importlib.resources.files("gyrocomp") / "configs"))


CONFIG_DIR = _config_dir()
"""The shipped configs; a bare name such as ``pe-lcd-anfis`` is looked up here.

In a checkout, the top-level ``configs/``; in an installed wheel, the same
files as package data (``gyrocomp/configs/``, see ``setup.py``)."""

PIPELINE_TABLES = ("pipeline", "rate", "model", "decompose", "classify", "denoise", "greybox")
"""Top-level tables of a pipeline config (``configs/pe-lcd-anfis.toml`` and its kin)."""

T = TypeVar("T")


SEED_MAX = 2**32 - 1
"""Largest seed: scikit-learn's ``random_state`` (the BP learner's) and NumPy's legacy ``RandomState`` take 0..2**32-1."""


def check_seed(seed: Any, where: str = "--seed") -> int | None:
    """`seed` as an int in 0..:data:`SEED_MAX` (``None``, no seed given, passes).

    Every command that takes a seed checks it here, when its options are
    built, before anything is read or written; so do a simulator config's
    ``run.seed``, a model's stored seed and a learner's ``seed``.

    Raises
    ------
    InputError
        Naming `where` (the option or setting): not an integer (a bool, a
        float, text), negative, or above :data:`SEED_MAX`.
    """
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or not 0 <= seed <= SEED_MAX:
        raise InputError(f"{where} = {seed!r}: a seed must be an integer in 0..{SEED_MAX}")
    return int(seed)


def load_config(path: str | os.PathLike) -> dict:
    """Read a TOML config by path, or by bare name from :data:`CONFIG_DIR`.

    Raises
    ------
    InputError
        No such file, or invalid TOML (with the line the parser names).
    """
    from gyrocomp.artefacts import open_input

    candidate = Path(path)
    if not candidate.is_file() and candidate.suffix == "" and not candidate.parent.name:
        candidate = CONFIG_DIR / f"{candidate.name}.toml"  # a bare name is a shipped config, whatever folder ./<name> may be
    try:
        with open_input(os.fspath(candidate)) as fh:
            return tomllib.load(fh)
    except InputError as err:
        if "no such file" in str(err):
            raise InputError(f"{path}: no such config file") from None
        raise
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: invalid TOML ({err})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file (TOML is UTF-8)") from None


def apply_overrides(config: dict, assignments: Iterable[str]) -> dict:
    """Return a copy of `config` with ``dotted.key=value`` assignments applied.

    The value is parsed as a TOML value (``1``, ``2.5``, ``true``,
    ``"text"``, ``[1, 2]``); anything else is taken as a bare string.
    """
    result = _deepcopy(config)
    for assignment in assignments:
        key, sep, raw = assignment.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--set {assignment!r}: expected key=value")
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw
        node = result
        parts = key.strip().split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise InputError(f"--set {assignment!r}: {part!r} is not a table")
        if not isinstance(value, dict) and isinstance(node.get(parts[-1]), dict):
            # a table replaced by a number (`model=5`) would reach the stage as one
            raise InputError(f"--set {assignment!r}: {key.strip()} is a table; set one of its keys ({key.strip()}.<key>=value)")
        node[parts[-1]] = value
    return result


def check_tables(config: dict, known: Iterable[str], source: str) -> dict:
    """Refuse a top-level table (or ``--set`` prefix) that no stage reads: a typo would be ignored.

    Returns `config` unchanged.

    Raises
    ------
    InputError
        Naming the file (or ``--set``), the unknown tables and the known ones.
    """
    known = tuple(known)
    unknown = sorted(set(config) - set(known))
    if unknown:
        raise InputError(
            f"{source}: unknown table {', '.join(unknown)}; this config has [{'], ['.join(known)}]"
        )
    return config


def bind(cls: type[T], table: dict | None, source: str) -> T:
    """Build the frozen dataclass `cls` from a config table.

    Missing keys take the dataclass defaults; nested dataclass fields bind
    recursively; lists become tuples where the field's default is a tuple.

    Raises
    ------
    InputError
        An unknown key (the message lists the known ones) or a value of the
        wrong type.
    """
    table = dict(table or {})
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(table) - set(fields))
    if unknown:
        raise InputError(
            f"{source}: unknown setting {', '.join(unknown)}; known: {', '.join(fields)}"
        )
    kwargs: dict[str, Any] = {}
    for name, value in table.items():
        f = fields[name]
        default = _default_of(f)
        if dataclasses.is_dataclass(default) and isinstance(value, dict):
            value = bind(type(default), value, f"{source} [{name}]")
        elif isinstance(default, tuple) and isinstance(value, list):
            value = tuple(value)
        elif isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if default is not None and not dataclasses.is_dataclass(default):
            if isinstance(default, bool) != isinstance(value, bool) or (
                isinstance(default, (int, float, str, tuple)) and not isinstance(value, type(default))
            ):
                raise InputError(
                    f"{source}: `{name}` = {value!r} should be of type {type(default).__name__}"
                )
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as err:
        raise InputError(f"{source}: {err}") from None


def settings_dict(settings: Any) -> dict:
    """A dataclass of settings as a plain dict (tuples become lists)."""
    return dataclasses.asdict(settings)


def _default_of(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return None


def _deepcopy(config: dict) -> dict:
    return {k: _deepcopy(v) if isinstance(v, dict) else v for k, v in config.items()}
