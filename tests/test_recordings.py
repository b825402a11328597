"""Recordings as real loggers write them: several axes, time bases, compression, CSV dialects, gaps, duplicates."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gyrocomp import artefacts, compressed, recordings
from gyrocomp.errors import InputError
from gyrocomp.recordings import ColumnSpec, read_recording, timebase

REPO = Path(__file__).resolve().parents[1]
REAL_DATA = Path(os.environ.get("GYROCOMP_REAL_DATA", REPO.parent / "shared" / "real-data"))  # as tests/conftest.py
LSM6DSM = REAL_DATA / "pan-lsm6dsm-tvac" / "pan_lsm6dsm_tvac_cold_2020-03-07.csv"


def _three_axis(n=200, fs=100.0, t0=0.0):
    t = t0 + np.arange(n) / fs
    return pd.DataFrame(
        {
            "time": t,
            "gx": 0.1 + 0.01 * np.sin(t),
            "gy": -0.2 + 0.0 * t,
            "gz": 0.3 + 0.001 * t,
            "ax": np.full(n, 0.0),
            "ay": np.full(n, 0.0),
            "az": np.full(n, 1.0),
            "temp": 25.0 + 0.01 * t,
        }
    )


def test_several_axes_by_list_and_glob_keep_their_names(tmp_path):
    frame = _three_axis()
    path = tmp_path / "imu.csv"
    frame.to_csv(path, index=False)
    by_list = read_recording(path, ColumnSpec(rate="gx,gy,gz", temperature="temp"), require_temperature=True)
    by_glob = read_recording(path, ColumnSpec(rate="g?", temperature="temp"))
    assert by_list.axis_names == by_glob.axis_names == ("gx", "gy", "gz")
    for name in ("gx", "gy", "gz"):
        np.testing.assert_array_equal(by_glob.column(name), frame[name].to_numpy())
    np.testing.assert_array_equal(by_list.temperature_c, frame["temp"].to_numpy())
    one = by_list.axis("gy")
    assert one.axis_names == ("gy",) and one.axes[0].column == "rate"
    np.testing.assert_array_equal(one.rate_dps, frame["gy"].to_numpy())
    with pytest.raises(InputError, match=r"imu.csv: 3 axes \(gx, gy, gz\); this command takes one"):
        by_list.rate_dps
    with pytest.raises(InputError, match="imu.csv: no column matches 'w_\\*'"):
        read_recording(path, ColumnSpec(rate="w_*"))


def test_exact_names_with_brackets_are_matched_before_globs(tmp_path):
    """Issue 35 item 6: 'Temperatur [°C]' is a name of the file, not the glob class [°C]."""
    t = np.arange(300) / 10.0
    frame = pd.DataFrame(
        {"time": t, "Gyro X [dps]": 0.1 + 0.001 * t, "Temperatur [°C]": 20.0 + 0.1 * t, "Temperatur C": np.full(300, -5.0)}
    )
    path = tmp_path / "bracket.csv"
    frame.to_csv(path, index=False, encoding="utf-8")
    spec = ColumnSpec(rate="Gyro X [dps]", temperature="Temperatur [°C]")
    for usecols in (None, ["Temperatur [°C]"]):
        rec = read_recording(path, spec, require_temperature=True, usecols=usecols)
        assert rec.axis_names == ("Gyro X [dps]",)
        np.testing.assert_allclose(rec.temperature_c, frame["Temperatur [°C]"].to_numpy(), rtol=0, atol=1e-12)
    from gyrocomp.columns import matching_columns  # the rule every reader (CSV, Parquet, flight logs) shares

    assert matching_columns(["Temperatur C", "Temperatur °"], "Temperatur [°C]") == ["Temperatur C", "Temperatur °"]
    assert matching_columns(["Temperatur [°C]", "Temperatur C"], "Temperatur [°C]") == ["Temperatur [°C]"]


def test_accelerometer_axes_have_their_own_units(tmp_path):
    frame = _three_axis()
    path = tmp_path / "imu.csv"
    frame.to_csv(path, index=False)
    spec = ColumnSpec(rate="g*,a*", rate_unit="rad/s,g", temperature="temp")
    rec = read_recording(path, spec)
    units = {a.name: (a.quantity, a.unit, a.file_unit) for a in rec.axes}
    assert units["gx"] == ("angular_rate", "deg/s", "rad/s")
    assert units["az"] == ("acceleration", "m/s^2", "g")
    np.testing.assert_allclose(rec.column("az"), 9.80665)  # standard gravity, SI brochure
    np.testing.assert_allclose(rec.column("gy"), -0.2 * 180 / math.pi)
    with pytest.raises(InputError, match="give one unit, or one per --rate-col entry"):
        ColumnSpec(rate="g*,a*", rate_unit="deg/s,g,g")
    with pytest.raises(InputError, match="unknown rate unit 'furlong'"):
        ColumnSpec(rate_unit="furlong")


def test_microseconds_without_a_unit_are_refused_naming_the_unit(tmp_path):
    n, fs = 2000, 100.0
    us = (1_700_000_000_000_000 + np.arange(n) * int(1e6 / fs)).astype(np.int64)
    frame = pd.DataFrame({"timestamp": us, "rate": np.zeros(n)})
    path = tmp_path / "px4.csv"
    frame.to_csv(path, index=False)
    with pytest.raises(InputError) as info:
        read_recording(path, ColumnSpec(time="timestamp"))
    message = str(info.value)
    assert message.startswith(f"{path}: `timestamp` read as seconds")
    assert "microseconds (µs, us): pass --time-unit us" in message
    assert "\n" not in message
    rec = read_recording(path, ColumnSpec(time="timestamp", time_unit="us"))
    assert rec.fs_hz == pytest.approx(fs, rel=1e-12)
    assert rec.time_s[-1] - rec.time_s[0] == pytest.approx((n - 1) / fs, rel=1e-12)


@pytest.mark.parametrize(
    "scale, unit, fs, span_s",
    [(1e3, "ms", 100.0, 3600.0), (1e9, "ns", 1000.0, 4.0), (1e6, "us", 200.0, 20.0), (1e6, "us", 1000.0, 4.0)],
)
def test_other_wrong_time_bases_name_their_unit(tmp_path, scale, unit, fs, span_s):
    n = int(span_s * fs)
    t = np.arange(n) / fs * scale
    path = tmp_path / "t.csv"
    pd.DataFrame({"time": t, "rate": np.zeros(n)}).to_csv(path, index=False)
    with pytest.raises(InputError, match=f"it looks like .*: pass --time-unit {unit}"):
        read_recording(path)
    assert read_recording(path, ColumnSpec(time_unit=unit)).fs_hz == pytest.approx(fs)
    # an explicit unit is obeyed, plausible or not
    assert read_recording(path, ColumnSpec(time_unit="s")).fs_hz == pytest.approx(fs / scale)


def test_iso_datetimes_are_read_as_seconds_from_the_first(tmp_path):
    start = pd.Timestamp("2024-03-07T15:45:00Z")
    stamps = start + pd.to_timedelta(np.arange(300) * 0.5, unit="s")
    frame = pd.DataFrame({"time": [s.isoformat() for s in stamps], "rate": np.arange(300.0)})
    path = tmp_path / "lab.csv"
    frame.to_csv(path, index=False)
    for spec in (ColumnSpec(), ColumnSpec(time_unit="datetime")):
        rec = read_recording(path, spec)
        np.testing.assert_allclose(rec.time_s, np.arange(300) * 0.5, atol=1e-9)
        assert rec.fs_hz == pytest.approx(2.0)
        assert rec.time_origin == "2024-03-07T15:45:00+00:00"
    frame.loc[7, "time"] = "yesterday"
    frame.to_csv(path, index=False)
    with pytest.raises(InputError, match="lab.csv line 9: `time` = 'yesterday' is not an ISO 8601 date"):
        read_recording(path)


@pytest.mark.parametrize("suffix", [".csv.gz", ".csv.bz2", ".csv.xz", ".csv.zst", ".csv.zip"])
def test_compressed_csv_reads_like_the_plain_file(tmp_path, suffix):
    frame = _three_axis()
    plain = tmp_path / "imu.csv"
    frame.to_csv(plain, index=False)
    packed = tmp_path / f"imu{suffix}"
    frame.to_csv(packed, index=False)  # pandas compresses by extension
    assert packed.read_bytes() != plain.read_bytes()
    spec = ColumnSpec(rate="gx,gy,gz", temperature="temp")
    a, b = read_recording(plain, spec), read_recording(packed, spec)
    pd.testing.assert_frame_equal(a.data, b.data, check_exact=True)
    assert b.sha256 == artefacts.file_sha256(packed)


def test_a_zip_member_in_a_method_zipfile_cannot_read_is_refused_by_name(tmp_path):
    """Deflate64 (method 9), which Windows' Explorer writes for large files: a one-line error naming the member and method."""
    import zipfile

    path = tmp_path / "imu.csv.zip"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        archive.writestr("imu.csv", "time,rate\n0,1\n1,2\n")
    data = bytearray(path.read_bytes())
    central = data.index(b"PK\x01\x02")  # the central directory's method field, which zipfile reads
    data[central + 10 : central + 12] = (9).to_bytes(2, "little")
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"imu\.csv\.zip: imu\.csv is compressed with zip method 9, which gyrocomp does not read "
                                         r"\(stored, deflate, bzip2, lzma\); recompress it"):
        read_recording(path)


