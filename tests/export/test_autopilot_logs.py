"""Warm-up logs with three gyros and three accelerometers → one PX4 and one ArduPilot parameter file, checked against the truth (issue 35, items 2 and 3).

The logs are written by pyulog and with pymavlink's formats from a truth
written in plain NumPy (``tests/warmup_logs.py``); the parameters are
evaluated with the firmwares' published formulas (``test_firmware.py``:
``TemperatureCompensation::calc_thermal_offsets_3D``,
``AP_InertialSensor::TCal::correct_sensor``), not with gyrocomp.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from gyrocomp.cli import app
from gyrocomp.errors import InputError

pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

_spec = importlib.util.spec_from_file_location("warmup_logs", Path(__file__).resolve().parents[1] / "warmup_logs.py")
warmup = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(warmup)

GYRO_TOLERANCE_DEG_H, ACCEL_TOLERANCE_M_S2 = warmup.GYRO_TOLERANCE_DEG_H, warmup.ACCEL_TOLERANCE_M_S2

PX4_RECIPE = ["train", "warmup.ulg", "--rate-col", "sensor_*_[xyz]", "--config", "firmware", "--out", "imu.json"], ["export", "imu.json", "--format", "px4", "--out", "tcal.params"]
ARDUPILOT_RECIPE = ["train", "warmup.bin", "--rate-col", "IMU_*_Gyr?,IMU_*_Acc?", "--config", "firmware", "--out", "imu.json"], ["export", "imu.json", "--format", "ardupilot", "--out", "tcal.parm"]


def _run(folder: Path, monkeypatch, *commands) -> list:
    monkeypatch.chdir(folder)
    results = []
    for argv in commands:
        result = CliRunner().invoke(app, list(argv))
        assert result.exit_code == 0, result.output
        results.append(result)
    return results


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("warmup")
    warmup.write_ulog(folder / "warmup.ulg")
    warmup.write_dataflash(folder / "warmup.bin")
    return folder


def test_px4_every_instance_in_one_file_with_its_device_id(logs, tmp_path, monkeypatch):
    for name in ("warmup.ulg",):
        (tmp_path / name).symlink_to(logs / name)
    train, export = _run(tmp_path, monkeypatch, *PX4_RECIPE)
    notes = [line for line in train.stderr.splitlines() if "TC_G_ENABLE" in line]
    assert len(notes) == 1 and "TC_G_ENABLE = 1 in the log" in notes[0] and "nothing to undo" in notes[0] and "TC_A_ENABLE" not in notes[0]
    params = warmup.parameters(tmp_path / "tcal.params")
    assert params["TC_G_ENABLE"] == 1 and params["TC_A_ENABLE"] == 1
    for i in range(warmup.N_INSTANCES):
        assert params[f"TC_G{i}_ID"] == warmup.GYRO_IDS[i] and params[f"TC_A{i}_ID"] == warmup.ACCEL_IDS[i]
        assert params[f"TC_G{i}_TREF"] == pytest.approx(0.5 * (params[f"TC_G{i}_TMIN"] + params[f"TC_G{i}_TMAX"]))
        assert params[f"TC_A{i}_X0_2"] == 0.0  # gravity is the 6-point calibration's, not the thermal offset's
    errors = warmup.px4_errors(params)
    print("px4", {k: round(v, 5) for k, v in errors.items()})
    for slot, error in errors.items():
        assert error < (GYRO_TOLERANCE_DEG_H if slot.startswith("TC_G") else ACCEL_TOLERANCE_M_S2), (slot, error)
    text = (tmp_path / "tcal.params").read_text()
    assert "# TC_G1 (id 2490634) TREF " in text and "training midpoint" in text
    assert "TREF = each instance's training midpoint" in export.stderr and "TC_A2 (id 3014674)" in export.stderr
    assert "TC_G0_ID = 0" not in export.stderr


def test_ardupilot_every_imu_in_one_file_from_a_rotated_and_compensated_log(logs, tmp_path, monkeypatch):
    """The .bin was logged with AHRS_ORIENTATION = 2 and IMU 1's INS_TCAL active: both are undone (one line says so)."""
    (tmp_path / "warmup.bin").symlink_to(logs / "warmup.bin")
    train, export = _run(tmp_path, monkeypatch, *ARDUPILOT_RECIPE)
    notes = [line for line in train.stderr.splitlines() if "logged corrected" in line]
    assert len(notes) == 1 and "AHRS_ORIENTATION = 2" in notes[0] and "INS_TCAL1 temperature calibration added back" in notes[0]
    params = warmup.parameters(tmp_path / "tcal.parm")
    errors = warmup.ardupilot_errors(params)
    print("ardupilot", {k: round(v, 5) for k, v in errors.items()})
    for imu, error in errors.items():
        assert error < (GYRO_TOLERANCE_DEG_H if "gyro" in imu else ACCEL_TOLERANCE_M_S2), (imu, error)
    assert all(params[f"INS_TCAL{n}_ENABLE"] == 1 for n in (1, 2, 3))
    assert not any(name.startswith("INS_ACC") for name in params)  # the accelerometer calibration's own
    assert "polynomials about ArduPilot's fixed 35 degC" in export.stderr and "INS_TCAL3 (gyro, accel) TMIN" in export.stderr


