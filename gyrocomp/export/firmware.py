"""PX4 and ArduPilot gyro thermal-calibration parameters from a temperature polynomial.

Both firmwares hold, per IMU and per axis, a cubic in temperature and clamp
the temperature to the calibrated range before evaluating it; they differ
in reference temperature, scaling and where the constant goes.

* **PX4** (``src/modules/temperature_compensation``; written by
  ``Tools/process_sensor_caldata.py``): ``offset = X0 + X1 dT + X2 dT^2 +
  X3 dT^3`` [rad/s] with ``dT = clamp(T, TMIN, TMAX) - TREF``, subtracted
  from the raw rate (``Correct``: ``data - thermal_offset - offset``).
  Parameters ``TC_G<i>_X<k>_<axis>`` (axis 0, 1, 2 = x, y, z),
  ``TC_G<i>_TREF``, ``TMIN``, ``TMAX``, ``TC_G<i>_ID`` (the gyro's device
  id: the calibration applies only to that sensor), ``TC_G_ENABLE``.
  QGroundControl ``.params``: tab-separated ``vehicle component name value
  type`` (type 9 REAL32, 6 INT32). TREF here is the training range's
  midpoint, as PX4's script chooses it.
* **ArduPilot** (``AP_InertialSensor_tempcal``; ``Tools/scripts/tempcal_IMU.py``):
  ``corrected = raw - P(clamp(T) - 35) + P(clamp(CALTEMP) - 35) - GYROFFS``
  with ``P(x) = (GYR1 x + GYR2 x^2 + GYR3 x^3) * 1e-6`` [rad/s] about the
  fixed 35 degC reference; the constant term lives in the gyro offsets
  ``INS_GYROFFS_<axis>`` (``INS_GYR<n>OFFS_<axis>`` for IMU 2, 3), measured at
  ``INS_GYR<n>_CALTEMP``. gyrocomp writes the offset its model gives at
  CALTEMP = the training midpoint, so the three add up to the model. A
  start-up gyro calibration (``INS_GYR_CAL = 1``, ArduPilot's default)
  re-measures the offset and CALTEMP at every boot, which replaces the
  model's constant by that run's turn-on bias: the temperature part stays.
  MAVProxy / Mission Planner ``.parm``: ``NAME VALUE`` lines, ``#`` comments.

gyrocomp's drift is in deg/s and subtracted, the same sign as both
firmwares' offsets; only the unit (rad/s) changes.
"""

from __future__ import annotations

import math

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["AXES", "px4_params", "ardupilot_params", "ARDUPILOT_REFERENCE_C", "ARDUPILOT_SCALE"]

AXES = ("x", "y", "z")
"""Gyro axes in the firmwares' order (PX4 suffix 0, 1, 2; ArduPilot X, Y, Z)."""

ARDUPILOT_REFERENCE_C = 35.0
"""TEMP_REFERENCE of AP_InertialSensor_tempcal [degC]."""

ARDUPILOT_SCALE = 1.0e6
"""SCALE_FACTOR of AP_InertialSensor_tempcal: stored coefficient = coefficient [rad/s/degC^k] * 1e6."""

_RAD = math.pi / 180.0


def px4_params(cubics: dict, *, instance: int = 0, device_id: int = 0, source: str = "") -> str:
    """QGroundControl ``.params`` text for PX4's gyro thermal compensation.

    Parameters
    ----------
    cubics : dict of str to Cubic
        Per axis (``"x"``, ``"y"``, ``"z"``); the axes not given are not written.
    instance : int
        Gyro calibration slot i of ``TC_G<i>_*`` (0..3).
    device_id : int
        ``TC_G<i>_ID``: PX4 applies the slot to the gyro with this device id
        (``CAL_GYRO<n>_ID``).
    source : str
        Written into the header comment.
    """
    if not 0 <= instance <= 3:
        raise InputError(f"--instance {instance}: PX4 has gyro calibration slots 0..3")
    t_lo, t_hi = _shared_range(cubics)
    t_ref = 0.5 * (t_lo + t_hi)
    rows = [("TC_G_ENABLE", 1, 6), (f"TC_G{instance}_ID", int(device_id), 6)]
    rows += [(f"TC_G{instance}_TMIN", t_lo, 9), (f"TC_G{instance}_TMAX", t_hi, 9), (f"TC_G{instance}_TREF", t_ref, 9)]
    for axis, cubic in cubics.items():
        coef = np.asarray(cubic.about(t_ref).coef_dps) * _RAD
        for k, value in enumerate(_padded(coef, 4)):
            rows.append((f"TC_G{instance}_X{k}_{AXES.index(axis)}", float(value), 9))
    lines = [
        "# Gyro thermal compensation parameters (PX4 TC_G*), written by gyrocomp export",
        f"# model: {source}",
        "# offset [rad/s] = X0 + X1 dT + X2 dT^2 + X3 dT^3, dT = clamp(T, TMIN, TMAX) - TREF; subtracted from the gyro rate",
        "#",
        "# Vehicle-Id Component-Id Name Value Type",
    ]
    _check_real32([(name, value) for name, value, kind in rows if kind == 9])
    _check_int32([(name, value) for name, value, kind in rows if kind == 6])
    lines += [f"1\t1\t{name}\t{value!r}\t{kind}" for name, value, kind in rows]
    return "\n".join(lines) + "\n"


