"""The simulator: identity of the contributions, seeds and truth, profiles, configs."""

import dataclasses
import json
import tomllib

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from gyrocomp import artefacts, recordings, sim
from gyrocomp.config import CONFIG_DIR
from gyrocomp.errors import InputError
from gyrocomp.sim import model
from gyrocomp.sim.profile import profile_duration_s, setpoint

ALL_ON = dict(
    hysteresis=model.Hysteresis(enabled=True),
    rate_ramp=model.RateRamp(enabled=True),
    periodic=model.Periodic(enabled=True),
)
SHORT = sim.ProfileSettings(start_hold_s=600.0, levels_c=(40.0, 10.0), hold_s=(1800.0,), ramp_c_per_min=(2.0,))


def _run(seed=0, gyro=None, profile=SHORT, **kw):
    return sim.simulate(gyro or sim.GyroSettings(**ALL_ON), profile, fs_hz=2.0, seed=seed, truth_columns=True, **kw)


def test_contributions_add_up_to_the_rate():
    frame, truth = _run(reference=sim.ReferenceSettings(kind="steps"))
    total = (
        frame.reference_rate + frame.truth_scale_factor + frame.truth_drift + frame.truth_noise
        + frame.truth_bias_instability + frame.truth_rate_random_walk + frame.truth_quantization
    )
    assert_allclose(frame.rate, total, atol=1e-12)
    effects_sum = frame.truth_baseline + sum(frame[f"truth_{name}"] for name in
                                             ("thermal_lag", "temp_rate", "hysteresis", "warmup", "rate_ramp", "periodic"))
    assert_allclose(frame.truth_drift, effects_sum, atol=1e-12)
    assert truth["active_effects"] == list(model.EFFECTS)
    assert np.all(np.abs(frame.truth_quantization) <= 0.5e-4 + 1e-15)


def test_scale_factor_acts_on_the_reference_rate_with_temperature():
    gyro = sim.GyroSettings(scale_factor_ppm=50.0, scale_factor_ppm_per_c=100.0)
    frame, _ = _run(gyro=gyro, reference=sim.ReferenceSettings(kind="sine", amplitude_dps=100.0, period_s=10.0))
    expected = 1e-6 * (50.0 + 100.0 * (frame.truth_temperature - 25.0)) * frame.reference_rate
    assert_allclose(frame.truth_scale_factor, expected, atol=1e-15)
    assert frame.reference_rate.abs().max() == pytest.approx(100.0, rel=1e-3)


def test_same_seed_same_values_different_seed_different_noise_same_truth():
    a, truth_a = _run(seed=5)
    b, truth_b = _run(seed=5)
    c, truth_c = _run(seed=6)
    pd.testing.assert_frame_equal(a, b)
    assert truth_a == truth_b == truth_c
    deterministic = ["truth_drift", "truth_temperature", "truth_thermal_lag", "truth_hysteresis", "time"]
    pd.testing.assert_frame_equal(a[deterministic], c[deterministic])
    for column in ("truth_noise", "truth_bias_instability", "truth_rate_random_walk", "temperature"):
        assert not np.allclose(a[column], c[column])


def test_switching_an_effect_off_leaves_the_other_noise_draws_alone():
    on, _ = _run(seed=3)
    off, _ = _run(seed=3, gyro=sim.GyroSettings(bias_instability=model.BiasInstability(enabled=False)))
    assert "truth_bias_instability" not in off
    assert_allclose(off.truth_noise, on.truth_noise)
    assert_allclose(off.truth_rate_random_walk, on.truth_rate_random_walk)


def test_temp_rate_term_vanishes_in_a_soak_of_the_simulated_run():
    # A soak of 12 chamber time constants: the housing's dT/dt has decayed by e^-12.
    profile = dataclasses.replace(SHORT, hold_s=(12 * SHORT.chamber_tau_s,))
    frame, _ = _run(profile=profile)
    times, _ = profile.breakpoints()
    late_soak = (frame.time > times[-1] - 600) & (frame.time <= times[-1])
    assert frame.truth_temp_rate.abs().max() > 0.03
    assert frame.truth_temp_rate[late_soak].abs().max() < 1e-4 * frame.truth_temp_rate.abs().max()


def test_paper_profile_shape():
    profile = sim.ProfileSettings()
    times, temps = profile.breakpoints()
    assert temps[:4].tolist() == [25.0, 25.0, 60.0, 60.0]
    assert temps[-1] == -40.0 and len(set(temps[2:].tolist())) == 11
    assert times[3] - times[2] == 3600.0 and times[1] == 3600.0
    assert profile_duration_s(profile) == pytest.approx(3600 + 7 * 60 + 3600 + 10 * (600 + 3600))
    assert setpoint(profile, [1e9])[0] == -40.0


