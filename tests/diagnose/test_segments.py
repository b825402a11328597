"""Diagnosis of a recording in segments with gaps: block means within segments, nothing interpolated.

A constructed burst recording (bursts of 5 s at 50 Hz every 305 s, as the
PAN LSM6DSM thermal-vacuum log) and that real log (skipped when
``../shared/real-data`` is absent).
"""

import numpy as np
import pandas as pd
import pytest

from gyrocomp.diagnose import diagnose, problems
from gyrocomp.effects.likelihood import NoiseBasis
from gyrocomp.recordings import ColumnSpec, read_recording, recording_from_frame


def _bursts(seed, n_bursts=30, every_s=305.0, burst=250, fs=50.0, drop=()):
    rng = np.random.default_rng(seed)
    t = np.concatenate([k * every_s + np.arange(burst) / fs for k in range(n_bursts) if k not in drop])
    temp = 24.0 - 8.0 * t / t[-1]
    rate = 0.03 * (temp - 20.0) + 0.005 * np.sqrt(fs) * rng.standard_normal(t.size)
    frame = pd.DataFrame({"time": t, "rate": rate, "temperature": temp})
    return recording_from_frame(frame, name=f"bursts{seed}", allow_gaps=True)


def test_noise_basis_with_contiguous_starts_is_the_default():
    a, b = NoiseBasis(40, 10.0), NoiseBasis(40, 10.0, starts=np.arange(40) * 10.0)
    np.testing.assert_allclose(a.random_walk, b.random_walk, rtol=1e-12)
    np.testing.assert_allclose(a.flicker, b.flicker, rtol=1e-9)


def test_noise_basis_counts_the_gap():
    starts = np.array([0.0, 10.0, 1000.0, 1010.0])
    basis = NoiseBasis(4, 10.0, starts=starts)
    # a random walk from power-on: the covariance of two blocks is the earlier centre (IEEE Std 952 K^2 t)
    assert basis.random_walk[2, 3] == pytest.approx(1005.0)
    assert basis.random_walk[0, 2] == pytest.approx(5.0)
    # flicker decorrelates through the gap: blocks 1000 s apart covary less than neighbours
    assert basis.flicker[1, 2] < basis.flicker[0, 1]


def test_blocks_stay_within_segments():
    rec = _bursts(1, drop=(7,))
    assert len(rec.segments) == 29  # one burst left out: still one segment per burst
    fit_p, _, skipped = problems(_bursts(2), None)
    # 50 Hz averaged to 1 Hz at entry (max_rate_hz) in groups of 50 within a burst: 5 per block
    assert fit_p.run.gapped and fit_p.y.size == 30 and fit_p.run.n_per_block == 5
    # every block's samples are 5 consecutive 1 s means of one burst
    t = fit_p.run.time_s.reshape(30, 5)
    np.testing.assert_allclose(np.diff(t, axis=1), 1.0, atol=1e-9)
    np.testing.assert_allclose(fit_p.run.arw_sample, 0.005, rtol=0.05)
    assert set(skipped) >= {"thermal_lag", "temp_rate", "hysteresis", "periodic"}
    assert all("gaps" in why for why in skipped.values())


def test_burst_recording_is_diagnosed():
    report = diagnose(_bursts(3), _bursts(4))
    assert report["selected_effects"] == []
    assert report["unexplained"]["present"] is False
    assert report["blocks"]["segments"] == {"fit": 30, "holdout": 30}
    assert report["gap"]["selected"]["fit"] is None and "gap_note" in report
    # the white level from differences within blocks only: 0.005 deg/s/sqrt(Hz) = 0.3 deg/sqrt(h)
    assert report["models"]["selected"]["noise"]["arw"]["value"] == pytest.approx(0.3, rel=0.2)


def test_lsm6dsm_tvac_bursts(real_data):
    folder = real_data("pan-lsm6dsm-tvac")
    rec = read_recording(
        folder / "pan_lsm6dsm_tvac_cold_2020-03-07.csv", ColumnSpec(rate="rate_x,rate_y,rate_z", dedupe="mean"), allow_gaps=True
    )
    assert len(rec.segments) == 25
    report = diagnose(rec.axis("rate_x"))
    assert report["blocks"]["segments"]["fit"] == 25 and report["blocks"]["n_fit"] == 25
    # 5 s bursts 305 s apart on a monotonic 8 degC cooling: the cubic in temperature carries the drift
    # (+0.03 deg/s/degC, README) and no effect of the vocabulary is named; what is left is a residual
    # correlated from burst to burst (Ljung-Box), no structure of a known shape
    assert report["selected_effects"] == []
    assert {w["test"] for w in report["unexplained"]["where"]} <= {"noise_correlation"}
    assert 0.2 < report["models"]["baseline"]["noise"]["arw"]["value"] < 0.6  # deg/sqrt(h), 3-digit quantised
