"""PX4 and ArduPilot thermal-calibration parameters of gyros and accelerometers from temperature polynomials.

Both firmwares hold, per IMU sensor and per axis, a cubic in temperature
and clamp the temperature to the calibrated range before evaluating it;
they differ in reference temperature, scaling and where the constant goes.
A file holds every instance given (:class:`Block`: one sensor of one IMU).

* **PX4** (``src/modules/temperature_compensation``; written by
  ``Tools/process_sensor_caldata.py``): ``offset = X0 + X1 dT + X2 dT^2 +
  X3 dT^3`` with ``dT = clamp(T, TMIN, TMAX) - TREF``, subtracted from the
  sensor's value (``Correct``: ``data - thermal_offset - offset``), in
  rad/s for a gyro (``TC_G<i>_*``) and m/s^2 for an accelerometer
  (``TC_A<i>_*``). Parameters ``TC_<G|A><i>_X<k>_<axis>`` (axis 0, 1, 2 =
  x, y, z), ``TREF``, ``TMIN``, ``TMAX``, ``ID`` (the sensor's device id:
  PX4 applies slot i to the sensor with that id), ``TC_G_ENABLE`` /
  ``TC_A_ENABLE``. QGroundControl ``.params``: tab-separated ``vehicle
  component name value type`` (type 9 REAL32, 6 INT32). TREF is each
  instance's training midpoint, as PX4's script chooses it. An
  accelerometer's X0 makes the offset 0 at TREF: its constant is gravity
  plus the bias the 6-point calibration (``CAL_ACC*``) measures, as PX4's
  script fits the value less its median.
* **ArduPilot** (``AP_InertialSensor_tempcal``; ``Tools/scripts/tempcal_IMU.py``):
  ``corrected = raw - P(clamp(T) - 35) + P(clamp(CALTEMP) - 35) - OFFS``
  with ``P(x) = (c1 x + c2 x^2 + c3 x^3) * 1e-6`` about the fixed 35 degC
  reference, per IMU n (``INS_TCAL<n>_*``, one TMIN/TMAX for its gyro and
  accelerometer: the intersection of their training ranges), in rad/s for
  ``GYR1..3`` and m/s^2 for ``ACC1..3``. The gyro's constant lives in
  ``INS_GYROFFS_<axis>`` (``INS_GYR<n>OFFS_<axis>`` for IMU 2, 3), measured
  at ``INS_GYR<n>_CALTEMP``: gyrocomp writes the offset its model gives at
  CALTEMP = the IMU range's midpoint, so the three add up to the model. A
  start-up gyro calibration (``INS_GYR_CAL = 1``, ArduPilot's default)
  re-measures the offset and CALTEMP at every boot, which replaces the
  model's constant by that run's turn-on bias: the temperature part stays.
  The accelerometer's constant and ``INS_ACC<n>_CALTEMP`` are its 6-point
  calibration's and are not written (``tempcal_IMU.py`` writes only the
  polynomial too). MAVProxy / Mission Planner ``.parm``: ``NAME VALUE``
  lines, ``#`` comments.

gyrocomp's drift is subtracted, the same sign as both firmwares' offsets;
a gyro's unit changes from deg/s to rad/s, an accelerometer's m/s^2 stays.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.logparams import ARDUPILOT_REFERENCE_C, ARDUPILOT_SCALE

__all__ = ["AXES", "SENSORS", "Block", "px4_params", "ardupilot_params", "ARDUPILOT_REFERENCE_C", "ARDUPILOT_SCALE"]

AXES = ("x", "y", "z")
"""Sensor axes in the firmwares' order (PX4 suffix 0, 1, 2; ArduPilot X, Y, Z)."""

SENSORS = {"deg/s": "gyro", "m/s^2": "accel"}
"""The sensor a model's unit calibrates; the firmware parameter families: PX4 ``TC_G`` / ``TC_A``, ArduPilot ``GYR`` / ``ACC``."""

_RAD = math.pi / 180.0
_FACTOR = {"gyro": _RAD, "accel": 1.0}
"""From gyrocomp's unit to the firmwares' (deg/s to rad/s; m/s^2 stays)."""


@dataclasses.dataclass(frozen=True)
class Block:
    """One sensor of one IMU: what a firmware calibrates as a unit.

    Attributes
    ----------
    sensor : {"gyro", "accel"}
    instance : int
        The sensor's instance, 0-based (PX4 slot ``TC_G<i>``; ArduPilot IMU ``INS_TCAL<i + 1>``).
    cubics : dict of str to Cubic
        Per axis (``"x"``, ``"y"``, ``"z"``), in deg/s (gyro) or m/s^2; the axes not given are not written.
    device_id : int
        PX4 ``TC_<G|A><i>_ID``.
    """

    sensor: str
    instance: int
    cubics: dict
    device_id: int = 0


