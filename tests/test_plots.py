"""Every figure of gyrocomp.plots is drawn here, from the sample data or a simulated run, and written as PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from gyrocomp import plots
from gyrocomp.cli import app

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def sample():
    if not (SAMPLE / "oven_train.parquet").exists():
        pytest.skip("sample_data absent")
    return SAMPLE


def test_no_global_matplotlib_state_in_the_library():
    """Object API only: no ``matplotlib.use``, no ``pyplot``, no lock around drawing."""
    for path in (ROOT / "gyrocomp").rglob("*.py"):
        text = path.read_text()
        assert "matplotlib.use(" not in text and "import matplotlib.pyplot" not in text and "import pyplot" not in text and "PLOT_LOCK" not in text, path


def test_train_and_compensate_plot_bias_against_temperature_with_branches(sample, tmp_path):
    runner = CliRunner()
    model, train_png, comp_png = tmp_path / "m.json", tmp_path / "train.png", tmp_path / "comp.png"
    result = runner.invoke(app, ["train", str(sample / "oven_train.parquet"), "--config", "polynomial", "--out", str(model), "--plot", str(train_png)])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["compensate", str(sample / "oven_test.parquet"), str(model), "--out", str(tmp_path / "c.parquet"), "--plot", str(comp_png)])
    assert result.exit_code == 0, result.output
    assert train_png.read_bytes()[:8] == PNG and comp_png.read_bytes()[:8] == PNG


def test_drift_figure_content(sample):
    from gyrocomp import recordings
    from gyrocomp.config import load_config
    from gyrocomp.pipeline.compensate import compensate, load_model
    from gyrocomp.pipeline.train import train_direct

    test = recordings.read_recording(sample / "oven_test.parquet", require_temperature=True).axis()
    train = recordings.read_recording(sample / "oven_train.parquet", require_temperature=True).axis()
    model = load_model(train_direct(train, load_config("polynomial"), source="p", seed=0))
    frame, _ = compensate(test, model, "causal")
    columns = [frame[c].to_numpy() for c in ("time", "temperature", "rate", "compensated")]
    fig = plots.drift_figure([plots.drift_axis("gx", *columns, model), plots.drift_axis("gy", *columns, model)])
    left, right = fig.axes[0], fig.axes[2]
    labels = [line.get_label() for line in left.get_lines()]
    assert any(label.startswith("heating") for label in labels) and any(label.startswith("cooling") for label in labels)
    assert "model, dT/dt = 0" in labels
    assert {line.get_label() for line in right.get_lines()} == {"raw", "compensated"}
    assert any(ax.get_ylabel() == "temperature [degC]" for ax in fig.axes)  # the second axis
    assert len(fig.axes) == 8  # two axes, four panels each (bias before, bias after, rate, its temperature twin)
    # the test run cools first: its cooling branch lies below its heating branch at the same temperature
    heating = next(line for line in left.get_lines() if line.get_label().startswith("heating"))
    cooling = next(line for line in left.get_lines() if line.get_label().startswith("cooling"))
    at = lambda line: np.interp(0.0, *sorted_xy(line))  # noqa: E731
    assert at(cooling) < at(heating)


def test_drift_figure_shows_the_loop_before_and_after_compensation(sample):
    """The middle panel is the heating/cooling loop of the compensated run: a cubic leaves the loop open, the grey-box model closes it."""
    from gyrocomp import recordings
    from gyrocomp.config import load_config
    from gyrocomp.pipeline.compensate import compensate, load_model
    from gyrocomp.pipeline.greybox import load_greybox, train_greybox
    from gyrocomp.pipeline.train import train_direct

    test = recordings.read_recording(sample / "oven_test.parquet", require_temperature=True).axis()
    train = recordings.read_recording(sample / "oven_train.parquet", require_temperature=True).axis()
    cubic = load_model(train_direct(train, load_config("polynomial"), source="p", seed=0))
    greybox = load_greybox(next(iter(train_greybox([train], load_config("greybox"), source="g")[0].values())), "g")
    gaps = {}
    for name, model in (("cubic", cubic), ("greybox", greybox)):
        frame, _ = compensate(test, model, "causal")
        columns = [frame[c].to_numpy() for c in ("time", "temperature", "rate", "compensated")]
        before, after = plots.drift_figure([plots.drift_axis("gx", *columns, model)]).axes[:2]
        assert after.get_title() == "gx: after compensation" and after.get_ylim() == before.get_ylim()
        branch = {line.get_label().split()[0]: line for line in after.get_lines() if line.get_label()[0] != "_"}
        assert set(branch) == {"soak", "heating", "cooling"}
        assert all(line.get_label().endswith(" deg/h") for line in branch.values())  # each branch's std
        compensated_means = frame["compensated"].to_numpy()[: len(frame) // 60 * 60].reshape(-1, 60).mean(axis=1) * 3600.0  # 1 Hz, 60 s blocks
        shown = np.concatenate([line.get_ydata() for line in branch.values()])
        np.testing.assert_allclose(np.sort(shown), np.sort(compensated_means), rtol=1e-12)
        gap = lambda ax: np.interp(0.0, *sorted_xy(_line(ax, "heating"))) - np.interp(0.0, *sorted_xy(_line(ax, "cooling")))  # noqa: E731
        gaps[name] = (gap(before), gap(after))
    assert gaps["cubic"][0] == pytest.approx(gaps["greybox"][0])  # the same run before compensation: a 260 deg/h loop at 0 degC
    assert abs(gaps["cubic"][1]) > 0.5 * abs(gaps["cubic"][0])  # the cubic leaves it open (213 deg/h)
    assert abs(gaps["greybox"][1]) < 0.25 * abs(gaps["greybox"][0])  # the grey-box model closes it (34 deg/h)


def _line(ax, prefix):
    return next(line for line in ax.get_lines() if line.get_label().startswith(prefix))


def sorted_xy(line):
    x, y = line.get_xdata(), line.get_ydata()
    order = np.argsort(x)
    return x[order], y[order]


def test_decompose_and_classify_plots(tmp_path, sample):
    from gyrocomp import artefacts, recordings

    rec = recordings.read_recording(sample / "oven_train.parquet", require_temperature=True).axis()
    short = tmp_path / "short.parquet"
    artefacts.write_table(short, rec.data.iloc[:3000], {})
    runner = CliRunner()
    comps, png = tmp_path / "c.parquet", tmp_path / "components.png"
    result = runner.invoke(app, ["decompose", str(short), "--method", "emd", "--out", str(comps), "--plot", str(png)])
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == PNG
    classes_png = tmp_path / "classes.png"
    result = runner.invoke(app, ["classify", str(comps), "--out", str(tmp_path / "classes.json"), "--plot", str(classes_png)])
    assert result.exit_code == 0, result.output
    assert classes_png.read_bytes()[:8] == PNG
    frame, header = artefacts.read_table(comps, "gyrocomp.components")
    entries = artefacts.read_json(tmp_path / "classes.json")["components"]
    stack = [(e["name"], frame[e["name"]].to_numpy(), e["class"]) for e in entries]
    fig = plots.components_figure(frame["time"].to_numpy(), stack)
    assert [ax.get_ylabel() for ax in fig.axes] == [f"{e['name']}\n{e['class']}" for e in entries]


def test_allan_figure_has_guides_readoffs_and_one_colour_per_series():
    from gyrocomp.allan import analyse

    rng = np.random.default_rng(3)
    n = 200_000
    walk = np.cumsum(rng.normal(0, 2e-5, n))
    series = [analyse(rng.normal(0, 0.01, n) + k * walk, 1.0, name=f"g{axis}") for k, axis in enumerate("xyz")]
    fig = plots.allan_figure(series)
    ax = fig.axes[0]
    guides = [line for line in ax.get_lines() if line.get_linestyle() == ":"]
    assert len(guides) == 3
    assert sorted(t.get_text() for t in ax.texts) == ["slope +0.5", "slope -0.5", "slope 0"]
    curves = [line for line in ax.get_lines() if line.get_linestyle() == "-"]
    assert len({line.get_color() for line in curves}) == 3
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[0].startswith("gx: N ") and "B " in legend[0] and "K " in legend[0]
    markers = {line.get_marker() for line in ax.get_lines()}
    assert "v" in markers
    # white noise and random walk have no flat region: no B, so no B point (issue 35 item 7)
    assert all(s.terms["bias_instability"]["readoff"] is None for s in series) and "o" not in markers
    # the N point sits on the read-off: sigma(1 s) = N / 60
    n_point = next(line for line in ax.get_lines() if line.get_marker() == "v")
    assert n_point.get_ydata()[0] == pytest.approx(series[0].terms["arw"]["readoff"] / 60)


def test_a_plot_there_already_is_overwritten_not_taken_for_an_input(sample, tmp_path):
    """Re-running with the same --plot path replaces the PNG (it is an output, not an input to protect)."""
    png = tmp_path / "allan.png"
    args = ["allan", str(sample / "oven_test.parquet"), "--out", str(tmp_path / "a.json"), "--plot", str(png)]
    for _ in range(2):
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == PNG
    same = CliRunner().invoke(app, ["compensate", str(sample / "oven_test.parquet"), str(tmp_path / "a.json"), "--out", str(tmp_path / "c.parquet"), "--plot", str(sample / "oven_test.parquet")])
    assert same.exit_code == 2 and "would overwrite the input" in same.output


def test_drift_figure_averages_within_segments():
    """Issue 35 item 4: 25 bursts of 5 s every 5 min give 25 points per axis (blocks counted across gaps gave 2), each a burst's mean."""
    fs, n, period = 50.0, 250, 300.0
    time = np.concatenate([k * period + np.arange(n) / fs for k in range(25)])
    burst = np.repeat(np.arange(25), n)
    temperature = 20.0 - 0.4 * burst + 0.001 * np.tile(np.arange(n), 25)
    rate = 1e-3 * burst + np.random.default_rng(0).normal(0.0, 1e-4, time.size)
    axis = {
        "name": "gx", "time_s": time, "temperature_c": temperature, "rate_dps": rate, "compensated_dps": None,
        "temperature_rate_c_per_s": np.gradient(temperature, time), "model_temperature_c": np.array([10.0, 20.0]),
        "model_dps": np.zeros(2), "segments": [slice(k * n, (k + 1) * n) for k in range(25)],
    }
    fig = plots.drift_figure([axis])
    raw = next(line for line in fig.axes[-2].get_lines() if line.get_label() == "raw")
    np.testing.assert_allclose(raw.get_ydata(), rate.reshape(25, n).mean(axis=1) * 3600.0, rtol=1e-12)
    np.testing.assert_allclose(raw.get_xdata(), (time.reshape(25, n).mean(axis=1) - time[0]) / 3600.0, rtol=1e-12)
    points = sum(len(line.get_xdata()) for line in fig.axes[0].get_lines() if line.get_marker() == ".")
    assert points == 25


