"""The papers' parallel pipelines through the command line: decompose -> classify -> train -> compensate."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from gyrocomp import artefacts, recordings
from gyrocomp.cli import app
from gyrocomp.pipeline import evaluate

runner = CliRunner()

FAST = {
    "pe-lcd-anfis": ["model.drift.epochs=10", "model.mixed.epochs=10"],
    "iceemdan-se-tfpf-nsga2elm": ["model.drift.pop_size=10", "model.drift.n_gen=3"],
}


def _invoke(args):
    result = runner.invoke(app, ["--quiet", *[str(a) for a in args]])
    assert result.exit_code == 0, result.output
    return result


def _chain(tmp_path, train_path, config, extra_decompose=()):
    comps, classes, model = tmp_path / "components.parquet", tmp_path / "classes.json", tmp_path / "model.json"
    _invoke(["decompose", train_path, "--config", config, *extra_decompose, "--out", comps])
    _invoke(["classify", comps, "--config", config, "--out", classes])
    sets = [x for s in FAST[config] for x in ("--set", s)]
    _invoke(["train", comps, classes, "--config", config, *sets, "--out", model])
    return model


@pytest.mark.parametrize(
    "config, extra",
    [("pe-lcd-anfis", []), pytest.param("iceemdan-se-tfpf-nsga2elm", ["--ensemble", "10"], marks=pytest.mark.slow)],
)
def test_cli_chain_round_trips_and_compensates_a_held_out_run(tmp_path, oven_files, config, extra):
    """Every artefact feeds the next stage; held-out drift falls >= 10x causal, >= 5x full."""
    train_path, test_path = oven_files
    model = _chain(tmp_path, train_path, config, extra)
    obj = artefacts.read_json(model)
    assert list(obj["axes"]) == ["rate"] and obj["axes"]["rate"]["parallel"] and obj["axes"]["rate"]["kind"] == config
    assert obj["inputs"][0]["name"] == "components.parquet" and obj["settings"]["classify"]
    test = recordings.read_recording(test_path)
    raw = evaluate.residual_drift(test.rate_dps, test.fs_hz)["std_deg_h"]
    for mode, factor in (("causal", 10), ("full", 5)):
        out = tmp_path / f"compensated_{mode}.parquet"
        _invoke(["compensate", test_path, model, "--mode", mode, "--out", out])
        frame, header = artefacts.read_table(out, "gyrocomp.compensation")
        assert list(frame.columns) == ["time", "rate", "temperature", "drift_model", "compensated"]
        sidecar = artefacts.read_json(artefacts.sidecar_path(out), "gyrocomp.compensation")
        assert sidecar["mode"] == mode and (mode == "causal" or sidecar["axes"]["rate"]["classes"])
        left = evaluate.residual_drift(frame["compensated"], test.fs_hz)["std_deg_h"]
        assert raw / left >= factor, f"{config} {mode}: {raw:.1f} -> {left:.2f} deg/h"


def test_full_pipeline_improves_arw_and_bias_instability_on_sample_like_data(make_recording, tmp_path):
    """The papers' qualitative claim (Cao 2021 Fig. 17): ARW and bias instability fall after PE-LCD-ANFIS."""
    recording = make_recording
    from gyrocomp.sim import GyroSettings

    gyro = GyroSettings()  # the sample data's gyro: ARW 1 deg/sqrt(h), flicker, random walk, warm-up
    train, _ = recording([40, 20, 0], seed=5, hold_s=1200.0, gyro=gyro)
    test, _ = recording([40, 20, 0], seed=6, hold_s=1200.0, gyro=gyro)
    paths = []
    for rec, name in ((train, "train.parquet"), (test, "test.parquet")):
        paths.append(tmp_path / name)
        artefacts.write_table(paths[-1], rec.data, {})
    model = _chain(tmp_path, paths[0], "pe-lcd-anfis")
    out = tmp_path / "full.parquet"
    _invoke(["compensate", paths[1], model, "--mode", "full", "--out", out])
    frame, _ = artefacts.read_table(out, "gyrocomp.compensation")
    before = evaluate.allan_terms(test.rate_dps, test.fs_hz)
    after = evaluate.allan_terms(frame["compensated"].to_numpy(), test.fs_hz)
    assert after["arw"]["value"] < 0.5 * before["arw"]["value"]
    assert after["bias_instability"]["value"] < before["bias_instability"]["value"]


