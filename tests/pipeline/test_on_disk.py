"""Training on a long record with its decomposition on disk (issue 38, training memory)."""

from __future__ import annotations

import json
import tracemalloc

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import recordings
from gyrocomp.cli import app
from gyrocomp.decompose import lcd_blocks
from gyrocomp.pipeline.rate import RateSettings

SAMPLE = "sample_data/oven_train.parquet"
FAST = ["--set", "model.drift.epochs=5", "--set", "model.mixed.epochs=5"]


def _train(path, out):
    result = CliRunner().invoke(app, ["--quiet", "train", str(path), "--config", "pe-lcd-anfis", *FAST, "--out", str(out)])
    assert result.exit_code == 0, result.output
    return json.loads(out.read_text())


def test_train_on_disk_writes_the_model_of_the_whole_record_in_memory(tmp_path, monkeypatch):
    """49 621 samples: in memory by default; with blocks of 4096 on disk, the same model.json."""
    whole = _train(SAMPLE, tmp_path / "whole.json")
    monkeypatch.setattr(lcd_blocks, "BLOCK", 4096)
    blocks = _train(SAMPLE, tmp_path / "blocks.json")
    assert blocks == whole
    assert whole["axes"]["rate"]["training"]["classes"][0]["class"] == "noise"


def _oven(n, fs_hz=100.0, seed=38):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs_hz
    temperature = 25.0 + 20.0 * np.sin(2 * np.pi * t / t[-1]) + rng.normal(0, 0.02, n)
    rate = 0.1 + 0.002 * (temperature - 25.0) + rng.normal(0, 0.05, n)
    return recordings.recording_from_frame(pd.DataFrame({"time": t, "rate": rate, "temperature": temperature}), name="oven")


def test_training_memory_does_not_grow_with_the_record(monkeypatch):
    """Beside the recording, training on 600 000 samples takes no more than on 300 000
    (blocks of 2^14; to 1 byte a sample); in memory the decomposition alone grows by 88."""
    from gyrocomp.commands.train import _train_axis
    from gyrocomp.config import load_config

    monkeypatch.setattr(lcd_blocks, "BLOCK", 1 << 14)
    config = load_config("pe-lcd-anfis")
    config["model"]["drift"]["epochs"] = config["model"]["mixed"]["epochs"] = 2
    peaks = []
    for n in (300_000, 600_000):
        recording = _oven(n)
        task = {"axis": "rate", "recording": recording, "config": config, "source": "pe-lcd-anfis", "seed": 0, "bounds": list(recording.segments)}
        _train_axis(task)  # imports and compiled kernels out of the measurement
        tracemalloc.start()
        try:
            start = tracemalloc.get_traced_memory()[0]
            _train_axis(task)
            peaks.append(tracemalloc.get_traced_memory()[1] - start)
        finally:
            tracemalloc.stop()
    assert peaks[1] - peaks[0] < 300_000, peaks  # measured: 7.41 and 7.44 MB


def test_sample_rate_and_causal_range_in_runs_equal_the_whole_arrays():
    """`_fs_of` (the median interval, selected without the array of intervals) and `_causal_rate_range` (streamed) bit for bit."""
    from gyrocomp.pipeline.block_fit import TRAIN_ROWS, _causal_rate_range
    from gyrocomp.pipeline.train import _fs_of, segment_inputs

    rng = np.random.default_rng(5)
    n = 2 * TRAIN_ROWS + 7
    for t in (np.arange(n) / 1000.0, np.cumsum(rng.uniform(0.5, 1.5, n)), np.arange(n) * 0.1 + 1e6, np.arange(4.0), np.array([0.0, 1.0])):
        assert _fs_of(t) == 1.0 / float(np.median(np.diff(t)))
    temperature = 25 + np.cumsum(rng.normal(0, 0.01, n))
    for bounds in (None, [slice(0, n)], [slice(0, n // 3), slice(n // 3, n)]):
        rate = segment_inputs(temperature, 10.0, RateSettings(), bounds, causal=True)[:, 1]
        assert _causal_rate_range(temperature, 10.0, RateSettings(), bounds) == (float(rate.min()), float(rate.max()))


@pytest.mark.parametrize("quantised", [False, True])
def test_coverage_checks_in_runs_equal_the_whole_arrays(quantised):
    """`check_run` gathers distinct temperatures and window sums a run at a time: the same warnings and ramp."""
    from gyrocomp.pipeline import coverage

    rng = np.random.default_rng(6)
    n = 700_001
    t = np.arange(n) / 1000.0 + rng.uniform(0, 1e-4, n)
    temperature = 25 + 10 * np.sin(t / 30) + rng.normal(0, 0.01, n)
    if quantised:
        temperature = np.round(temperature * 2) / 2
    segments = [slice(0, n // 3), slice(n // 3, n)]
    index = np.floor((t[n // 3 :] - t[n // 3]) / 60.0).astype(np.int64)
    means = np.bincount(index, weights=temperature[n // 3 :]) / np.bincount(index)
    first = np.floor((t[: n // 3] - t[0]) / 60.0).astype(np.int64)
    means_first = np.bincount(first, weights=temperature[: n // 3]) / np.bincount(first)
    whole = max(float(np.max(np.abs(np.diff(m)))) / 60.0 * 60.0 for m in (means_first, means))
    assert coverage._steepest_ramp(t, temperature, segments, 60.0) == whole
    assert coverage._coarse_quantum(temperature, 0.25) == (coverage.quantum(temperature) if quantised else 0.0)
    assert coverage._coarse_quantum(temperature, 0.25) == (0.5 if quantised else 0.0)