def test_measured_temperature_is_noisy_and_quantised_housing():
    frame, _ = _run()
    residual = frame.temperature - frame.truth_temperature
    assert_allclose(residual.std(), np.sqrt(0.02**2 + 0.0625**2 / 12), rtol=0.1)
    assert_allclose(frame.temperature / 0.0625, np.round(frame.temperature / 0.0625), atol=1e-9)


def test_profile_from_recording_drives_the_run():
    driver, _ = _run()
    recording = recordings.recording_from_frame(driver[["time", "rate", "temperature"]], name="driver.csv")
    profile = sim.profile_from_recording(recording)
    frame, truth = sim.simulate(sim.GyroSettings(), profile, fs_hz=None, seed=1, truth_columns=True)
    assert_allclose(frame.temperature, driver.temperature)
    assert_allclose(frame.truth_temperature, driver.temperature, atol=0.2)  # the housing: the reading smoothed over 60 s
    assert truth["profile"] == {"source": "driver.csv"}
    resampled, _ = sim.simulate(sim.GyroSettings(), profile, fs_hz=1.0, seed=1)
    assert len(resampled) == int(driver.time.iloc[-1]) + 1
    with pytest.raises(InputError, match="temperature"):
        sim.profile_from_recording(recordings.recording_from_frame(driver[["time", "rate"]], name="x.csv"))


def test_truth_has_every_effect_with_units():
    _, truth = _run()
    assert set(truth["effects"]) == set(model.EFFECTS)
    lag = truth["effects"]["thermal_lag"]
    assert lag["params"] == {"tau_s": 400.0} and lag["units"] == {"tau_s": "s"}
    assert truth["baseline"]["units"]["arw"] == "deg/sqrt(h)"
    assert truth["effects"]["bias_instability"]["units"]["b_deg_per_h"] == "deg/h"


def _defaults_match(cls, table):
    instance = cls()
    for f in dataclasses.fields(cls):
        value = getattr(instance, f.name)
        if dataclasses.is_dataclass(value):
            _defaults_match(type(value), table[f.name])
        else:
            expected = tuple(table[f.name]) if isinstance(value, tuple) else table[f.name]
            assert value == expected, f"{cls.__name__}.{f.name}"
    assert set(table) == {f.name for f in dataclasses.fields(cls)}


def test_defaults_equal_the_shipped_toml():
    with open(CONFIG_DIR / "gyro" / "default.toml", "rb") as fh:
        _defaults_match(sim.GyroSettings, tomllib.load(fh)["gyro"])
    with open(CONFIG_DIR / "profiles" / "oven-paper.toml", "rb") as fh:
        _defaults_match(sim.ProfileSettings, tomllib.load(fh)["profile"])


def test_shipped_configs_all_load():
    for path in sorted((CONFIG_DIR / "sample").glob("*.toml")):
        cfg = sim.load_sim_config(path)
        if path.stem in ("imu_y", "imu_z"):  # the other axes of the three-axis log: their own offset and cubic
            cfg = dataclasses.replace(cfg, gyro=dataclasses.replace(cfg.gyro, offset_dps=0.12, temperature_coefficients=(1.5e-3, 2.0e-5, 8.0e-7)))
        assert cfg.gyro == sim.GyroSettings()
    for path in sorted((CONFIG_DIR / "profiles").glob("*.toml")):
        assert profile_duration_s(sim.load_sim_config(None, profile=path).profile) > 0


def test_config_overrides_and_unknown_keys():
    cfg = sim.load_sim_config(None, overrides=["gyro.thermal_lag.tau_s=600", "profile.hold_s=[1800.0]"], seed=9)
    assert cfg.gyro.thermal_lag.tau_s == 600.0 and cfg.profile.hold_s == (1800.0,) and cfg.run.seed == 9
    with pytest.raises(InputError, match="tau_x"):
        sim.load_sim_config(None, overrides=["gyro.thermal_lag.tau_x=1"])
    with pytest.raises(InputError, match="gyr0"):
        sim.load_sim_config(None, overrides=["gyr0.arw=1"])
    with pytest.raises(InputError, match="levels"):
        sim.load_sim_config(None, overrides=["profile.hold_s=[1.0, 2.0]"])