def test_semicolon_and_decimal_comma(tmp_path):
    text = "time;rate;temperature\n0,0;1,5;20,25\n0,5;1,75;20,5\n1,0;2,0;20,75\n"
    path = tmp_path / "lab.csv"
    path.write_text(text)
    rec = read_recording(path, ColumnSpec(sep=";", decimal=","))
    np.testing.assert_array_equal(rec.rate_dps, [1.5, 1.75, 2.0])
    np.testing.assert_array_equal(rec.temperature_c, [20.25, 20.5, 20.75])
    with pytest.raises(InputError, match=r"lab\.csv: the first data row has more fields than the header \(a header read as one column: pass --sep\)"):
        read_recording(path)
    (tmp_path / "dots.csv").write_text("time;rate;temperature\n0.0;1.5;20.25\n0.5;1.75;20.5\n")
    with pytest.raises(InputError, match="one column only: is the separator another one\\? pass --sep"):
        read_recording(tmp_path / "dots.csv")


def test_duplicate_stamps_refused_naming_the_line_or_merged(tmp_path):
    text = "time,rate,temperature\n0,1,20\n1,2,20\n1,4,21\n2,3,20\n3,5,20\n"
    path = tmp_path / "d.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=r"d.csv line 4: `time` = 1.0 duplicates the previous time 1.0;.*--dedupe first\|mean"):
        read_recording(path)
    first = read_recording(path, ColumnSpec(dedupe="first"))
    np.testing.assert_array_equal(first.time_s, [0, 1, 2, 3])
    np.testing.assert_array_equal(first.rate_dps, [1, 2, 3, 5])
    mean = read_recording(path, ColumnSpec(dedupe="mean"))
    np.testing.assert_array_equal(mean.rate_dps, [1, 3, 3, 5])
    np.testing.assert_array_equal(mean.temperature_c, [20, 20.5, 20, 20])
    assert mean.notes == ("merged 1 duplicate time stamps in 1 places (averaged the rows; --dedupe mean)",)
    # a row after the merge is still named by its line in the file
    path.write_text(text + "4,x,20\n")
    with pytest.raises(InputError, match="d.csv line 7: `rate` = 'x' is not a number"):
        read_recording(path, ColumnSpec(dedupe="first"))


