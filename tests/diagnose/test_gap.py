"""The scalar gap: Barnes' bias functions and its null behaviour."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.diagnose.gap import barnes_b1, gap
from gyrocomp.effects.likelihood import NoiseModel
from gyrocomp.effects import noise as sim_noise


def test_barnes_b1_published_values():
    """NBS TN 375: B1(N, mu=1) = N/2 (random walk FM), B1(N, 0) = N ln N / (2 (N-1) ln 2)."""
    assert_allclose(barnes_b1(10, 1), 5.0)
    assert_allclose(barnes_b1(2, 0), 1.0)
    # mu = 0 is the limit of the general formula.
    assert_allclose(barnes_b1(64, 0), barnes_b1(64, 1e-7), rtol=1e-5)


def test_gap_is_small_for_the_simulation_itself_and_large_for_drift():
    rng = np.random.default_rng(5)
    fs, n = 2.0, 4 * 3600 * 2
    noise = NoiseModel(arw=1 / 60)
    x = sim_noise.white(n, fs, 1.0, rng)
    null = gap(x, fs, noise)
    assert null["total"] < 0.1
    t = np.arange(n) / fs
    drifted = gap(x + 0.005 * np.sin(2 * np.pi * t / 3000.0), fs, noise)
    assert drifted["total"] > 0.5
    assert drifted["deterministic"] > 0.5


def test_noise_level_is_the_95th_percentile_of_the_null_gap():
    """On 400 recordings that are the simulation (white noise, 2 h at 1 Hz), about 5 % exceed `noise_level`."""
    rng = np.random.default_rng(8)
    fs, n = 1.0, 2 * 3600
    noise = NoiseModel(arw=1 / 60)
    results = [gap(sim_noise.white(n, fs, 1.0, rng), fs, noise) for _ in range(400)]
    level = results[0]["noise_level"]
    assert all(r["noise_level"] == level for r in results)
    totals = np.array([r["total"] for r in results])
    assert 0.02 < np.mean(totals > level) < 0.09
    assert_allclose(np.quantile(totals, 0.95), level, rtol=0.15)


def test_noise_level_of_a_chi_square():
    """Equal variances make D^2 + S exactly v chi2_k: the level is sqrt(v (chi2_k(0.95) - k))."""
    from scipy import stats

    from gyrocomp.diagnose.gap import noise_level

    assert_allclose(noise_level([0.01] * 4), np.sqrt(0.01 * (stats.chi2.ppf(0.95, 4) - 4)))
    assert noise_level([]) == 0.0


@pytest.mark.parametrize("terms", [{"rate_random_walk": 20.0}, {"bias_instability": 20.0}])
def test_noise_floor_and_level_under_coloured_noise(terms):
    """A random walk (or flicker) the simulation models exactly: E_0 is the mean of D^2 + S, about 5 % of G exceed the level.

    The 100 s spread of a random walk has about three degrees of freedom:
    with the white count, ``E_0`` was 0.01 and a perfect model read as a gap
    of order 1 (Monte Carlo over 150 two-hour runs at 1 Hz).
    """
    rng = np.random.default_rng(11)
    fs, n = 1.0, 2 * 3600
    k = terms.get("rate_random_walk", 0.0)
    b = terms.get("bias_instability", 0.0)
    noise = NoiseModel(arw=1 / 60, bias_instability=b / 3600, rate_random_walk=k / 216000)
    results = []
    for _ in range(150):
        x = sim_noise.white(n, fs, 1.0, rng)
        x = x + (sim_noise.random_walk(n, fs, k, rng) if k else sim_noise.flicker(n, fs, b, rng))
        results.append(gap(x, fs, noise))
    raw = np.array([r["deterministic"] ** 2 + r["stochastic"] for r in results])
    assert_allclose(raw.mean(), results[0]["noise_floor"], rtol=0.25)
    assert results[0]["noise_floor"] > 2 * gap(sim_noise.white(n, fs, 1.0, rng), fs, NoiseModel(arw=1 / 60))["noise_floor"]
    totals = np.array([r["total"] for r in results])
    assert 0.005 < np.mean(totals > results[0]["noise_level"]) < 0.12
