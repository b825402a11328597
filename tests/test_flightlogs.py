"""PX4 ULog and ArduPilot DataFlash logs read as recordings, checked against the formats' own tools and specs."""

from __future__ import annotations

import math
import os
import struct
from pathlib import Path

import numpy as np
import pytest

from gyrocomp.errors import InputError
from gyrocomp.recordings import ColumnSpec, read_recording

pyulog = pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

REPO = Path(__file__).resolve().parents[1]
REAL_DATA = Path(os.environ.get("GYROCOMP_REAL_DATA", REPO.parent / "shared" / "real-data"))  # as tests/conftest.py
PX4_SAMPLE = REAL_DATA / "px4-ulog-sample" / "sample_log_small.ulg"


@pytest.mark.skipif(not PX4_SAMPLE.exists(), reason="shared real data absent")
@pytest.mark.parametrize("topic", ["sensor_gyro", "sensor_accel"])
@pytest.mark.parametrize("instance", [0, 1, 2])
def test_px4_sample_every_instance_equals_pyulog(topic, instance):
    """The BSD PX4 sample (CubeOrange): each instance's axes, temperature and µs time, as pyulog reads them."""
    log = pyulog.ULog(str(PX4_SAMPLE), [topic])
    data = next(d for d in log.data_list if d.multi_id == instance).data
    rec = read_recording(PX4_SAMPLE, ColumnSpec(rate=f"{topic}_{instance}_*"))
    assert rec.axis_names == tuple(f"{topic}_{instance}_{a}" for a in "xyz")
    scale = 180.0 / math.pi if topic == "sensor_gyro" else 1.0  # rad/s -> deg/s; m/s^2 stays
    for a in "xyz":
        np.testing.assert_allclose(rec.column(f"{topic}_{instance}_{a}"), data[a].astype(float) * scale, rtol=1e-12)
    np.testing.assert_allclose(rec.temperature_c, data["temperature"].astype(float))
    stamps = data["timestamp_sample"].astype(np.int64)
    np.testing.assert_allclose(rec.time_s, (stamps - stamps[0]) * 1e-6, rtol=0, atol=1e-12)
    assert rec.time_origin == f"{stamps[0]} us"
    if topic == "sensor_accel":  # a resting flight controller measures 1 g
        norm = np.sqrt(sum(rec.column(f"{topic}_{instance}_{a}") ** 2 for a in "xyz"))
        assert np.median(norm) == pytest.approx(9.81, abs=0.3)
        assert {a.unit for a in rec.axes} == {"m/s^2"}


@pytest.mark.skipif(not PX4_SAMPLE.exists(), reason="shared real data absent")
def test_px4_defaults_and_refusals():
    rec = read_recording(PX4_SAMPLE)  # the first gyro and its own temperature
    assert rec.axis_names == ("sensor_gyro_0_x", "sensor_gyro_0_y", "sensor_gyro_0_z")
    assert 35 < float(np.mean(rec.temperature_c)) < 45  # a heated IMU, ~40 degC (the sample's README)
    with pytest.raises(InputError, match="logged with their own time stamps; read one stream per run"):
        read_recording(PX4_SAMPLE, ColumnSpec(rate="sensor_*_0_x"))
    with pytest.raises(InputError, match="no column matches 'gyro'; the log has sensor_gyro_0_x"):
        read_recording(PX4_SAMPLE, ColumnSpec(rate="gyro"))
    with pytest.raises(InputError, match="a log's units come from its format .*; drop --time-unit, --rate-unit"):
        read_recording(PX4_SAMPLE, ColumnSpec(time_unit="ms", rate_unit="rad/s"))


@pytest.mark.skipif(not PX4_SAMPLE.exists(), reason="shared real data absent")
def test_longer_ulog_written_by_pyulog(tmp_path):
    """The sample with instance 1 of sensor_gyro replaced by 150 s at 200 Hz, written by pyulog's write_ulog."""
    log = pyulog.ULog(str(PX4_SAMPLE))
    data = next(d for d in log.data_list if d.name == "sensor_gyro" and d.multi_id == 1)
    n, fs = 30000, 200.0
    rng = np.random.default_rng(17)
    t0 = int(data.data["timestamp"][0])
    stamps = (t0 + np.round(np.arange(n) * 1e6 / fs)).astype(np.uint64)
    truth = {a: rng.normal(0.01 * k, 0.002, n).astype(np.float32) for k, a in enumerate("xyz")}
    temperature = (30.0 + 10.0 * np.arange(n) / n).astype(np.float32)
    data.data = {
        **{k: np.resize(v, n) for k, v in data.data.items()},
        "timestamp": stamps + 50,
        "timestamp_sample": stamps,
        **truth,
        "temperature": temperature,
    }
    path = tmp_path / "long.ulg"
    log.write_ulog(str(path))
    rec = read_recording(path, ColumnSpec(rate="sensor_gyro_1_[xyz]"), require_temperature=True)
    assert rec.n_samples == n
    assert rec.fs_hz == pytest.approx(fs, rel=1e-9)
    for a in "xyz":
        np.testing.assert_allclose(rec.column(f"sensor_gyro_1_{a}"), np.rad2deg(truth[a].astype(float)), rtol=1e-12)
    np.testing.assert_allclose(rec.temperature_c, temperature.astype(float))