def test_gaps_become_segments_never_silently_filled(tmp_path):
    t = np.r_[np.arange(100) * 0.1, 60.0 + np.arange(50) * 0.1, 200.0 + np.arange(30) * 0.1]
    frame = pd.DataFrame({"time": t, "rate": t.copy()})
    with pytest.raises(InputError, match=r"<table> row 151: sampling interval 135.1 s"):
        recordings.recording_from_frame(frame)
    rec = recordings.recording_from_frame(frame, allow_gaps=True)
    assert [(s.start, s.stop) for s in rec.segments] == [(0, 100), (100, 150), (150, 180)]
    assert rec.fs_hz == pytest.approx(10.0)
    assert rec.notes == ("3 segments: 2 gaps, the longest 135.1 s (not interpolated)",)
    parts = rec.split()
    assert [p.n_samples for p in parts] == [100, 50, 30]
    np.testing.assert_array_equal(parts[1].rate_dps, t[100:150])
    filled = recordings.recording_from_frame(frame, resample=True)
    assert filled.notes == ("resampled onto a uniform 0.1 s grid: 2 gaps filled by linear interpolation, the longest 135.1 s",)
    assert len(filled.segments) == 1 and filled.n_samples == 2030


def test_time_limits_equal_the_shipped_config():
    from gyrocomp.config import bind, load_config

    table = load_config("recordings")
    assert bind(recordings.TimeLimits, table["time"], "recordings.toml") == recordings.TimeLimits()
    assert bind(recordings.AxisLimits, table["axes"], "recordings.toml") == recordings.AxisLimits()
    assert recordings.file_limits() == compressed.FileLimits()
    assert bind(recordings.TemperatureLimits, table["temperature"], "recordings.toml") == recordings.TemperatureLimits()
    assert recordings.length_limits() == recordings.LengthLimits()