def test_a_log_read_without_undoing_its_rotation_misses_the_truth(logs):
    """The check above can fail: the rotated, compensated IMU 1 data as logged are far from the sensor's bias."""
    from pymavlink import DFReader

    log = DFReader.DFReader_binary(str(logs / "warmup.bin"))
    rows = []
    while (msg := log.recv_match(type="IMU")) is not None:
        if msg.I == 0:
            rows.append((msg.T, msg.GyrX, msg.GyrY))
    t, gx, gy = np.array(rows).T
    truth = warmup.gyro_bias_dps(0, t)
    assert np.max(np.abs(np.rad2deg(gx) - truth[:, 0])) * 3600 > 100 * GYRO_TOLERANCE_DEG_H
    assert np.max(np.abs(np.rad2deg(gy) - truth[:, 1])) * 3600 > 100 * GYRO_TOLERANCE_DEG_H


def test_accelerometer_model_exports_as_accelerometer_parameters_without_deg_to_rad(tmp_path):
    """Item 2: an m/s^2 model becomes TC_A0 / INS_TCAL1_ACC*, with no degree-to-radian factor (it became TC_G0 with one)."""
    import pandas as pd

    rng = np.random.default_rng(4)
    t = np.arange(4000.0)
    temperature = 5.0 + 50.0 * t / t[-1]
    frame = pd.DataFrame({"time": t, "ax": 0.002 * (temperature - 30.0) + rng.normal(0, 1e-3, t.size), "temperature": temperature})
    frame.to_csv(tmp_path / "acc.csv", index=False)
    runner = CliRunner()
    result = runner.invoke(app, ["train", str(tmp_path / "acc.csv"), "--rate-col", "ax", "--rate-unit", "m/s^2", "--config", "firmware", "--out", str(tmp_path / "a.json")])
    assert result.exit_code == 0, result.output
    for fmt, out in (("px4", "a.params"), ("ardupilot", "a.parm")):
        result = runner.invoke(app, ["export", str(tmp_path / "a.json"), "--format", fmt, "--device-id" if fmt == "px4" else "--axis", "7" if fmt == "px4" else "x", "--out", str(tmp_path / out)])
        assert result.exit_code == 0, result.output
    px4 = warmup.parameters(tmp_path / "a.params")
    assert not any(name.startswith("TC_G") for name in px4) and px4["TC_A0_ID"] == 7
    assert px4["TC_A0_X1_0"] == pytest.approx(0.002, rel=0.02)  # m/s^2 per degC, not * pi / 180
    parm = warmup.parameters(tmp_path / "a.parm")
    assert not any("GYR" in name for name in parm)
    assert parm["INS_TCAL1_ACC1_X"] == pytest.approx(0.002 * 1e6, rel=0.02)


def test_log_instances_refuse_a_hand_given_instance_or_id(logs, tmp_path, monkeypatch):
    (tmp_path / "warmup.ulg").symlink_to(logs / "warmup.ulg")
    _run(tmp_path, monkeypatch, PX4_RECIPE[0])
    result = CliRunner().invoke(app, ["export", "imu.json", "--format", "px4", "--device-id", "5", "--out", "x.params"])
    assert result.exit_code == 2 and "come from its log" in result.stderr and "drop --device-id" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    model = json.loads((tmp_path / "imu.json").read_text())
    assert model["axes"]["sensor_accel_2_z"]["sensor"] == {"stream": "sensor_accel_2", "autopilot": "px4", "instance": 2, "device_id": warmup.ACCEL_IDS[2]}


