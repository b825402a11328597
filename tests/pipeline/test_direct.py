"""Direct pipelines (BP, ELM, polynomial, and every learner in that role): train, compensate, round trips."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from gyrocomp.config import apply_overrides, load_config
from gyrocomp.pipeline import evaluate
from gyrocomp.pipeline.compensate import ExtrapolationWarning, compensate, load_model
from gyrocomp.pipeline.settings import SignalSettings
from gyrocomp.pipeline.train import train_direct

LEARNERS = {
    "polynomial": ("polynomial", []),
    "elm": ("elm", []),
    "bp": ("bp", ["model.drift.max_iter=300"]),
    "anfis": ("elm", ['model.drift={learner="anfis", n_mfs=[4, 4], epochs=10}']),
    "nsga2elm": ("elm", ['model.drift={learner="nsga2elm", pop_size=10, n_gen=3, pick="min_rmse"}']),
}


def _config(key):
    name, overrides = LEARNERS[key]
    return apply_overrides(load_config(name), overrides)


@pytest.fixture(scope="module")
def trained(oven_pair):
    train, *_ = oven_pair
    return {key: train_direct(train, _config(key), source=key, seed=0) for key in LEARNERS}


@pytest.mark.parametrize("key", list(LEARNERS))
def test_held_out_drift_falls_tenfold_causal_and_fivefold_full(key, trained, oven_pair):
    """Issue 8: causal compensation cuts residual drift >= 10x for each learned model, full >= 5x.

    One training seed here, with a margin measured over seeds 0-5 (issue #20): the
    factors are 35-43 causal and 69-164 full for the seeded learners (ELM, BP,
    NSGA-II-ELM), 38 / 88 for the polynomial and 40 / 81 for ANFIS (both
    seed-free), so the bounds sit 3.5x below the worst seed.
    """
    _, test, _, truth = oven_pair
    model = load_model(json.loads(json.dumps(trained[key])))
    raw = evaluate.residual_drift(test.rate_dps, test.fs_hz)["std_deg_h"]
    floor = evaluate.residual_drift(test.rate_dps - truth["truth_drift"].to_numpy(), test.fs_hz)["std_deg_h"]
    assert raw > 100 * floor  # the drift dominates the noise: the test can tell 10x apart
    for mode, factor in (("causal", 10), ("full", 5)):
        frame, summary = compensate(test, model, mode)
        assert list(frame.columns) == ["time", "rate", "temperature", "drift_model", "compensated"]
        left = evaluate.residual_drift(frame["compensated"], test.fs_hz)["std_deg_h"]
        assert raw / left >= factor, f"{key} {mode}: {raw:.1f} -> {left:.2f} deg/h"
        assert [w for w in summary["warnings"] if "dT/dt" not in w] == []  # the longer held-out ramps leave the dT/dt range


@pytest.mark.parametrize("key", ["polynomial", "elm"])
def test_retrained_on_its_own_compensated_run_learns_nothing(key, trained, oven_pair):
    """A model re-trained on its compensated training run finds a drift indistinguishable from zero.

    Bound: a least-squares fit of p parameters to white noise of std s over
    n samples predicts with RMS s * sqrt(p / n); allow 3x that.
    """
    train, _, train_truth, _ = oven_pair
    model = load_model(trained[key])
    frame, _ = compensate(train, model, "full")
    again = train.data.copy()
    again["rate"] = frame["compensated"].to_numpy()
    from gyrocomp.recordings import recording_from_frame

    rec = recording_from_frame(again, name="compensated.parquet")
    second = load_model(train_direct(rec, _config(key), seed=0))
    pred = second.predict(second.inputs(rec.temperature_c, rec.fs_hz, causal=False))["drift"]
    first = model.predict(model.inputs(rec.temperature_c, rec.fs_hz, causal=False))["drift"]
    noise = np.std(train.rate_dps - train_truth["truth_drift"].to_numpy())
    p = {"polynomial": 5, "elm": 21}[key]
    assert np.std(pred) < 3 * noise * np.sqrt(p / rec.data.shape[0])
    assert np.std(pred) < 0.01 * np.std(first)


def test_model_json_is_plain_reproducible_and_round_trips(trained, oven_pair):
    """Same seed, same bytes: exact within one machine and one process type (both fits run here)."""
    train, test, *_ = oven_pair
    again = train_direct(train, _config("elm"), source="elm", seed=0)
    assert json.dumps(again, sort_keys=True) == json.dumps(trained["elm"], sort_keys=True)
    text = json.dumps(trained["elm"], allow_nan=False)
    reloaded = load_model(json.loads(text))
    original = load_model(trained["elm"])
    a, _ = compensate(test, original, "causal")
    b, _ = compensate(test, reloaded, "causal")
    assert_array_equal(a["compensated"], b["compensated"])
    m = trained["elm"]
    assert m["schema"]["name"] == "gyrocomp.model" and m["kind"] == "elm" and not m["parallel"]
    assert m["training"]["temperature_c"]["min"] < -29 and m["training"]["temperature_c"]["max"] > 49
    assert m["rate_estimator"]["window_s"] == 60.0 and len(m["rate_estimator"]["causal_coefficients"]) == 13


def test_causal_mode_keeps_a_true_angular_rate(trained, oven_pair):
    _, test, *_ = oven_pair
    model = load_model(trained["polynomial"])
    signal, parts = evaluate.injected_signal(test.time_s, test.fs_hz, SignalSettings(sine_hz=(0.002, 0.01)))
    shifted = test.data.copy()
    shifted["rate"] = shifted["rate"] + signal
    from gyrocomp.recordings import recording_from_frame

    a, _ = compensate(test, model, "causal")
    b, _ = compensate(recording_from_frame(shifted, name="s"), model, "causal")
    kept = evaluate.signal_preservation(b["compensated"], a["compensated"], parts)
    assert abs(kept["gain"] - 1) < 1e-12 and kept["rms_error_dps"] < 1e-12


def test_out_of_range_recording_warns_by_how_much(make_recording, trained):
    recording = make_recording

    hot, _ = recording([60, 40], seed=3, hold_s=600.0, name="hot.parquet")
    with pytest.warns(ExtrapolationWarning, match=r"leaves the training range \[-29.9, 49.9\] degC .* by 9.[5-9]\d* degC above"):
        _, summary = compensate(hot, load_model(trained["elm"]), "causal")
    assert summary["ranges"]["temperature_c"]["above_by"] == pytest.approx(9.75, abs=0.3)
    assert summary["ranges"]["temperature_c"]["share_outside"] > 0.1


def test_block_means_never_span_a_gap():
    """Training on block means (``[model] max_samples``): each gap-free range starts a block, runs hold whole blocks."""
    from gyrocomp.pipeline.block_fit import _runs

    ranges = [(0, 5), (5, 12)]
    starts = np.array([0, 3, 5, 8, 11])  # blocks of ceil(12 / 4) = 3 samples: rows 0-2, 3-4 | 5-7, 8-10, 11
    runs = _runs(ranges, starts, rows=6)
    assert [(first, stop) for first, stop, *_ in runs] == [(0, 5), (5, 11), (11, 12)]
    assert [(lo, hi) for _, _, lo, hi, _ in runs] == [(0, 5), (5, 12), (5, 12)]
    assert [list(local) for *_, local in runs] == [[0, 3], [0, 3], [0]]
    assert [(first, stop) for first, stop, *_ in _runs([(0, 12)], np.arange(12), rows=1 << 16)] == [(0, 12)]




@pytest.mark.parametrize("name", ["polynomial", "elm"])
def test_training_run_by_run_equals_the_whole_arrays(name, oven_pair, monkeypatch):
    """Inputs computed 50 samples at a time (many runs) give the model of one run (all samples at once) to 1e-12."""
    import gyrocomp.pipeline.block_fit as train_module

    train, *_ = oven_pair
    whole = train_direct(train, load_config(name), source=name, seed=0)
    monkeypatch.setattr(train_module, "TRAIN_ROWS", 50)
    runs = train_direct(train, load_config(name), source=name, seed=0)
    whole_numbers, run_numbers = _numbers(whole), _numbers(runs)
    assert whole_numbers.keys() == run_numbers.keys()
    for key, value in whole_numbers.items():
        assert run_numbers[key] == pytest.approx(value, rel=1e-12, abs=1e-300), key


def _numbers(obj, path=""):
    """Every number of a JSON-like object by its path."""
    if isinstance(obj, dict):
        return {k: v for key, value in obj.items() for k, v in _numbers(value, f"{path}/{key}").items()}
    if isinstance(obj, list):
        return {k: v for i, value in enumerate(obj) for k, v in _numbers(value, f"{path}[{i}]").items()}
    return {path: obj} if isinstance(obj, (int, float)) and not isinstance(obj, bool) else {}