@pytest.mark.skipif(not LSM6DSM.exists(), reason="shared real data absent")
def test_lsm6dsm_bursts_read_as_segments_with_the_published_slopes():
    """PAN LSM6DSM TVAC log: 25 bursts of 5 s at 50 Hz, 5 duplicate stamps; slopes as in its README."""
    with pytest.raises(InputError, match="duplicates the previous time"):
        read_recording(LSM6DSM, ColumnSpec(rate="rate_*"), allow_gaps=True)
    rec = read_recording(LSM6DSM, ColumnSpec(rate="rate_*", dedupe="first"), allow_gaps=True, require_temperature=True)
    assert rec.axis_names == ("rate_x", "rate_y", "rate_z")
    assert len(rec.segments) == 25
    assert rec.n_samples == 6250 - 5
    assert rec.fs_hz == pytest.approx(50.0, rel=0.01)
    assert all(240 <= s.stop - s.start <= 250 for s in rec.segments)
    # bias against temperature from the burst medians, as the folder's README fits it
    parts = rec.split()
    temps = np.array([np.median(p.temperature_c) for p in parts])
    expected = {"rate_x": 0.0301, "rate_y": -0.0142, "rate_z": 0.0014}  # deg/s/degC, README of the data set
    for axis, slope in expected.items():
        medians = np.array([np.median(p.column(axis)) for p in parts])
        assert np.polyfit(temps, medians, 1)[0] == pytest.approx(slope, abs=6e-4)


def test_the_command_line_says_what_resample_filled(tmp_path):
    """A gap: `allan` analyses each segment alone (never across the gap) and pools them into one series,
    each segment's on request (`--segments`); `--resample` is never silent: a note on stderr, and the note
    in the artefact's inputs."""
    import json

    from typer.testing import CliRunner

    from gyrocomp.cli import app

    t = np.r_[np.arange(400) * 0.5, 400.0 + np.arange(400) * 0.5]
    path = tmp_path / "gappy.csv"
    pd.DataFrame({"time": t, "rate": np.random.default_rng(3).normal(0, 0.01, t.size)}).to_csv(path, index=False)
    out = tmp_path / "allan.json"
    segmented = CliRunner().invoke(app, ["allan", str(path), "--out", str(out)])
    assert segmented.exit_code == 0, segmented.output
    assert "2 segments: 1 gaps, the longest 200.5 s (not interpolated)" in segmented.stderr
    (pooled,) = json.loads(out.read_text())["series"]
    assert pooled["name"] == "gappy.csv" and pooled["n"][0] == 2 * 399  # both segments' terms, none across the gap
    assert CliRunner().invoke(app, ["allan", str(path), "--out", str(out), "--segments"]).exit_code == 0
    series = json.loads(out.read_text())["series"]
    assert [s["name"] for s in series] == ["gappy.csv", "gappy.csv segment 1", "gappy.csv segment 2"]
    for s in series[1:]:
        assert s["n"][0] == 399
    for s in series:  # white noise of 0.01 deg/s at 2 Hz is ARW 0.424 deg/sqrt(h)
        assert s["terms"]["arw"]["value"] == pytest.approx(0.01 * np.sqrt(0.5) * 60, rel=0.1)
    result = CliRunner().invoke(app, ["allan", str(path), "--out", str(out), "--resample"])
    assert result.exit_code == 0, result.output
    note = "resampled onto a uniform 0.5 s grid: 1 gaps filled by linear interpolation, the longest 200.5 s"
    assert f"gyrocomp: note: {path}: {note}" in result.stderr
    assert json.loads(out.read_text())["inputs"][0]["notes"] == [note]