def px4_params(blocks, *, source: str = "") -> tuple[str, str]:
    """QGroundControl ``.params`` text for PX4's thermal compensation of every block.

    Parameters
    ----------
    blocks : sequence of Block
        Instance i goes to slot ``TC_G<i>`` / ``TC_A<i>`` (0..3).
    source : str
        Written into the header comment.

    Returns
    -------
    text : str
    statement : str
        One line: TREF, TMIN and TMAX of each slot and the convention.
    """
    _check_blocks(blocks, range(4), "PX4 has calibration slots 0..3")
    rows, ranges = [], []
    for sensor, letter in (("gyro", "G"), ("accel", "A")):
        if any(b.sensor == sensor for b in blocks):
            rows.append((f"TC_{letter}_ENABLE", 1, 6))
    for block in blocks:
        slot = f"TC_{'G' if block.sensor == 'gyro' else 'A'}{block.instance}"
        t_lo, t_hi = _shared_range(block.cubics, block.sensor)
        t_ref = 0.5 * (t_lo + t_hi)
        ranges.append(f"{slot} (id {int(block.device_id)}) TREF {t_ref:.6g} in [{t_lo:.6g}, {t_hi:.6g}]")
        rows += [(f"{slot}_ID", int(block.device_id), 6), (f"{slot}_TMIN", t_lo, 9), (f"{slot}_TMAX", t_hi, 9), (f"{slot}_TREF", t_ref, 9)]
        for axis, cubic in block.cubics.items():
            coef = _padded(cubic.about(t_ref).coef_dps, 4)
            if block.sensor == "accel":
                coef[0] = 0.0  # gravity and the bias are the 6-point calibration's
            for k, value in enumerate(coef):
                rows.append((f"{slot}_X{k}_{AXES.index(axis)}", float(value * _FACTOR[block.sensor]), 9))
    statement = f"px4: {'; '.join(ranges)} degC; TREF = each instance's training midpoint (PX4's process_sensor_caldata.py)"
    lines = [
        "# Thermal compensation parameters (PX4 TC_G*, TC_A*), written by gyrocomp export",
        f"# model: {source}",
        "# offset = X0 + X1 dT + X2 dT^2 + X3 dT^3, dT = clamp(T, TMIN, TMAX) - TREF, subtracted; gyro rad/s, accel m/s^2 (X0 = 0: offset 0 at TREF)",
        *[f"# {r} degC" for r in ranges],
        "# TREF = the instance's training midpoint, as PX4's process_sensor_caldata.py; TMIN, TMAX = its training range",
        "#",
        "# Vehicle-Id Component-Id Name Value Type",
    ]
    _check_real32([(name, value) for name, value, kind in rows if kind == 9])
    _check_int32([(name, value) for name, value, kind in rows if kind == 6])
    lines += [f"1\t1\t{name}\t{value!r}\t{kind}" for name, value, kind in rows]
    return "\n".join(lines) + "\n", statement


