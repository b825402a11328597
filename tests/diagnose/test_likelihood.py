"""The block-mean likelihood: covariances against exact and IEEE Std 952 values."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import linalg, stats

from gyrocomp.effects.likelihood import FLICKER_AVAR, NoiseBasis, NoiseModel, block_means, fit_noise, profile_deviance
from gyrocomp.effects import noise as sim_noise


def _avar_of_blocks(cov, lag_blocks):
    """Allan variance at lag_blocks * T_b from a block-mean covariance (stationary part)."""
    m = lag_blocks
    k = cov.shape[0] // m * m
    # Means of m consecutive blocks, then half the mean squared difference.
    w = np.zeros((k // m, cov.shape[0]))
    for i in range(k // m):
        w[i, i * m : (i + 1) * m] = 1.0 / m
    c = w @ cov @ w.T
    d = np.diag(c)[:-1] + np.diag(c)[1:] - 2 * np.diag(c, 1)
    return 0.5 * d.mean()


def test_ieee_read_offs():
    """REFERENCES.md 2.2: sigma(1 s) = N for white, sigma(3 s) = K for RRW, floor 0.6643 B."""
    assert_allclose(np.sqrt(NoiseModel(arw=0.02).avar(1.0)), 0.02)
    assert_allclose(np.sqrt(NoiseModel(arw=0.0, rate_random_walk=3e-5).avar(3.0)), 3e-5)
    assert_allclose(np.sqrt(NoiseModel(arw=0.0, bias_instability=1.0).avar(100.0)), 0.66428, rtol=1e-4)


def test_flicker_basis_is_flat_in_allan():
    """The Gauss-Markov sum has the IEEE flicker floor at T_b and stays within 10 % over a decade."""
    basis = NoiseBasis(400, 10.0)
    for lag in (1, 3, 10):
        assert_allclose(_avar_of_blocks(basis.flicker, lag), FLICKER_AVAR, rtol=0.1)


def test_random_walk_basis_exact():
    """E[m_0^2] = T_b / 3 for a Wiener process from 0; Allan variance K^2 tau / 3 at every lag."""
    basis = NoiseBasis(200, 5.0)
    assert_allclose(basis.random_walk[0, 0], 5.0 / 3.0)
    for lag in (1, 4):
        assert_allclose(_avar_of_blocks(basis.random_walk, lag), 5.0 * lag / 3.0, rtol=1e-12)


def test_whitener_paths_agree_with_scipy():
    """-2 log L from the eigen and Cholesky paths equals scipy's multivariate normal at the GLS beta."""
    rng = np.random.default_rng(3)
    basis = NoiseBasis(60, 20.0)
    y = rng.standard_normal(60) * 0.01
    X = np.column_stack([np.ones(60), np.linspace(-1, 1, 60)])
    for noise in (
        NoiseModel(arw=0.03),
        NoiseModel(arw=0.03, bias_instability=0.002),
        NoiseModel(arw=0.03, rate_random_walk=1e-4),
        NoiseModel(arw=0.03, bias_instability=0.002, rate_random_walk=1e-4),
    ):
        dev, beta = profile_deviance(y, X, basis.whitener(noise))
        ref = -2 * stats.multivariate_normal(X @ beta, basis.covariance(noise)).logpdf(y)
        assert_allclose(dev, ref, rtol=1e-9)


@pytest.mark.parametrize("starts", [None, np.cumsum(np.r_[0.0, np.full(39, 20.0), 300.0, np.full(19, 20.0)])])
@pytest.mark.parametrize("correlation_s", [0.0, 300.0])
def test_semiseparable_whitener_is_the_dense_cholesky_factor(starts, correlation_s):
    """celerite2's O(k J^2) factorisation whitens as the dense Cholesky factor of Sigma does (D^-1/2 L^-1 = the
    lower Cholesky factor's inverse, exactly), with the same log-determinant, on contiguous and gapped blocks:
    flicker or its Markov form beside a random walk, and the Markov form alone."""
    rng = np.random.default_rng(5)
    basis = NoiseBasis(60, 20.0, starts)
    V = rng.standard_normal((60, 3))
    for noise in (
        NoiseModel(arw=0.03, bias_instability=0.004, rate_random_walk=3e-4, bias_correlation_s=correlation_s),
        NoiseModel(arw=0.03, bias_instability=0.004, bias_correlation_s=correlation_s or 300.0),
    ):
        lower = linalg.cholesky(basis.covariance(noise), lower=True)
        w = basis._semiseparable(noise)
        assert_allclose(w.whiten(V), linalg.solve_triangular(lower, V, lower=True), rtol=1e-10, atol=1e-10 * np.abs(V).max())
        assert_allclose(w.whiten(V[:, 0]), linalg.solve_triangular(lower, V[:, 0], lower=True), rtol=1e-10, atol=1e-9)
        assert_allclose(w.logdet, 2.0 * np.sum(np.log(np.diag(lower))), rtol=1e-12)


