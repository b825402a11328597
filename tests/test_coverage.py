"""Issue 35, the checks users ask for: quantised temperature, thermal span and ramp, even weighting over temperature."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp.cli import app
from gyrocomp.pipeline import coverage

FULL = [slice(0, None)]


def _messages(time, temperature, window_s=60.0):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return coverage.check_run("run.csv", time, temperature, [slice(0, len(time))], window_s)


def test_whole_degrees_are_quantised_sixteenths_are_not():
    time = np.arange(3600.0)
    ramp = 10.0 + 30.0 * time / 3600.0  # 0.5 degC/min over 30 degC
    assert coverage.quantum(np.round(ramp)) == pytest.approx(1.0)
    assert coverage.quantum(np.round(ramp * 16) / 16) == pytest.approx(0.0625)
    assert coverage.quantum(ramp + np.random.default_rng(0).normal(0.0, 0.01, ramp.size)) == 0.0  # a ramp read to full precision
    assert coverage.quantum(np.round(ramp) + 273.15 - 273.15) == pytest.approx(1.0)  # from Kelvin
    (line,) = _messages(time, np.round(ramp))
    assert line == (
        "run.csv: temperature quantised to 1 degC steps: dT/dt over the 60 s window moves in steps of 0.0167 degC/s "
        "(1 degC/min) and is 0 between level changes"
    )
    assert _messages(time, np.round(ramp * 16) / 16) == []


def test_a_narrow_span_is_named_a_wide_one_is_not():
    time = np.arange(3600.0)
    (line,) = _messages(time, 20.0 + 5.0 * np.minimum(time / 600.0, 1.0))  # 0.5 degC/min, then a soak
    assert line.startswith("run.csv: temperature spans 5 degC (20 to 25), under min_span_c 10")
    assert _messages(time, 20.0 + 30.0 * time / 3600.0) == []


def test_a_run_that_never_ramps_is_named_a_ramp_is_not():
    time = np.arange(0.0, 4 * 3600.0, 0.5)
    creep = 20.0 + 12.0 * time / time[-1]  # 0.05 degC/min: a drift of the room, not a ramp
    (line,) = _messages(time, creep)
    assert line.startswith("run.csv: the run never ramps: |dT/dt| over 60 s windows reaches 0.05 degC/min")
    assert _messages(time, 20.0 + 12.0 * np.minimum(time / 720.0, 1.0)) == []  # 1 degC/min, then a soak


def test_even_over_temperature_gives_every_bin_one_row():
    X = np.array([[20.1, 0.0], [20.2, 1.0], [20.3, 2.0], [21.5, 9.0]])
    Xe, ye = coverage.even_over_temperature(X, np.array([1.0, 2.0, 3.0, 10.0]), X[:, 0], 1.0)
    np.testing.assert_allclose(Xe, [[20.2, 1.0], [21.5, 9.0]])
    np.testing.assert_allclose(ye, [2.0, 10.0])


def _warmup(path, quantised=False):
    """A 1 h warm-up from 5 to 55 degC (tau 10 min, most samples near 55) whose drift is a cubic plus a wiggle no cubic follows."""
    time = np.arange(0.0, 3600.0, 0.5)
    temperature = 55.0 - 50.0 * np.exp(-time / 600.0)
    drift = 0.002 * (temperature - 30.0) + 0.02 * np.sin(temperature / 4.0)
    rate = drift + np.random.default_rng(3).normal(0.0, 0.005, time.size)
    pd.DataFrame({"time": time, "rate": rate, "temperature": np.round(temperature) if quantised else temperature}).to_csv(path, index=False)


def _static_error(model_path):
    """RMS [deg/s] over an even temperature grid 6..54 degC of the model's drift against the truth."""
    from gyrocomp.pipeline.compensate import load_models

    (model,) = load_models(json.loads(model_path.read_text()), str(model_path)).values()
    grid = np.linspace(6.0, 54.0, 97)
    predicted = np.sum(list(model.predict(np.column_stack([grid, np.zeros_like(grid)])).values()), axis=0)
    truth = 0.002 * (grid - 30.0) + 0.02 * np.sin(grid / 4.0)
    return float(np.sqrt(np.mean((predicted - truth - np.mean(predicted - truth)) ** 2)))


def test_train_weights_evenly_over_temperature_on_request(tmp_path):
    """A warm-up spends most samples near its end: weighted by samples the cubic follows 50-55 degC; by degrees it follows the whole range."""
    path = tmp_path / "warmup.csv"
    _warmup(path)
    runner = CliRunner()
    plain, even = tmp_path / "plain.json", tmp_path / "even.json"
    result = runner.invoke(app, ["train", str(path), "--config", "firmware", "--out", str(plain)])
    assert result.exit_code == 0, result.stderr
    result = runner.invoke(app, ["train", str(path), "--config", "firmware", "--out", str(even), "--even-temperature"])
    assert result.exit_code == 0, result.stderr
    assert json.loads(even.read_text())["axes"]["rate"]["segments"]["drift"]["input_offset"] is not None
    grid = np.linspace(6.0, 54.0, 97)  # the best a cubic can do over the range, every degree alike
    truth = 0.002 * (grid - 30.0) + 0.02 * np.sin(grid / 4.0)
    best = np.polyval(np.polyfit(grid, truth, 3), grid) - truth
    best = float(np.sqrt(np.mean((best - best.mean()) ** 2)))  # 0.0134 deg/s
    assert _static_error(even) < 1.02 * best  # 0.0135
    assert _static_error(plain) > 1.12 * best  # 0.0155: the hour near 55 degC pulls the cubic there


def test_train_names_a_whole_degree_temperature(tmp_path):
    path = tmp_path / "bosch.csv"
    _warmup(path, quantised=True)
    result = CliRunner().invoke(app, ["train", str(path), "--config", "firmware", "--out", str(tmp_path / "m.json")])
    assert result.exit_code == 0, result.stderr
    assert "bosch.csv: temperature quantised to 1 degC steps" in result.stderr
    assert result.stderr.count("quantised") == 1
