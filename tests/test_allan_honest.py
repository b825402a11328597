"""Issue 35 item 7: ``allan`` reads no term off too few samples, no B off a curve without a flat region, and says when its rise follows temperature."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import allan as al
from gyrocomp.allan import ieee952
from gyrocomp.allan.fit import add_readoffs, fit_terms
from gyrocomp.cli import app

SETTINGS = al.AllanConfig()
TAU = 0.01 * 2.0 ** np.arange(18)  # 0.01 .. 1311 s, octaves


def _readoffs(clusters, **terms):
    """Read-offs of the analytic five-term curve (library units) with the given independent clusters at each tau."""
    coefficients = {k: ieee952.from_datasheet(k, v) for k, v in terms.items()}
    avar = ieee952.avar(TAU, **coefficients)
    out = fit_terms(TAU, avar, np.full(TAU.size, 1e4), 2.0, 0.1)
    add_readoffs(out, TAU, np.sqrt(avar), np.asarray(clusters), SETTINGS)
    return out


PLENTY = np.full(TAU.size, 1000)


def test_a_flicker_floor_gives_b_and_a_v_without_one_does_not():
    """B only off a flat region: a floor B = 10 deg/h (within 1.25x over > 3 octaves) is read, N meeting K with B = 0 is not."""
    floor = _readoffs(PLENTY, arw=0.1, bias_instability=10.0, rrw=1.0)
    assert floor["bias_instability"]["readoff"] == pytest.approx(10.0, rel=0.1)
    low, high = floor["bias_instability"]["flat_tau_s"]
    assert high / low >= SETTINGS.flat_span
    v = _readoffs(PLENTY, arw=0.1, rrw=1.0)
    assert v["bias_instability"]["readoff"] is None
    assert "no flat region" in v["bias_instability"]["readoff_note"]
    assert v["arw"]["readoff"] == pytest.approx(0.1, rel=0.05)  # the -1/2 line is still read


def test_no_readoff_at_taus_with_too_few_independent_clusters():
    """The floor of the curve that gives B = 10 deg/h with plenty of clusters, but 600 samples at 100 Hz: 9 clusters end at 0.64 s, before it."""
    clusters = 600 // np.rint(TAU * 100).astype(int)
    assert clusters[6] == 9 and clusters[7] == 4
    short = _readoffs(clusters, arw=0.1, bias_instability=10.0, rrw=1.0)
    assert short["bias_instability"]["readoff"] is None
    assert "to 0.64 s (at least 9 independent clusters)" in short["bias_instability"]["readoff_note"]
    assert short["arw"]["readoff"] == pytest.approx(0.1, rel=0.05)  # its line lies below 0.64 s
    assert short["rrw"]["readoff"] is None
    few = _readoffs(np.full(TAU.size, 8), arw=0.1, bias_instability=10.0, rrw=1.0)
    assert all(few[k]["readoff"] is None for k in ("arw", "bias_instability", "rrw"))
    assert "fewer than 9 independent clusters at every tau" in few["arw"]["readoff_note"]


def test_twelve_samples_give_no_readoff():
    """12 samples at 1 Hz: 12, 6 and 3 clusters at m = 1, 2, 4; main read B off the last point (3 clusters)."""
    series = al.analyse(np.random.default_rng(2).normal(0.0, 1e-3, 12), 1.0)
    np.testing.assert_array_equal(series.clusters, [12, 6, 3])
    for key in ("arw", "bias_instability", "rrw"):
        assert series.terms[key]["readoff"] is None, key
    assert "at least 9 independent clusters" in series.terms["bias_instability"]["readoff_note"]


FS, HOURS = 5.0, 4.0


def _oven(path, *, thermal: bool, seed=5):
    """White rate noise with a temperature cycle (1 h period, +-15 degC); the drift a cubic in T, or a random walk that ignores T."""
    rng = np.random.default_rng(seed)
    n = int(HOURS * 3600 * FS)
    t = np.arange(n) / FS
    temperature = 25.0 + 15.0 * np.sin(2 * np.pi * t / 3600.0)
    u = (temperature - 25.0) / 15.0
    drift = 0.02 * (u + 0.5 * u**2 - 0.3 * u**3) if thermal else np.cumsum(rng.normal(0.0, 2e-4, n))
    pd.DataFrame({"time": t, "rate": drift + rng.normal(0.0, 0.05, n), "temperature": temperature}).to_csv(path, index=False)


@pytest.mark.parametrize("source", ["chunked", "stdin"])
def test_a_rise_that_follows_temperature_is_said_and_removed(tmp_path, source):
    path, out = tmp_path / "oven.csv", tmp_path / "allan.json"
    _oven(path, thermal=True)
    args = [str(path)] if source == "chunked" else ["-"]
    stdin = None if source == "chunked" else path.read_text()
    result = CliRunner().invoke(app, ["allan", *args, "--out", str(out)], input=stdin)
    assert result.exit_code == 0, result.stderr
    assert "follows temperature" in result.stderr and "--detrend-temperature" in result.stderr
    (series,) = json.loads(out.read_text())["series"]
    assert series["thermal"]["follows_temperature"] is True and max(series["thermal"]["explained"]) > 0.9
    assert not series["terms"]["rrw"]["identified"] and not series["terms"]["rate_ramp"]["identified"]
    assert series["terms"]["rrw"]["readoff"] is None
    result = CliRunner().invoke(app, ["allan", *args, "--out", str(out), "--detrend-temperature"], input=stdin)
    assert result.exit_code == 0, result.stderr
    (clean,) = json.loads(out.read_text())["series"]
    assert clean["thermal"]["detrended"] is True and clean["thermal"]["follows_temperature"] is not True
    theory = 0.05 / np.sqrt(FS * np.asarray(clean["tau_s"]))  # white noise alone once the cubic is removed
    usable = np.asarray(clean["clusters"]) >= 9
    np.testing.assert_allclose(np.asarray(clean["adev"])[usable], theory[usable], rtol=0.35)
    assert np.max(np.asarray(series["adev"])[usable] / theory[usable]) > 3.0  # the rise it removed


def test_a_random_walk_beside_a_temperature_cycle_is_not_blamed_on_it(tmp_path):
    path, out = tmp_path / "rw.csv", tmp_path / "allan.json"
    _oven(path, thermal=False)
    result = CliRunner().invoke(app, ["allan", str(path), "--out", str(out)])
    assert result.exit_code == 0, result.stderr
    assert "follows temperature" not in result.stderr
    (series,) = json.loads(out.read_text())["series"]
    assert series["thermal"]["follows_temperature"] is False and len(series["thermal"]["tau_s"]) >= 2


def test_detrend_without_a_temperature_is_refused(tmp_path):
    path = tmp_path / "plain.csv"
    pd.DataFrame({"time": np.arange(100) / 10.0, "rate": np.random.default_rng(0).normal(size=100)}).to_csv(path, index=False)
    result = CliRunner().invoke(app, ["allan", str(path), "--out", str(tmp_path / "a.json"), "--detrend-temperature"])
    assert result.exit_code == 2
    assert "plain.csv: --detrend-temperature needs a temperature column" in result.stderr


def test_lsm6dsm_bursts_give_no_b_without_a_flat_region(real_data, tmp_path):
    """The TVAC log's pooled curves fall to their last well-sampled tau (1.28 s): no B (main gave 75 B read-offs, one a burst)."""
    path = real_data("pan-lsm6dsm-tvac") / "pan_lsm6dsm_tvac_cold_2020-03-07.csv"
    out = tmp_path / "allan.json"
    result = CliRunner().invoke(app, ["allan", str(path), "--rate-col", "rate_*", "--dedupe", "first", "--out", str(out)])
    assert result.exit_code == 0, result.stderr
    series = json.loads(out.read_text())["series"]
    assert len(series) == 3
    for s in series:
        assert s["terms"]["bias_instability"]["readoff"] is None
        assert "no flat region" in s["terms"]["bias_instability"]["readoff_note"]
        assert s["terms"]["arw"]["readoff"] == pytest.approx({"rate_x": 0.231, "rate_y": 0.143, "rate_z": 0.144}[s["column"]], rel=0.02)
        assert s["thermal"] == {"detrended": False, "follows_temperature": None}
