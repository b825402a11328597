"""``gyrocomp allan`` end to end: artefact, piping, thresholds, bad input."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import allan as al
from gyrocomp.cli import app

WHITE_SIGMA, FS = 0.5, 100.0


@pytest.fixture
def white_csv(tmp_path):
    rng = np.random.default_rng(4)
    frame = pd.DataFrame({"t_ms": np.arange(20_000) * 10.0, "w": rng.normal(size=20_000) * WHITE_SIGMA})
    path = tmp_path / "white.csv"
    frame.to_csv(path, index=False)
    return path


def _run(*args):
    """In-process run (fast); result has returncode, stdout and stderr."""
    result = CliRunner().invoke(app, ["allan", *map(str, args)])
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.stderr)


def _subprocess(*args, stdin=None):
    return subprocess.run(
        [sys.executable, "-m", "gyrocomp", "allan", *map(str, args)],
        input=stdin,
        capture_output=True,
        text=True,
    )


def test_artefact_plot_and_column_mapping(white_csv, tmp_path):
    out, png = tmp_path / "allan.json", tmp_path / "allan.png"
    proc = _run(white_csv, "--time-col", "t_ms", "--time-unit", "ms", "--rate-col", "w", "--out", out, "--plot", png)
    assert proc.returncode == 0, proc.stderr
    art = json.loads(out.read_text())
    assert art["schema"]["name"] == "gyrocomp.allan"
    assert art["inputs"][0]["name"] == "white.csv"
    (series,) = art["series"]
    assert series["fs_hz"] == pytest.approx(FS)
    expected = al.analyse(pd.read_csv(white_csv)["w"].to_numpy(), FS)
    np.testing.assert_allclose(series["adev"], expected.adev, rtol=1e-12)
    assert series["terms"]["arw"]["readoff"] == pytest.approx(WHITE_SIGMA / np.sqrt(FS) * 60, rel=0.03)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "arw" in proc.stdout


def test_stdin_to_stdout(white_csv):
    proc = _subprocess("-", "--rate-col", "w", "--time-col", "t_ms", "--time-unit", "ms", "--out", "-", "--taus", "0.1,1,10", stdin=white_csv.read_text())
    assert proc.returncode == 0, proc.stderr
    art = json.loads(proc.stdout)  # only JSON on stdout; the table went to stderr
    assert art["series"][0]["tau_s"] == pytest.approx([0.1, 1.0, 10.0])
    assert "arw" in proc.stderr


def test_threshold_exits_3_after_writing(white_csv, tmp_path):
    out = tmp_path / "allan.json"
    proc = _run(white_csv, "--rate-col", "w", "--time-col", "t_ms", "--time-unit", "ms", "--out", out, "--max-arw", "0.5")
    assert proc.returncode == 3
    line = proc.stderr.strip().splitlines()[-1]
    assert line.startswith("gyrocomp: white.csv `w`: arw = ") and "--max-arw 0.5" in line  # the axis keeps its name
    assert out.exists()


def test_bad_input_exits_2(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,rate\n0,1\n0.01,x\n0.02,3\n")
    proc = _run(bad, "--out", tmp_path / "a.json")
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "bad.csv line 3" in proc.stderr
    proc = _run(bad, "--out", tmp_path / "a.json", "--taus", "weekly")
    assert proc.returncode == 2
    assert not (tmp_path / "a.json").exists()


def test_unknown_column_exits_2(white_csv, tmp_path):
    proc = _run(white_csv, "--rate-col", "w", "--time-col", "t_ms", "--time-unit", "ms", "--column", "compensated", "--out", tmp_path / "a.json")
    assert proc.returncode == 2
    assert "no column 'compensated'" in proc.stderr


def _gapped_csv(path, sizes=(970, 700, 2, 500), fs=2.0):
    """White noise in bursts separated by gaps of 100 s; returns the bursts' rates."""
    rng = np.random.default_rng(9)
    parts, start = [], 0.0
    for n in sizes:
        t = start + np.arange(n) / fs
        parts.append(pd.DataFrame({"time": t, "rate": rng.normal(0.0, 0.01, n)}))
        start = t[-1] + 100.0
    pd.concat(parts, ignore_index=True).to_csv(path, index=False)
    return [p["rate"].to_numpy() for p in parts]


