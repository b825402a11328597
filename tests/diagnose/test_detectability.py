"""Evidence of an effect for an ideal detector, against Monte Carlo and closed forms.

Each expected value is checked against the average of the likelihood-ratio
statistic over simulated block means (scipy's multivariate normal log
density, not the library's whitening), so a wrong projection, whitening or
divergence shows as a mismatch far beyond the Monte Carlo error.
"""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from gyrocomp.diagnose import DiagnoseSettings, problems
from gyrocomp.diagnose.detectability import (
    deterministic_detection,
    deterministic_evidence,
    edge_evidence,
    noise_detection,
    noise_evidence,
    noise_ratios,
    threshold,
)
from gyrocomp.effects.likelihood import NoiseModel, block_means
from gyrocomp.recordings import recording_from_frame
from gyrocomp.effects import shapes

FS = 1.0
N = 2 * 3600


@pytest.fixture(scope="module")
def problem():
    """A 2-hour run at 1 Hz: half an hour's soak, a 1 degC/min ramp, a soak; 720 blocks of 10 s."""
    t = np.arange(N) / FS
    temperature = 25.0 + np.clip((t - 1800.0) / 60.0, 0.0, 40.0)
    frame = pd.DataFrame({"time": t, "rate": np.zeros(N), "temperature": temperature})
    fit_p, _, _ = problems(recording_from_frame(frame, name="run"), [], DiagnoseSettings())
    return fit_p


def test_edge_of_a_one_parameter_effect():
    """720 blocks, margin 10: threshold ln 720 + 10; 95 % power needs about (sqrt(thr) + z_0.95)^2."""
    thr = threshold(720, "rate_ramp", 10.0)
    assert_allclose(thr, np.log(720) + 10.0)
    edge = edge_evidence(thr)
    assert_allclose(edge, (np.sqrt(thr) + stats.norm.ppf(0.95)) ** 2, atol=0.01)
    assert_allclose(deterministic_detection(edge, thr), 0.95, atol=1e-9)


def test_ramp_under_white_noise_closed_form(problem):
    """White noise, a ramp beside an offset and a cubic in a ramp-and-soak temperature.

    With ``Sigma = s^2 I`` the evidence is the ramp's residual sum of squares
    after least squares on the nuisance columns, over ``s^2``.
    """
    noise = NoiseModel(arw=1.0 / 60.0)
    slope = 2e-7
    contribution = slope * problem.run.time_s
    X, _ = problem.design_blocks({})
    s = block_means(contribution, problem.run.n_per_block)
    resid = s - X @ np.linalg.lstsq(X, s, rcond=None)[0]
    expected = resid @ resid / (noise.arw**2 / problem.run.block_s)
    assert_allclose(deterministic_evidence(problem, contribution, {}, noise), expected, rtol=1e-8)


def test_deterministic_evidence_is_the_mean_likelihood_ratio(problem):
    """Under flicker + white noise, the mean -2 log L drop of adding the true warm-up is evidence + 1."""
    noise = NoiseModel(arw=1.0 / 60.0, bias_instability=15.0 / 3600.0)
    contribution = shapes.warmup(problem.run.time_s, 2e-2, 600.0)
    lam = deterministic_evidence(problem, contribution, {}, noise)
    assert 5.0 < lam < 200.0, lam
    X, _ = problem.design_blocks({})
    s = block_means(contribution, problem.run.n_per_block)
    cov = problem.basis.covariance(noise)
    chol = np.linalg.cholesky(cov)
    inv = np.linalg.inv(cov)
    rng = np.random.default_rng(3)
    drops = []
    for _ in range(400):
        y = X @ rng.normal(size=X.shape[1]) * 1e-3 + s + chol @ rng.normal(size=s.size)
        drops.append(_gls_rss(y, X, inv) - _gls_rss(y, np.column_stack([X, s]), inv))
    # Var of a noncentral chi2_1 is 2 + 4 lambda: the mean of 400 has a standard error of 0.05 sqrt(2 + 4 lambda).
    assert abs(np.mean(drops) - (lam + 1.0)) < 3.0 * np.sqrt((2.0 + 4.0 * lam) / 400.0)
    # Detection probability at a threshold near the median drop.
    thr = float(np.median(drops))
    p = deterministic_detection(lam, thr)
    assert abs(np.mean(np.array(drops) > thr) - p) < 3.0 * np.sqrt(p * (1 - p) / 400.0) + 0.01


def _gls_rss(y, X, inv):
    beta = np.linalg.solve(X.T @ inv @ X, X.T @ inv @ y)
    r = y - X @ beta
    return r @ inv @ r


@pytest.mark.parametrize("term, value", [("bias_instability", 10.0 / 3600.0), ("rate_random_walk", 25.0 / 216000.0)])
def test_noise_evidence_and_detection_against_scipy(problem, term, value):
    """2 log p_true(y) / p_white(y) on the contrasts (scipy densities, white level at its optimum):
    its mean is the evidence and its spread the detection probability's."""
    noise = NoiseModel(arw=1.0 / 60.0, **{term: value})
    ratios = noise_ratios(problem, {}, noise, term)
    lam = noise_evidence(ratios)
    X, _ = problem.design_blocks({})
    q, _ = np.linalg.qr(X, mode="complete")
    c = q[:, X.shape[1] :]
    true = c.T @ problem.basis.covariance(noise) @ c
    white = np.trace(true) / true.shape[0] * np.eye(true.shape[0])
    rng = np.random.default_rng(5)
    y = rng.multivariate_normal(np.zeros(true.shape[0]), true, size=400)
    ratio = 2.0 * (stats.multivariate_normal(cov=true).logpdf(y) - stats.multivariate_normal(cov=white).logpdf(y))
    assert abs(ratio.mean() - lam) < 3.0 * ratio.std() / np.sqrt(ratio.size), (ratio.mean(), lam)
    assert lam > 20.0
    # The statistic spreads far wider than a non-central chi2_1 of the same mean (sd sqrt(2 + 4 lam)).
    assert ratio.std() > 1.5 * np.sqrt(2.0 + 4.0 * lam)
    thr = float(np.median(ratio))
    p = noise_detection(ratios, thr)
    assert abs(np.mean(ratio > thr) - p) < 3.0 * np.sqrt(p * (1 - p) / ratio.size) + 0.01