def ardupilot_params(blocks, *, source: str = "") -> tuple[str, str]:
    """MAVProxy / Mission Planner ``.parm`` text for ArduPilot's IMU temperature calibration of every block.

    Parameters
    ----------
    blocks : sequence of Block
        Instance i goes to IMU ``INS_TCAL<i + 1>`` (1..3); an IMU's gyro and
        accelerometer share its TMIN and TMAX.
    source : str
        The model, named in the header comment.

    Returns
    -------
    text, statement : str
        The file, and one line giving TMIN, TMAX and CALTEMP of each IMU and the convention.
    """
    _check_blocks(blocks, range(3), "ArduPilot has IMU temperature calibrations 1..3 (instances 0..2)")
    rows, ranges = [], []
    for instance in sorted({b.instance for b in blocks}):
        n = instance + 1
        mine = {b.sensor: b for b in blocks if b.instance == instance}
        limits = [_shared_range(b.cubics, b.sensor) for b in mine.values()]
        t_lo, t_hi = max(lo for lo, _ in limits), min(hi for _, hi in limits)
        if not t_lo < t_hi:
            raise InputError(f"export: IMU {n}'s gyro and accelerometer were trained over temperature ranges {limits} that do not overlap; ArduPilot holds one TMIN/TMAX per IMU")
        cal_temp = 0.5 * (t_lo + t_hi)
        rows += [(f"INS_TCAL{n}_ENABLE", 1), (f"INS_TCAL{n}_TMIN", t_lo), (f"INS_TCAL{n}_TMAX", t_hi)]
        for sensor, family in (("accel", "ACC"), ("gyro", "GYR")):
            for axis, cubic in (mine[sensor].cubics.items() if sensor in mine else ()):
                coef = np.asarray(_padded(cubic.about(ARDUPILOT_REFERENCE_C).coef_dps, 4)) * _FACTOR[sensor]
                rows += [(f"INS_TCAL{n}_{family}{k}_{axis.upper()}", coef[k] * ARDUPILOT_SCALE) for k in (1, 2, 3)]
        if "gyro" in mine:
            offsets = "INS_GYR" if n == 1 else f"INS_GYR{n}"
            rows += [(f"{offsets}OFFS_{axis.upper()}", float(cubic(cal_temp)) * _RAD) for axis, cubic in mine["gyro"].cubics.items()]
            rows.append((f"INS_GYR{n}_CALTEMP", cal_temp))
        ranges.append(f"INS_TCAL{n} ({', '.join(mine)}) TMIN {t_lo:.6g}, TMAX {t_hi:.6g}" + (f", INS_GYR{n}_CALTEMP {cal_temp:.6g}" if "gyro" in mine else ""))
    statement = f"ardupilot: {'; '.join(ranges)} degC; polynomials about ArduPilot's fixed 35 degC, gyro offsets at CALTEMP = the IMU range's midpoint"
    lines = [
        "# IMU temperature calibration (ArduPilot INS_TCAL), written by gyrocomp export",
        f"# model: {source}",
        "# corrected = raw - P(clamp(T) - 35) + P(clamp(CALTEMP) - 35) - OFFS, P(x) = 1e-6 (c1 x + c2 x^2 + c3 x^3); GYR rad/s, ACC m/s^2",
        *[f"# {r} degC" for r in ranges],
        "# the reference is ArduPilot's fixed 35 degC; TMIN, TMAX = the IMU's training range (gyro and accel: their intersection)",
        "# a start-up gyro calibration (INS_GYR_CAL = 1) replaces GYROFFS and CALTEMP with the boot's own; accel offsets and",
        "# INS_ACC<n>_CALTEMP stay your accelerometer calibration's",
    ]
    _check_real32(rows)
    lines += [f"{name} {_positional(value)}" for name, value in rows]
    return "\n".join(lines) + "\n", statement


def _check_blocks(blocks, instances: range, message: str) -> None:
    """Refuse no block, an instance the firmware has no slot for, or one sensor instance twice."""
    if not blocks:
        raise InputError("export: no axis to write")
    seen = set()
    for block in blocks:
        if block.instance not in instances:
            raise InputError(f"export: {block.sensor} instance {block.instance}: {message}")
        if (block.sensor, block.instance) in seen:
            raise InputError(f"export: two models of {block.sensor} instance {block.instance}; a firmware holds one calibration per sensor")
        seen.add((block.sensor, block.instance))


def _shared_range(cubics: dict, sensor: str = "gyro") -> tuple[float, float]:
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
    _check_offsets(cubics, float(lo), float(hi), sensor)
    return float(lo), float(hi)


def _check_offsets(cubics: dict, lo: float, hi: float, sensor: str, points: int = 257) -> None:
    """Refuse a polynomial whose offset over [TMIN, TMAX] no sensor reads (:class:`gyrocomp.recordings.AxisLimits`): single precision would overflow on it."""
    from gyrocomp.recordings import AxisLimits

    unit = {v: k for k, v in SENSORS.items()}[sensor]
    bound = AxisLimits().bound(unit)
    grid = np.linspace(lo, hi, points)
    for axis, cubic in cubics.items():
        with np.errstate(over="ignore", invalid="ignore"):
            values = cubic(grid)
            bad = np.flatnonzero(~(np.abs(values) <= bound))
        if bad.size:
            i = int(bad[np.argmax(np.abs(values[bad]))]) if np.all(np.isfinite(values[bad])) else int(bad[0])
            raise InputError(
                f"export: axis {axis}: the offset reaches {float(values[i]):.6g} {unit} at {grid[i]:.6g} degC, beyond +-{bound:g} {unit} "
                f"that any {sensor} reads (configs/recordings.toml [axes]); a corrupted model"
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
