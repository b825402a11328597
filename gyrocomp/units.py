"""Units of sensor axes and of the models that compensate them: the one place they are compared.

A recording's axes are read into one of two units (:mod:`gyrocomp.recordings`
converts deg/h and rad/s to deg/s, g to m/s^2); a model is trained on one
axis and keeps that axis' unit (``unit`` of each axis in ``model.json``;
a version-1 file, which has none, is a gyro model in deg/s). A model only
compensates an axis in its own unit, and an export format only takes the
units it has parameters for (:attr:`gyrocomp.export.Format.units`: PX4's
``TC_G*`` and ArduPilot's ``INS_TCAL*_GYR*`` hold deg/s; the
accelerometer's ``TC_A*`` and ``INS_TCAL*_ACC*`` are a format's to add,
with ``m/s^2`` in its units).
"""

from __future__ import annotations

from typing import Sequence

from gyrocomp.errors import InputError

__all__ = ["SENSOR_UNITS", "model_unit", "check_compensates", "check_exportable"]

SENSOR_UNITS = {"deg/s": "angular rate (gyro)", "m/s^2": "acceleration (accelerometer)"}
"""The units of a recording's axes after reading, and so of a model: unit to quantity."""


def model_unit(model) -> str:
    """The unit of a loaded model's axis (:class:`gyrocomp.pipeline.compensate.DriftModel`).

    Raises
    ------
    InputError
        A unit that is not one of :data:`SENSOR_UNITS` (``"furlong/fortnight"``), naming the model.
    """
    unit = model.obj.get("unit", "deg/s")
    if unit not in SENSOR_UNITS:
        raise InputError(f"{model.name}: unit {unit!r} is not a sensor unit; a model is in {' or '.join(SENSOR_UNITS)}")
    return unit


def check_compensates(model, unit: str, recording: str, axis: str) -> None:
    """Refuse a model applied to an axis of another unit (an accelerometer model on a gyro axis, or the reverse).

    Parameters
    ----------
    model : DriftModel
    unit : str
        Unit of the recording's axis after reading (deg/s or m/s^2).
    recording, axis : str
        The recording's name and the axis, for the message.
    """
    have = model_unit(model)
    if have != unit:
        raise InputError(
            f"{model.name}: a model in {have} ({SENSOR_UNITS[have]}) cannot compensate axis {axis} of {recording}, "
            f"in {unit} ({SENSOR_UNITS.get(unit, 'unknown')}); pick the axes with --rate-col or give --rate-unit"
        )


def check_exportable(model, fmt: str, units: Sequence[str]) -> None:
    """Refuse exporting a model whose unit the format has no parameter for (`units`: the format's)."""
    have = model_unit(model)
    if have not in units:
        raise InputError(f"{model.name}: --format {fmt} has no parameter for a model in {have} ({SENSOR_UNITS[have]}); it takes {', '.join(units)}")
