"""Recording I/O: every rejection names file, row and column; writes are atomic."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyrocomp import artefacts, recordings
from gyrocomp.errors import InputError, SchemaError


def _frame(n=20, fs=10.0, temperature=True):
    t = np.arange(n) / fs
    data = {"time": t, "rate": np.sin(t)}
    if temperature:
        data["temperature"] = 25.0 + 0.1 * t
    return pd.DataFrame(data)


def _write_csv(tmp_path, text, name="rec.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    n=st.integers(2, 60),
    fs=st.sampled_from([0.5, 1.0, 2.0, 100.0, 1000.0]),
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["csv", "parquet"]),
)
def test_valid_tables_round_trip_exactly(tmp_path, n, fs, seed, kind):
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame(
        {
            "time": 12.5 + np.arange(n) / fs,
            "rate": rng.normal(0, 1, n) * 10.0 ** rng.integers(-6, 3),
            "temperature": rng.uniform(-40, 85, n),
        }
    )
    path = tmp_path / f"rec_{seed}_{n}.{kind}"
    artefacts.write_table(path, frame, artefacts.artefact_header("gyrocomp.recording"))
    rec = recordings.read_recording(path, require_temperature=True)
    pd.testing.assert_frame_equal(rec.data, frame, check_exact=True)
    assert rec.fs_hz == pytest.approx(fs, rel=1e-9)


def test_sha256_is_of_the_file_bytes(tmp_path):
    import hashlib

    path = tmp_path / "r.csv"
    _frame().to_csv(path, index=False)
    rec = recordings.read_recording(path)
    assert rec.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert rec.input_record() == {"name": "r.csv", "sha256": rec.sha256}


def test_sha256_on_a_thread_is_the_file_sha256(tmp_path):
    """The streamed reader's hash, computed beside the reading, is :func:`file_sha256`; a missing file is refused at once."""
    import hashlib

    from gyrocomp import streaming

    path = tmp_path / "r.parquet"
    pd.DataFrame({"time": np.arange(3000) / 10.0, "rate": np.random.default_rng(5).normal(size=3000)}).to_parquet(path)
    digest = artefacts.file_sha256_started(path)
    assert digest() == hashlib.sha256(path.read_bytes()).hexdigest() == artefacts.file_sha256(path)
    reader = streaming.read_chunks(path, rows=1000)
    assert sum(len(c.time_s) for c in reader) == 3000 == reader.n_rows
    assert reader.input_record() == {"name": "r.parquet", "sha256": artefacts.file_sha256(path)}
    with pytest.raises(InputError, match="no such file"):
        artefacts.file_sha256_started(tmp_path / "gone.parquet")


def test_chunks_read_only_are_the_chunks_without_their_copies(tmp_path):
    """``writable=False`` hands out views of the decoded row groups, with the values and checks of the copies."""
    from gyrocomp import streaming

    path = tmp_path / "r.parquet"
    frame = pd.DataFrame({"time": np.arange(5000) / 10.0, "rate": np.random.default_rng(6).normal(size=5000)})
    frame.to_parquet(path, row_group_size=2000)
    copies = list(streaming.read_chunks(path, rows=1000))
    views = list(streaming.read_chunks(path, rows=1000, writable=False))
    assert copies[0].rate_dps.base is None and copies[1].time_s.base is None  # copied out of the row group
    assert views[0].rate_dps.base is views[1].rate_dps.base is not None  # the first row group's 2000 rates
    assert views[0].time_s.base is views[1].time_s.base is not None
    for a, b in zip(copies, views, strict=True):
        np.testing.assert_array_equal(a.rate_dps, b.rate_dps)
        np.testing.assert_array_equal(a.time_s, b.time_s)
    frame.loc[3500, "rate"] = np.nan
    frame.to_parquet(path, row_group_size=2000)
    with pytest.raises(InputError, match="row 3501: `rate` is missing or NaN"):
        list(streaming.read_chunks(path, rows=1000, writable=False))