# -- DataFlash, written here from the format's definition (ArduPilot AP_Logger: LogStructure.h) --

_HEAD = b"\xa3\x95"
_FMT_ID, _IMU_ID = 0x80, 0x43
_FMT_STRUCT = "<BB4s16s64s"  # Type, Length, Name (n), Format (N), Columns (Z)
_IMU_FORMAT, _IMU_COLUMNS = "QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"
_IMU_STRUCT = "<QBffffffIIfBBHH"


def _fmt(msg_id: int, name: str, fmt: str, columns: str, length: int) -> bytes:
    return _HEAD + bytes([_FMT_ID]) + struct.pack(_FMT_STRUCT, msg_id, length, name.encode(), fmt.encode(), columns.encode())


def _write_dataflash(path: Path, imus: dict[int, dict]) -> None:
    fmt_len = 3 + struct.calcsize(_FMT_STRUCT)
    imu_len = 3 + struct.calcsize(_IMU_STRUCT)
    assert fmt_len == 89  # the FMT message length every DataFlash log declares
    out = [_fmt(_FMT_ID, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns", fmt_len), _fmt(_IMU_ID, "IMU", _IMU_FORMAT, _IMU_COLUMNS, imu_len)]
    n = len(imus[0]["TimeUS"])
    for i in range(n):  # instances interleaved, as the logger writes them
        for inst, d in imus.items():
            row = (int(d["TimeUS"][i]), inst, *(float(d[f][i]) for f in ("GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ")), 0, 0, float(d["T"][i]), 1, 1, 400, 400)
            out.append(_HEAD + bytes([_IMU_ID]) + struct.pack(_IMU_STRUCT, *row))
    path.write_bytes(b"".join(out))


def _imu(n, fs, seed, t0_us=5_000_000):
    rng = np.random.default_rng(seed)
    d = {"TimeUS": t0_us + np.round(np.arange(n) * 1e6 / fs).astype(np.int64)}
    for k, f in enumerate(("GyrX", "GyrY", "GyrZ")):
        d[f] = rng.normal(0.002 * (k + 1), 1e-3, n).astype(np.float32)
    for k, f in enumerate(("AccX", "AccY", "AccZ")):
        d[f] = rng.normal(-9.80665 if f == "AccZ" else 0.0, 0.05, n).astype(np.float32)
    d["T"] = np.linspace(25.0, 45.0, n).astype(np.float32)
    return d


def test_dataflash_imu_instances_read_with_units_and_temperature(tmp_path):
    n, fs = 4000, 400.0
    imus = {0: _imu(n, fs, 1), 1: _imu(n, fs, 2)}
    path = tmp_path / "00000042.BIN"
    _write_dataflash(path, imus)
    rec = read_recording(path)  # the first gyro, its temperature T
    assert rec.axis_names == ("IMU_0_GyrX", "IMU_0_GyrY", "IMU_0_GyrZ")
    assert rec.fs_hz == pytest.approx(fs, rel=1e-9)
    np.testing.assert_allclose(rec.column("IMU_0_GyrY"), np.rad2deg(imus[0]["GyrY"].astype(float)), rtol=1e-12)
    np.testing.assert_allclose(rec.temperature_c, imus[0]["T"].astype(float))
    both = read_recording(path, ColumnSpec(rate="IMU_1_Gyr?,IMU_1_Acc?"))
    assert [(a.name, a.unit) for a in both.axes][2:4] == [("IMU_1_GyrZ", "deg/s"), ("IMU_1_AccX", "m/s^2")]
    np.testing.assert_allclose(both.column("IMU_1_AccZ"), imus[1]["AccZ"].astype(float), rtol=1e-12)
    np.testing.assert_allclose(both.time_s, (imus[1]["TimeUS"] - imus[1]["TimeUS"][0]) * 1e-6, atol=1e-12)


def test_damaged_or_foreign_logs_give_one_line(tmp_path):
    path = tmp_path / "x.ulg"
    path.write_bytes(b"not a log at all")
    with pytest.raises(InputError, match=r"x.ulg: not a readable ULog file") as info:
        read_recording(path)
    assert "\n" not in str(info.value)
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="empty.bin: not a readable DataFlash log"):
        read_recording(empty)
    formats_only = tmp_path / "formats.bin"
    _write_dataflash(formats_only, {0: {"TimeUS": []}})
    with pytest.raises(InputError, match="formats.bin: no IMU message in the log"):
        read_recording(formats_only)


# -- gyro and accelerometer of a ULog in one run: each topic on its own time stamps --


def _two_topic_ulog(path: Path) -> dict:
    """The PX4 sample with sensor_gyro 0 (120 s at 200 Hz) and sensor_accel 0 (120 s at 100 Hz, stamps 1.7 ms
    later) replaced, written with pyulog's write_ulog; both warm 30 -> 40 degC with a known drift. Returns the truth."""
    log = pyulog.ULog(str(PX4_SAMPLE))
    rng = np.random.default_rng(21)
    truth = {}
    for topic, fs, lag_us, drift in (("sensor_gyro", 200.0, 0, 0.002), ("sensor_accel", 100.0, 1700, 0.05)):
        data = next(d for d in log.data_list if d.name == topic and d.multi_id == 0)
        n = int(120 * fs)
        t0 = int(data.data["timestamp"][0]) + lag_us
        stamps = (t0 + np.round(np.arange(n) * 1e6 / fs)).astype(np.uint64)
        temperature = (30.0 + 10.0 * np.arange(n) / n + 0.5 * np.sin(np.arange(n) / fs / 7.0)).astype(np.float32)
        axes = {a: (drift * (temperature - 35.0) + rng.normal(0.0, 1e-3, n)).astype(np.float32) for a in "xyz"}
        data.data = {**{k: np.resize(v, n) for k, v in data.data.items()}, "timestamp": stamps + 50, "timestamp_sample": stamps, **axes, "temperature": temperature}
        truth[topic] = {"n": n, "fs": fs, "stamps": stamps}
    log.write_ulog(str(path))
    return truth


def _cli(*args) -> None:
    from typer.testing import CliRunner

    from gyrocomp.cli import app

    result = CliRunner().invoke(app, ["-q", *[str(a) for a in args]])
    assert result.exit_code == 0, result.output


@pytest.mark.skipif(not PX4_SAMPLE.exists(), reason="shared real data absent")
def test_ulog_gyro_and_accel_in_one_run_each_on_its_own_time_base(tmp_path):
    """allan, train and compensate take gyro and accel of one ULog together; each stream equals the same command
    on that stream alone (to 1e-12), on its own stamps: nothing is put onto the other topic's time base."""
    import json

    import pandas as pd

    from gyrocomp.recordings import read_recordings

    path = tmp_path / "two.ulg"
    truth = _two_topic_ulog(path)
    both = "sensor_*_0_[xyz]"
    streams = read_recordings(path, ColumnSpec(rate=both), require_temperature=True)
    assert [r.metadata["stream"] for r in streams] == ["sensor_gyro_0", "sensor_accel_0"]
    for rec, topic in zip(streams, ("sensor_gyro", "sensor_accel")):
        stamps = truth[topic]["stamps"].astype(np.int64)
        assert rec.n_samples == truth[topic]["n"] and rec.fs_hz == pytest.approx(truth[topic]["fs"], rel=1e-9)
        assert rec.time_origin == f"{stamps[0]} us"
    with pytest.raises(InputError, match="own time stamps; read one stream per run .allan, train and compensate take several"):
        read_recording(path, ColumnSpec(rate=both))

    _cli("allan", path, "--rate-col", both, "--out", tmp_path / "a.json")
    series = {s["column"]: s for s in json.loads((tmp_path / "a.json").read_text())["series"]}
    assert list(series) == [f"{t}_0_{a}" for t in ("sensor_gyro", "sensor_accel") for a in "xyz"]
    _cli("train", path, "--rate-col", both, "--config", "polynomial", "--out", tmp_path / "m.json")
    model = json.loads((tmp_path / "m.json").read_text())
    assert list(model["axes"]) == list(series)
    _cli("compensate", path, tmp_path / "m.json", "--rate-col", both, "--out", tmp_path / "c.parquet")
    assert not (tmp_path / "c.parquet").exists()
    for topic in ("sensor_gyro", "sensor_accel"):
        alone = f"{topic}_0_[xyz]"
        _cli("allan", path, "--rate-col", alone, "--out", tmp_path / f"a_{topic}.json")
        for s in json.loads((tmp_path / f"a_{topic}.json").read_text())["series"]:
            np.testing.assert_allclose(series[s["column"]]["adev"], s["adev"], rtol=1e-12)
        _cli("train", path, "--rate-col", alone, "--config", "polynomial", "--out", tmp_path / f"m_{topic}.json")
        for axis, one in json.loads((tmp_path / f"m_{topic}.json").read_text())["axes"].items():
            assert model["axes"][axis]["segments"] == one["segments"] and model["axes"][axis]["training"] == one["training"]
        _cli("compensate", path, tmp_path / f"m_{topic}.json", "--rate-col", alone, "--out", tmp_path / f"c_{topic}.parquet")
        together = pd.read_parquet(tmp_path / f"c_{topic}_0.parquet")
        by_itself = pd.read_parquet(tmp_path / f"c_{topic}.parquet")
        assert len(together) == truth[topic]["n"]  # its own samples, none added from the other topic
        pd.testing.assert_frame_equal(together, by_itself, rtol=1e-12)
        assert (tmp_path / f"c_{topic}_0.meta.json").is_file()
        scale = 180 / np.pi if topic == "sensor_gyro" else 1.0  # the drift put in, in the recording's unit
        for a in "xyz":
            left = np.polyfit(together["temperature"], together[f"{topic}_0_{a}_compensated"], 1)[0]
            assert abs(left) < 0.05 * (0.002 * scale if topic == "sensor_gyro" else 0.05)
