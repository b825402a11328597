"""Dataclass fields that carry their unit (the settings tables of the simulator and the vocabulary)."""

from __future__ import annotations

import dataclasses

__all__ = ["unit_field"]


def unit_field(default, unit):
    """A dataclass field whose unit :func:`gyrocomp.sim.model.units_of` reports."""
    return dataclasses.field(default=default, metadata={"unit": unit})