@pytest.mark.parametrize(
    "text, expected",
    [
        ("", "file is empty"),
        ("\n\n", "file is empty"),
        ("time,rate,temperature\n", "no data rows"),
        ("time,rate\n0,1\n1,2\n", "missing column 'temperature'"),
        ("time,rate,temperature\n0,1,20\n1,abc,20\n2,1,20\n", "line 3: `rate` = 'abc' is not a number"),
        ("time,rate,temperature\n0,1,20\n1,nan,20\n2,1,20\n", "line 3: `rate` is missing or NaN"),
        ("time,rate,temperature\n0,1,20\n1,inf,20\n2,1,20\n", "line 3: `rate` is inf"),
        ("time,rate,temperature\n0,1,20\n1,1,20\n2,1\n", "line 4: `temperature` is missing or NaN"),
        ("time,rate,temperature\n0,1,20\n2,1,20\n1,1,20\n", "line 4: `time` = 1.0 goes back"),
        ("time,rate,temperature\n0,1,20\n1,1,20\n1,1,20\n2,1,20\n", "line 4: `time` = 1.0 duplicates"),
        ("time,rate,temperature\n0,1,20\n1,1,20\n2,1,20\n5,1,20\n6,1,20\n", "line 5: sampling interval 3 s"),
        ("time,rate,temperature\n0,1,300\n1,1,300\n", "line 2: `temperature` = 300 degC is outside"),
    ],
)
def test_bad_csv_is_rejected_naming_line_and_column(tmp_path, text, expected):
    path = _write_csv(tmp_path, text)
    with pytest.raises(InputError) as info:
        recordings.read_recording(path, require_temperature=True)
    message = str(info.value)
    assert message.startswith(str(path))
    assert expected in message
    assert "\n" not in message


