"""A corrupted or hand-edited ``model.json`` is refused on load, naming the field (issue 21, item 2).

Each case takes a model trained here, changes one thing in its JSON text
or object, and expects :func:`load_model` to raise ``InputError`` with a
message that names the field. Before the model validator, a NaN,
``Infinity`` or ``1e999`` coefficient, or a zero scale, loaded silently and
compensated to all-NaN output with exit 0.
"""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from gyrocomp import artefacts
from gyrocomp.cli import app
from gyrocomp.config import apply_overrides, load_config
from gyrocomp.errors import InputError
from gyrocomp.pipeline.compensate import load_model
from gyrocomp.pipeline.train import train_direct

CONFIGS = {
    "polynomial": ("polynomial", []),
    "elm": ("elm", ["model.drift.n_hidden=8"]),
    "bp": ("bp", ["model.drift.max_iter=50", "model.drift.hidden_layer_sizes=[4]"]),
    "anfis": ("elm", ['model.drift={learner="anfis", n_mfs=[2, 2], epochs=3}']),
}


@pytest.fixture(scope="module")
def models(oven_pair):
    train, *_ = oven_pair
    out = {}
    for key, (name, overrides) in CONFIGS.items():
        out[key] = json.loads(json.dumps(train_direct(train, apply_overrides(load_config(name), overrides), seed=0)))
    return out


def _learner(obj):
    return obj["segments"]["drift"]["learner"]["fitted"]


def _set(path, value):
    """A tampering that sets ``obj[path...] = value``."""

    def tamper(obj):
        *parents, last = path
        node = obj
        for key in parents:
            node = node[key]
        node[last] = value

    return tamper


CASES = [
    # (learner, tampering, words the message must contain)
    ("polynomial", lambda o: _learner(o)["coef_"].__setitem__(0, float("nan")), "coef_"),
    ("polynomial", lambda o: _learner(o)["coef_"].__setitem__(1, float("inf")), "coef_"),
    ("polynomial", lambda o: _learner(o)["coef_"].pop(), "coef_"),
    ("polynomial", lambda o: _learner(o).__setitem__("coef_", []), "coef_"),
    ("polynomial", lambda o: _learner(o)["coef_"].__setitem__(0, "1.0"), "coef_"),
    ("polynomial", lambda o: _learner(o).__setitem__("rate_coef_", float("nan")), "rate_coef_"),
    ("polynomial", lambda o: o["segments"]["drift"]["learner"]["params"].__setitem__("degree", 2), "coef_"),
    ("polynomial", _set(("segments", "drift", "input_scale"), [0.0, 1.0]), "positive scales"),
    ("polynomial", _set(("segments", "drift", "input_offset"), [float("nan"), 0.0]), "input_offset"),
    ("polynomial", _set(("segments", "drift", "output_scale"), 0.0), "output_scale"),
    ("polynomial", _set(("segments", "drift", "output_offset"), float("inf")), "output_offset"),
    ("polynomial", _set(("training", "temperature_c", "min"), float("nan")), "temperature_c"),
    ("polynomial", _set(("training", "temperature_rate_c_per_s", "max"), -1e9), "temperature_rate_c_per_s"),
    ("polynomial", _set(("clip_inputs",), "no"), "clip_inputs"),
    ("polynomial", _set(("parallel",), 0), "parallel"),
    ("polynomial", _set(("kind",), "evil"), "kind"),
    ("polynomial", lambda o: (o.__setitem__("parallel", True), o.setdefault("settings", {}).__setitem__("decompose_seed", -1)), "settings.decompose_seed = -1: a seed"),
    ("polynomial", lambda o: o["rate_estimator"]["causal_coefficients"].__setitem__(0, 0.5), "rate_estimator.causal_coefficients"),
    ("polynomial", lambda o: o["rate_estimator"]["causal_coefficients"].pop(), "rate_estimator.causal_coefficients"),
    ("polynomial", lambda o: o["rate_estimator"]["recursion"].__setitem__("slope_gain", 2 * o["rate_estimator"]["recursion"]["slope_gain"]), "rate_estimator.recursion.slope_gain"),
    ("polynomial", lambda o: o["rate_estimator"].__setitem__("window_samples", 7), "rate_estimator.window_samples"),
    ("polynomial", _set(("rate_estimator", "fs_hz"), float("nan")), "fs_hz"),
    ("elm", lambda o: _learner(o)["beta_"].pop(), "beta_"),
    ("elm", lambda o: _learner(o)["input_weights_"][0].__setitem__(0, float("nan")), "input_weights_"),
    ("elm", lambda o: _learner(o).__setitem__("n_features_in_", 0), "n_features_in_"),
    ("elm", lambda o: o["segments"]["drift"]["learner"]["params"].__setitem__("activation", "evil"), "activation"),
    ("bp", lambda o: _learner(o).__setitem__("y_scale_", 0.0), "y_scale_"),
    ("bp", lambda o: _learner(o)["coefs_"].pop(), "layers"),
    ("bp", lambda o: _learner(o)["x_scale_"].__setitem__(0, 0.0), "x_scale_"),
    ("anfis", lambda o: _learner(o)["premises_"].pop(), "premises_"),
    ("anfis", lambda o: _learner(o)["premises_"][0][0].__setitem__(0, 0.0), "membership width"),
    ("anfis", lambda o: _learner(o)["consequents_"].pop(), "consequents_"),
    ("anfis", lambda o: _learner(o)["input_scale_"].__setitem__(0, -1.0), "input_scale_"),
    ("anfis", lambda o: o["segments"]["drift"]["learner"]["params"].__setitem__("mf", "evil"), "mf"),
]


