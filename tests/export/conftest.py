"""Models trained on the sample data for the export tests (skipped cleanly when the sample data is absent)."""

from __future__ import annotations

from pathlib import Path

import pytest

from gyrocomp import recordings
from gyrocomp.config import apply_overrides, load_config
from gyrocomp.pipeline.train import train_direct

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


def _sample(name):
    path = SAMPLE / name
    if not path.exists():
        pytest.skip(f"sample_data/{name} absent")
    return recordings.read_recording(path, require_temperature=True)


@pytest.fixture(scope="session")
def sample_train():
    return _sample("oven_train.parquet")


@pytest.fixture(scope="session")
def sample_test():
    return _sample("oven_test.parquet")


@pytest.fixture(scope="session")
def cubic_model(sample_train):
    """The firmwares' form: a cubic in temperature, no dT/dt term."""
    cfg = apply_overrides(load_config("polynomial"), ["model.drift.rate_term=false"])
    return train_direct(sample_train, cfg, source="polynomial", seed=0)