def test_command_line_time_bases_and_compression(tmp_path):
    """µs stamps: exit 2 naming µs, nothing written; with --time-unit us, and as .csv.gz with ISO datetimes, read right."""
    from typer.testing import CliRunner

    from gyrocomp.cli import app

    n, fs = 3000, 100.0
    rng = np.random.default_rng(5)
    rate = rng.normal(0.0, 0.1, n)
    frame = pd.DataFrame({"timestamp": 1_000_000 + np.arange(n) * 10_000, "rate": rate})
    path = tmp_path / "px4.csv"
    frame.to_csv(path, index=False)
    out = tmp_path / "allan.json"
    refused = CliRunner().invoke(app, ["allan", str(path), "--time-col", "timestamp", "--out", str(out)])
    assert refused.exit_code == 2
    assert refused.stderr.count("\n") == 1 and "microseconds (µs, us): pass --time-unit us" in refused.stderr
    assert not out.exists()
    ok = CliRunner().invoke(app, ["allan", str(path), "--time-col", "timestamp", "--time-unit", "us", "--out", str(out), "-q"])
    assert ok.exit_code == 0, ok.output
    fs_us = pd.read_json(out, typ="series")["series"][0]["fs_hz"]
    iso = tmp_path / "lab.csv.gz"
    stamps = pd.Timestamp("2024-01-01T00:00:00Z") + pd.to_timedelta(np.arange(n) * 10, unit="ms")
    pd.DataFrame({"time": [s.isoformat() for s in stamps], "rate": rate}).to_csv(iso, index=False)
    ok = CliRunner().invoke(app, ["allan", str(iso), "--out", str(out), "-q"])
    assert ok.exit_code == 0, ok.output
    assert fs_us == pd.read_json(out, typ="series")["series"][0]["fs_hz"] == pytest.approx(fs)


@pytest.mark.parametrize("at", [1, 65_535, 65_536, 65_537, 150_000, 199_999])
def test_checks_in_chunks_name_the_row_past_the_first_chunk(at):
    """The per-sample checks look at 65 536 samples at a time: a defect anywhere, on either side of a chunk's edge, is named by its row."""
    n = 200_000
    base = {"time": np.arange(n) / 1000.0, "rate": np.zeros(n), "temperature": np.full(n, 25.0)}

    def refused(column, value):
        arrays = {k: v.copy() for k, v in base.items()}
        arrays[column][at] = value
        with pytest.raises(InputError) as err:
            recordings.recording_from_frame(arrays, name="long")
        return str(err.value)

    assert refused("rate", np.nan).startswith(f"long row {at + 1}: `rate` is missing or NaN")
    assert refused("rate", -np.inf).startswith(f"long row {at + 1}: `rate` is -inf")
    assert refused("time", np.inf).startswith(f"long row {at + 1}: `time` is inf")
    assert refused("rate", 2e5).startswith(f"long row {at + 1}: `rate` = 200000 deg/s is beyond")
    assert refused("temperature", 300.0).startswith(f"long row {at + 1}: `temperature` = 300 degC is outside")
    assert refused("time", base["time"][at - 1] - 1.0).startswith(f"long row {at + 1}: `time` = ")
    assert "goes back" in refused("time", base["time"][at - 1] - 1.0)
    assert refused("time", base["time"][at - 1]).startswith(f"long row {at + 1}: `time` = {float(base['time'][at - 1])!r} duplicates")
    jitter = refused("time", base["time"][at] - 0.0009) if at < n - 1 else None
    if jitter is not None:
        assert jitter.startswith(f"long row {at + 1}: sampling interval 0.0001 s in `time`")


