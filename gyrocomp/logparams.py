"""What a flight log says about itself: the autopilot parameters under which its IMU data were logged.

A temperature calibration must be fitted to the sensor as it reads, not
to data the autopilot has already rotated or compensated: compensating
twice is a known bug class of both autopilots (PX4 PR #20660, ArduPilot
PR #27294). :mod:`gyrocomp.flightlogs` calls this module on every log it
reads, so every command sees the sensor's own output, and one line
(:class:`~gyrocomp.errors.RecordingNote`) says what was found and done.

* **PX4** (ULog initial parameters). ``sensor_gyro`` and ``sensor_accel``
  are published by the drivers, before the sensors module applies
  ``TC_G_ENABLE`` / ``TC_A_ENABLE`` thermal compensation, the ``CAL_*``
  offsets and ``SENS_BOARD_ROT`` (``Gyroscope::Correct`` runs on those
  topics' values). Their data are the sensor's whatever the parameters
  say: nothing is undone, and an enabled compensation or a board rotation
  is named, since the exported file replaces the coefficients.
* **ArduPilot** (``PARM`` messages). ``IMU`` logs the corrected rate:
  ``logged = R (raw - P(clamp(T) - 35) + P(clamp(CALTEMP) - 35) - OFFS)``
  with ``R`` the ``AHRS_ORIENTATION`` rotation and ``P`` the
  ``INS_TCAL<n>_GYR*`` / ``_ACC*`` cubic (``AP_InertialSensor_tempcal``;
  :mod:`gyrocomp.export.firmware`). gyrocomp undoes it as
  ``tempcal_IMU.py`` does: rotated back by ``R^T`` (pymavlink's table of
  ArduPilot rotations), the temperature calibration of every instance with
  ``INS_TCAL<n>_ENABLE = 1`` added back, and the gyro offsets
  ``INS_GYROFFS_*`` / ``INS_GYR<n>OFFS_*`` too, so that the exported offset
  is the sensor's own. Accelerometer offsets and scales are left (their
  constant is the 6-point calibration's, which export does not write).
  Refused, in one line: a custom orientation (no table), an enabled
  calibration whose coefficients the log lacks, and a parameter that
  changes during the log (the data would mix two calibrations).
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from gyrocomp.errors import InputError, RecordingNote

__all__ = ["px4_note", "ardupilot_undo", "ARDUPILOT_REFERENCE_C", "ARDUPILOT_SCALE"]

ARDUPILOT_REFERENCE_C = 35.0
"""TEMP_REFERENCE of AP_InertialSensor_tempcal [degC]."""

ARDUPILOT_SCALE = 1.0e6
"""SCALE_FACTOR of AP_InertialSensor_tempcal: stored coefficient = coefficient [unit/degC^k] * 1e6."""

_PX4_ENABLE = re.compile(r"^TC_([GA])\d?_ENABLE$")
_ARDUPILOT = re.compile(r"^(INS_TCAL\d_\w+|AHRS_ORIENTATION|INS_GYR\d?OFFS_[XYZ]|INS_(GYR|ACC)\d_CALTEMP)$")
_CALTEMP_UNSET_C = -80.0
"""A CALTEMP below this was never measured; ArduPilot then applies no temperature correction (as ``tempcal_IMU.py`` reads it)."""


def px4_note(name: str, params: dict) -> None:
    """One note when a ULog was recorded with PX4 thermal compensation enabled or a board rotation (its sensor topics are the sensor's all the same)."""
    said = [f"{key} = 1" for key, value in sorted(params.items()) if _PX4_ENABLE.match(key) and int(value) == 1]
    said += [f"SENS_BOARD_ROT = {int(params['SENS_BOARD_ROT'])}"] if params.get("SENS_BOARD_ROT", 0) else []
    if said:
        warnings.warn(
            f"{name}: {', '.join(said)} in the log: PX4 applies thermal compensation and the board rotation after sensor_gyro / sensor_accel "
            "are logged, so they are read as the sensor gave them (nothing to undo); exported TC_* replace the log's",
            RecordingNote,
            stacklevel=3,
        )


def ardupilot_undo(name: str, params: dict):
    """The function that returns an ``IMU`` instance's rows to the sensor's own output, from the log's ``PARM`` values.

    Parameters
    ----------
    name : str
        The log, for messages.
    params : dict of str to list of float
        Every value each parameter takes in the log, in order.

    Returns
    -------
    callable
        ``undo(instance, table) -> table``, `table` of rows ``TimeUS, GyrX,
        GyrY, GyrZ`` [rad/s] ``, AccX, AccY, AccZ`` [m/s^2] ``, T`` [degC]
        (instance 0 is IMU 1 of the parameters).

    Raises
    ------
    InputError
        A parameter that changes during the log, a custom or unknown
        ``AHRS_ORIENTATION``, or an enabled temperature calibration without
        its coefficients.
    """
    values = {}
    for key, seen in params.items():
        if _ARDUPILOT.match(key):
            if len(set(seen)) > 1:
                raise InputError(f"{name}: PARM {key} changes from {seen[0]:g} to {next(v for v in seen if v != seen[0]):g} during the log; "
                                 "its IMU data mix two calibrations: cut the log where it changes")
            values[key] = seen[0]
    rotation = _rotation(name, values.get("AHRS_ORIENTATION", 0.0))
    enabled = sorted(int(key[8]) for key, value in values.items() if re.fullmatch(r"INS_TCAL\d_ENABLE", key) and value == 1)
    calibrations = {n - 1: _calibration(name, values, n) for n in enabled}
    offsets = {n: [values.get(f"INS_GYR{'' if n == 0 else n + 1}OFFS_{a}", 0.0) for a in "XYZ"] for n in range(3)}
    undone = [what for what, done in (
        (f"rotated back from AHRS_ORIENTATION = {int(values.get('AHRS_ORIENTATION', 0))}", rotation is not None),
        (f"INS_TCAL{', '.join(map(str, enabled))} temperature calibration added back", bool(enabled)),
        ("gyro offsets added back", any(any(o) for o in offsets.values())),
    ) if done]
    if undone:
        warnings.warn(f"{name}: the IMU data were logged corrected; undone to the sensor's output: {'; '.join(undone)}", RecordingNote, stacklevel=3)

    def undo(instance: int, table: np.ndarray) -> np.ndarray:
        out = table.copy()
        if rotation is not None:
            out[:, 1:4] = out[:, 1:4] @ rotation  # rows are vectors: (R^T v)^T = v^T R
            out[:, 4:7] = out[:, 4:7] @ rotation
        if instance in calibrations:
            temperature = out[:, 7]
            for block, (coef, tmin, tmax, caltemp) in zip((slice(1, 4), slice(4, 7)), calibrations[instance]):
                if caltemp is None or caltemp < _CALTEMP_UNSET_C:
                    continue
                out[:, block] += _poly(coef, np.clip(temperature, tmin, tmax)) - _poly(coef, np.clip(caltemp, tmin, tmax))
        out[:, 1:4] += offsets.get(instance, [0.0, 0.0, 0.0])
        return out

    return undo


def _rotation(name: str, value: float):
    """The matrix R of ArduPilot rotation `value` (None for none): pymavlink's table of ArduPilot's ``enum Rotation``."""
    if value == 0:
        return None
    from pymavlink.rotmat import rotations

    if value != int(value) or not 0 < value < len(rotations):
        raise InputError(f"{name}: PARM AHRS_ORIENTATION = {value:g} is a custom or unknown board rotation; "
                         "gyrocomp cannot undo it: log the IMU with AHRS_ORIENTATION = 0")
    m = rotations[int(value)].r
    return np.array([[m.a.x, m.a.y, m.a.z], [m.b.x, m.b.y, m.b.z], [m.c.x, m.c.y, m.c.z]])


def _calibration(name: str, values: dict, n: int) -> tuple:
    """IMU n's gyro and accel (coefficients [unit/degC^k] of x^1..x^3 per axis, TMIN, TMAX, CALTEMP) from its parameters."""
    out = []
    for kind in ("GYR", "ACC"):
        keys = [f"INS_TCAL{n}_{kind}{k}_{a}" for a in "XYZ" for k in (1, 2, 3)]
        limits = [f"INS_TCAL{n}_TMIN", f"INS_TCAL{n}_TMAX"]
        missing = [key for key in keys + limits if key not in values]
        if missing:
            raise InputError(f"{name}: INS_TCAL{n}_ENABLE = 1 but the log has no {missing[0]}; the IMU data are compensated "
                             f"with coefficients gyrocomp cannot undo: log with INS_TCAL{n}_ENABLE = 0")
        coef = np.array([values[key] for key in keys]).reshape(3, 3) / ARDUPILOT_SCALE
        out.append((coef, values[limits[0]], values[limits[1]], values.get(f"INS_{kind}{n}_CALTEMP")))
    return out


def _poly(coef: np.ndarray, temperature) -> np.ndarray:
    """``P(T - 35)`` per axis: rows of `coef` are an axis' coefficients of x, x^2, x^3 (``AP_InertialSensor_tempcal``)."""
    x = np.asarray(temperature, dtype=float)[..., None] - ARDUPILOT_REFERENCE_C
    return (coef[:, 0] + (coef[:, 1] + coef[:, 2] * x) * x) * x
