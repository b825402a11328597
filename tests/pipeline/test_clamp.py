"""Causal compensation clamps temperature and dT/dt to the training ranges (issue 18), and says so."""

from __future__ import annotations

import numpy as np
import pytest

from gyrocomp.config import load_config
from gyrocomp.pipeline.compensate import ExtrapolationWarning, compensate, load_model
from gyrocomp.pipeline.train import train_direct


@pytest.fixture(scope="module")
def polynomial(oven_pair):
    train, *_ = oven_pair
    return load_model(train_direct(train, load_config("polynomial"), source="polynomial", seed=0))


@pytest.fixture(scope="module")
def hot(make_recording):
    """Soaks at 60 degC, 10 degC above the training range."""
    rec, _ = make_recording([60], seed=3, hold_s=1200.0, name="hot.parquet")
    return rec


def _by_hand(model, X):
    """The polynomial written out from its stored coefficients: sum c_k (T - T_ref)^k + d dT/dt, then de-normalised."""
    learner, offset, scale, y_offset, y_scale, _ = model.learners["drift"]
    Xn = (X - offset) / scale
    dt = Xn[:, 0] - learner.reference_temperature
    y = sum(c * dt**k for k, c in enumerate(learner.coef_)) + learner.rate_coef_ * Xn[:, 1]
    return y * y_scale + y_offset


def test_causal_clamps_temperature_and_rate_by_default(polynomial, hot):
    with pytest.warns(ExtrapolationWarning):
        frame, summary = compensate(hot, polynomial, "causal")
    X = polynomial.inputs(hot.data["temperature"].to_numpy(), hot.fs_hz, causal=True)
    (t_lo, t_hi), (r_lo, r_hi) = polynomial.temperature_range_c, polynomial.rate_range_c_per_s
    held = np.column_stack([np.clip(X[:, 0], t_lo, t_hi), np.clip(X[:, 1], r_lo, r_hi)])
    np.testing.assert_allclose(frame["drift_model"], _by_hand(polynomial, held), rtol=0, atol=1e-12)
    assert summary["clamp"] is True
    hottest = X[:, 0] > t_hi + 5
    assert hottest.any()
    # above the range the temperature part stays at its value at the edge: only the rate term moves it
    edge = _by_hand(polynomial, np.column_stack([np.full(hottest.sum(), t_hi), held[hottest, 1]]))
    np.testing.assert_allclose(frame["drift_model"][hottest], edge, atol=1e-12)
    assert np.abs(_by_hand(polynomial, X[hottest]) - edge).min() > 1e-3


def test_no_clamp_extrapolates(polynomial, hot):
    with pytest.warns(ExtrapolationWarning, match="the model extrapolates there"):
        frame, summary = compensate(hot, polynomial, "causal", clamp=False)
    X = polynomial.inputs(hot.data["temperature"].to_numpy(), hot.fs_hz, causal=True)
    np.testing.assert_allclose(frame["drift_model"], _by_hand(polynomial, X), rtol=0, atol=1e-12)
    assert summary["clamp"] is False


def test_each_range_left_is_reported_by_how_much(polynomial, hot):
    with pytest.warns(ExtrapolationWarning) as caught:
        _, summary = compensate(hot, polynomial, "causal")
    messages = [str(w.message) for w in caught]
    rate = summary["ranges"]["temperature_rate_c_per_s"]
    X = polynomial.inputs(hot.data["temperature"].to_numpy(), hot.fs_hz, causal=True)
    lo, hi = polynomial.rate_range_c_per_s
    assert rate["above_by"] == pytest.approx(max(0.0, X[:, 1].max() - hi))
    assert rate["below_by"] == pytest.approx(max(0.0, lo - X[:, 1].min()))
    left = [m for m in messages if "dT/dt" in m]
    if rate["above_by"] > 0 or rate["below_by"] > 0:
        assert len(left) == 1 and "degC/s" in left[0] and "clamped to the range there" in left[0]
    temperature = [m for m in messages if m.startswith("hot.parquet: temperature")]
    assert len(temperature) == 1 and "degC above" in temperature[0]
    assert summary["ranges"]["temperature_c"]["above_by"] == pytest.approx(10.0, abs=0.5)


def test_a_rate_outside_its_range_alone_is_reported(polynomial, oven_pair):
    """A recording inside the temperature range but with a faster ramp than training: today's code said nothing."""
    from gyrocomp.recordings import recording_from_frame

    _, test, *_ = oven_pair
    frame = test.data.copy()
    t = frame["time"].to_numpy()
    lo, hi = polynomial.temperature_range_c
    frame["temperature"] = (lo + hi) / 2 + (hi - lo) / 2.5 * np.sin(2 * np.pi * t / 3000.0)  # 1.6x the training ramps
    fast = recording_from_frame(frame, name="fast.parquet")
    with pytest.warns(ExtrapolationWarning, match=r"fast.parquet: dT/dt .* leaves the training range .* degC/s"):
        _, summary = compensate(fast, polynomial, "causal")
    assert summary["ranges"]["temperature_c"]["share_outside"] == 0
    assert summary["ranges"]["temperature_rate_c_per_s"]["share_outside"] > 0