def test_what_an_ardupilot_log_says_is_refused_when_it_cannot_be_undone(tmp_path, monkeypatch):
    """A custom board rotation, an active calibration without its coefficients, a parameter changing mid-log: one line each, exit 2."""
    from gyrocomp.logparams import ardupilot_undo

    with pytest.raises(InputError, match=r"^x\.bin: PARM AHRS_ORIENTATION = 100 is a custom or unknown board rotation"):
        ardupilot_undo("x.bin", {"AHRS_ORIENTATION": [100.0]})
    with pytest.raises(InputError, match=r"^x\.bin: INS_TCAL2_ENABLE = 1 but the log has no INS_TCAL2_GYR1_X"):
        ardupilot_undo("x.bin", {"INS_TCAL2_ENABLE": [1.0]})
    with pytest.raises(InputError, match=r"^x\.bin: PARM INS_TCAL1_ENABLE changes from 2 to 1 during the log"):
        ardupilot_undo("x.bin", {"INS_TCAL1_ENABLE": [2.0, 2.0, 1.0]})
    table = np.array([[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 30.0]])
    assert np.array_equal(ardupilot_undo("x.bin", {"INS_TCAL1_ENABLE": [2.0], "AHRS_ORIENTATION": [0.0]})(0, table), table)  # learning: data raw


def test_one_ardupilot_gyro_from_a_rotated_compensated_log_meets_the_truth(logs, tmp_path, monkeypatch):
    """Item 3 alone: IMU 1's gyro, logged rotated (yaw 90) and with its INS_TCAL and offsets active, exports within 20 deg/h (the log was read as logged)."""
    (tmp_path / "warmup.bin").symlink_to(logs / "warmup.bin")
    _run(tmp_path, monkeypatch, ["train", "warmup.bin", "--rate-col", "IMU_0_Gyr?", "--config", "firmware", "--out", "g.json"],
         ["export", "g.json", "--format", "ardupilot", "--out", "g.parm"])
    params = warmup.parameters(tmp_path / "g.parm")
    grid = np.linspace(params["INS_TCAL1_TMIN"], params["INS_TCAL1_TMAX"], 201)
    c = np.array([[params[f"INS_TCAL1_GYR{k}_{a}"] for k in (1, 2, 3)] for a in "XYZ"]) * 1e-6
    x = grid[:, None] - 35.0
    poly = (c[:, 0] + (c[:, 1] + c[:, 2] * x) * x) * x
    x0 = params["INS_GYR1_CALTEMP"] - 35.0
    total = poly - (c[:, 0] + (c[:, 1] + c[:, 2] * x0) * x0) * x0 + np.array([params[f"INS_GYROFFS_{a}"] for a in "XYZ"])
    error = np.max(np.abs(np.rad2deg(total) - warmup.gyro_bias_dps(0, grid))) * 3600.0
    assert error < GYRO_TOLERANCE_DEG_H, error


@pytest.mark.parametrize("field, value", [("instance", "0"), ("instance", -1), ("device_id", 1.5), ("instance", 7)])
def test_a_hand_edited_instance_is_refused_in_one_line(logs, tmp_path, monkeypatch, field, value):
    (tmp_path / "warmup.ulg").symlink_to(logs / "warmup.ulg")
    _run(tmp_path, monkeypatch, ["train", "warmup.ulg", "--rate-col", "sensor_gyro_1_[xyz]", "--config", "firmware", "--out", "g.json"])
    model = json.loads((tmp_path / "g.json").read_text())
    model["axes"]["sensor_gyro_1_y"]["sensor"][field] = value
    (tmp_path / "g.json").write_text(json.dumps(model))
    result = CliRunner().invoke(app, ["export", "g.json", "--format", "px4", "--out", "g.params"])
    assert result.exit_code == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    expected = "gyro instance 7: PX4 has calibration slots 0..3" if value == 7 else f"g.json axis sensor_gyro_1_y: sensor {field} = {value!r}"
    assert expected in result.stderr, result.stderr
    assert not (tmp_path / "g.params").exists()


def test_px4_parameters_are_named_and_nothing_is_undone():
    """PX4's sensor topics precede its compensation and board rotation: one note, the data untouched."""
    from gyrocomp.errors import RecordingNote
    from gyrocomp.logparams import px4_note

    with pytest.warns(RecordingNote, match=r"^x\.ulg: TC_A_ENABLE = 1, SENS_BOARD_ROT = 2 in the log: PX4 applies .* \(nothing to undo\)"):
        px4_note("x.ulg", {"TC_A_ENABLE": 1, "TC_G_ENABLE": 0, "SENS_BOARD_ROT": 2})
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        px4_note("x.ulg", {"TC_A_ENABLE": 0, "TC_G_ENABLE": 0, "SENS_BOARD_ROT": 0})
