"""Causal compensation chunk by chunk: the same bytes as the whole recording at once, in constant memory."""

from __future__ import annotations

import json
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gyrocomp import artefacts
from gyrocomp.commands import compensate as stage
from gyrocomp.config import apply_overrides, load_config
from gyrocomp.pipeline.train import train_direct
from gyrocomp.streaming import GapError, read_chunks

LEARNERS = {
    "polynomial": ("polynomial", []),
    "elm": ("elm", []),
    "bp": ("bp", ["model.drift.max_iter=50"]),
    "anfis": ("elm", ['model.drift={learner="anfis", n_mfs=[3, 3], epochs=3}']),
}
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def models(oven_pair, tmp_path_factory):
    train, *_ = oven_pair
    folder = tmp_path_factory.mktemp("models")
    paths = {}
    for key, (name, overrides) in LEARNERS.items():
        paths[key] = folder / f"{key}.json"
        artefacts.write_json(paths[key], train_direct(train, apply_overrides(load_config(name), overrides), source=key, seed=0))
    return paths


@pytest.fixture(scope="module")
def test_csv(oven_pair, tmp_path_factory):
    _, test, *_ = oven_pair
    path = tmp_path_factory.mktemp("csv") / "test.csv"
    test.data[["time", "rate", "temperature"]].to_csv(path, index=False)
    return path


@pytest.fixture
def chunks_of_97(monkeypatch):
    """Chunks, and the learners' row blocks, of 97 samples (a divisor of nothing here) instead of 65 536."""
    for module, name in (("gyrocomp.models._base", "PREDICT_ROWS"), ("gyrocomp.pipeline.compensate", "CHUNK_ROWS"), ("gyrocomp.streaming", "CHUNK_ROWS")):
        monkeypatch.setattr(sys.modules[module], name, 97)


@pytest.mark.parametrize("key", list(LEARNERS))
def test_chunks_give_the_bytes_of_the_whole_recording(key, models, test_csv, tmp_path, chunks_of_97):
    """A stream against the in-memory compensation of the whole recording, written at once."""
    whole = tmp_path / "whole.csv"
    _, whole_summaries, _ = stage.to_files([test_csv, models[key]], whole)
    for suffix in (".csv", ".parquet"):
        streamed = tmp_path / f"streamed{suffix}"
        n_samples, summaries, _ = stage.stream_to_files([test_csv, models[key]], streamed, rows=97)
        figures = summaries["rate"]["figures"]
        if suffix == ".csv":
            assert streamed.read_bytes() == whole.read_bytes()
        else:
            frame, header = artefacts.read_table(streamed, "gyrocomp.compensation")
            pd.testing.assert_frame_equal(frame, pd.read_csv(whole), check_exact=True)
            assert header["inputs"][0]["name"] == "test.csv"
        sidecar = json.loads(artefacts.sidecar_path(streamed).read_text())
        reference = pd.read_csv(whole)
        assert n_samples == len(reference) == sidecar["axes"]["rate"]["figures"]["n_samples"]
        np.testing.assert_allclose(figures["compensated_std"], np.std(reference["compensated"]), rtol=1e-12)
        np.testing.assert_allclose(figures["drift_model_rms"], np.sqrt(np.mean(reference["drift_model"] ** 2)), rtol=1e-12)
        assert summaries["rate"]["ranges"] == whole_summaries["rate"]["ranges"]  # the same rates, bit for bit


@pytest.mark.parametrize("key", ["elm", "anfis"])
def test_stdin_to_stdout_equals_the_one_shot_output(key, models, tmp_path):
    """The CLI reads 150 000 lines of standard input in chunks and writes standard output: the one-shot file's bytes."""
    source = _long_csv(tmp_path / "long.csv", 150_000)
    whole = tmp_path / "whole.csv"
    stage.to_files([source, models[key]], whole)
    env = {"PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-m", "gyrocomp", "compensate", "-", str(models[key]), "--mode", "causal", "--out", "-"],
        input=source.read_bytes(), capture_output=True, env=env, check=True,
    )
    assert done.stdout == whole.read_bytes()


def _long_csv(path: Path, n: int) -> Path:
    t = np.arange(n) * 5.0
    frame = pd.DataFrame({"time": t, "rate": 0.01 * np.sin(t / 700), "temperature": 20 + 10 * np.sin(t / 9000)})
    frame.to_csv(path, index=False)
    return path


def test_memory_does_not_grow_with_the_length_of_the_stream(models, tmp_path):
    """Peak traced allocations of a 4x longer stream within 10 % of the shorter one's."""
    peaks = []
    for n in (20_000, 80_000):
        source = _long_csv(tmp_path / f"long{n}.csv", n)
        tracemalloc.start()
        stage.stream_to_files([source, models["anfis"]], tmp_path / f"out{n}.parquet", rows=2_000)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[1] <= 1.1 * peaks[0], peaks


def test_a_time_step_between_chunks_names_the_line(tmp_path):
    source = _long_csv(tmp_path / "gap.csv", 1_000)
    frame = pd.read_csv(source)
    frame.loc[500:, "time"] += 1000.0  # a gap between line 501 and line 502, the first of the second chunk
    frame.to_csv(source, index=False)
    with pytest.raises(GapError, match=r"gap.csv line 502: a gap in `time`"):
        for _ in read_chunks(source, rows=500):
            pass


def test_a_file_with_gaps_is_compensated_whole_by_segments(models, tmp_path):
    """compensate_files streams until the gap, then drops that output and compensates the file by segments."""
    source = _long_csv(tmp_path / "gap.csv", 3_000)
    frame = pd.read_csv(source)
    frame.loc[1500:, "time"] += 3600.0
    frame.to_csv(source, index=False)
    by_segments = tmp_path / "segments.csv"
    stage.to_files([source, models["polynomial"]], by_segments)
    out = tmp_path / "out.csv"
    n_samples, summaries, _ = stage.compensate_files([source, models["polynomial"]], out)
    assert n_samples == 3_000 and out.read_bytes() == by_segments.read_bytes()
    assert summaries["rate"]["figures"]["compensated_std"] > 0


def test_a_parquet_file_streams_in_longer_chunks_after_the_first_with_the_same_output(models, tmp_path, monkeypatch):
    """Chunks of 300 after a first of 97 (the sample rate's): the table of chunks of 97 throughout, value for value."""
    source = _long_csv(tmp_path / "long.csv", 3_000)
    parquet = tmp_path / "long.parquet"
    pd.read_csv(source).to_parquet(parquet, index=False)
    assert [len(c.time_s) for c in read_chunks(parquet, rows=300, first_rows=97)] == [97] + [300] * 9 + [3_000 - 97 - 2_700]
    assert all(len(c.time_s) == 300 for c in read_chunks(source, rows=300, first_rows=97))  # CSV: rows throughout
    even = tmp_path / "even.parquet"
    stage.stream_to_files([parquet, models["anfis"]], even, rows=97)
    monkeypatch.setattr("gyrocomp.streaming.CHUNK_ROWS", 97)
    monkeypatch.setattr("gyrocomp.streaming.FILE_CHUNK_ROWS", 300)
    longer = tmp_path / "longer.parquet"
    stage.stream_to_files([parquet, models["anfis"]], longer)
    pd.testing.assert_frame_equal(artefacts.read_table(longer, "gyrocomp.compensation")[0], artefacts.read_table(even, "gyrocomp.compensation")[0], check_exact=True)
