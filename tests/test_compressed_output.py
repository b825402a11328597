"""Issue 35 item 9: ``--out x.csv.gz`` (and every compressed extension the readers take) writes compressed CSV by extension."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import artefacts
from gyrocomp.cli import app
from gyrocomp.errors import InputError
from gyrocomp.recordings import ColumnSpec, read_recording

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data"
MAGIC = {"gz": b"\x1f\x8b", "bz2": b"BZh", "xz": b"\xfd7zXZ", "zst": b"\x28\xb5\x2f\xfd", "zip": b"PK\x03\x04"}


@pytest.mark.parametrize("ext", sorted(MAGIC))
def test_write_table_compresses_by_extension_and_reads_back(tmp_path, ext):
    frame = {"time": np.arange(1000) / 10.0, "rate": np.random.default_rng(1).normal(size=1000)}
    path = tmp_path / f"t.csv.{ext}"
    artefacts.write_table(path, frame, {})
    assert path.read_bytes()[: len(MAGIC[ext])] == MAGIC[ext]
    rec = read_recording(path, ColumnSpec())
    np.testing.assert_array_equal(rec.rate_dps, frame["rate"])
    with pytest.raises(InputError, match=r"t.parquet.gz: a compressed table must be CSV"):
        artefacts.write_table(tmp_path / "t.parquet.gz", frame, {})


@pytest.mark.parametrize("ext", ["gz", "zst", "zip"])
def test_compensate_writes_compressed_csv_chunk_by_chunk(tmp_path, ext):
    """The chunked writer: one compressed stream whose content equals the plain CSV; gzip bytes the same on a second run."""
    if not (SAMPLE / "oven_train.parquet").exists():
        pytest.skip("sample_data absent")
    runner = CliRunner()
    model = tmp_path / "m.json"
    assert runner.invoke(app, ["train", str(SAMPLE / "oven_train.parquet"), "--config", "polynomial", "--out", str(model)]).exit_code == 0
    outs = {}
    for name in (f"c.csv.{ext}", "plain.csv", f"again.csv.{ext}"):
        result = runner.invoke(app, ["compensate", str(SAMPLE / "oven_test.parquet"), str(model), "--out", str(tmp_path / name)])
        assert result.exit_code == 0, result.stderr
        outs[name] = tmp_path / name
    packed = outs[f"c.csv.{ext}"]
    assert packed.read_bytes()[: len(MAGIC[ext])] == MAGIC[ext]
    assert packed.stat().st_size < outs["plain.csv"].stat().st_size / 2
    pd.testing.assert_frame_equal(pd.read_csv(packed), pd.read_csv(outs["plain.csv"]))
    if ext == "gz":
        assert packed.read_bytes() == outs[f"again.csv.{ext}"].read_bytes()


def test_a_sidecar_takes_no_model_name(tmp_path):
    """Issue 35 item 9: train --out run1.json, then compensate run1.json --out run1.parquet writes run1.meta.json; an output naming an input is still refused."""
    if not (SAMPLE / "oven_train.parquet").exists():
        pytest.skip("sample_data absent")
    assert artefacts.sidecar_path("a/run1.parquet").as_posix() == "a/run1.meta.json"
    assert artefacts.sidecar_path("run1.csv.gz").name == "run1.meta.json"
    assert artefacts.sidecar_path("run.v2.csv").name == "run.v2.meta.json"
    runner = CliRunner()
    model = tmp_path / "run1.json"
    assert runner.invoke(app, ["train", str(SAMPLE / "oven_train.parquet"), "--config", "polynomial", "--out", str(model)]).exit_code == 0
    before = model.read_bytes()
    result = runner.invoke(app, ["compensate", str(SAMPLE / "oven_test.parquet"), str(model), "--out", str(tmp_path / "run1.parquet")])
    assert result.exit_code == 0, result.stderr
    assert model.read_bytes() == before
    assert json.loads((tmp_path / "run1.meta.json").read_text())["schema"]["name"] == "gyrocomp.compensation"
    result = runner.invoke(app, ["compensate", str(SAMPLE / "oven_test.parquet"), str(model), "--out", str(tmp_path / "run1.meta.parquet")])
    assert result.exit_code == 0, result.stderr  # its sidecar run1.meta.meta.json
    result = runner.invoke(app, ["compensate", str(SAMPLE / "oven_test.parquet"), str(tmp_path / "run1.meta.json"), "--out", str(tmp_path / "run1.parquet")])
    assert result.exit_code == 2 and "would overwrite the input" in result.stderr
