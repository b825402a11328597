"""Classification thresholds, the [classify] config tables, and the classify CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import artefacts
from gyrocomp.classify import ClassifySettings, PermutationSettings, SampleSettings, class_of, classify
from gyrocomp.cli import app
from gyrocomp.config import bind, load_config
from gyrocomp.errors import InputError


@pytest.mark.parametrize("name", ["pe-lcd-anfis", "iceemdan-se-tfpf-nsga2elm"])
def test_defaults_equal_shipped_toml(name):
    settings = bind(ClassifySettings, load_config(name)["classify"], name)
    assert settings == dataclasses.replace(ClassifySettings(), entropy=settings.entropy)
    assert settings.entropy == ("permutation" if name == "pe-lcd-anfis" else "sample")


def test_paper_thresholds():
    """Cao et al. (2021): PE 0.6 / 0.4; Zhang et al. (2024): SE 0.6 / 0.1."""
    pe, se = ClassifySettings(), ClassifySettings(entropy="sample")
    assert (pe.noise_above, pe.drift_below) == (0.6, 0.4)
    assert (se.noise_above, se.drift_below) == (0.6, 0.1)


@pytest.mark.parametrize(
    "value, expected",
    [(0.61, "noise"), (0.6, "mixed"), (0.5, "mixed"), (0.4, "mixed"), (0.3999, "drift"), (float("inf"), "noise")],
)
def test_threshold_boundaries(value, expected):
    assert class_of(value, ClassifySettings()) == expected


def test_sample_thresholds_boundaries():
    settings = ClassifySettings(entropy="sample")
    assert [class_of(v, settings) for v in (0.0999, 0.1, 0.6, 0.6001)] == ["drift", "mixed", "mixed", "noise"]
    with pytest.raises(InputError):
        class_of(float("nan"), settings)


def test_bad_settings():
    with pytest.raises(InputError):
        ClassifySettings(entropy="fuzzy")
    with pytest.raises(InputError):
        PermutationSettings(noise_above=0.3, drift_below=0.4)
    with pytest.raises(InputError):
        SampleSettings(r_factor=0.0)


def _components(n=4000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    return np.stack([rng.standard_normal(n), np.sin(2 * np.pi * t / 100) + 0.02 * rng.standard_normal(n), 1e-3 * t]), [
        "imf1",
        "imf2",
        "residue",
    ]


@pytest.mark.parametrize("kind", ["permutation", "sample"])
def test_classify_noise_mixed_drift(kind):
    comps, names = _components()
    result = classify(comps, names, ClassifySettings(entropy=kind))
    assert [r["name"] for r in result] == names
    assert [r["class"] for r in result] == ["noise", "mixed", "drift"]


def _write_components(path, schema="gyrocomp.components"):
    comps, names = _components()
    frame = pd.DataFrame({"time": np.arange(comps.shape[1]) / 10.0, "rate": comps.sum(axis=0)})
    for name, c in zip(names, comps):
        frame[name] = c
    header = artefacts.artefact_header(schema, inputs=[{"name": "rec.csv", "sha256": "0" * 64}])
    header["components"] = names
    artefacts.write_table(path, frame, header)


def test_cli_round_trip(tmp_path):
    comp = tmp_path / "components.parquet"
    _write_components(comp)
    out, png = tmp_path / "classes.json", tmp_path / "entropy.png"
    res = CliRunner().invoke(app, ["classify", str(comp), "--config", "iceemdan-se-tfpf-nsga2elm", "--plot", str(png), "--out", str(out)])
    assert res.exit_code == 0, res.output
    doc = artefacts.read_json(out, "gyrocomp.classes")
    assert [c["class"] for c in doc["components"]] == ["noise", "mixed", "drift"]
    assert doc["entropy"]["kind"] == "sample" and doc["thresholds"] == {"noise_above": 0.6, "drift_below": 0.1}
    assert doc["settings"]["sample"]["m"] == 2
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "imf2" in res.output


def test_cli_entropy_option_and_stdout(tmp_path):
    comp = tmp_path / "components.parquet"
    _write_components(comp)
    res = CliRunner().invoke(app, ["classify", str(comp), "--entropy", "permutation", "--out", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["thresholds"] == {"noise_above": 0.6, "drift_below": 0.4}
    assert doc["entropy"] == {"kind": "permutation", "order": 6, "delay": 1, "noise_above": 0.6, "drift_below": 0.4}


@pytest.mark.parametrize("args", [["--entropy", "fuzzy"], ["--config", "no-such-config"], ["--set", "classify.sample.q=1"]])
def test_cli_bad_options_exit_2(tmp_path, args):
    comp = tmp_path / "components.parquet"
    _write_components(comp)
    res = CliRunner().invoke(app, ["classify", str(comp), *args, "--out", str(tmp_path / "c.json")])
    assert res.exit_code == 2, res.output
    assert not (tmp_path / "c.json").exists()


def test_cli_foreign_schema_exit_2(tmp_path):
    comp = tmp_path / "compensated.parquet"
    _write_components(comp, schema="gyrocomp.compensated")
    res = CliRunner().invoke(app, ["classify", str(comp), "--out", str(tmp_path / "c.json")])
    assert res.exit_code == 2
    assert "expected 'gyrocomp.components'" in res.output


def test_cli_missing_file_exit_2(tmp_path):
    res = CliRunner().invoke(app, ["classify", str(tmp_path / "none.parquet"), "--out", str(tmp_path / "c.json")])
    assert res.exit_code == 2