@pytest.mark.parametrize("starts", [None, np.cumsum(np.r_[0.0, np.full(39, 20.0), 300.0, np.full(19, 20.0)])])
def test_covariance_is_the_sum_of_its_terms_to_the_bit(starts):
    """Sigma summed in place equals N^2 C_w + B^2 C_f + K^2 C_k added matrix by matrix, in every form, bit for bit."""
    basis = NoiseBasis(60, 20.0, starts)
    for noise in (
        NoiseModel(arw=0.03),
        NoiseModel(arw=0.03, bias_instability=0.002),
        NoiseModel(arw=0.03, bias_instability=0.002, bias_correlation_s=300.0),
        NoiseModel(arw=0.03, rate_random_walk=1e-4),
        NoiseModel(arw=0.03, bias_instability=0.002, rate_random_walk=1e-4),
    ):
        expected = noise.arw**2 * basis.white
        if noise.bias_instability:
            expected = expected + noise.bias_instability**2 * basis.bias(noise.bias_correlation_s)
        if noise.rate_random_walk:
            expected = expected + noise.rate_random_walk**2 * basis.random_walk
        np.testing.assert_array_equal(basis.covariance(noise), expected)


@pytest.mark.parametrize("b_deg_h", [20.0])
def test_fit_noise_recovers_bias_instability(b_deg_h):
    """ML on block means of simulated white + flicker noise recovers B within 25 %."""
    rng = np.random.default_rng(11)
    fs, n = 1.0, 6 * 3600
    x = sim_noise.white(n, fs, 1.0, rng) + sim_noise.flicker(n, fs, b_deg_h, rng)
    y = block_means(x, 20)
    basis = NoiseBasis(y.size, 20.0)
    start = NoiseModel(arw=1 / 60, bias_instability=1e-3)
    noise, _, _ = fit_noise(y, np.ones((y.size, 1)), basis, start, ("arw", "bias_instability"))
    assert_allclose(noise.bias_instability * 3600, b_deg_h, rtol=0.25)
    assert_allclose(noise.arw * 60, 1.0, rtol=0.1)


def test_restricted_white_level_is_the_unbiased_residual_variance():
    """White only, restricted: ``N^2 / T_b`` is the least-squares residual variance over ``n - p`` (the textbook REML)."""
    rng = np.random.default_rng(5)
    y = 0.01 * rng.standard_normal(120)
    X = np.vander(np.linspace(-1.0, 1.0, y.size), 6)
    rss = float(np.sum((y - X @ np.linalg.lstsq(X, y, rcond=None)[0]) ** 2))
    noise, _, _ = fit_noise(y, X, NoiseBasis(y.size, 10.0), NoiseModel(arw=0.03), ("arw",), restricted=True)
    assert_allclose(noise.arw**2 / 10.0, rss / (y.size - X.shape[1]), rtol=0.02)
    ml, _, _ = fit_noise(y, X, NoiseBasis(y.size, 10.0), NoiseModel(arw=0.03), ("arw",))
    assert_allclose(ml.arw**2 / 10.0, rss / y.size, rtol=1e-9)


