"""Small simulated oven runs with known drift for the pipeline tests (fast: 0.2 Hz, short soaks)."""

from __future__ import annotations

import dataclasses

import pytest

from gyrocomp import artefacts, recordings
from gyrocomp.sim import GyroSettings, ProfileSettings, simulate

FS_HZ = 0.2


def quiet_gyro() -> GyroSettings:
    """The default gyro's temperature drift (cubic, temperature rate, a 60 s thermal lag) with little noise.

    White noise of 0.05 deg/sqrt(h) leaves a floor of 0.3 deg/h in the 100 s
    means, 1/400 of the drift's 150 deg/h; no warm-up, flicker or random walk,
    which no temperature model can remove.
    """
    g = GyroSettings()
    return dataclasses.replace(
        g,
        arw=0.05,
        thermal_lag=dataclasses.replace(g.thermal_lag, tau_s=60.0),
        warmup=dataclasses.replace(g.warmup, enabled=False),
        bias_instability=dataclasses.replace(g.bias_instability, enabled=False),
        rate_random_walk=dataclasses.replace(g.rate_random_walk, enabled=False),
    )


def oven(levels, hold_s=1500.0, start_c=25.0):
    return ProfileSettings(
        start_c=start_c,
        start_hold_s=600.0,
        levels_c=tuple(levels),
        hold_s=(hold_s,),
        ramp_c_per_min=(1.0,),
        chamber_tau_s=240.0,
    )


def recording(levels, seed, *, hold_s=1500.0, name="run.parquet", gyro=None, start_c=25.0):
    frame, _ = simulate(gyro or quiet_gyro(), oven(levels, hold_s, start_c), fs_hz=FS_HZ, seed=seed, truth_columns=True)
    rec = recordings.recording_from_frame(frame[["time", "rate", "temperature"]], name=name)
    return rec, frame


@pytest.fixture(scope="session")
def make_recording():
    """:func:`recording`, for tests that simulate runs of their own."""
    return recording


@pytest.fixture(scope="session")
def oven_pair():
    """Training run (10 degC steps from 50 down to -30 degC) and a held-out run (another seed, 20 degC steps, longer soaks).

    As in the papers, the held-out run soaks at levels the training run
    soaked at: a 16-rule ANFIS does not interpolate between soak levels it
    only crossed on a ramp.
    """
    train, train_truth = recording([50, 40, 30, 20, 10, 0, -10, -20, -30], seed=11, hold_s=900.0, name="train.parquet")
    test, test_truth = recording([40, 20, 0, -20], seed=12, hold_s=1200.0, name="test.parquet")
    return train, test, train_truth, test_truth


@pytest.fixture(scope="session")
def oven_files(tmp_path_factory, oven_pair):
    """The pair written as Parquet recordings."""
    folder = tmp_path_factory.mktemp("oven")
    train, test, *_ = oven_pair
    paths = []
    for rec in (train, test):
        path = folder / rec.name
        artefacts.write_table(path, rec.data, {})
        paths.append(path)
    return paths
