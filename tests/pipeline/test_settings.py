"""Defaults equal the shipped TOML; unknown keys and learners are refused with the file named."""

from __future__ import annotations

import dataclasses

import pytest

from gyrocomp.config import bind, load_config
from gyrocomp.errors import InputError
from gyrocomp.pipeline.settings import (
    EvaluateSettings,
    ModelSettings,
    PipelineSettings,
    RateSettings,
    RunSettings,
    SignalSettings,
    model_settings,
    pipeline_settings,
    rate_settings,
)

PIPELINES = ["pe-lcd-anfis", "iceemdan-se-tfpf-nsga2elm", "bp", "elm", "polynomial"]


@pytest.mark.parametrize("name", PIPELINES)
def test_rate_and_model_defaults_equal_every_shipped_config(name):
    config = load_config(name)
    assert rate_settings(config, name) == RateSettings()
    model = model_settings(config, name, pipeline_settings(config, name).parallel)
    assert model.max_samples == ModelSettings.__dataclass_fields__["max_samples"].default
    assert model.clip_inputs == model.clip_output == (name != "polynomial")


def test_pipeline_defaults_equal_polynomial_toml():
    assert pipeline_settings(load_config("polynomial"), "polynomial") == PipelineSettings()


def test_run_config_defaults_equal_compare_toml():
    config = load_config("compare")
    assert bind(RunSettings, config["run"], "compare") == RunSettings()
    assert bind(EvaluateSettings, config["evaluate"], "compare") == EvaluateSettings()
    assert bind(SignalSettings, config["signal"], "compare") == SignalSettings()


def test_paper_model_tables():
    pe = model_settings(load_config("pe-lcd-anfis"), "pe", True)
    assert pe.segments["drift"].params["n_mfs"] == [4, 4] and pe.segments["mixed"].params["n_mfs"] == [2, 2]
    ice = model_settings(load_config("iceemdan-se-tfpf-nsga2elm"), "ice", True)
    assert set(ice.segments) == {"drift"}
    p = ice.segments["drift"].params
    assert (p["pop_size"], p["crossover"], p["mutation"], p["n_gen"]) == (40, 0.8, 0.15, 15)


@pytest.mark.parametrize(
    "table, match",
    [
        ({"drift": {"learner": "svm"}}, "learner = 'svm'"),
        ({"drift": {"learner": "elm", "n_hiden": 3}}, "unknown setting n_hiden"),
        ({"drift": {"learner": "elm"}, "mixed": {"learner": "elm"}}, "unknown segment or key mixed"),
        ({"mixed": {"learner": "elm"}}, r"needs a \[model.drift\]"),
        ({"drift": {"learner": "elm"}, "clip_inputs": 1}, "clip_inputs"),
    ],
)
def test_bad_model_tables_are_refused(table, match):
    with pytest.raises(InputError, match=match):
        model_settings({"model": table}, "my.toml", parallel=False)


def test_run_settings_validate():
    with pytest.raises(InputError):
        RunSettings(modes=("offline",))
    with pytest.raises(InputError):
        RunSettings(overrides=("nocolon",))
    assert dataclasses.replace(SignalSettings(), sine_hz=(0.01,)).sine_hz == (0.01,)