def test_restricted_likelihood_does_not_read_a_random_walk_low_beside_a_slow_polynomial():
    """A random walk (numpy cumulative sums) beside a cubic in time over a 4 h run: the cubic takes the walk's slow
    part, so maximum likelihood reads ``K^2`` at about 0.4 of the truth over 24 draws; the restricted
    likelihood (Patterson-Thompson) at 0.75-1.25 of it."""
    k, n_white = 3.0 / 3600.0 / 60.0, 0.005
    ml, restricted = [], []
    for seed in range(24):
        rng = np.random.default_rng(seed)
        x = n_white * rng.standard_normal(4 * 3600) + np.cumsum(k * rng.standard_normal(4 * 3600))
        y = block_means(x, 60)
        X = np.vander(np.linspace(-1.0, 1.0, y.size), 4)
        start = NoiseModel(arw=n_white, rate_random_walk=k)
        for out, flag in ((ml, False), (restricted, True)):
            noise = fit_noise(y, X, NoiseBasis(y.size, 60.0), start, ("arw", "rate_random_walk"), restricted=flag)[0]
            out.append((noise.rate_random_walk / k) ** 2)
    assert np.mean(ml) < 0.6
    assert 0.75 < np.mean(restricted) < 1.25


def test_fit_noise_concentrates_the_white_level_to_the_same_optimum():
    """White, flicker and random walk free: the ratios' search with N^2 concentrated out reaches the deviance of a
    tight three-dimensional search, and N^2 is its closed-form ML (no better N nearby)."""
    from scipy import optimize

    rng = np.random.default_rng(7)
    fs, n = 1.0, 4 * 3600
    x = sim_noise.white(n, fs, 1.0, rng) + sim_noise.flicker(n, fs, 15.0, rng) + np.cumsum(rng.standard_normal(n)) * 3e-4
    y = block_means(x, 20)
    X = np.column_stack([np.ones(y.size), np.linspace(-1.0, 1.0, y.size)])
    basis = NoiseBasis(y.size, 20.0)
    free = ("arw", "bias_instability", "rate_random_walk")
    noise, deviance, _ = fit_noise(y, X, basis, NoiseModel(arw=1 / 60, bias_instability=1e-3), free)

    def full(z):
        return profile_deviance(y, X, basis.whitener(NoiseModel(*np.exp(0.5 * z))))[0]

    z0 = np.log([noise.arw**2, noise.bias_instability**2, noise.rate_random_walk**2])
    tight = optimize.minimize(full, z0 + 0.5, method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-8, "maxfev": 4000})
    assert deviance == pytest.approx(full(z0), abs=1e-9)
    assert deviance <= tight.fun + 1e-2
    for scale in (0.99, 1.01):  # N^2 at its maximum given the ratios
        assert full(z0 + np.log(scale)) > deviance


def test_periodic_grid_deviances_equal_the_direct_fits():
    """The batched period scan equals one least-squares fit per period, alone and on two runs."""
    import pandas as pd

    from gyrocomp.diagnose import DiagnoseSettings, problems
    from gyrocomp.diagnose import nonlinear, select
    from gyrocomp.recordings import recording_from_frame

    rng = np.random.default_rng(11)
    t = np.arange(4 * 3600, dtype=float)
    temperature = 25.0 + 10.0 * np.sin(2 * np.pi * t / 7200.0)
    recs = [
        recording_from_frame(
            pd.DataFrame({"time": t, "rate": 1e-3 * temperature + 3e-3 * np.sin(2 * np.pi * t / 900.0 + k)
                          + sim_noise.white(t.size, 1.0, 1.0, rng) + sim_noise.flicker(t.size, 1.0, 20.0, rng),
                          "temperature": temperature}),
            name=f"run{k}",
        )
        for k in range(2)
    ]
    fit_p, (hold_p,), _ = problems(recs[0], recs[1:], DiagnoseSettings())
    model = select.extend(fit_p, select.fit_baseline(fit_p), "bias_instability")
    length = fit_p.y.size * fit_p.run.block_s
    periods = 1.0 / np.arange(2.0 / length, 1.0 / (4.0 * fit_p.run.block_s), 1.0 / length)  # a third of the selection's grid
    for others in ((), ((hold_p, model),)):
        parts = [nonlinear._JointPart(fit_p, model, "periodic")] + [nonlinear._JointPart(p, m, "periodic") for p, m in others]
        direct = [nonlinear._joint_deviance(parts, {"period_s": float(p)}, "periodic").sum() for p in periods]
        (one,) = nonlinear._periodic_grid_deviances(parts, periods, np.ones(periods.size, dtype=int))
        assert_allclose(one, direct, rtol=1e-10)
        assert 850.0 < periods[int(np.argmin(direct))] < 950.0
        # Three harmonics from each period's own largest number (3 or 5) of harmonics; five only where it is 5.
        h_max = np.where(np.arange(periods.size) % 2, 3, 5)
        grid = nonlinear._periodic_grid_deviances(parts, periods, h_max)
        for h in (1, 3, 5):
            direct_h = [nonlinear._joint_deviance(parts, {"period_s": float(p), "harmonics": h}, "periodic").sum() for p in periods]
            assert_allclose(grid[h - 1], np.where(h_max >= h, direct_h, np.inf), rtol=1e-10)