def test_bad_model_files_exit_2(tmp_path, oven_files):
    _, test_path = oven_files
    good = tmp_path / "poly.json"
    _invoke(["train", oven_files[0], "--config", "polynomial", "--out", good])
    obj = json.loads(good.read_text())
    axis = obj["axes"]["rate"]
    cases = {
        "future.json": {**obj, "schema": {"name": "gyrocomp.model", "version": "3.0"}},
        "foreign.json": {**obj, "schema": {"name": "gyrocomp.classes", "version": "1.0"}},
        "unfitted.json": {**obj, "axes": {"rate": {**axis, "segments": {"drift": {**axis["segments"]["drift"], "learner": {**axis["segments"]["drift"]["learner"], "fitted": None}}}}}},
        "nosegment.json": {**obj, "axes": {"rate": {k: v for k, v in axis.items() if k != "segments"}}},
        "noaxes.json": {k: v for k, v in obj.items() if k != "axes"},
    }
    for name, content in cases.items():
        (tmp_path / name).write_text(json.dumps(content))
    (tmp_path / "truncated.json").write_text(good.read_text()[:200])
    for name in [*cases, "truncated.json"]:
        result = runner.invoke(app, ["compensate", str(test_path), str(tmp_path / name), "--out", str(tmp_path / "x.parquet")])
        assert result.exit_code == 2, (name, result.output)
        assert name in result.output
    assert not (tmp_path / "x.parquet").exists()


def test_train_refuses_mismatched_inputs(tmp_path, oven_files):
    train_path, _ = oven_files
    result = runner.invoke(app, ["train", str(train_path), str(train_path), "--config", "elm", "--out", str(tmp_path / "m.json")])
    assert result.exit_code == 2 and "recording alone" in result.output
    result = runner.invoke(app, ["train", str(train_path), "--config", "elm", "--set", "model.drift.n_hiden=3", "--out", str(tmp_path / "m.json")])
    assert result.exit_code == 2 and "n_hiden" in result.output


def test_compensate_cli_warns_out_of_range_on_stderr(make_recording, tmp_path, oven_files):
    recording = make_recording

    model = tmp_path / "elm.json"
    _invoke(["train", oven_files[0], "--config", "elm", "--out", model])
    hot, _ = recording([60, 40], seed=3, hold_s=600.0)
    path = tmp_path / "hot.parquet"
    artefacts.write_table(path, hot.data, {})
    result = runner.invoke(app, ["compensate", str(path), str(model), "--out", str(tmp_path / "c.parquet")])
    assert result.exit_code == 0
    assert "warning" in result.output and "degC above" in result.output


def test_pipeline_writes_the_cli_artefacts_byte_for_byte(tmp_path, oven_files):
    """`run`'s decompose and classify stage and the two commands share one writer per artefact.

    Both runs are in this process: exact bytes hold within one machine and one process type.
    """
    from gyrocomp.config import load_config
    from gyrocomp.commands.run import decompose_and_classify

    train_path, _ = oven_files
    cli, pipe = tmp_path / "cli", tmp_path / "pipe"
    cli.mkdir()
    pipe.mkdir()
    _invoke(["decompose", train_path, "--config", "pe-lcd-anfis", "--out", cli / "components.parquet"])
    _invoke(["classify", cli / "components.parquet", "--config", "pe-lcd-anfis", "--out", cli / "classes.json"])
    rec = recordings.read_recording(train_path, require_temperature=True)
    _, paths = decompose_and_classify(rec, load_config("pe-lcd-anfis"), "pe-lcd-anfis", pipe, seed=0, workers=1)
    for name in ("components.parquet", "components.meta.json", "classes.json"):
        assert (pipe / name).read_bytes() == (cli / name).read_bytes(), name
    assert set(paths) == {"components", "classes"}


def test_class_sums_one_component_at_a_time_equal_the_stacked_sum():
    """`segments` denoises one component at a time into its class's sum (issue 38, memory):
    the bytes of summing `denoise.apply`'s rows over the first axis, whether the
    components come as one array or as separate columns."""
    import numpy as np

    from gyrocomp import denoise
    from gyrocomp.denoise import DenoiseSettings
    from gyrocomp.pipeline.signal_path import segments

    rng = np.random.default_rng(11)
    stack = rng.standard_normal((7, 3000)) * np.logspace(0, -2, 7)[:, None] + np.linspace(0, 1, 3000)
    labels = ["noise", "mixed", "noise", "mixed", "drift", "mixed", "drift"]
    settings = DenoiseSettings()
    processed = denoise.apply(stack, labels, settings)
    for given in (stack, [row.copy() for row in stack]):
        parts = segments(given, labels, settings)
        for cls in ("noise", "mixed", "drift"):
            rows = [i for i, label in enumerate(labels) if label == cls]
            np.testing.assert_array_equal(parts[cls], processed[rows].sum(axis=0))
    assert not np.any(segments(stack[:2], ["mixed", "mixed"], settings)["drift"])
