"""A 45-minute warm-up of an IMU with three gyros and three accelerometers, written as a PX4 ULog (by pyulog) and an ArduPilot DataFlash log (by pymavlink's formats), with its truth.

Independent of gyrocomp (no ``gyrocomp.sim``): the truth is written here
with plain NumPy. Each instance warms from about 5 to 55 degC along its own
exponential; its gyro bias is a cubic in temperature [deg/s] and its
accelerometer bias a cubic [m/s^2] (plus gravity on z), with white noise.

The PX4 log is what ``sensor_gyro`` / ``sensor_accel`` carry: the sensor's
output in rad/s and m/s^2 with real-looking device ids, recorded with
``TC_G_ENABLE = 1`` (PX4 compensates after those topics). The ArduPilot log
is what ``IMU`` carries: the rate after the firmware's corrections,
``R (raw - P(T) + P(CALTEMP) - OFFS)``, with ``AHRS_ORIENTATION = 2`` (yaw
90) and IMU 1's own temperature calibration enabled, so reading it must
undo both (``tempcal_IMU.py``'s convention).
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

DURATION_S = 2700.0
FS_HZ = 4.0
N_INSTANCES = 3
GYRO_IDS = (2490378, 2490634, 3014666)
ACCEL_IDS = (2490386, 2490642, 3014674)
GRAVITY = np.array([0.0, 0.0, -9.80665])
REFERENCE_C = 30.0
"""The truth's polynomials are in T - 30 degC."""

_RNG = np.random.default_rng(35)
GYRO_COEF = _RNG.uniform(-1, 1, (N_INSTANCES, 3, 4)) * np.array([0.2, 6e-3, 1.5e-4, 3e-6])
"""Gyro bias [deg/s] per instance and axis: coefficients of (T - 30)^0..3."""
ACCEL_COEF = _RNG.uniform(-1, 1, (N_INSTANCES, 3, 4)) * np.array([0.1, 3e-3, 5e-5, 1e-6])
"""Accelerometer bias [m/s^2] per instance and axis: coefficients of (T - 30)^0..3."""
GYRO_NOISE_DPS = 0.01                # white, per sample at 4 Hz: ~0.3 deg/sqrt(h), a typical MEMS gyro
ACCEL_NOISE_M_S2 = 0.005             # ~0.25 mg/sqrt(Hz)

ORIENTATION = 2
"""AHRS_ORIENTATION of the ArduPilot log: ROTATION_YAW_90."""
_YAW_90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
OLD_TCAL = {"GYR": np.array([[2e-3, -4e-5, 1e-6]] * 3) * [[1.0], [-0.5], [0.8]], "ACC": np.array([[1e-2, 2e-4, -3e-6]] * 3)}
"""IMU 1's temperature calibration active in the ArduPilot log: coefficients of (T - 35)^1..3 per axis [rad/s, m/s^2]."""
OLD_TMIN, OLD_TMAX, OLD_CALTEMP = 10.0, 50.0, 25.0
OLD_GYROFFS = np.array([[1e-3, -2e-3, 5e-4], [-1e-3, 0.0, 2e-3], [0.0, 0.0, 0.0]])
"""INS_GYROFFS_* (IMU 1) and INS_GYR2OFFS_* [rad/s] in the ArduPilot log."""


def temperature(instance: int, time_s: np.ndarray) -> np.ndarray:
    """Each instance's temperature [degC]: an exponential warm-up from ~5 towards ~55 degC."""
    return 55.0 + 0.4 * instance - (50.0 + 0.3 * instance) * np.exp(-time_s / (600.0 + 60.0 * instance))


def gyro_bias_dps(instance: int, temperature_c) -> np.ndarray:
    """Gyro bias [deg/s], shape (..., 3)."""
    return _cubic(GYRO_COEF[instance], temperature_c)


def accel_bias(instance: int, temperature_c) -> np.ndarray:
    """Accelerometer bias [m/s^2], shape (..., 3), gravity not included."""
    return _cubic(ACCEL_COEF[instance], temperature_c)


def _cubic(coef: np.ndarray, temperature_c) -> np.ndarray:
    u = np.asarray(temperature_c, dtype=float)[..., None] - REFERENCE_C
    return sum(coef[:, k] * u**k for k in range(4))


