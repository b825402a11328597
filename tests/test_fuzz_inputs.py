"""Property-based fuzzing of recordings and model files at the command line (issue 21).

Hypothesis builds hostile recordings (CSV or Parquet bytes: random columns,
NaN and huge cells, text, unsorted or duplicated time, truncation) and
random tamperings of a valid ``model.json``, and runs the real commands.
Whatever the input: the exit code is 0, 2 or 3 (never 1, an unexpected
error), no traceback, a failure ends in one ``gyrocomp: `` line, and the
output folder holds the finished artefact or nothing (no half-written or
hidden temporary file).
"""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from gyrocomp.cli import app

pytestmark = pytest.mark.slow

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

CELL = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e300, -1e300, 0.0, 1e-300, 5e15]),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.text(max_size=4),
)


def _check(result, out_dir, outputs) -> None:
    assert result.exit_code in (0, 2, 3), (result.exit_code, result.stderr, result.exception)
    assert "Traceback" not in result.stderr
    if result.exit_code:
        lines = result.stderr.strip().splitlines()
        assert lines and lines[-1].startswith("gyrocomp: "), result.stderr
        assert sorted(p.name for p in out_dir.iterdir()) == [], "an output was left behind by a failure"
    else:
        names = sorted(p.name for p in out_dir.iterdir())
        assert not [n for n in names if n.startswith(".")], names
        assert set(outputs) <= set(names), names


@st.composite
def recordings(draw):
    n = draw(st.integers(min_value=0, max_value=80))
    columns = draw(st.lists(st.sampled_from(["time", "rate", "temperature", "extra", "gx"]), min_size=1, max_size=5, unique=True))
    frame = {}
    for name in columns:
        kind = draw(st.sampled_from(["clean", "cells"]))
        if kind == "clean" and name == "time":
            t = np.arange(n, dtype=float)
            order = draw(st.sampled_from(["sorted", "reversed", "duplicated"]))
            frame[name] = t[::-1] if order == "reversed" else (np.floor(t / 2) if order == "duplicated" else t)
        elif kind == "clean":
            frame[name] = 20.0 + 0.01 * np.sin(np.arange(n)) + np.arange(n) / 60.0
        else:
            frame[name] = draw(st.lists(CELL, min_size=n, max_size=n))
    table = pd.DataFrame(frame)
    fmt = draw(st.sampled_from(["csv", "parquet"]))
    if fmt == "csv":
        raw = table.to_csv(index=False).encode()
    else:
        buffer = io.BytesIO()
        try:
            table.astype({c: str for c in table if table[c].dtype == object}).to_parquet(buffer)
        except Exception:  # a column pyarrow cannot store: write it as CSV instead
            fmt, raw = "csv", table.to_csv(index=False).encode()
        else:
            raw = buffer.getvalue()
    if draw(st.booleans()):
        raw = raw[: draw(st.integers(min_value=0, max_value=len(raw)))]
    return fmt, raw


@FUZZ
@given(recording=recordings())
def test_fuzzed_recordings_never_crash(tmp_path_factory, recording):
    fmt, raw = recording
    folder = tmp_path_factory.mktemp("rec")
    path = folder / f"x.{fmt}"
    path.write_bytes(raw)
    out = folder / "out"
    out.mkdir()
    for argv, outputs in (
        (["allan", str(path), "--out", str(out / "a.json")], ["a.json"]),
        (["train", str(path), "--config", "polynomial", "--out", str(out / "m.json")], ["m.json"]),
    ):
        result = CliRunner().invoke(app, argv)
        _check(result, out, outputs)
        for p in out.iterdir():
            p.unlink()
        assert path.read_bytes() == raw


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A recording that heats and cools, and the polynomial model.json trained on it."""
    folder = tmp_path_factory.mktemp("model")
    n = 2400
    t = np.arange(n, dtype=float)
    temperature = 25.0 + 20.0 * np.sin(2 * math.pi * t / n)
    rate = 0.02 * (temperature - 25.0) + 0.01 * np.random.default_rng(0).standard_normal(n)
    pd.DataFrame({"time": t, "rate": rate, "temperature": temperature}).to_parquet(folder / "r.parquet")
    result = CliRunner().invoke(app, ["-q", "train", str(folder / "r.parquet"), "--config", "polynomial", "--out", str(folder / "model.json")])
    assert result.exit_code == 0, result.output
    return folder / "r.parquet", json.loads((folder / "model.json").read_text())


def _paths(obj, prefix=()):
    """Every path to a leaf or container of a JSON object."""
    yield prefix
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for key, value in items:
        yield from _paths(value, (*prefix, key))


REPLACEMENT = st.one_of(
    st.sampled_from([float("nan"), float("inf"), -float("inf"), 0.0, -1.0, 1e308, None, True, "no", [], {}, [1.0], 10**400]),
    st.floats(allow_nan=False, allow_infinity=False),
    st.integers(),
    st.text(max_size=6),
)


@FUZZ
@given(data=st.data())
def test_tampered_models_never_crash(tmp_path_factory, trained, data):
    recording, model = trained
    obj = json.loads(json.dumps(model))
    paths = [p for p in _paths(obj) if p]
    path = data.draw(st.sampled_from(paths))
    node = obj
    for key in path[:-1]:
        node = node[key]
    if data.draw(st.booleans()) and isinstance(node, dict):
        del node[path[-1]]
    else:
        node[path[-1]] = data.draw(REPLACEMENT)
    folder = tmp_path_factory.mktemp("tamper")
    text = json.dumps(obj)  # NaN and Infinity as Python writes them
    (folder / "model.json").write_text(text)
    out = folder / "out"
    out.mkdir()
    result = CliRunner().invoke(app, ["compensate", str(recording), str(folder / "model.json"), "--out", str(out / "c.parquet")])
    _check(result, out, ["c.parquet"])
    assert (folder / "model.json").read_text() == text