def test_minmax_columns_keeps_the_envelope_in_two_points_a_column():
    """Issue 35 item 9: a series is decimated before drawing, to its min and max in each pixel column."""
    rng = np.random.default_rng(8)
    x = np.arange(100_000) / 1000.0
    y = rng.normal(size=x.size)
    xs, ys = plots.minmax_columns(x, y, 100)
    assert len(xs) == len(ys) == 200
    spans = np.array_split(np.arange(x.size), 100)  # equal spans of an evenly sampled x
    np.testing.assert_allclose(ys[0::2], [y[s].min() for s in spans])
    np.testing.assert_allclose(ys[1::2], [y[s].max() for s in spans])
    short_x, short_y = plots.minmax_columns(x[:150], y[:150], 100)
    np.testing.assert_array_equal(short_y, y[:150])  # nothing to gain: drawn as it is


def test_block_means_chunk_by_chunk_equal_the_whole():
    rng = np.random.default_rng(9)
    x = rng.normal(size=10_007)
    for sizes in ([10_007], [1, 999, 9_007], [3_000] * 3 + [1_007]):
        kept = plots.BlockMeans(600)
        edges = np.cumsum([0, *sizes])
        for a, b in zip(edges[:-1], edges[1:]):
            kept.add({"x": x[a:b], "twice": 2 * x[a:b]})
        means = kept.means()
        np.testing.assert_allclose(means["x"], plots._block_means(x, 600), rtol=1e-12)
        np.testing.assert_allclose(means["twice"], 2 * plots._block_means(x, 600), rtol=1e-12)
    short = plots.BlockMeans(600)
    short.add({"x": x[:100]})
    np.testing.assert_allclose(short.means()["x"], [x[:100].mean()])


