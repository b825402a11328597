"""`gyrocomp simulate` on the command line."""

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from gyrocomp import recordings
from gyrocomp.cli import app

runner = CliRunner()
SHORT = ["--set", "run.duration_s=3000", "--fs", "2"]


def _invoke(*args):
    return runner.invoke(app, ["simulate", *args])


def test_same_seed_same_bytes_different_seed_different_noise_same_truth(tmp_path):
    # Both runs are in this process: exact bytes hold within one machine and one process type.
    paths = [tmp_path / name for name in ("a.parquet", "b.parquet", "c.parquet")]
    for path, seed in zip(paths, (4, 4, 5)):
        result = _invoke(*SHORT, "--seed", str(seed), "--truth-columns", "--out", str(path))
        assert result.exit_code == 0, result.output
    assert paths[0].read_bytes() == paths[1].read_bytes()
    a, c = (recordings.read_recording(p) for p in (paths[0], paths[2]))
    assert a.metadata["truth"] == c.metadata["truth"]
    assert a.metadata["seed"] == 4 and c.metadata["seed"] == 5
    assert a.metadata["schema"]["name"] == "gyrocomp.recording"
    assert np.array_equal(a.data.truth_drift, c.data.truth_drift)
    assert not np.allclose(a.data.truth_noise, c.data.truth_noise)
    assert a.fs_hz == 2.0 and len(a.data) == 6001


def test_default_run_is_the_paper_oven_test(tmp_path):
    out = tmp_path / "oven.parquet"
    result = _invoke("--out", str(out))
    assert result.exit_code == 0, result.output
    rec = recordings.read_recording(out, require_temperature=True)
    assert rec.metadata["settings"]["profile"]["levels_c"][0] == 60.0
    temperature = rec.temperature_c
    assert temperature.max() > 59.5 and temperature.min() < -39.5
    drift_span = np.ptp(pd.Series(rec.rate_dps).rolling(600).mean().dropna())
    assert 0.2 < drift_span < 0.6  # a few tenths of deg/s, like the papers' gyro


def test_bad_config_key_exits_2_naming_the_key(tmp_path):
    result = _invoke("--set", "gyro.thermal_lag.tau=3", "--out", str(tmp_path / "x.parquet"))
    assert result.exit_code == 2
    assert "tau" in result.output and "tau_s" in result.output
    bad = tmp_path / "bad.toml"
    bad.write_text("[gyro]\narw_typo = 1.0\n")
    result = _invoke(str(bad), "--out", str(tmp_path / "x.parquet"))
    assert result.exit_code == 2 and "arw_typo" in result.output and "bad.toml" in result.output
    assert not (tmp_path / "x.parquet").exists()


def test_profile_by_name_and_by_recording_and_csv_output(tmp_path):
    driver = tmp_path / "driver.csv"
    result = _invoke("--profile", "oven-reverse", "--set", "run.duration_s=8000", "--out", str(driver))
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(driver)
    assert list(frame.columns) == ["time", "rate", "temperature"]
    assert frame.temperature.iloc[-1] < 0
    out = tmp_path / "driven.parquet"
    result = _invoke("--profile", str(driver), "--truth-columns", "--out", str(out))
    assert result.exit_code == 0, result.output
    rec = recordings.read_recording(out)
    assert np.allclose(rec.data.truth_temperature, frame.temperature, rtol=0, atol=0.2)  # the housing: the reading smoothed over 60 s
    assert rec.metadata["inputs"][0]["name"] == "driver.csv"


def test_reference_rate_column(tmp_path):
    out = tmp_path / "turntable.parquet"
    result = _invoke(*SHORT, "--set", 'reference.kind="steps"', "--out", str(out))
    assert result.exit_code == 0, result.output
    rec = recordings.read_recording(out)
    assert set(np.unique(rec.data.reference_rate)) == {-10.0, 0.0, 10.0}
