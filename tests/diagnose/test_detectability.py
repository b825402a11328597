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
from gyrocomp.diagnose.detectability import deterministic_evidence, edge_evidence, noise_evidence, threshold
from gyrocomp.diagnose.likelihood import NoiseModel, block_means
from gyrocomp.io import recording_from_frame
from gyrocomp.sim import effects as shapes

FS = 1.0
N = 2 * 3600


@pytest.fixture(scope="module")
def problem():
    """A 2-hour run at 1 Hz: half an hour's soak, a 1 degC/min ramp, a soak; 720 blocks of 10 s."""
    t = np.arange(N) / FS
    temperature = 25.0 + np.clip((t - 1800.0) / 60.0, 0.0, 40.0)
    frame = pd.DataFrame({"time": t, "rate": np.zeros(N), "temperature": temperature})
    fit_p, _, _ = problems(recording_from_frame(frame, name="run"), None, DiagnoseSettings())
    return fit_p


def test_edge_gives_the_stated_power():
    """(sqrt(thr) + z)^2 crosses the threshold with probability 0.95 for a noncentral chi2_1."""
    thr = threshold(720, "rate_ramp", 10.0)
    assert_allclose(thr, np.log(720) + 10.0)
    edge = edge_evidence(720, "rate_ramp", 10.0)
    assert_allclose(edge, 32.68, atol=0.01)
    # The two-sided noncentral chi2 adds the negative tail (< 1e-6 here).
    assert_allclose(stats.ncx2.sf(thr, 1, edge), 0.95, atol=1e-4)


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


def _gls_rss(y, X, inv):
    beta = np.linalg.solve(X.T @ inv @ X, X.T @ inv @ y)
    r = y - X @ beta
    return r @ inv @ r


@pytest.mark.parametrize("term, value", [("bias_instability", 10.0 / 3600.0), ("rate_random_walk", 25.0 / 216000.0)])
def test_noise_evidence_is_twice_the_divergence(problem, term, value):
    """Against scipy: 2 E[log p_true(y) - log p_white(y)] on the contrasts, white level at its optimum."""
    noise = NoiseModel(arw=1.0 / 60.0, **{term: value})
    lam = noise_evidence(problem, {}, noise, term)
    X, _ = problem.design_blocks({})
    q, _ = np.linalg.qr(X, mode="complete")
    c = q[:, X.shape[1] :]
    true = c.T @ problem.basis.covariance(noise) @ c
    white = np.trace(true) / true.shape[0] * np.eye(true.shape[0])
    rng = np.random.default_rng(5)
    y = rng.multivariate_normal(np.zeros(true.shape[0]), true, size=200)
    ratio = 2.0 * (stats.multivariate_normal(cov=true).logpdf(y) - stats.multivariate_normal(cov=white).logpdf(y))
    assert abs(ratio.mean() - lam) < 3.0 * ratio.std() / np.sqrt(ratio.size), (ratio.mean(), lam)
    assert lam > 20.0


def test_noise_evidence_beside_the_other_term_is_smaller(problem):
    """A random walk beside flicker: the flicker term absorbs part of it, so its evidence drops."""
    alone = NoiseModel(arw=1.0 / 60.0, rate_random_walk=10.0 / 216000.0)
    both = NoiseModel(arw=1.0 / 60.0, bias_instability=20.0 / 3600.0, rate_random_walk=10.0 / 216000.0)
    lam_alone = noise_evidence(problem, {}, alone, "rate_random_walk")
    lam_both = noise_evidence(problem, {}, both, "rate_random_walk")
    assert 0.0 < lam_both < lam_alone
    with pytest.raises(ValueError, match="not a noise term present"):
        noise_evidence(problem, {}, alone, "bias_instability")