def test_noise_evidence_beside_the_other_term_is_smaller(problem):
    """A random walk beside flicker: the flicker term absorbs part of it, so its evidence drops."""
    alone = NoiseModel(arw=1.0 / 60.0, rate_random_walk=10.0 / 216000.0)
    both = NoiseModel(arw=1.0 / 60.0, bias_instability=20.0 / 3600.0, rate_random_walk=10.0 / 216000.0)
    lam_alone = noise_evidence(noise_ratios(problem, {}, alone, "rate_random_walk"))
    lam_both = noise_evidence(noise_ratios(problem, {}, both, "rate_random_walk"))
    assert 0.0 < lam_both < lam_alone
    with pytest.raises(ValueError, match="not a noise term present"):
        noise_ratios(problem, {}, alone, "bias_instability")


def test_noise_evidence_beside_flicker_against_a_dense_minimisation(problem):
    """The closest flicker-plus-white covariance found by dense Cholesky algebra gives the same divergence."""
    from scipy import linalg, optimize

    noise = NoiseModel(arw=1.0 / 60.0, bias_instability=8.0 / 3600.0, rate_random_walk=15.0 / 216000.0)
    lam = noise_evidence(noise_ratios(problem, {}, noise, "rate_random_walk"))
    X, _ = problem.design_blocks({})
    q, _ = np.linalg.qr(X, mode="complete")
    c = q[:, X.shape[1] :]
    true = c.T @ problem.basis.covariance(noise) @ c
    flicker = c.T @ problem.basis.flicker @ c
    m = true.shape[0]
    logdet_true = np.linalg.slogdet(true)[1]

    def divergence(z):
        sigma0 = np.exp(z[0]) * np.eye(m) + np.exp(z[1]) * flicker
        chol = linalg.cholesky(sigma0, lower=True)
        return np.trace(linalg.cho_solve((chol, True), true)) - m - logdet_true + 2 * np.sum(np.log(np.diag(chol)))

    z0 = np.log([noise.arw**2 / problem.run.block_s, noise.bias_instability**2])
    best = optimize.minimize(divergence, z0, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-6})
    assert_allclose(lam, best.fun, rtol=1e-3)
    assert 0.0 < lam < noise_evidence(noise_ratios(problem, {}, NoiseModel(arw=noise.arw, rate_random_walk=noise.rate_random_walk), "rate_random_walk"))


def test_detection_limit_in_the_report_is_an_amplitude_diagnose_finds():
    """A pair without a ramp reports the weakest ramp it would find: twice as strong is found, half is not.

    At half the limit an ideal detector has a quarter of the edge evidence
    (8 against a threshold of 17): it finds the ramp with probability 0.03;
    at twice the limit it misses it with probability below 1e-4. (Noise
    seeds 40/41 are one of those 3 %: the fit run's noise alone shows a ramp
    of 2e-7 deg/s/s, which the joint criterion then accepts.)
    """
    from gyrocomp.diagnose import diagnose
    import dataclasses

    from gyrocomp.sim import EFFECTS
    from gyrocomp.sim.model import GyroSettings, RateRamp
    from gyrocomp.sim.profile import ProfileSettings
    from gyrocomp.sim.simulate import simulate

    profile = ProfileSettings(start_c=25.0, start_hold_s=1800.0, levels_c=(50.0, 20.0), hold_s=(2700.0,), ramp_c_per_min=(1.0,))
    default = GyroSettings()
    off = {e: dataclasses.replace(getattr(default, e), enabled=False) for e in EFFECTS if e != "rate_ramp"}

    def pair(slope):
        gyro = GyroSettings(**off, rate_ramp=RateRamp(enabled=slope != 0.0, slope_dps_per_s=slope or 1e-7))
        frames = [simulate(gyro, profile, fs_hz=1.0, seed=50 + k, duration_s=3 * 3600.0)[0] for k in range(2)]
        return [recording_from_frame(f[["time", "rate", "temperature"]], name=f"run{k}") for k, f in enumerate(frames)]

    report = diagnose(*pair(0.0))
    assert report["selected_effects"] == []
    limit = report["candidates"]["rate_ramp"]["detection_limit"]["slope_dps_per_s"]
    assert limit["unit"] == "deg/s/s"
    # 3 h of 1 deg/sqrt(h) white noise beside a cubic in temperature: a few 1e-7 deg/s/s.
    assert 3e-8 < limit["value"] < 1e-6, limit
    found = diagnose(*pair(2.0 * limit["value"]))
    assert found["selected_effects"] == ["rate_ramp"]
    assert found["candidates"]["rate_ramp"]["detection_limit"] is None
    assert diagnose(*pair(0.5 * limit["value"]))["selected_effects"] == []
