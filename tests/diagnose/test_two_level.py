"""Two levels against a Gaussian wander (gyrocomp.diagnose.two_level) on series drawn here with numpy, and against hmmlearn (peer)."""

import numpy as np
import pytest
from hmmlearn.hmm import GaussianHMM

from gyrocomp.diagnose import two_level as tl


def _gauss_markov_cov(n, phi, var):
    lag = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    return var * phi**lag + np.eye(n)


def _telegraph(n, switch_prob, amp, rng):
    """Levels +-amp/2 that switch with probability `switch_prob` per block (geometric dwell)."""
    flips = rng.random(n) < switch_prob
    return amp * np.where(np.cumsum(flips) % 2 == 0, 0.5, -0.5)


def test_markov_loglik_matches_the_dense_gaussian_likelihood():
    # the Kalman recursion against the density of N(mean, cov) evaluated by Cholesky, mean profiled by the row mean
    rng = np.random.default_rng(0)
    n, phi, ratio = 120, 0.7, 2.0
    y = rng.standard_normal((1, n)) * 0.3 + 1.0
    x = y[0] - y[0].mean()
    cov = _gauss_markov_cov(n, phi, ratio)
    lower = np.linalg.cholesky(cov)
    w = np.linalg.solve(lower, x)
    # sigma^2 profiled: s2 = w'w / n
    s2 = w @ w / n
    dense = -0.5 * n * (np.log(2.0 * np.pi * s2) + 1.0) - np.log(np.diag(lower)).sum()
    assert tl.markov_loglik(y, np.array([phi]), np.array([ratio]))[0] == pytest.approx(dense, abs=1e-8)


def test_two_level_fit_recovers_a_telegraph():
    # the likelihood of the fitted two levels is at least that of the true levels and switching law
    rng = np.random.default_rng(1)
    n, p_switch, amp = 600, 0.05, 2.0
    s = _telegraph(n, p_switch, amp, rng)
    y = s + rng.standard_normal(n)
    fitted = tl.two_level_loglik(y[None, :], 80)[0]
    # the true model's likelihood by the forward recursion, written out densely for two states
    em = np.exp(-0.5 * (y[:, None] - np.array([-0.5, 0.5]) * amp) ** 2) / np.sqrt(2.0 * np.pi)
    trans = np.array([[1 - p_switch, p_switch], [p_switch, 1 - p_switch]])
    f, ll = np.array([0.5, 0.5]) * em[0], 0.0
    for i in range(1, n):
        ll += np.log(f.sum())
        f = (f / f.sum()) @ trans * em[i]
    ll += np.log(f.sum())
    assert fitted >= ll - 0.5


def _peer(startprob, transmat, means, var, params=""):
    """hmmlearn's Gaussian HMM of two states with one (tied) variance, these parameters."""
    peer = GaussianHMM(n_components=2, covariance_type="tied", init_params="", params=params, n_iter=1000, tol=1e-10)
    peer.startprob_, peer.transmat_ = np.asarray(startprob, float), np.asarray(transmat, float)
    peer.means_, peer.covars_ = np.asarray(means, float)[:, None], np.array([[var]])
    return peer


def test_forward_likelihood_matches_hmmlearn():
    # the same two-state model, started in its stationary law: the same log-likelihood as hmmlearn's score
    rng = np.random.default_rng(5)
    y = _telegraph(500, 0.05, 2.0, rng) + rng.standard_normal(500)
    stay = np.array([0.93, 0.9])
    go = 1.0 - stay
    ours = tl._forward_loglik(y[None, :], np.array([[-0.8, 1.1]]), np.array([0.9]), stay[None, :])[0]
    peer = _peer(go[::-1] / go.sum(), [[stay[0], go[0]], [go[1], stay[1]]], [-0.8, 1.1], 0.81)
    assert ours == pytest.approx(peer.score(y[:, None]), abs=1e-8)


def test_baum_welch_reaches_hmmlearns_maximum():
    # hmmlearn also fits the start law (it goes to one state: ln 2 at most beyond our stationary start)
    rng = np.random.default_rng(6)
    y = _telegraph(500, 0.05, 2.0, rng) + rng.standard_normal(500)
    ours = tl.two_level_loglik(y[None, :], 300)[0]
    peer = _peer([0.5, 0.5], [[0.9, 0.1], [0.1, 0.9]], [y.mean() - y.std(), y.mean() + y.std()], 0.36 * y.var(), "stmc")
    best = peer.fit(y[:, None]).score(y[:, None])
    assert best - np.log(2.0) - 0.1 <= ours <= best + 1e-6


@pytest.mark.parametrize("phi, var", [(0.8, 0.5), (0.95, 2.0)])
def test_switching_test_holds_its_rate_on_a_gaussian_wander(phi, var):
    # Gauss-Markov wander under white noise, the sampler its exact covariance: z about N(0, 1), its upper
    # tail no heavier (30 series: none beyond z = 3)
    rng = np.random.default_rng(2)
    n = 300
    lower = np.linalg.cholesky(_gauss_markov_cov(n, phi, var))
    z = np.array([tl.switching_test(lower @ rng.standard_normal(n), lower, 60, 40, seed=k)["z"] for k in range(30)])
    assert abs(z.mean()) < 0.5 and 0.6 < z.std() < 1.5, z
    assert z.max() < 3.0, z


def test_switching_test_finds_a_telegraph_of_the_same_spectrum():
    # a telegraph of 3 white-noise sd between its levels with the Gauss-Markov's autocovariance (phi = 1 -
    # 2 p_switch, variance amp^2 / 4): to second order the same series
    rng = np.random.default_rng(3)
    n, p_switch, amp = 300, 0.05, 3.0
    lower = np.linalg.cholesky(_gauss_markov_cov(n, 1.0 - 2.0 * p_switch, amp**2 / 4.0))
    z = [tl.switching_test(_telegraph(n, p_switch, amp, rng) + rng.standard_normal(n), lower, 60, 40, seed=k)["z"] for k in range(5)]
    assert min(z) > 3.0, z  # measured 4.0-5.8; the Gaussian wander of the same spectrum stays below 3


def test_switching_test_is_the_same_for_the_same_seed():
    rng = np.random.default_rng(4)
    lower = np.linalg.cholesky(_gauss_markov_cov(200, 0.9, 1.0))
    r = lower @ rng.standard_normal(200)
    a, b = tl.switching_test(r, lower, 30, 20, seed=7), tl.switching_test(r, lower, 30, 20, seed=7)
    assert a == b