def sensors(instance: int, seed: int):
    """Time [s], temperature, gyro [rad/s] and accelerometer [m/s^2] of one instance, as its sensor reads them."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(int(DURATION_S * FS_HZ)) / FS_HZ
    t = temperature(instance, time_s)
    gyro = np.deg2rad(gyro_bias_dps(instance, t) + rng.normal(0.0, GYRO_NOISE_DPS, (t.size, 3)))
    accel = accel_bias(instance, t) + GRAVITY + rng.normal(0.0, ACCEL_NOISE_M_S2, (t.size, 3))
    return time_s, t, gyro, accel


# -- PX4 ULog, written by pyulog ------------------------------------------------------------

_ULOG_FIELDS = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("uint32_t", "device_id"), ("float", "x"), ("float", "y"),
                ("float", "z"), ("float", "temperature"), ("uint32_t", "error_count")]


def write_ulog(path: Path) -> None:
    """The warm-up as PX4 logs it: sensor_gyro and sensor_accel, instances 0..2, each on its own stamps."""
    from pyulog import ULog

    log = ULog(None)
    log._file_version = 1
    formats = {}
    for topic in ("sensor_gyro", "sensor_accel"):
        text = topic + ":" + "".join(f"{kind} {name};" for kind, name in _ULOG_FIELDS)
        formats[topic] = ULog.MessageFormat(text.encode(), None)
    log._message_formats = formats
    log._initial_parameters = {"TC_G_ENABLE": 1, "TC_A_ENABLE": 0, "SENS_BOARD_ROT": 0}
    msg_id = 0
    for topic, ids in (("sensor_gyro", GYRO_IDS), ("sensor_accel", ACCEL_IDS)):
        for instance in range(N_INSTANCES):
            time_s, t, gyro, accel = sensors(instance, seed=100 + instance)
            values = gyro if topic == "sensor_gyro" else accel
            added = ULog._MessageAddLogged(struct.pack("<BH", instance, msg_id) + topic.encode(), None, formats)
            table = np.zeros(t.size, dtype=added.dtype)
            stamps = (1_000_000 + np.round(time_s * 1e6) + 700 * (topic == "sensor_accel") + 37 * instance).astype(np.uint64)
            table["timestamp"], table["timestamp_sample"], table["device_id"] = stamps + 50, stamps, ids[instance]
            for k, axis in enumerate("xyz"):
                table[axis] = values[:, k]
            table["temperature"] = t
            added.buffer = bytearray(table.tobytes())
            log._data_list.append(ULog.Data(added))
            msg_id += 1
    log.write_ulog(str(path))


# -- ArduPilot DataFlash, packed with pymavlink's formats -------------------------------------

_FORMATS = {
    0x80: ("FMT", "BBnNZ", "Type,Length,Name,Format,Columns"),
    0x40: ("PARM", "QNf", "TimeUS,Name,Value"),
    0x43: ("IMU", "QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"),
}


def ardupilot_params() -> dict:
    """The PARM values of the ArduPilot log."""
    params = {"AHRS_ORIENTATION": float(ORIENTATION), "INS_TCAL1_ENABLE": 1.0, "INS_TCAL2_ENABLE": 0.0, "INS_TCAL3_ENABLE": 2.0,
              "INS_TCAL1_TMIN": OLD_TMIN, "INS_TCAL1_TMAX": OLD_TMAX, "INS_GYR1_CALTEMP": OLD_CALTEMP, "INS_ACC1_CALTEMP": OLD_CALTEMP}
    for kind, coef in OLD_TCAL.items():
        for a, axis in enumerate("XYZ"):
            for k in (1, 2, 3):
                params[f"INS_TCAL1_{kind}{k}_{axis}"] = float(coef[a, k - 1] * 1e6)
    for n, prefix in ((0, "INS_GYROFFS_"), (1, "INS_GYR2OFFS_")):
        for a, axis in enumerate("XYZ"):
            params[prefix + axis] = float(OLD_GYROFFS[n, a])
    return params


def _old_poly(kind: str, temperature_c) -> np.ndarray:
    x = np.clip(np.asarray(temperature_c, dtype=float), OLD_TMIN, OLD_TMAX)[..., None] - 35.0
    c = OLD_TCAL[kind]
    return (c[:, 0] + (c[:, 1] + c[:, 2] * x) * x) * x


def write_dataflash(path: Path) -> None:
    """The warm-up as ArduPilot logs it: PARM, then IMU instances 0..2 interleaved, corrected and rotated by the firmware."""
    from pymavlink.DFReader import DFFormat

    fmts = {t: DFFormat(t, name, 0, fmt, columns) for t, (name, fmt, columns) in _FORMATS.items()}
    head = b"\xa3\x95"
    out = []
    for t, fmt in fmts.items():
        length = 3 + struct.calcsize(fmt.msg_struct)
        out.append(head + bytes([0x80]) + struct.pack(fmts[0x80].msg_struct, t, length, fmt.name.encode(), fmt.format.encode(), ",".join(fmt.columns).encode()))
    for name, value in ardupilot_params().items():
        out.append(head + bytes([0x40]) + struct.pack(fmts[0x40].msg_struct, 1000, name.encode(), value))
    logged = []
    for instance in range(N_INSTANCES):
        time_s, t, gyro, accel = sensors(instance, seed=200 + instance)
        if instance == 0:  # IMU 1's active temperature calibration
            gyro = gyro - _old_poly("GYR", t) + _old_poly("GYR", OLD_CALTEMP)
            accel = accel - _old_poly("ACC", t) + _old_poly("ACC", OLD_CALTEMP)
        gyro = gyro - OLD_GYROFFS[instance]
        logged.append((time_s, t, gyro @ _YAW_90.T, accel @ _YAW_90.T))
    imu = fmts[0x43].msg_struct
    for i in range(logged[0][0].size):
        for instance, (time_s, t, gyro, accel) in enumerate(logged):
            row = (int(5_000_000 + round(time_s[i] * 1e6)) + 11 * instance, instance, *gyro[i], *accel[i], 0, 0, float(t[i]), 1, 1, 400, 400)
            out.append(head + bytes([0x43]) + struct.pack(imu, *row))
    path.write_bytes(b"".join(out))


# -- the truth against the firmwares' published formulas ------------------------------------

GYRO_TOLERANCE_DEG_H = 20.0
"""Issue 35: every gyro instance within 20 deg/h of the truth over its temperature range."""
ACCEL_TOLERANCE_M_S2 = 2e-3
"""0.2 mg: the accelerometer's temperature dependence (its constant is the 6-point calibration's)."""


def parameters(path: Path) -> dict:
    """Name → value of a QGroundControl ``.params`` or a ``.parm`` file."""
    params = {}
    for line in path.read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        parts = line.split("\t") if "\t" in line else line.split()
        name, value = (parts[2], parts[3]) if len(parts) == 5 else parts
        params[name] = float(value)
    return params


def px4_errors(params: dict) -> dict:
    """Per slot: the largest |firmware offset - truth| over [TMIN, TMAX] (gyro deg/h; accel m/s^2 less its value at TREF)."""
    errors = {}
    for letter, sensor in (("G", "gyro"), ("A", "accel")):
        for i in range(N_INSTANCES):
            s = f"TC_{letter}{i}"
            grid = np.linspace(params[f"{s}_TMIN"], params[f"{s}_TMAX"], 201)
            d = grid - params[f"{s}_TREF"]
            offset = np.stack([sum(params[f"{s}_X{k}_{a}"] * d**k for k in range(4)) for a in range(3)], axis=1)
            if sensor == "gyro":
                errors[s] = float(np.max(np.abs(np.rad2deg(offset) - gyro_bias_dps(i, grid)))) * 3600.0
            else:
                truth = accel_bias(i, grid) - accel_bias(i, params[f"{s}_TREF"])
                errors[s] = float(np.max(np.abs(offset - truth)))
    return errors


def ardupilot_errors(params: dict) -> dict:
    """Per IMU: the largest |firmware correction - truth| over [TMIN, TMAX] (gyro deg/h with GYROFFS at CALTEMP; accel m/s^2 less its value at 35 degC)."""
    errors = {}
    for i in range(N_INSTANCES):
        n = i + 1
        grid = np.linspace(params[f"INS_TCAL{n}_TMIN"], params[f"INS_TCAL{n}_TMAX"], 201)
        for family in ("GYR", "ACC"):
            c = np.array([[params[f"INS_TCAL{n}_{family}{k}_{a}"] for k in (1, 2, 3)] for a in "XYZ"]) * 1e-6

            def poly(t):
                x = np.asarray(t, dtype=float)[..., None] - 35.0
                return (c[:, 0] + (c[:, 1] + c[:, 2] * x) * x) * x

            if family == "GYR":
                offsets = "INS_GYROFFS_" if n == 1 else f"INS_GYR{n}OFFS_"
                caltemp = params[f"INS_GYR{n}_CALTEMP"]
                total = poly(grid) - poly(caltemp) + np.array([params[offsets + a] for a in "XYZ"])
                errors[f"IMU{n} gyro"] = float(np.max(np.abs(np.rad2deg(total) - gyro_bias_dps(i, grid)))) * 3600.0
            else:
                truth = accel_bias(i, grid) - accel_bias(i, 35.0)
                errors[f"IMU{n} accel"] = float(np.max(np.abs(poly(grid) - truth)))
    return errors


def within_tolerance(errors: dict) -> bool:
    """Every gyro within :data:`GYRO_TOLERANCE_DEG_H`, every accelerometer within :data:`ACCEL_TOLERANCE_M_S2`."""
    return all(e < (GYRO_TOLERANCE_DEG_H if ("gyro" in k or k.startswith("TC_G")) else ACCEL_TOLERANCE_M_S2) for k, e in errors.items())
