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
