"""Exact selection on fixed simulated fit/holdout pairs whose effects are withheld.

The pairs are simulated with :func:`gyrocomp.sim.simulate.simulate` (fixed
seeds) on a 5-hour up-and-down oven profile at 1 Hz; only the recordings
(time, rate, measured temperature) reach :func:`gyrocomp.diagnose.diagnose`.
"""

import numpy as np
import pytest

from gyrocomp.diagnose import diagnose
from gyrocomp.recordings import recording_from_frame
from gyrocomp.sim.model import (
    BiasInstability,
    GyroSettings,
    Hysteresis,
    Periodic,
    RateRamp,
    RateRandomWalk,
    TempRate,
    ThermalLag,
    Warmup,
)
from gyrocomp.sim.profile import ProfileSettings
from gyrocomp.sim.simulate import simulate

PROFILE = ProfileSettings(
    start_c=25.0,
    start_hold_s=1800.0,
    levels_c=(50.0, 20.0, 0.0, 30.0),
    hold_s=(2700.0,),
    ramp_c_per_min=(1.0,),
)
NONE = dict(
    thermal_lag=ThermalLag(enabled=False),
    temp_rate=TempRate(enabled=False),
    warmup=Warmup(enabled=False),
    bias_instability=BiasInstability(enabled=False),
    rate_random_walk=RateRandomWalk(enabled=False),
)


def _pair(seed, **effects):
    gyro = GyroSettings(**{**NONE, **effects})
    recs = []
    for k in range(2):
        frame, _ = simulate(gyro, PROFILE, fs_hz=1.0, seed=seed + k, duration_s=5 * 3600.0)
        recs.append(recording_from_frame(frame[["time", "rate", "temperature"]], name=f"run{k}"))
    return recs


def _check(report, truth):
    assert report["selected_effects"] == truth or set(report["selected_effects"]) == set(truth)
    if truth:
        base = report["gap"]["baseline"]["holdout"]
        after = report["gap"]["selected"]["holdout"]
        assert after <= 0.5 * base, (base, after)


def test_effect_free_pair_names_nothing():
    fit, hold = _pair(100)
    report = diagnose(fit, hold)
    assert report["selected_effects"] == []
    assert set(report["candidates"]) == {
        "thermal_lag", "temp_rate", "hysteresis", "warmup", "rate_ramp", "periodic", "bias_instability", "rate_random_walk"
    }


def test_thermal_lag_is_not_mistaken_for_temp_rate():
    fit, hold = _pair(200, thermal_lag=ThermalLag(tau_s=300.0))
    report = diagnose(fit, hold)
    _check(report, ["thermal_lag"])
    tau = report["candidates"]["thermal_lag"]["params"]["tau_s"]["value"]
    assert 240.0 < tau < 375.0
    # The gap's white level is the sample-level one: at the shortest tau the
    # baseline's residual (drift and all) matches it within sampling error,
    # instead of reading a fraction of it with a block-mean ARW that absorbed the drift.
    for run in ("fit", "holdout"):
        first = report["localization"][run]["baseline"]["timescale"]["adev"][0]
        assert 0.9 < first["ratio"] < 1.1, (run, first)


@pytest.mark.slow
@pytest.mark.parametrize(
    "seed, effects, truth",
    [
        (300, dict(temp_rate=TempRate(coefficient_dps_per_c_per_s=0.8)), ["temp_rate"]),
        (400, dict(hysteresis=Hysteresis(enabled=True, amplitude_dps=0.005, deadband_c=0.5)), ["hysteresis"]),
        (500, dict(bias_instability=BiasInstability(b_deg_per_h=15.0)), ["bias_instability"]),
        (600, dict(rate_random_walk=RateRandomWalk(k_deg_per_h_per_sqrt_h=20.0)), ["rate_random_walk"]),
        (700, dict(rate_ramp=RateRamp(enabled=True, slope_dps_per_s=5e-7)), ["rate_ramp"]),
        (
            800,
            dict(warmup=Warmup(amplitude_dps=0.02, tau_s=600.0), periodic=Periodic(enabled=True, amplitude_dps=0.004, period_s=1200.0)),
            ["warmup", "periodic"],
        ),
        (900, dict(thermal_lag=ThermalLag(tau_s=500.0), bias_instability=BiasInstability(b_deg_per_h=15.0)), ["thermal_lag", "bias_instability"]),
    ],
)
def test_withheld_effects_are_found(seed, effects, truth):
    fit, hold = _pair(seed, **effects)
    _check(diagnose(fit, hold), truth)


def test_static_recording_is_diagnosed_on_its_stochastic_part():
    """Without temperature, the temperature effects are skipped and said so."""
    rng = np.random.default_rng(1)
    n = 2 * 3600
    t = np.arange(n, dtype=float)
    from gyrocomp.effects import noise as sim_noise

    recs = []
    for k in range(2):
        rate = 0.1 + sim_noise.white(n, 1.0, 1.0, rng) + sim_noise.flicker(n, 1.0, 30.0, rng)
        import pandas as pd

        recs.append(recording_from_frame(pd.DataFrame({"time": t, "rate": rate}), name=f"static{k}"))
    report = diagnose(*recs)
    assert set(report["skipped"]) == {"thermal_lag", "temp_rate", "hysteresis"}
    assert report["selected_effects"] == ["bias_instability"]