@pytest.mark.parametrize("key, tamper, words", CASES, ids=[f"{c[0]}-{c[2]}-{i}" for i, c in enumerate(CASES)])
def test_tampered_model_is_refused_naming_the_field(models, key, tamper, words):
    obj = copy.deepcopy(models[key])
    load_model(copy.deepcopy(obj))  # the untouched model loads
    tamper(obj)
    with pytest.raises(InputError, match=words):
        load_model(obj, name="model.json")


@pytest.mark.parametrize("text", ["NaN", "Infinity", "-Infinity", "1e999"])
def test_non_finite_json_numbers_give_exit_2_with_one_line(tmp_path, models, oven_files, text):
    """The whole path: JSON text with NaN/Infinity/1e999 in a coefficient -> exit 2, one line naming the
    file, the line and the literal, and no output (Python's JSON reader accepts all three by default)."""
    obj = copy.deepcopy(models["polynomial"])
    _learner(obj)["coef_"][0] = 12345.678
    path = tmp_path / "model.json"
    path.write_text(json.dumps(obj).replace("12345.678", text))
    out = tmp_path / "compensated.parquet"
    result = CliRunner().invoke(app, ["-q", "compensate", str(oven_files[1]), str(path), "--out", str(out)])  # -q: no progress line (stderr is not a terminal here)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "model.json line" in lines[0] and text.lstrip("-") in lines[0], lines
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


def test_a_valid_model_still_compensates_to_finite_output(models, oven_pair):
    """The validator refuses only what is broken: every trained model loads and gives finite output."""
    from gyrocomp.pipeline.compensate import compensate

    _, test, *_ = oven_pair
    for obj in models.values():
        frame, _ = compensate(test, load_model(copy.deepcopy(obj)), mode="causal")
        assert np.isfinite(frame["compensated"]).all()


def test_a_tampered_decomposition_setting_is_refused_before_decomposing(models, oven_pair):
    """``ensemble = 1e9`` in a parallel model's settings: full-mode compensate names it instead of running forever."""
    from gyrocomp.pipeline.compensate import compensate

    _, test, *_ = oven_pair
    obj = copy.deepcopy(models["polynomial"])
    obj["parallel"] = True
    obj.setdefault("settings", {})["decompose"] = {"ensemble": 10**9}
    with pytest.raises(InputError, match=r"model\.json settings\.decompose: ensemble = 1000000000; must be in 1\.\.10000"):
        compensate(test, load_model(obj, name="model.json"), mode="full")


def test_read_json_refuses_non_finite_constants(tmp_path):
    path = tmp_path / "x.json"
    path.write_text('{"a": [1.0, NaN]}')
    with pytest.raises(InputError, match="x.json.*NaN"):
        artefacts.read_json(path)