def test_components_are_drawn_decimated(tmp_path):
    hours = np.arange(200_000) / 3.6e6
    components = [("c1", np.sin(np.arange(200_000) / 50.0), "noise"), ("c2", np.arange(200_000) * 1e-6, "drift")]
    fig = plots.components_figure(hours * 3600.0, components)
    for ax in fig.axes:
        (line,) = ax.get_lines()
        assert len(line.get_xdata()) <= 2 * int(np.ceil(fig.get_figwidth() * 200))
        assert line.get_ydata().max() == pytest.approx(max(c[1].max() for c in components if c[0] == ax.get_ylabel().split("\n")[0]))


def test_compensate_plot_streams(sample, tmp_path, monkeypatch):
    """compensate --plot in causal mode goes through the streaming writer (constant memory), its figure from block means."""
    from gyrocomp.commands import compensate as stage

    model = tmp_path / "m.json"
    runner = CliRunner()
    assert runner.invoke(app, ["train", str(sample / "oven_train.parquet"), "--config", "polynomial", "--out", str(model)]).exit_code == 0

    def whole(*args, **kwargs):
        raise AssertionError("compensated whole")

    monkeypatch.setattr(stage, "to_files", whole)
    png = tmp_path / "c.png"
    result = runner.invoke(app, ["compensate", str(sample / "oven_test.parquet"), str(model), "--out", str(tmp_path / "c.parquet"), "--plot", str(png)])
    assert result.exit_code == 0, result.stderr
    assert png.read_bytes()[:8] == PNG