def test_missing_file_and_unknown_extension(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        recordings.read_recording(tmp_path / "absent.csv")
    path = tmp_path / "rec.xlsx"
    path.write_bytes(b"x")
    with pytest.raises(InputError, match="unknown extension '.xlsx'"):
        recordings.read_recording(path)


def test_too_few_samples(tmp_path):
    path = _write_csv(tmp_path, "time,rate\n0,1\n1,1\n2,1\n")
    with pytest.raises(InputError, match="3 samples, this command needs at least 10"):
        recordings.read_recording(path, min_samples=10)


def test_corrupted_parquet_is_rejected(tmp_path):
    good = tmp_path / "good.parquet"
    artefacts.write_table(good, _frame(), artefacts.artefact_header("gyrocomp.recording"))
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(good.read_bytes()[: len(good.read_bytes()) // 2])
    with pytest.raises(InputError, match="bad.parquet: not a readable Parquet file"):
        recordings.read_recording(bad)


def test_parquet_nan_names_row(tmp_path):
    frame = _frame()
    frame.loc[7, "rate"] = np.nan
    path = tmp_path / "r.parquet"
    artefacts.write_table(path, frame, artefacts.artefact_header("gyrocomp.recording"))
    with pytest.raises(InputError, match=r"r.parquet row 8: `rate` is missing or NaN"):
        recordings.read_recording(path)


def test_column_mapping_and_units(tmp_path):
    n = 50
    frame = pd.DataFrame(
        {
            "t_ms": np.arange(n) * 10.0,
            "gz": np.full(n, 3600.0),
            "temp_k": np.full(n, 298.15),
        }
    )
    path = tmp_path / "r.csv"
    frame.to_csv(path, index=False)
    spec = recordings.ColumnSpec(time="t_ms", rate="gz", temperature="temp_k", time_unit="ms", rate_unit="deg/h", temperature_unit="K")
    rec = recordings.read_recording(path, spec, require_temperature=True)
    assert rec.fs_hz == pytest.approx(100.0)
    np.testing.assert_allclose(rec.rate_dps, 1.0)
    np.testing.assert_allclose(rec.temperature_c, 25.0)
    frame_rad = pd.DataFrame({"time": np.arange(4.0), "rate": np.full(4, np.pi)})
    rec = recordings.recording_from_frame(frame_rad, columns=recordings.ColumnSpec(rate_unit="rad/s"))
    np.testing.assert_allclose(rec.rate_dps, 180.0)


def test_unknown_unit_is_refused():
    with pytest.raises(InputError, match="unknown rate unit 'deg/min'"):
        recordings.ColumnSpec(rate_unit="deg/min")


def test_kelvin_given_as_celsius_is_refused(tmp_path):
    path = _write_csv(tmp_path, "time,rate,temperature\n0,1,298\n1,1,298\n")
    with pytest.raises(InputError, match="wrong unit"):
        recordings.read_recording(path)


def test_resample_fixes_jitter(tmp_path):
    t = np.array([0.0, 1.0, 2.0, 3.7, 4.0, 5.0])
    frame = pd.DataFrame({"time": t, "rate": 2 * t})
    rec = recordings.recording_from_frame(frame, resample=True)
    np.testing.assert_allclose(rec.time_s, np.arange(6.0))
    np.testing.assert_allclose(rec.rate_dps, 2 * np.arange(6.0))


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "sub" / "out.json"
    with pytest.raises(RuntimeError):
        with artefacts.atomic_path(target) as tmp:
            Path(tmp).write_text("half")
            raise RuntimeError("interrupted")
    assert not target.exists()
    assert list(target.parent.iterdir()) == []


def test_written_files_get_ordinary_permissions(tmp_path):
    target = tmp_path / "out.json"
    artefacts.write_json(target, {"a": 1})
    assert target.stat().st_mode & 0o777 == 0o666 & ~artefacts._umask()


def test_atomic_write_keeps_previous_file_on_failure(tmp_path):
    target = tmp_path / "out.json"
    artefacts.write_json(target, {"a": 1})
    with pytest.raises(TypeError):
        artefacts.write_json(target, {"a": object()})
    assert json.loads(target.read_text()) == {"a": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_json_is_deterministic_and_has_no_nan(tmp_path):
    header = artefacts.artefact_header("gyrocomp.test", settings={"x": np.float64(np.nan), "y": np.arange(3)}, seed=3)
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    artefacts.write_json(a, header)
    artefacts.write_json(b, header)
    assert a.read_bytes() == b.read_bytes()
    obj = json.loads(a.read_text())
    assert obj["settings"] == {"x": None, "y": [0, 1, 2]}
    assert obj["schema"] == {"name": "gyrocomp.test", "version": "1.0"}
    assert obj["seed"] == 3


def test_parquet_artefact_is_deterministic_and_checked(tmp_path):
    header = artefacts.artefact_header("gyrocomp.components", settings={"method": "emd"}, seed=1)
    a, b = tmp_path / "a.parquet", tmp_path / "b.parquet"
    artefacts.write_table(a, _frame(), header)
    artefacts.write_table(b, _frame(), header)
    assert a.read_bytes() == b.read_bytes()
    frame, read_header = artefacts.read_table(a, "gyrocomp.components")
    assert read_header["settings"] == {"method": "emd"}
    with pytest.raises(SchemaError, match="is a 'gyrocomp.components' artefact, expected 'gyrocomp.model'"):
        artefacts.read_table(a, "gyrocomp.model")


def test_foreign_and_future_schemas_are_refused(tmp_path):
    path = tmp_path / "model.json"
    obj = artefacts.artefact_header("gyrocomp.model")
    obj["schema"]["version"] = "2.0"
    path.write_text(json.dumps(obj))
    with pytest.raises(SchemaError, match="version 2.0 is newer"):
        artefacts.read_json(path, "gyrocomp.model")
    path.write_text(json.dumps({"weights": [1, 2]}))
    with pytest.raises(SchemaError, match="not a gyrocomp artefact"):
        artefacts.read_json(path, "gyrocomp.model")
    path.write_text('{"schema": {"name": "gyrocomp.model", "version": "1.0"}, "x": [1, 2')
    with pytest.raises(InputError, match="model.json line 1: not valid JSON"):
        artefacts.read_json(path, "gyrocomp.model")


def test_minor_version_is_accepted(tmp_path):
    path = tmp_path / "model.json"
    obj = artefacts.artefact_header("gyrocomp.model", version="1.7")
    artefacts.write_json(path, obj)
    assert artefacts.read_json(path, "gyrocomp.model")["schema"]["version"] == "1.7"


def test_write_table_takes_a_mapping_of_columns_as_a_frame(tmp_path):
    """A mapping of columns writes the same Parquet table as the DataFrame of it, and the same CSV."""
    import pyarrow.parquet as pq

    rng = np.random.default_rng(2)
    columns = {"time": np.arange(50) / 10.0, "rate": rng.standard_normal(50), "flag": np.arange(50) % 3,
               "strided": rng.standard_normal(100)[::2]}
    header = artefacts.artefact_header("gyrocomp.recording")
    artefacts.write_table(tmp_path / "a.parquet", columns, header)
    artefacts.write_table(tmp_path / "b.parquet", pd.DataFrame(columns), header)
    a, b = pq.read_table(tmp_path / "a.parquet"), pq.read_table(tmp_path / "b.parquet")
    assert a.schema.names == b.schema.names and a.schema.metadata == b.schema.metadata
    assert a.equals(b)
    artefacts.write_table(tmp_path / "a.csv", columns, header)
    artefacts.write_table(tmp_path / "b.csv", pd.DataFrame(columns), header)
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
