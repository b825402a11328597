"""`gyrocomp diagnose` on the command line."""

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from gyrocomp.cli import app
from gyrocomp.effects import noise as sim_noise

runner = CliRunner()


def _write(path, seed, temperature=True):
    rng = np.random.default_rng(seed)
    n = 5400
    t = np.arange(n, dtype=float)
    temp = 25.0 + 15.0 * np.sin(2 * np.pi * t / 3600.0)
    rate = 0.05 + 2e-3 * (temp - 25.0) + sim_noise.white(n, 1.0, 1.0, rng)
    frame = pd.DataFrame({"t_ms": t * 1000.0, "gyro": rate, "temp": temp})
    if not temperature:
        frame = frame.drop(columns="temp")
    frame.to_csv(path, index=False)


def test_help():
    result = runner.invoke(app, ["diagnose", "--help"])
    assert result.exit_code == 0
    assert "--holdout" in result.output


def test_diagnose_writes_json_markdown_and_plot(tmp_path):
    """Two holdouts: the first joins the selection, the last gives the held-out gap (``gap.protocol``)."""
    fit, extra, hold = tmp_path / "fit.csv", tmp_path / "extra.csv", tmp_path / "hold.csv"
    _write(fit, 1)
    _write(extra, 3)
    _write(hold, 2)
    out = tmp_path / "report.json"
    args = ["diagnose", str(fit), "--holdout", str(extra), "--holdout", str(hold), "--out", str(out), "--plot", str(tmp_path / "gap.png"),
            "--markdown", str(tmp_path / "report.md"), "--time-col", "t_ms", "--time-unit", "ms", "--rate-col", "gyro",
            "--temp-col", "temp"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    report = json.loads(out.read_text())
    assert report["schema"]["name"] == "gyrocomp.diagnosis"
    assert report["selected_effects"] == []
    assert set(report["gap"]) == {"baseline", "selected", "protocol"}
    assert report["gap"]["protocol"]["selection_runs"] == ["fit.csv", "extra.csv"]
    assert report["gap"]["protocol"]["holdout_run"] == "hold.csv"
    assert [i["name"] for i in report["inputs"]] == ["fit.csv", "extra.csv", "hold.csv"]
    assert set(report["gap"]["baseline"]) >= {"fit", "holdout"}
    assert "thermal_lag" in report["candidates"] and "params" in report["candidates"]["thermal_lag"]
    assert set(report["localization"]) == {"fit", "holdout"}
    assert (tmp_path / "gap.png").read_bytes()[:4] == b"\x89PNG"
    markdown = (tmp_path / "report.md").read_text()
    assert "Selected effects" in markdown
    # Nothing selected: every candidate states the weakest amplitude it would have been found at.
    limits = {e: c["detection_limit"] for e, c in report["candidates"].items()}
    assert all(limits.values()), limits
    assert f"slope_dps_per_s >= {limits['rate_ramp']['slope_dps_per_s']['value']:.3g} deg/s/s" in markdown
    assert "with probability 0.950" in markdown
    assert "the held-out gap is from hold.csv, which took no part in the selection" in markdown


def test_bad_input_exits_2(tmp_path):
    result = runner.invoke(app, ["diagnose", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "r.json")])
    assert result.exit_code == 2
    assert "no such file" in result.output or "no such file" in (result.stderr if result.stderr_bytes else "")


def test_holdout_must_match_temperature_presence(tmp_path):
    fit, hold = tmp_path / "fit.csv", tmp_path / "hold.csv"
    _write(fit, 1)
    _write(hold, 2, temperature=False)
    result = runner.invoke(
        app, ["diagnose", str(fit), "--holdout", str(hold), "--out", str(tmp_path / "r.json"), "--time-col", "t_ms",
              "--time-unit", "ms", "--rate-col", "gyro", "--temp-col", "temp"]
    )
    assert result.exit_code == 2