def _ar1(n, sigma, tc, fs, rng):
    """A stationary first-order Gauss-Markov sequence drawn here (scipy's AR(1) filter, not gyrocomp.sim)."""
    from scipy import signal

    phi = np.exp(-1.0 / (fs * tc))
    e = rng.standard_normal(n) * sigma * np.sqrt(1.0 - phi**2)
    x, _ = signal.lfilter([1.0], [1.0, -phi], e, zi=[phi * sigma * rng.standard_normal()])
    return x


def test_markov_avar_is_ieee952_exponentially_correlated_noise():
    """The Markov form's Allan deviation matches allantools on an AR(1) drawn in the test, and peaks at 0.664 B at 1.89 T_c."""
    allantools = pytest.importorskip("allantools")
    rng = np.random.default_rng(5)
    tc, fs, b = 200.0, 1.0, 1.0
    noise = NoiseModel(arw=0.0, bias_instability=b, bias_correlation_s=tc)
    x = _ar1(400_000, np.sqrt(noise.markov_variance), tc, fs, rng)
    taus = np.array([10.0, 50.0, 200.0, 400.0, 1000.0])
    t, adev, err, _ = allantools.oadev(x, rate=fs, data_type="freq", taus=taus)
    assert_allclose(adev, np.sqrt(noise.avar(t)), rtol=0.05)
    tau = np.geomspace(10.0, 10_000.0, 2001)
    peak = np.argmax(noise.avar(tau))
    assert_allclose(np.sqrt(noise.avar(tau[peak])), 0.66428, rtol=1e-4)
    assert_allclose(tau[peak] / tc, 1.8926, rtol=0.01)


def test_markov_basis_is_the_block_mean_covariance():
    """C_m(T_c) scaled to B equals the sample covariance of block means of the test's AR(1) at lags 0, 1 and 5."""
    rng = np.random.default_rng(6)
    tc, fs, tb = 120.0, 1.0, 20
    noise = NoiseModel(arw=0.0, bias_instability=1.0, bias_correlation_s=tc)
    x = _ar1(2_000_000, np.sqrt(noise.markov_variance), tc, fs, rng)
    m = block_means(x, tb)
    cov = NoiseBasis(8, float(tb)).covariance(noise)
    for lag in (0, 1, 5):
        empirical = np.mean(m[lag:] * m[: m.size - lag])
        assert_allclose(empirical, cov[0, lag], rtol=0.05, atol=0.01 * cov[0, 0])


def test_whitener_paths_agree_with_scipy_in_the_markov_form():
    """The eigen path of C_m and the Cholesky path with a random walk beside it give scipy's -2 log L."""
    rng = np.random.default_rng(4)
    basis = NoiseBasis(50, 30.0)
    y = rng.standard_normal(50) * 0.01
    X = np.ones((50, 1))
    for noise in (
        NoiseModel(arw=0.03, bias_instability=0.002, bias_correlation_s=300.0),
        NoiseModel(arw=0.03, bias_instability=0.002, rate_random_walk=1e-4, bias_correlation_s=300.0),
    ):
        dev, beta = profile_deviance(y, X, basis.whitener(noise))
        ref = -2 * stats.multivariate_normal(X @ beta, basis.covariance(noise)).logpdf(y)
        assert_allclose(dev, ref, rtol=1e-9)
