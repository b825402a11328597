"""``gyrocomp export`` on the command line: formats, a one-line refusal, atomic output."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from gyrocomp import artefacts
from gyrocomp.cli import app


@pytest.fixture(scope="module")
def model_files(tmp_path_factory, cubic_model, sample_train):
    from gyrocomp.config import load_config
    from gyrocomp.pipeline.train import train_direct

    folder = tmp_path_factory.mktemp("export")
    artefacts.write_json(folder / "cubic.json", cubic_model)
    artefacts.write_json(folder / "poly.json", train_direct(sample_train, load_config("polynomial"), source="polynomial", seed=0))
    return folder


@pytest.mark.parametrize("fmt, suffix", [("px4", "params"), ("ardupilot", "parm"), ("c", "h"), ("json-plain", "json")])
def test_each_format_writes_its_file(fmt, suffix, model_files):
    out = model_files / f"out.{suffix}"
    result = CliRunner().invoke(app, ["export", str(model_files / "cubic.json"), "--format", fmt, "--out", str(out), "--device-id", "7"])
    assert result.exit_code == 0, result.output
    text = out.read_text()
    if fmt == "json-plain":
        plain = json.loads(text)
        assert plain["units"]["rate"] == "deg/s" and plain["segments"][0]["learner"] == "polynomial"
        assert plain["input_basis"]["centre"] == [0.0, 0.0]


def test_a_model_the_format_cannot_hold_exits_2_in_one_line_and_writes_nothing(model_files):
    out = model_files / "refused.params"
    result = CliRunner().invoke(app, ["export", str(model_files / "poly.json"), "--format", "px4", "--out", str(out)])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.startswith("gyrocomp:")]
    assert len(lines) == 1 and "no temperature-rate term" in lines[0]
    assert not out.exists()
    result = CliRunner().invoke(app, ["export", str(model_files / "poly.json"), "--format", "px4", "--out", str(out), "--fit-polynomial"])
    assert result.exit_code == 0 and "deg/h RMS" in result.output and out.exists()
