"""Dataclass fields that carry their unit (the settings tables of the simulator and the vocabulary)."""

from __future__ import annotations

import dataclasses
import math

from gyrocomp.errors import InputError

__all__ = ["unit_field", "check_numbers"]


def unit_field(default, unit):
    """A dataclass field whose unit :func:`gyrocomp.sim.model.units_of` reports."""
    return dataclasses.field(default=default, metadata={"unit": unit})


def check_numbers(settings, where: str) -> None:
    """Refuse a non-finite number in a table of settings, and a time constant or period that is not > 0.

    Every numeric field of the simulator carries its unit
    (:func:`unit_field`); a NaN or infinite one, or a ``tau_s`` /
    ``period_s`` of 0 or less, would make every simulated sample NaN.

    Raises
    ------
    InputError
        Naming ``table.key`` and the value (exit 2).
    """
    for f in dataclasses.fields(settings):
        if "unit" not in f.metadata:
            continue
        value = getattr(settings, f.name)
        values = value if isinstance(value, tuple) else (value,)
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values):
            raise InputError(f"{where}.{f.name} = {value!r}: must be a finite number [{f.metadata['unit']}]")
        if (f.name.endswith("tau_s") or f.name.endswith("period_s")) and not all(v > 0 for v in values):
            raise InputError(f"{where}.{f.name} = {value!r}: a time constant or period must be > 0 s")
