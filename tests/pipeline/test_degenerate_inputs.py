"""Training inputs that leave a drift model rank-deficient are refused (issue 21, item 5).

A polynomial trained on a constant-temperature run used to come out with a
dT/dt coefficient of -4.9e15, fitted on round-off, and compensation then
produced 5e12 deg/s with exit 0.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gyrocomp import recordings
from gyrocomp.config import apply_overrides, load_config
from gyrocomp.errors import InputError
from gyrocomp.pipeline.train import train_direct


def _recording(temperature, name="soak.csv", fs_hz=1.0, seed=0):
    rng = np.random.default_rng(seed)
    n = len(temperature)
    frame = pd.DataFrame(
        {"time": np.arange(n) / fs_hz, "rate": 0.01 + 1e-3 * rng.standard_normal(n), "temperature": temperature}
    )
    return recordings.recording_from_frame(frame, name=name)


@pytest.mark.parametrize("config", ["polynomial", "elm"])
def test_constant_temperature_is_refused_naming_the_file_and_the_span(config):
    rec = _recording(np.full(4000, 25.0))
    with pytest.raises(InputError, match=r"soak.csv: the training temperature spans only 0 degC .*min_temperature_span_c"):
        train_direct(rec, load_config(config), seed=0)


def test_a_single_ramp_rate_is_refused_naming_the_rate_span():
    """A run that ramps at one constant rate cannot separate dT/dt sensitivity from the offset: a learned map is refused."""
    rec = _recording(np.linspace(-20.0, 40.0, 6000), name="ramp.csv")
    with pytest.raises(InputError, match=r"ramp.csv: the training temperature rate spans only .* degC/s"):
        train_direct(rec, load_config("elm"), seed=0)


def test_a_single_ramp_rate_leaves_the_polynomial_dtdt_term_out():
    """... and a polynomial fits its cubic in T and leaves dT/dt out, saying it does not vary."""
    model = train_direct(_recording(np.linspace(-20.0, 40.0, 6000), name="ramp.csv"), load_config("polynomial"), seed=0)
    segment = model["segments"]["drift"]
    assert segment["learner"]["params"]["rate_term"] is False and segment["learner"]["params"]["degree"] == 3
    assert [r["term"] for r in segment["not_fitted"]] == ["dT/dt"] and "does not vary" in segment["not_fitted"][0]["reason"]


def test_a_span_just_above_the_limit_trains_to_finite_coefficients():
    """The limit refuses only the degenerate case: a 3 degC heat-and-cool cycle trains a bounded model."""
    t = np.arange(8000.0)
    rec = _recording(25.0 + 1.5 * np.sin(2 * np.pi * t / 4000.0), name="cycle.csv")
    model = train_direct(rec, load_config("polynomial"), seed=0)
    fitted = model["segments"]["drift"]["learner"]["fitted"]
    assert np.all(np.isfinite(fitted["coef_"])) and abs(fitted["rate_coef_"]) < 10.0


@pytest.mark.parametrize("value", ["-1", "nan", "true", '"2"'])
def test_the_span_limits_are_validated_settings(value):
    config = apply_overrides(load_config("polynomial"), [f"model.min_temperature_span_c={value}"])
    with pytest.raises(InputError, match="min_temperature_span_c"):
        train_direct(_recording(np.full(100, 25.0)), config, seed=0)
