"""Scores: block-mean drift, signal preservation, Allan terms."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.errors import InputError
from gyrocomp.pipeline import evaluate
from gyrocomp.pipeline.settings import EvaluateSettings, SignalSettings


def test_block_means_exact():
    x = np.repeat([1.0, 2.0, 4.0], 10)
    assert_allclose(evaluate.block_means(np.append(x, 9.0), 1.0, 10.0), [1.0, 2.0, 4.0])
    r = evaluate.residual_drift(x, 1.0, EvaluateSettings(block_s=10.0))
    assert_allclose(r["p2p_deg_h"], 3 * 3600)
    assert_allclose(r["std_deg_h"], np.std([1, 2, 4]) * 3600)
    with pytest.raises(InputError):
        evaluate.block_means(np.ones(15), 1.0, 10.0)


def test_white_noise_floor_of_block_means():
    """White noise of std s at fs: 100 s means have std s / sqrt(100 fs)."""
    rng = np.random.default_rng(0)
    x = rng.normal(0, 0.01, 400_000)
    r = evaluate.residual_drift(x, 1.0)
    assert_allclose(r["std_deg_h"], 0.01 / 10 * 3600, rtol=0.1)  # 4000 blocks: 1.1 % std error


def test_injected_signal_parts_and_limits():
    t = np.arange(4800.0)
    s, parts = evaluate.injected_signal(t, 1.0, SignalSettings())
    assert list(parts) == ["steps", "sine_0.002hz", "sine_0.01hz", "sine_0.05hz"]
    assert_allclose(s, sum(parts.values()))
    assert set(np.unique(parts["steps"])) == {-0.05, 0.0, 0.05}
    assert parts["steps"][1200] == 0.05 and parts["steps"][3600] == -0.05
    with pytest.raises(InputError, match="fs/4"):
        evaluate.injected_signal(t, 0.1, SignalSettings())


def test_signal_preservation_gain_and_error():
    t = np.arange(7200.0)
    s, parts = evaluate.injected_signal(t, 1.0)
    base = np.random.default_rng(3).normal(0, 0.01, t.size)
    kept = evaluate.signal_preservation(base + s, base, parts)
    assert_allclose(kept["gain"], 1.0) and assert_allclose(kept["rms_error_dps"], 0, atol=1e-12)
    gone = evaluate.signal_preservation(base, base, parts)
    assert_allclose(gone["gain"], 0.0) and assert_allclose(gone["destroyed"], 1.0)
    assert_allclose(gone["rms_error_dps"], gone["rms_signal_dps"])
    # a filter that removes only the fastest sine
    partial = evaluate.signal_preservation(base + s - parts["sine_0.05hz"], base, parts)
    assert_allclose(partial["parts"]["sine_0.05hz"], 0.0, atol=1e-9)
    assert_allclose(partial["parts"]["steps"], 1.0, atol=1e-9)
    assert 0.6 < partial["gain"] < 0.9


def test_allan_terms_of_white_noise():
    """White noise of std s at 1 Hz: ARW = s * 60 deg/sqrt(h) (REFERENCES.md 2.9)."""
    x = np.random.default_rng(4).normal(0, 0.01, 20_000)
    terms = evaluate.allan_terms(x, 1.0)
    assert_allclose(terms["arw"]["value"], 0.6, rtol=0.05)
    assert terms["arw"]["unit"] == "deg/sqrt(h)"
    assert terms["bias_instability"]["unit"] == "deg/h"
