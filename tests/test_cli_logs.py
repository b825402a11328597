"""The command line in cron and CI: progress lines off a terminal, a closed pipe, global flags after the command."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from rich.console import Console
from typer.testing import CliRunner

from gyrocomp.cli import app
from gyrocomp.cli._app import SIGPIPE_EXIT, LogLines, globals_first
from gyrocomp.recordings import ColumnSpec

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_data" / "oven_test.parquet"
runner = CliRunner()


@pytest.mark.parametrize(
    "args, expected",
    [
        (["allan", "x.csv", "--out", "a.json", "--quiet"], ["--quiet", "allan", "x.csv", "--out", "a.json"]),
        (["-q", "allan", "x.csv", "--debug"], ["-q", "--debug", "allan", "x.csv"]),
        (["batch", "allan", "*.csv", "--", "--quiet"], ["batch", "allan", "*.csv", "--", "--quiet"]),  # after -- it is data
        (["--version"], ["--version"]),
    ],
)
def test_global_flags_after_the_command_move_before_it(args, expected):
    assert globals_first(args) == expected


def test_log_lines_at_most_every_ten_seconds():
    now = [0.0]
    console = Console(record=True, width=200, force_terminal=False)
    lines = LogLines(console, "diagnose", every_s=10.0, clock=lambda: now[0])
    for t, done in [(0.0, 0), (1.0, 1), (9.9, 2), (10.5, 3), (12.0, 4), (20.4, 5), (21.0, 6)]:
        now[0] = t
        lines(done, 8)
    assert console.export_text().splitlines() == [
        "gyrocomp: diagnose: 3/8 (38%), 10 s",
        "gyrocomp: diagnose: 6/8 (75%), 21 s",
    ]


def test_log_lines_say_each_new_stage_at_once_after_the_first_ten_seconds():
    now = [0.0]
    console = Console(record=True, width=200, force_terminal=False)
    lines = LogLines(console, "decompose", every_s=10.0, clock=lambda: now[0])
    for t, done, stage in [(0.5, 0, "decompose gx (1/2)"), (11.0, 1000, "decompose gy (2/2)"), (12.0, 1500, None), (13.0, 2000, "writing c.parquet")]:
        now[0] = t
        lines(done, 2000, stage)
    assert console.export_text().splitlines() == [
        "gyrocomp: decompose gy (2/2): 1000/2000 (50%), 11 s",
        "gyrocomp: writing c.parquet: 2000/2000 (100%), 13 s",
    ]


def test_a_multi_axis_decomposition_counts_one_whole_then_says_it_writes(tmp_path):
    """The axes are parts of one count: it rises to 100 % once, at the end of the last axis, then `writing`."""
    from gyrocomp.commands.decompose import write_axes
    from gyrocomp.decompose import DecomposeSettings
    from gyrocomp.recordings import recording_from_frame

    t = np.arange(2000) / 10.0
    rng = np.random.default_rng(0)
    frame = pd.DataFrame({"time": t, "gx": rng.normal(size=t.size), "gy": rng.normal(size=t.size), "gz": rng.normal(size=t.size)})
    rec = recording_from_frame(frame, name="three.csv", columns=ColumnSpec(rate="gx,gy,gz"))
    seen = []
    write_axes(rec, DecomposeSettings(method="emd"), tmp_path / "c.parquet", progress=lambda d, n, description=None: seen.append((d, n, description)))
    done = [d for d, _, _ in seen]
    assert {n for _, n, _ in seen} == {3000} and done == sorted(done)
    assert [d for d in done if d == 3000] == [3000, 3000]  # the end of the last axis, then the writing stage
    assert seen[-1][2] == "writing c.parquet"
    assert [s for s in dict.fromkeys(s for _, _, s in seen)] == ["decompose gx (1/3)", "decompose gy (2/3)", "decompose gz (3/3)", "writing c.parquet"]


def test_progress_lines_when_stderr_is_not_a_terminal(tmp_path, monkeypatch):
    import gyrocomp.cli._app as cli_app

    out = tmp_path / "sim.parquet"
    fast = runner.invoke(app, ["simulate", "--fs", "0.2", "--out", str(out)])
    assert fast.exit_code == 0, fast.output
    assert "\x1b[" not in fast.stderr  # no bar, no escape codes in a log
    monkeypatch.setattr(cli_app, "LOG_EVERY_S", 0.0)  # every update a line
    result = runner.invoke(app, ["simulate", "--fs", "0.2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    lines = result.stderr.splitlines()
    assert lines and all(line.startswith("gyrocomp: simulating: ") for line in lines)
    assert lines[-1].startswith("gyrocomp: simulating: 9/9 (100%), ")
    quiet = runner.invoke(app, ["simulate", "--fs", "0.2", "--out", str(out), "--quiet"])
    assert quiet.exit_code == 0 and quiet.stderr == "" and quiet.stdout == ""


@pytest.mark.skipif(not SAMPLE.exists(), reason="sample data absent")
def test_quiet_and_debug_after_the_command(tmp_path):
    loud = runner.invoke(app, ["allan", str(SAMPLE), "--out", str(tmp_path / "a.json")])
    assert "IEEE Std 952" in loud.stdout
    quiet = runner.invoke(app, ["allan", str(SAMPLE), "--out", str(tmp_path / "b.json"), "--quiet"])
    assert quiet.exit_code == 0 and quiet.stdout == ""
    assert (tmp_path / "b.json").read_text() == (tmp_path / "a.json").read_text()
    debug = runner.invoke(app, ["allan", str(tmp_path / "absent.csv"), "--out", str(tmp_path / "c.json"), "--debug"])
    assert debug.exit_code == 2 and "Traceback" in debug.stderr  # the traceback, and still exit 2


def test_a_closed_pipe_ends_quietly():
    """``gyrocomp simulate --out - | head -1``: exit 128 + SIGPIPE, no traceback, no error line."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "gyrocomp", "simulate", "--profile", "soak-25", "--fs", "10", "--out", "-"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        cwd=REPO,
    )
    assert proc.stdout.readline().startswith(b"time,rate,temperature")
    proc.stdout.close()  # the reader goes away, as head does
    stderr = proc.stderr.read().decode()
    assert proc.wait() == SIGPIPE_EXIT
    assert "Traceback" not in stderr and "BrokenPipe" not in stderr and "gyrocomp: " + "Broken" not in stderr