def ardupilot_params(cubics: dict, *, instance: int = 1, source: str = "") -> str:
    """MAVProxy / Mission Planner ``.parm`` text for ArduPilot's IMU temperature calibration.

    Parameters
    ----------
    cubics : dict of str to Cubic
        Per axis (``"x"``, ``"y"``, ``"z"``).
    instance : int
        IMU n of ``INS_TCAL<n>_*`` (1..3).
    """
    if not 1 <= instance <= 3:
        raise InputError(f"--instance {instance}: ArduPilot has IMU temperature calibrations 1..3")
    t_lo, t_hi = _shared_range(cubics)
    cal_temp = 0.5 * (t_lo + t_hi)
    offsets_prefix = "INS_GYR" if instance == 1 else f"INS_GYR{instance}"
    rows = [(f"INS_TCAL{instance}_ENABLE", 1), (f"INS_TCAL{instance}_TMIN", t_lo), (f"INS_TCAL{instance}_TMAX", t_hi)]
    for axis, cubic in cubics.items():
        coef = np.asarray(_padded(cubic.about(ARDUPILOT_REFERENCE_C).coef_dps, 4)) * _RAD
        for k in (1, 2, 3):
            rows.append((f"INS_TCAL{instance}_GYR{k}_{axis.upper()}", coef[k] * ARDUPILOT_SCALE))
    for axis, cubic in cubics.items():
        rows.append((f"{offsets_prefix}OFFS_{axis.upper()}", float(cubic(cal_temp)) * _RAD))
    rows.append((f"INS_GYR{instance}_CALTEMP", cal_temp))
    lines = [
        "# Gyro temperature calibration (ArduPilot INS_TCAL), written by gyrocomp export",
        f"# model: {source}",
        "# corrected = raw - P(clamp(T) - 35) + P(clamp(CALTEMP) - 35) - GYROFFS, P(x) = 1e-6 (GYR1 x + GYR2 x^2 + GYR3 x^3) [rad/s]",
        "# a start-up gyro calibration (INS_GYR_CAL = 1) replaces GYROFFS and CALTEMP with the boot's own",
    ]
    _check_real32(rows)
    lines += [f"{name} {_positional(value)}" for name, value in rows]
    return "\n".join(lines) + "\n"


def _shared_range(cubics: dict) -> tuple[float, float]:
    if not cubics:
        raise InputError("export: no axis to write")
    unknown = [a for a in cubics if a not in AXES]
    if unknown:
        raise InputError(f"export: axis {unknown[0]!r}; the firmware axes are x, y, z")
    ranges = {tuple(c.temperature_range_c) for c in cubics.values()}
    if len(ranges) > 1:
        raise InputError(f"export: the axes were trained over different temperature ranges {sorted(ranges)}; firmware holds one TMIN/TMAX per IMU")
    lo, hi = ranges.pop()
    if not lo < hi:
        raise InputError(f"export: TMIN = TMAX = {lo!r} degC: the model was trained at one temperature; firmware needs a calibrated range")
    _check_offsets(cubics, float(lo), float(hi))
    return float(lo), float(hi)


def _check_offsets(cubics: dict, lo: float, hi: float, points: int = 257) -> None:
    """Refuse a polynomial whose offset over [TMIN, TMAX] no gyro reads (:class:`gyrocomp.recordings.AxisLimits`): single precision would overflow on it."""
    from gyrocomp.recordings import AxisLimits

    bound = AxisLimits().max_abs_deg_s
    grid = np.linspace(lo, hi, points)
    for axis, cubic in cubics.items():
        with np.errstate(over="ignore", invalid="ignore"):
            values = cubic(grid)
            bad = np.flatnonzero(~(np.abs(values) <= bound))
        if bad.size:
            i = int(bad[np.argmax(np.abs(values[bad]))]) if np.all(np.isfinite(values[bad])) else int(bad[0])
            raise InputError(
                f"export: axis {axis}: the offset reaches {float(values[i]):.6g} deg/s at {grid[i]:.6g} degC, beyond +-{bound:g} deg/s "
                "that any gyro reads (configs/recordings.toml [axes]); a corrupted model"
            )


FLOAT32_MAX = float(np.finfo(np.float32).max)
"""Largest finite single-precision value: both firmwares hold their parameters as float (PX4 REAL32, ArduPilot AP_Float)."""

INT32 = (-(2**31), 2**31 - 1)
"""Range of a PX4 INT32 parameter (type 6)."""


def _check_real32(rows) -> None:
    """Refuse a float parameter that single precision cannot hold (it would load as inf)."""
    for name, value in rows:
        if not abs(float(value)) <= FLOAT32_MAX:
            raise InputError(f"export: {name} = {float(value)!r} is beyond single precision (+-{FLOAT32_MAX:.7g}), which the firmware stores")


def _check_int32(rows) -> None:
    """Refuse an integer parameter beyond INT32 (PX4 would store it wrapped)."""
    for name, value in rows:
        if not INT32[0] <= int(value) <= INT32[1]:
            raise InputError(f"export: {name} = {int(value)} is beyond INT32 ({INT32[0]}..{INT32[1]}), which PX4 stores")


def _padded(coef, n: int) -> list[float]:
    coef = [float(c) for c in coef]
    return coef + [0.0] * (n - len(coef))


def _positional(value) -> str:
    """Shortest round-trip decimal without an exponent (ArduPilot's scale factor exists to avoid one)."""
    if isinstance(value, int):
        return str(value)
    return np.format_float_positional(float(value), unique=True, trim="-")
