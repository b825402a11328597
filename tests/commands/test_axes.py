"""Several sensor axes in one go: one model per axis, ``<axis>_compensated``, one Allan plot; gaps as segments.

Every multi-axis result is checked against the same command run on one
column alone (to 1e-12) and against the drift the test itself put in.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from gyrocomp import artefacts
from gyrocomp.cli import app

AXES = ("gx", "gy", "gz")
NOISE_DPS = 0.01
"""White rate noise of every axis [deg/s]: ARW = 0.01 * 60 = 0.6 deg/sqrt(h) at any sample rate."""


def _drift(temperature: np.ndarray) -> dict[str, np.ndarray]:
    """A different cubic in temperature per axis [deg/s] (the polynomial pipeline's own form)."""
    d = temperature - 25.0
    return {"gx": 0.01 * d + 1e-3 * d**2, "gy": -0.02 * d + 0.3, "gz": 5e-5 * d**3 - 0.1}


@pytest.fixture(scope="module")
def log3(tmp_path_factory) -> tuple[Path, dict]:
    """A 2 h, 1 Hz `time,gx,gy,gz,temp` log over a 5..45 degC cycle; returns its path and the noise put in."""
    rng = np.random.default_rng(17)
    t = np.arange(7200.0)
    temperature = 25.0 + 20.0 * np.sin(2 * np.pi * t / 7200.0)
    noise = {axis: NOISE_DPS * rng.standard_normal(t.size) for axis in AXES}
    drift = _drift(temperature)
    frame = pd.DataFrame({"time": t, **{axis: drift[axis] + noise[axis] for axis in AXES}, "temp": temperature})
    path = tmp_path_factory.mktemp("axes") / "log3.csv"
    frame.to_csv(path, index=False)
    return path, noise


def _invoke(*args) -> None:
    result = CliRunner().invoke(app, ["-q", *[str(a) for a in args]])
    assert result.exit_code == 0, result.output


def _train(path, out, rate_col, *extra) -> dict:
    _invoke("train", path, "--config", "polynomial", "--rate-col", rate_col, "--temp-col", "temp", *extra, "--out", out)  # a later --config or --temp-col wins
    return json.loads(Path(out).read_text())


def test_one_train_writes_one_model_per_axis_equal_to_single_axis_runs(log3, tmp_path):
    path, _ = log3
    model = _train(path, tmp_path / "model.json", "gx,gy,gz")
    assert model["schema"] == {"name": "gyrocomp.model", "version": "2.0"}
    assert list(model["axes"]) == list(AXES)
    for axis in AXES:
        alone = _train(path, tmp_path / f"{axis}.json", axis)
        assert list(alone["axes"]) == [axis]
        assert model["axes"][axis] == alone["axes"][axis]
    # each axis learned its own drift: the cubic's value at 40 degC, an independent check of the fit
    from gyrocomp.pipeline.compensate import load_models

    models = load_models(model)
    for axis in AXES:
        X = np.array([[40.0, 0.0]])
        assert_allclose(models[axis].predict(X)["drift"][0], _drift(np.array([40.0]))[axis][0], atol=2e-3)


def test_train_workers_give_the_same_bytes(log3, tmp_path):
    path, _ = log3
    _train(path, tmp_path / "w1.json", "g?", "--workers", "1")
    _train(path, tmp_path / "w3.json", "g?", "--workers", "3")
    assert (tmp_path / "w1.json").read_bytes() == (tmp_path / "w3.json").read_bytes()


def test_one_compensate_writes_every_axis_as_the_single_axis_runs_do(log3, tmp_path):
    path, noise = log3
    _train(path, tmp_path / "model.json", "gx,gy,gz")
    out = tmp_path / "comp.parquet"
    _invoke("compensate", path, tmp_path / "model.json", "--rate-col", "gx,gy,gz", "--temp-col", "temp", "--out", out)
    frame = pd.read_parquet(out)
    assert [f"{axis}_compensated" for axis in AXES] == [c for c in frame.columns if c.endswith("_compensated")]
    sidecar = json.loads(artefacts.sidecar_path(out).read_text())
    assert list(sidecar["axes"]) == list(AXES)
    for axis in AXES:
        _train(path, tmp_path / f"{axis}_model.json", axis)
        single = tmp_path / f"{axis}.parquet"
        _invoke("compensate", path, tmp_path / f"{axis}_model.json", "--rate-col", axis, "--temp-col", "temp", "--out", single)
        assert_allclose(frame[f"{axis}_compensated"], pd.read_parquet(single)[f"{axis}_compensated"], rtol=0, atol=1e-12)
        # what is left is the noise the test put in (plus a constant): the drift is gone
        left = frame[f"{axis}_compensated"].to_numpy() - noise[axis]
        assert np.std(left) < 0.1 * NOISE_DPS, axis


def test_a_version_1_model_still_compensates(log3, tmp_path):
    """A model.json from before axes (schema 1.0, one model at the top level) reads as one unnamed axis."""
    path, _ = log3
    model = _train(path, tmp_path / "model.json", "gy")
    header = {k: model[k] for k in ("gyrocomp_version", "inputs", "settings", "seed")}
    entry = {k: v for k, v in model["axes"]["gy"].items() if k != "unit"}
    old = {"schema": {"name": "gyrocomp.model", "version": "1.0"}, **header, **entry}
    (tmp_path / "old.json").write_text(json.dumps(old))
    for name in ("model", "old"):
        _invoke("compensate", path, tmp_path / f"{name}.json", "--rate-col", "gy", "--temp-col", "temp", "--out", tmp_path / f"{name}_comp.parquet")
    assert_allclose(pd.read_parquet(tmp_path / "old_comp.parquet")["gy_compensated"], pd.read_parquet(tmp_path / "model_comp.parquet")["gy_compensated"], atol=0)


def test_compensate_names_an_axis_the_model_lacks(log3, tmp_path):
    path, _ = log3
    _train(path, tmp_path / "model.json", "gx,gy")
    result = CliRunner().invoke(app, ["compensate", str(path), str(tmp_path / "model.json"), "--rate-col", "gx,gz", "--temp-col", "temp", "--out", str(tmp_path / "c.parquet")])
    assert result.exit_code == 2 and "gz" in result.output and "gx, gy" in result.output
    assert not (tmp_path / "c.parquet").exists()


def test_allan_draws_every_axis_in_one_plot(log3, tmp_path, monkeypatch):
    import gyrocomp.plots

    path, _ = log3
    figures = []
    real = gyrocomp.plots.allan_figure
    monkeypatch.setattr(gyrocomp.plots, "allan_figure", lambda series, **kw: figures.append(real(series, **kw)) or figures[-1])
    _invoke("allan", path, "--rate-col", "g*", "--temp-col", "temp", "--taus", "1,2,4,8", "--out", tmp_path / "allan.json", "--plot", tmp_path / "allan.png")
    assert len(figures) == 1 and (tmp_path / "allan.png").stat().st_size > 0
    legend = [t.get_text() for ax in figures[0].axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    for axis in AXES:
        assert sum(f"[{axis}]" in text for text in legend) == 1, (axis, legend)
    series = json.loads((tmp_path / "allan.json").read_text())["series"]
    assert [s["column"] for s in series] == list(AXES)
    for axis, s in zip(AXES, series):
        _invoke("allan", path, "--rate-col", axis, "--temp-col", "temp", "--taus", "1,2,4,8", "--out", tmp_path / f"{axis}.json")
        alone = json.loads((tmp_path / f"{axis}.json").read_text())["series"][0]
        assert_allclose(s["adev"], alone["adev"], rtol=0, atol=1e-12)
        # white noise of 0.01 deg/s: ADEV(1 s) = 0.01 deg/s (NIST SP 1065, white FM), within its chi-square spread
        assert_allclose(s["adev"][0], NOISE_DPS, rtol=0.05)


def test_accelerometer_axes_keep_their_unit(tmp_path):
    """An accelerometer axis in g trains and compensates in m/s^2, and says so."""
    rng = np.random.default_rng(3)
    t = np.arange(3600.0)
    temperature = 20.0 + 10.0 * np.sin(2 * np.pi * t / 3600.0)
    ax_g = 1e-3 * (temperature - 20.0) + 1e-4 * rng.standard_normal(t.size)
    path = tmp_path / "acc.csv"
    pd.DataFrame({"time": t, "ax": ax_g, "temperature": temperature}).to_csv(path, index=False)
    model = _train(path, tmp_path / "m.json", "ax", "--rate-unit", "g", "--temp-col", "temperature")
    assert model["axes"]["ax"]["unit"] == "m/s^2"
    out = tmp_path / "c.parquet"
    _invoke("compensate", path, tmp_path / "m.json", "--rate-col", "ax", "--rate-unit", "g", "--out", out)
    frame = pd.read_parquet(out)
    assert_allclose(frame["ax"], ax_g * 9.80665, rtol=1e-12)  # standard gravity, CGPM 1901
    assert json.loads(artefacts.sidecar_path(out).read_text())["axes"]["ax"]["unit"] == "m/s^2"
    assert np.std(frame["ax_compensated"]) < 2e-3 * np.std(frame["ax"]) + 2e-3
    _invoke("allan", path, "--rate-col", "ax", "--rate-unit", "g", "--taus", "1,2,4,8", "--out", tmp_path / "allan.json")
    terms = json.loads((tmp_path / "allan.json").read_text())["series"][0]["terms"]
    assert terms["arw"]["unit"] == "m/s/sqrt(h)" and terms["bias_instability"]["unit"] == "m/s/h"
    assert_allclose(terms["arw"]["value"], 1e-4 * 9.80665 * 60, rtol=0.1)  # velocity random walk of 1e-4 g white noise at 1 Hz


def test_gaps_are_segments_never_bridged(tmp_path):
    """A gapped log compensates exactly as its segments do one by one: nothing crosses a gap, nothing is filled."""
    rng = np.random.default_rng(5)
    parts, start = [], 0.0
    for n, gap in ((900, 300.0), (600, 1200.0), (1200, 0.0)):
        t = start + np.arange(n)
        parts.append(pd.DataFrame({"time": t, "rate": 0.02 * np.sin(t / 900.0), "temperature": 25 + 10 * np.sin(t / 900.0)}))
        start = t[-1] + 1 + gap
    whole = pd.concat(parts, ignore_index=True)
    whole["rate"] += NOISE_DPS * rng.standard_normal(len(whole))
    path = tmp_path / "gapped.csv"
    whole.to_csv(path, index=False)
    model = _train(path, tmp_path / "m.json", "rate", "--temp-col", "temperature")
    assert model["axes"]["rate"]["training"]["n_segments"] == 3
    assert model["axes"]["rate"]["training"]["n_samples"] == len(whole)
    out = tmp_path / "c.parquet"
    _invoke("compensate", path, tmp_path / "m.json", "--out", out)
    frame = pd.read_parquet(out)
    assert_allclose(frame["time"], whole["time"], atol=0)  # no filled row
    row = 0
    for k, _ in enumerate(parts):
        n = len(parts[k])
        piece = tmp_path / f"part{k}.csv"
        whole.iloc[row : row + n].to_csv(piece, index=False)
        _invoke("compensate", piece, tmp_path / "m.json", "--out", tmp_path / f"part{k}.parquet")
        alone = pd.read_parquet(tmp_path / f"part{k}.parquet")
        assert_allclose(frame["compensated"].iloc[row : row + n], alone["compensated"], rtol=0, atol=1e-12)
        row += n


def test_lsm6dsm_bursts_train_and_compensate_by_segments(real_data, tmp_path):
    """The PAN LSM6DSM cold TVAC log: 25 bursts of 5 s, duplicate stamps, three axes.

    The temperature slope of a linear model trained on every sample of every
    burst agrees with the linear fit on the 25 burst medians that the data's
    README gives (X +0.0301, Y -0.0142, Z +0.0014 deg/s/degC), recomputed
    here with numpy from the file alone.
    """
    from gyrocomp.pipeline.compensate import load_models

    LSM6DSM = real_data("pan-lsm6dsm-tvac") / "pan_lsm6dsm_tvac_cold_2020-03-07.csv"
    model = _train(
        LSM6DSM, tmp_path / "m.json", "rate_x,rate_y,rate_z", "--temp-col", "temperature", "--dedupe", "first",
        "--set", "model.drift.degree=1", "--set", "model.drift.rate_term=false",
    )
    raw = pd.read_csv(LSM6DSM)
    burst = np.concatenate([[0], np.cumsum(np.diff(raw["time"].to_numpy()) > 1.0)])
    medians = raw.groupby(burst).median()
    readme = {"rate_x": 0.0301, "rate_y": -0.0142, "rate_z": 0.0014}
    models = load_models(model)
    for axis, published in readme.items():
        assert model["axes"][axis]["training"]["n_segments"] == 25
        slope = np.diff(models[axis].predict(np.array([[15.0, 0.0], [25.0, 0.0]]))["drift"])[0] / 10.0
        by_medians = np.polyfit(medians["temperature"], medians[axis], 1)[0]
        assert_allclose(by_medians, published, atol=5e-5)
        assert_allclose(slope, by_medians, rtol=0.1, atol=2e-4)
    out = tmp_path / "c.parquet"
    _invoke("compensate", LSM6DSM, tmp_path / "m.json", "--rate-col", "rate_*", "--dedupe", "first", "--out", out)
    frame = pd.read_parquet(out)
    assert len(frame) == len(raw) - 5  # five duplicate stamps merged, no gap filled
    assert np.std(frame["rate_x_compensated"]) < 0.4 * np.std(frame["rate_x"])  # X drifts -0.25 deg/s over the ramp


def test_a_parallel_pipeline_trains_every_axis_as_its_decompose_classify_train_chain(log3, tmp_path):
    """`train REC --config pe-lcd-anfis` decomposes and classifies each axis as the three commands do."""
    path, _ = log3
    fast = ["--set", "model.drift.epochs=5", "--set", "model.mixed.epochs=5"]
    model = _train(path, tmp_path / "model.json", "gx,gz", "--config", "pe-lcd-anfis", "--workers", "2", *fast)
    for axis in ("gx", "gz"):
        comps, classes = tmp_path / f"{axis}.parquet", tmp_path / f"{axis}_classes.json"
        _invoke("decompose", path, "--config", "pe-lcd-anfis", "--rate-col", axis, "--temp-col", "temp", "--out", comps)
        _invoke("classify", comps, "--config", "pe-lcd-anfis", "--out", classes)
        _invoke("train", comps, classes, "--config", "pe-lcd-anfis", *fast, "--out", tmp_path / f"{axis}_model.json")
        chain = json.loads((tmp_path / f"{axis}_model.json").read_text())
        assert list(chain["axes"]) == [axis]
        assert model["axes"][axis]["segments"] == chain["axes"][axis]["segments"]
        assert model["axes"][axis]["training"] == chain["axes"][axis]["training"]
    # the same chain on both axes at once: one components file, one classes file, one model
    comps, classes = tmp_path / "both.parquet", tmp_path / "both_classes.json"
    _invoke("decompose", path, "--config", "pe-lcd-anfis", "--rate-col", "gx,gz", "--temp-col", "temp", "--out", comps)
    _invoke("classify", comps, "--config", "pe-lcd-anfis", "--out", classes)
    _invoke("train", comps, classes, "--config", "pe-lcd-anfis", *fast, "--out", tmp_path / "both_model.json")
    both = json.loads((tmp_path / "both_model.json").read_text())
    assert list(both["axes"]) == ["gx", "gz"]
    for axis in ("gx", "gz"):
        assert both["axes"][axis]["segments"] == model["axes"][axis]["segments"]
        assert both["axes"][axis]["training"] == model["axes"][axis]["training"]


def test_decompose_and_classify_several_axes_equal_the_single_axis_runs(log3, tmp_path):
    """`decompose --rate-col gx,gy,gz`: prefixed components equal each axis decomposed alone; classes per axis."""
    path, _ = log3
    comps = tmp_path / "c.parquet"
    _invoke("decompose", path, "--method", "lcd", "--rate-col", "gx,gy,gz", "--temp-col", "temp", "--out", comps)
    frame = pd.read_parquet(comps)
    sidecar = json.loads(artefacts.sidecar_path(comps).read_text())
    assert list(sidecar["axes"]) == list(AXES)
    _invoke("classify", comps, "--out", tmp_path / "classes.json")
    classes = json.loads((tmp_path / "classes.json").read_text())
    assert list(classes["axes"]) == list(AXES) and "components" not in classes
    for axis in AXES:
        single = tmp_path / f"{axis}.parquet"
        _invoke("decompose", path, "--method", "lcd", "--rate-col", axis, "--temp-col", "temp", "--out", single)
        alone = pd.read_parquet(single)
        names = [c["name"] for c in json.loads(artefacts.sidecar_path(single).read_text())["components"]]
        assert [c["name"] for c in sidecar["axes"][axis]["components"]] == [f"{axis}_{n}" for n in names]
        assert_allclose(frame[axis], alone["rate"], rtol=0, atol=0)
        for name in names:
            assert_allclose(frame[f"{axis}_{name}"], alone[name], rtol=0, atol=1e-12)
        # the components add up to the axis (the decomposition's own identity, here on the file)
        assert_allclose(frame[[f"{axis}_{n}" for n in names]].sum(axis=1), frame[axis], rtol=0, atol=1e-9)
        _invoke("classify", single, "--out", tmp_path / f"{axis}_classes.json")
        one = json.loads((tmp_path / f"{axis}_classes.json").read_text())["components"]
        assert [{**e, "name": f"{axis}_{e['name']}"} for e in one] == classes["axes"][axis]["components"]
        assert classes["axes"][axis]["components"][-1]["class"] == "drift"  # the trend of a 20 degC cycle's drift


def test_decompose_several_axes_gives_the_same_bytes_for_any_workers(log3, tmp_path):
    path, _ = log3
    for workers in (1, 2):
        _invoke("decompose", path, "--method", "iceemdan", "--ensemble", "4", "--rate-col", "gx,gy", "--temp-col", "temp", "--workers", workers, "--seed", 7, "--out", tmp_path / f"w{workers}.parquet")
    assert pd.read_parquet(tmp_path / "w1.parquet").equals(pd.read_parquet(tmp_path / "w2.parquet"))
    assert (tmp_path / "w1.meta.json").read_bytes() == (tmp_path / "w2.meta.json").read_bytes()


def test_batch_passes_the_axes_and_reports_each(log3, tmp_path):
    """`batch allan|compensate --rate-col gx,gy,gz`: the key figures per axis, the command's own outputs."""
    from gyrocomp.batch import run_batch

    path, _ = log3
    columns = {"rate_col": "gx,gy,gz", "temp_col": "temp"}
    result = run_batch("allan", [str(path)], tmp_path / "allan", workers=1, options={**columns, "taus": "1,2,4,8"})
    row = result.rows[0]
    series = json.loads((tmp_path / "allan" / "log3" / "allan.json").read_text())["series"]
    for axis, s in zip(AXES, series):
        assert row[f"{axis}_arw_fit"] == s["terms"]["arw"]["value"]
        assert_allclose(row[f"{axis}_arw_fit"], 60 * NOISE_DPS, rtol=0.1)  # N = sigma * sqrt(1 s) * 60 [deg/sqrt(h)]
    _train(path, tmp_path / "model.json", "gx,gy,gz")
    result = run_batch("compensate", [str(path)], tmp_path / "comp", workers=1, options=columns, files={"model": tmp_path / "model.json"})
    row = result.rows[0]
    assert result.exit_code == 0, row
    for axis in AXES:
        assert row[f"{axis}_compensated_drift_std_deg_h"] < 0.1 * row[f"{axis}_drift_std_deg_h"], axis


def _two_axes(path, seed):
    """5400 s at 1 Hz: `g1` the baseline (offset + linear in T + ARW 1 deg/sqrt(h)), `g2` the same plus a 1000 s sinusoid."""
    from gyrocomp.effects import noise as sim_noise

    rng = np.random.default_rng(seed)
    t = np.arange(5400.0)
    temp = 25.0 + 15.0 * np.sin(2 * np.pi * t / 3600.0)
    base = 0.05 + 2e-3 * (temp - 25.0)
    frame = pd.DataFrame({
        "time": t,
        "g1": base + sim_noise.white(t.size, 1.0, 1.0, rng),
        "g2": base + 0.02 * np.sin(2 * np.pi * t / 1000.0 + 0.3) + sim_noise.white(t.size, 1.0, 1.0, rng),
        "temperature": temp,
    })
    frame.to_csv(path, index=False)


@pytest.mark.slow
def test_diagnose_gives_a_verdict_per_axis_as_the_single_axis_runs(tmp_path):
    fit, hold = tmp_path / "fit.csv", tmp_path / "hold.csv"
    _two_axes(fit, 1)
    _two_axes(hold, 2)
    out = tmp_path / "report.json"
    _invoke("diagnose", fit, "--holdout", hold, "--rate-col", "g1,g2", "--out", out, "--plot", tmp_path / "gap.png", "--markdown", tmp_path / "report.md")
    report = json.loads(out.read_text())
    assert list(report["axes"]) == ["g1", "g2"]
    assert (tmp_path / "gap_g1.png").is_file() and (tmp_path / "gap_g2.png").is_file()
    assert report["axes"]["g1"]["selected_effects"] == [] and "periodic" in report["axes"]["g2"]["selected_effects"]
    for axis in ("g1", "g2"):
        _invoke("diagnose", fit, "--holdout", hold, "--rate-col", axis, "--out", tmp_path / f"{axis}.json")
        alone = json.loads((tmp_path / f"{axis}.json").read_text())
        assert alone["axis"] == axis
        assert report["axes"][axis]["selected_effects"] == alone["selected_effects"]
        for model in ("baseline", "selected"):
            for run in ("fit", "holdout"):
                assert_allclose(report["axes"][axis]["gap"][model][run], alone["gap"][model][run], rtol=0, atol=1e-12)


def test_run_scores_every_method_on_every_axis_as_the_single_axis_runs(log3, tmp_path):
    """`run compare TRAIN --test HOLD --rate-col gx,gz`: rows per axis, each equal to `run` on that column alone."""
    path, _ = log3
    hold = tmp_path / "hold.csv"
    frame = pd.read_csv(path)
    frame[list(AXES)] += 0.002 * np.random.default_rng(23).standard_normal((len(frame), len(AXES)))
    frame.to_csv(hold, index=False)
    methods = ["--set", 'run.methods=["polynomial", "elm"]']
    _invoke("run", "compare", path, "--test", hold, "--rate-col", "gx,gz", "--temp-col", "temp", *methods, "--out", tmp_path / "both")
    report = json.loads((tmp_path / "both" / "report.json").read_text())
    assert report["axes"] == ["gx", "gz"]
    assert [(r["axis"], r["method"]) for r in report["rows"]] == [(a, m) for a in ("gx", "gz") for m in ("raw", "polynomial", "elm")]
    assert (tmp_path / "both" / "gz" / "elm" / "model.json").is_file()
    assert "[gz]" in (tmp_path / "both" / "report.md").read_text()
    for axis in ("gx", "gz"):
        _invoke("run", "compare", path, "--test", hold, "--rate-col", axis, "--temp-col", "temp", *methods, "--out", tmp_path / axis)
        alone = json.loads((tmp_path / axis / "report.json").read_text())["rows"]
        mine = [r for r in report["rows"] if r["axis"] == axis]
        for row, one in zip(mine, alone, strict=True):
            assert (row["method"], row["mode"], one["axis"]) == (one["method"], one["mode"], axis)
            assert_allclose(row["allan"]["adev"], one["allan"]["adev"], rtol=0, atol=1e-12)
            assert_allclose(row["means_dph"], one["means_dph"], rtol=0, atol=1e-12)
            assert_allclose(row["residual_drift"]["std_deg_h"], one["residual_drift"]["std_deg_h"], rtol=0, atol=1e-12)
            if one["signal"] is not None:
                assert_allclose(row["signal"]["gain"], one["signal"]["gain"], rtol=0, atol=1e-12)
        # the polynomial takes out the drift the test put in: its 100 s means spread far less than the raw axis'
        raw, poly = (next(r for r in mine if r["method"] == m) for m in ("raw", "polynomial"))
        assert poly["residual_drift"]["std_deg_h"] < 0.05 * raw["residual_drift"]["std_deg_h"], axis


def test_batch_run_reports_each_axis(log3, tmp_path):
    """`batch run --rate-col gx,gz`: the key figures per axis, from the unit's own report."""
    from gyrocomp.batch import run_batch

    path, _ = log3
    options = {"rate_col": "gx,gz", "temp_col": "temp", "overrides": ['run.methods=["polynomial"]']}
    result = run_batch("run", [str(path)], tmp_path / "out", workers=1, options=options, files={"config": "compare"})
    assert result.exit_code == 0, result.rows[0]
    row = result.rows[0]
    report = json.loads((tmp_path / "out" / "log3" / "report.json").read_text())
    for r in report["rows"]:
        label = r["method"] if r["mode"] is None else f"{r['method']}_{r['mode']}"
        assert row[f"{r['axis']}_{label}_drift_std_deg_h"] == r["residual_drift"]["std_deg_h"]
    assert row["gx_polynomial_causal_drift_std_deg_h"] < 0.05 * row["gx_raw_drift_std_deg_h"]