def test_sample_data_is_what_the_sample_configs_generate(tmp_path):
    """sample_data/ is regenerated by `make sample-data`; check it is up to date."""
    for name in ("oven_train", "oven_test"):
        frame, header = sim.run(sim.load_sim_config(CONFIG_DIR / "sample" / f"{name}.toml"))
        shipped = CONFIG_DIR.parent / "sample_data" / f"{name}.parquet"
        shipped_frame, shipped_header = artefacts.read_table(shipped, "gyrocomp.recording")
        # Values and header, not bytes: the Parquet writer's version string may differ between machines.
        pd.testing.assert_frame_equal(shipped_frame, frame, check_exact=True, obj=f"run `make sample-data` ({name})")
        assert shipped_header == json.loads(json.dumps(artefacts.jsonable(header)))


def test_a_measured_profile_keeps_the_configured_arw():
    """Issue 18: the twin of a quantised measured temperature (1/16 degC, sample data) keeps ARW 1.0 deg/sqrt(h).

    Differentiating the staircase raw fed the temp_rate effect spikes that
    read as extra white noise: fitted ARW 1.11 (read-off 1.20) before the fix.
    """
    import dataclasses
    from pathlib import Path

    from gyrocomp import allan, recordings
    from gyrocomp.sim import GyroSettings, simulate
    from gyrocomp.sim.profile import profile_from_recording

    path = Path(__file__).resolve().parents[2] / "sample_data" / "oven_test.parquet"
    if not path.exists():
        pytest.skip("sample_data/oven_test.parquet absent")
    g = GyroSettings()
    off = {name: dataclasses.replace(getattr(g, name), enabled=False) for name in ("bias_instability", "rate_random_walk", "warmup")}
    g = dataclasses.replace(g, **off)
    frame, _ = simulate(g, profile_from_recording(recordings.read_recording(path, require_temperature=True)), fs_hz=None, seed=1)
    terms = allan.analyse(frame["rate"].to_numpy(), 1.0).terms
    assert terms["arw"]["value"] == pytest.approx(g.arw, rel=0.05)
    assert terms["arw"]["readoff"] == pytest.approx(g.arw, rel=0.05)


def test_a_negative_correlation_time_is_refused():
    with pytest.raises(InputError, match="correlation_s"):
        sim.load_sim_config(None, overrides=["gyro.bias_instability.correlation_s=-5"])


def test_the_markov_bias_has_the_allan_peak_of_its_b():
    """gyro.bias_instability.correlation_s > 0 draws a Gauss-Markov bias whose Allan deviation peaks near 0.664 B at 1.89 T_c."""
    from gyrocomp import allan
    from gyrocomp.effects import noise as sim_noise

    x = sim_noise.markov(400_000, 1.0, 36.0, 100.0, np.random.default_rng(3))
    tau, adev, _ = allan.oadev(x, 1.0, "octave")
    peak = np.argmax(adev)
    assert 100.0 < tau[peak] < 400.0
    assert adev[peak] * 3600.0 == pytest.approx(0.664 * 36.0, rel=0.08)


def test_three_axis_sample_log_is_what_the_sample_configs_generate(tmp_path):
    """sample_data/imu_oven.csv.gz (the README's firmware recipe) as `make sample-data` builds it: gx, then gy
    and gz simulated on gx's recorded temperature (`--profile`), one table; values exact (CSV keeps repr)."""
    from typer.testing import CliRunner

    from gyrocomp.cli import app

    for axis in "xyz":
        args = ["simulate", str(CONFIG_DIR / "sample" / f"imu_{axis}.toml"), "--out", str(tmp_path / f"{axis}.parquet")]
        result = CliRunner().invoke(app, args + ([] if axis == "x" else ["--profile", str(tmp_path / "x.parquet")]))
        assert result.exit_code == 0, result.output
    runs = {axis: pd.read_parquet(tmp_path / f"{axis}.parquet") for axis in "xyz"}
    shipped = pd.read_csv(CONFIG_DIR.parent / "sample_data" / "imu_oven.csv.gz")
    assert list(shipped.columns) == ["time", "gx", "gy", "gz", "temperature"]
    for axis in "yz":
        np.testing.assert_array_equal(runs[axis].temperature, runs["x"].temperature)
    for column, values in [("time", runs["x"].time), ("temperature", runs["x"].temperature)] + [(f"g{a}", runs[a].rate) for a in "xyz"]:
        np.testing.assert_array_equal(shipped[column].to_numpy(), values.to_numpy(), err_msg=f"run `make sample-data` ({column})")