def test_gaps_and_duplicates_across_chunks_are_counted_whole():
    n = 200_000
    time = np.arange(n) / 1000.0
    time[[65_536, 140_000]] = time[[65_535, 139_999]]  # two duplicates, one at a chunk's edge
    arrays = {"time": time, "rate": np.zeros(n)}
    with pytest.raises(InputError, match=r"long row 65537: .*\(2 duplicate stamps;"):
        recordings.recording_from_frame(arrays, name="long")
    gapped = np.arange(n) / 1000.0
    gapped[65_536:] += 1.0
    gapped[150_000:] += 2.5
    with pytest.warns(recordings.RecordingNote, match="3 segments: 2 gaps, the longest 2.501 s"):
        rec = recordings.recording_from_frame({"time": gapped, "rate": np.zeros(n)}, name="long", allow_gaps=True)
    assert [(s.start, s.stop) for s in rec.segments] == [(0, 65_536), (65_536, 150_000), (150_000, n)]


@pytest.mark.parametrize("n", [40_001, 40_002])
def test_median_interval_of_a_long_axis_is_numpys_without_the_intervals(monkeypatch, n):
    """The chunked selection gives ``np.median(np.diff(time))`` bit for bit: regular, random, gapped and two-valued axes."""
    monkeypatch.setattr(timebase, "_MEDIAN_ROWS", 1000)  # select a chunk at a time from 1000 intervals on
    monkeypatch.setattr(timebase, "_CHECK_ROWS", 4096)
    rng = np.random.default_rng(38)
    gapped = np.arange(n) / 100.0
    gapped[n // 2 :] += 5.0
    axes = {
        "regular": np.arange(n) / 1000.0,
        "random": np.cumsum(rng.uniform(0.5, 1.5, n)),
        "gapped": gapped,
        "rounding": np.cumsum(rng.choice([0.001, 0.0010000001, 0.002], n, p=[0.49, 0.02, 0.49])),
        "halves": np.cumsum(np.r_[np.full(n // 2, 0.001), np.full(n - n // 2, 0.002)]),
        "lognormal": np.cumsum(rng.lognormal(0.0, 2.0, n)),
    }
    for name, time in axes.items():
        expected = np.median(np.diff(time))
        assert recordings.median_interval(time) == expected, name


def test_interval_range_is_the_least_and_largest_interval(monkeypatch):
    """The one pass that clears a regular time axis gives ``np.diff``'s min and max, NaN for a NaN interval, across its blocks."""
    monkeypatch.setattr(timebase, "_CHECK_ROWS", 1000)
    rng = np.random.default_rng(38)
    time = np.cumsum(rng.uniform(0.5, 1.5, 10_001))
    time[7_500:] += 3.0  # a gap in the eighth block
    assert timebase.interval_range(time) == (np.diff(time).min(), np.diff(time).max())
    time[2_000] = time[1_999]  # a duplicate on a block's edge
    assert timebase.interval_range(time)[0] == 0.0
    time[9_000] = np.nan
    assert all(math.isnan(v) for v in timebase.interval_range(time))
    assert timebase.interval_range(np.array([1.0])) == (math.inf, -math.inf)


def test_an_extra_column_of_infinities_is_kept_and_one_with_a_nan_dropped():
    """A further column is kept when every cell is a number, infinities included (their sum is NaN, as a NaN's is)."""
    n = 1000
    arrays = {"time": np.arange(n) / 100.0, "rate": np.zeros(n), "both": np.r_[np.inf, -np.inf, np.ones(n - 2)], "hole": np.r_[np.ones(n - 1), np.nan]}
    rec = recordings.recording_from_frame(arrays, name="extra")
    assert "hole" not in rec.columns
    np.testing.assert_array_equal(rec.column("both"), arrays["both"])
