"""``json-plain`` evaluated from its own description, in numpy written here, equals causal compensation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gyrocomp.config import apply_overrides, load_config
from gyrocomp.export import export_model
from gyrocomp.pipeline.compensate import compensate, load_model
from gyrocomp.pipeline.train import train_direct

KINDS = {
    "polynomial": ("polynomial", []),
    "elm": ("elm", ["model.max_samples=500"]),
    "anfis": ("elm", ["model.max_samples=300", 'model.drift={learner="anfis", n_mfs=[3, 3], epochs=5}']),
    "anfis_gauss": ("elm", ["model.max_samples=300", 'model.drift={learner="anfis", n_mfs=[2, 2], mf="gauss", epochs=5}']),
    "bp": ("bp", ["model.max_samples=300", "model.drift.max_iter=100"]),
}

ACTIVATIONS = {
    "sigmoid": lambda z: 1 / (1 + np.exp(-z)),
    "logistic": lambda z: 1 / (1 + np.exp(-z)),
    "tanh": np.tanh,
    "sin": np.sin,
    "hardlim": lambda z: (z >= 0).astype(float),
    "tribas": lambda z: np.maximum(1 - np.abs(z), 0),
    "radbas": lambda z: np.exp(-(z**2)),
    "relu": lambda z: np.maximum(z, 0),
    "identity": lambda z: z,
}


def evaluate(plain, temperature):
    """The plain model's drift [deg/s], from the fields its ``formula`` and module notes describe."""
    c = np.asarray(plain["rate_estimator"]["causal_coefficients"])
    primed = np.concatenate([np.full(len(c) - 1, temperature[0]), temperature])
    rate = np.array([c @ primed[i : i + len(c)] for i in range(len(temperature))])
    t = np.clip(temperature, *plain["clamp"]["temperature_c"])
    r = np.clip(rate, *plain["clamp"]["temperature_rate_c_per_s"])
    x = np.column_stack([t, r])
    total = np.zeros(len(t))
    for seg in plain["segments"]:
        if seg["learner"] == "polynomial":
            y = sum(k * (t - seg["reference_c"]) ** i for i, k in enumerate(seg["coef_dps"])) + seg["rate_coef_dps_per_c_per_s"] * r
        elif seg["learner"] == "elm":
            y = ACTIVATIONS[seg["activation"]](x @ np.asarray(seg["input_weights"]) + seg["biases"]) @ seg["beta"] + seg["offset_dps"]
        elif seg["learner"] == "anfis":
            mu = []
            for j, premises in enumerate(seg["premises"]):
                p = np.asarray(premises)
                if seg["mf"] == "gbell":
                    mu.append(1 / (1 + np.abs((x[:, j, None] - p[:, 2]) / p[:, 0]) ** (2 * p[:, 1])))
                else:
                    mu.append(np.exp(-0.5 * ((x[:, j, None] - p[:, 0]) / p[:, 1]) ** 2))
            w = (mu[0][:, :, None] * mu[1][:, None, :]).reshape(len(t), -1)
            rules = x @ np.asarray(seg["slopes"]).T + seg["intercepts"]
            y = np.sum(w * rules, axis=1) / np.sum(w, axis=1)
        else:
            a = x
            for i, (wt, b) in enumerate(zip(seg["weights"], seg["biases"])):
                a = a @ np.asarray(wt) + b
                if i < len(seg["weights"]) - 1:
                    a = ACTIVATIONS[seg["activation"]](a)
            y = a[:, 0]
        if seg["output_range_dps"] is not None:
            y = np.clip(y, *seg["output_range_dps"])
        total += y
    return total


@pytest.mark.parametrize("key", list(KINDS))
def test_plain_model_reproduces_causal_compensation(key, sample_train, sample_test):
    config, overrides = KINDS[key]
    model = load_model(train_direct(sample_train, apply_overrides(load_config(config), overrides), source=key, seed=0))
    plain = json.loads(export_model(model, "json-plain")[0])
    assert plain["input_basis"]["centre"] == [0.0, 0.0] and plain["units"]["rate"] == "deg/s"
    n = 3000
    from gyrocomp.recordings import recording_from_frame

    recording = recording_from_frame(sample_test.data.iloc[:n].reset_index(drop=True), name="head")
    frame, _ = compensate(recording, model, "causal")
    drift = evaluate(plain, frame["temperature"].to_numpy())
    np.testing.assert_allclose(drift, frame["drift_model"], rtol=0, atol=1e-9)
