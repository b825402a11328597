"""Issue 35 item 4: ``allan`` pools the segments of a gapped record into one series per axis."""

from __future__ import annotations

import json

import allantools
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import allan as al
from gyrocomp.cli import app

FS, SIGMA = 100.0, 0.5
LENGTHS = (3000, 5000, 2500, 6000, 3500)


def _segments(seed=7):
    """A contiguous white-noise record [deg/s] cut into segments of LENGTHS samples."""
    x = np.random.default_rng(seed).normal(0.0, SIGMA, sum(LENGTHS))
    return np.split(x, np.cumsum(LENGTHS)[:-1])


def test_pooled_equals_allantools_gap_resistant_adev():
    """The pooled deviation is allantools' gradev of the segments' phases with NaN gaps longer than any 2m."""
    parts = _segments()
    pooled = al.pool_segments([al.analyse(p, FS, name=f"s{k}") for k, p in enumerate(parts)], name="whole")
    gap = np.full(2 * max(LENGTHS), np.nan)
    phase = np.concatenate([np.concatenate([[0.0], np.cumsum(p) / FS, gap]) for p in parts])
    taus, dev, _, ns = allantools.gradev(phase, rate=FS, data_type="phase", taus=pooled.tau_s)
    np.testing.assert_allclose(taus, pooled.tau_s, rtol=1e-12)
    np.testing.assert_allclose(pooled.adev, dev, rtol=1e-9)
    np.testing.assert_array_equal(pooled.n, ns.astype(int))
    assert pooled.segments == 5 and pooled.name == "whole"
    np.testing.assert_array_equal(pooled.clusters[:3], [sum(n // m for n in LENGTHS) for m in (1, 2, 4)])


def test_pooled_white_noise_follows_theory_within_its_interval():
    """White rate noise, 60 records: sigma^2(tau) = SIGMA^2 / (FS tau) on average, and the 68.3 % interval covers it 68 % of the time."""
    ratios, covered = [], []
    for seed in range(60):
        pooled = al.pool_segments([al.analyse(p, FS) for p in _segments(seed)], name="white")
        theory = SIGMA / np.sqrt(FS * pooled.tau_s)
        ratios.append((pooled.adev / theory) ** 2)
        covered.append((pooled.adev_lo <= theory) & (theory <= pooled.adev_hi))
    np.testing.assert_allclose(np.mean(ratios, axis=0)[:8], 1.0, atol=0.02)  # taus to 1.28 s: edf > 200 each
    assert 0.62 <= np.mean(covered) <= 0.74
    assert pooled.terms["arw"]["readoff"] == pytest.approx(SIGMA / np.sqrt(FS) * 60.0, rel=0.05)


def _bursts(path, n_bursts=25, n=250, fs=50.0, period=300.0, seed=3):
    rng = np.random.default_rng(seed)
    frames = []
    for k in range(n_bursts):
        t = k * period + np.arange(n) / fs
        frames.append(pd.DataFrame({"time": t, **{a: rng.normal(0.0, 0.05, n) for a in ("gx", "gy", "gz")}}))
    pd.concat(frames, ignore_index=True).to_csv(path, index=False)


@pytest.mark.parametrize("resample_free", [True, False], ids=["chunked", "whole"])
def test_a_bursty_log_gives_one_series_per_axis(tmp_path, resample_free):
    """25 bursts, 3 axes: 3 series (main gave 75), each pooled over 25 segments; --segments adds the 75."""
    path = tmp_path / "bursts.csv"
    _bursts(path)
    source = str(path) if resample_free else "-"
    stdin = None if resample_free else path.read_text()
    out = tmp_path / "allan.json"
    result = CliRunner().invoke(app, ["allan", source, "--rate-col", "g?", "--out", str(out)], input=stdin)
    assert result.exit_code == 0, result.stderr
    series = json.loads(out.read_text())["series"]
    assert len(series) == 3
    assert [(s["name"], s["column"], s["segments"]) for s in series] == [(("bursts.csv" if resample_free else "-"), a, 25) for a in ("gx", "gy", "gz")]
    assert series[0]["n"][0] == 25 * 249
    result = CliRunner().invoke(app, ["allan", str(path), "--rate-col", "g?", "--out", str(out), "--segments"])
    assert result.exit_code == 0, result.stderr
    series = json.loads(out.read_text())["series"]
    assert len(series) == 3 + 75 and series[1]["name"] == "bursts.csv segment 1" and series[1]["segments"] == 1