def test_a_gapped_file_read_in_chunks_gives_each_segment_as_read_whole(tmp_path):
    """Chunks of 97 rows: one gap at a chunk boundary (after 970 rows), others inside chunks, a 2-sample burst."""
    from gyrocomp import streaming
    from gyrocomp.commands.allan import _pieces

    path = tmp_path / "gapped.csv"
    bursts = _gapped_csv(path)
    reader = streaming.read_chunks(path, rows=97, gaps=True)
    with pytest.warns(Warning, match="4 segments: 3 gaps, the longest 100 s") as notes:
        found = al.analyse_segment_chunks(lambda: _pieces(reader, reader, lambda c: c.rate_dps), lambda: reader.fs_hz, name="gapped.csv")
    assert len(notes) == 1  # two readings, one note
    assert reader.breaks == [970, 1670, 1672]
    assert [s.name for s in found] == ["gapped.csv segment 1", "gapped.csv segment 2", "gapped.csv segment 4"]  # 2 samples: no deviation
    for series, burst in zip(found, [bursts[0], bursts[1], bursts[3]]):
        whole = al.analyse(burst, 2.0)
        np.testing.assert_allclose(series.adev, whole.adev, rtol=1e-9)
        np.testing.assert_array_equal(series.n, whole.n)
    with pytest.raises(streaming.GapError):  # without gaps=True a gap still stops a stream
        list(streaming.read_chunks(path, rows=97))


def test_allan_reads_a_gapped_csv_as_a_gap_free_one_and_notes_once(tmp_path, monkeypatch):
    """No whole-file read after the chunked one (the file is read as often as a gap-free file of its size) and one note."""
    from gyrocomp import recordings, streaming

    gapped, plain = tmp_path / "gapped.csv", tmp_path / "plain.csv"
    _gapped_csv(gapped)
    pd.DataFrame({"time": np.arange(2172) / 2.0, "rate": np.random.default_rng(1).normal(0, 0.01, 2172)}).to_csv(plain, index=False)

    def whole(*args, **kwargs):
        raise AssertionError("read whole")

    monkeypatch.setattr(recordings, "read_recording", whole)
    monkeypatch.setattr(recordings, "read_recordings", whole)
    opened = []
    frames = streaming.ChunkReader._csv_frames
    monkeypatch.setattr(streaming.ChunkReader, "_csv_frames", lambda self: (opened.append(self.name), frames(self))[1])
    result = CliRunner().invoke(app, ["allan", str(gapped), "--out", str(tmp_path / "a.json")])
    assert result.exit_code == 0, result.output
    assert result.stderr.count("segments:") == 1 and "4 segments: 3 gaps, the longest 100 s (not interpolated)" in result.stderr
    reads = len(opened)
    opened.clear()
    assert CliRunner().invoke(app, ["allan", str(plain), "--out", str(tmp_path / "b.json")]).exit_code == 0
    assert reads == len(opened) == 2  # the mean (its first chunk gives the columns), then the phase


def test_allan_reads_a_parquet_file_once_with_the_bits_of_a_csv(tmp_path, monkeypatch):
    """A Parquet file's phase fits in memory: one reading (issue 38), and the series of the same samples as CSV (two readings), bit for bit."""
    import json

    from gyrocomp import streaming

    frame = pd.DataFrame({"time": np.arange(200_000) / 100.0, "rate": np.random.default_rng(38).normal(0.2, 0.05, 200_000)})
    frame.to_parquet(tmp_path / "r.parquet", row_group_size=30_000)
    frame.to_csv(tmp_path / "r.csv", index=False, float_format="%.17g")
    opened = []
    frames = streaming.ChunkReader._parquet_frames
    monkeypatch.setattr(streaming.ChunkReader, "_parquet_frames", lambda self: (opened.append(self.name), frames(self))[1])
    for name in ("r.parquet", "r.csv"):
        assert CliRunner().invoke(app, ["allan", str(tmp_path / name), "--out", str(tmp_path / f"{name}.json")]).exit_code == 0
    assert len(opened) == 1
    parquet, csv = (json.loads((tmp_path / f"{name}.json").read_text())["series"][0] for name in ("r.parquet", "r.csv"))
    assert parquet.pop("name") == "r.parquet" and csv.pop("name") == "r.csv"
    assert parquet == csv
