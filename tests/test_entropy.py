"""Permutation and sample entropy against published values and peer libraries.

Sources: REFERENCES.md sections 2.6 (Bandt & Pompe 2002; antropy docstrings)
and 2.7 (EntropyHub docs Ex1 on ExampleData/gaussian.txt; Richman & Moorman).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.entropy import _sample_entropy_vector, permutation_entropy, sample_entropy
from gyrocomp.errors import InputError


def _gaussian(real_data):
    path = real_data("entropyhub-example-signals") / "gaussian.txt"
    return np.array(path.read_text().split("\n", 1)[1].split(), float)


def _sampen_brute(x, m, r):
    """O(N^2) reference: sampenc counting, Chebyshev, strict <, N - m templates."""
    n = x.size - m
    def pairs(dim):
        t = np.stack([x[k : k + n] for k in range(dim)], axis=1) if dim else np.zeros((n, 0))
        d = np.max(np.abs(t[:, None, :] - t[None, :, :]), axis=2, initial=0.0)
        return (np.count_nonzero(d < r) - n) // 2
    return -math.log(pairs(m + 1) / pairs(m))


def _pe_sort(x, order, delay):
    """Independent PE: stable argsort patterns (ties by index), normalised by ln(order!)."""
    x = np.asarray(x, float)
    n = x.size - (order - 1) * delay
    w = np.stack([x[k * delay : k * delay + n] for k in range(order)], axis=1)
    _, counts = np.unique(np.argsort(w, axis=1, kind="stable"), axis=0, return_counts=True)
    p = counts / n
    return -np.sum(p * np.log(p)) / math.log(math.factorial(order))


def test_bandt_pompe_example():
    """Bandt & Pompe (2002): x = (4, 7, 9, 10, 6, 11, 3): H(2) = 0.918 bits, H(3) = 1.522 bits."""
    x = [4, 7, 9, 10, 6, 11, 3]
    assert round(permutation_entropy(x, 3), 4) == 0.5888
    assert_allclose(permutation_entropy(x, 2, normalize=False) / math.log(2), 0.918, atol=5e-4)
    assert_allclose(permutation_entropy(x, 3, normalize=False) / math.log(2), 1.522, atol=5e-4)


def test_antropy_docstring_values():
    """antropy ``perm_entropy`` docstring (order 3, delay 1, normalised)."""
    sine = np.sin(2 * np.pi * 1 * np.arange(3000) / 100)
    assert round(permutation_entropy(sine, 3, 1), 4) == 0.4463
    assert permutation_entropy(np.arange(1000), 3, 1) == 0
    assert round(permutation_entropy(np.random.default_rng(42).random(1000), 3, 1), 4) == 0.9997


@pytest.mark.parametrize("order", [2, 3, 4, 5, 6])
@pytest.mark.parametrize("delay", [1, 3])
def test_permutation_entropy_matches_sort_with_ties(order, delay):
    """Quantised data (many ties) against a stable-argsort implementation of eq. (14)."""
    x = np.round(np.random.default_rng(order * 10 + delay).standard_normal(3000) * 2)
    assert_allclose(permutation_entropy(x, order, delay), _pe_sort(x, order, delay), rtol=1e-12)


def test_entropyhub_gaussian_published(real_data):
    """EntropyHub docs Ex1: SampEn m = 0..4 on gaussian.txt = 2.1789, 2.1757, 2.1819, 2.2209, 2.1756."""
    x = _gaussian(real_data)
    assert_allclose(_sample_entropy_vector(x, 4), [2.1789, 2.1757, 2.1819, 2.2209, 2.1756], atol=1e-3)
    # the vector as sampenc's e: -ln(A(1) / (N(N - 1)/2)) for m = 0
    assert_allclose(_sample_entropy_vector(x, 4), [2.178924, 2.175742, 2.181970, 2.220984, 2.175567], atol=2e-6)


@pytest.mark.parametrize("m", [0, 1, 2, 3, 4])
@pytest.mark.parametrize("quantised", [False, True])
def test_sample_entropy_matches_brute_force(m, quantised):
    """Against the O(N^2) sampenc count, also with ties at distance r."""
    rng = np.random.default_rng(m)
    x = np.cumsum(rng.standard_normal(1500)) * 0.1 + rng.standard_normal(1500)
    r = 0.2 * np.std(x)
    if quantised:
        x = np.round(x * 4) / 4  # distances equal to r = 0.5 occur: strict < must exclude them
        r = 0.5
    assert_allclose(sample_entropy(x, m, r), _sampen_brute(x, m, r), rtol=1e-12)


@pytest.mark.parametrize("m", [0, 1, 2])
@pytest.mark.parametrize("kind", ["sine", "random walk"])
def test_smooth_signal_matches_brute_force(m, kind):
    """Smooth signals (nearly every template pair matches) against the O(N^2) count."""
    rng = np.random.default_rng(21)
    t = np.arange(1500)
    if kind == "sine":
        x = np.sin(2 * np.pi * t / 400) + 0.01 * rng.standard_normal(t.size)
    else:
        x = np.cumsum(rng.standard_normal(t.size))
    r = 0.2 * np.std(x)
    assert_allclose(sample_entropy(x, m, r), _sampen_brute(x, m, r), rtol=1e-12)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_compiled_counts_equal_grid_counts(dim):
    """The compiled sweeps (lengths 1-3) and the grid search (any length) count the same pairs."""
    from gyrocomp.entropy import _count_grid, _count_sorted

    rng = np.random.default_rng(dim)
    quantised = np.round(rng.standard_normal(4000) * 8) / 8  # ties at distance r = 0.25
    smooth = np.cumsum(rng.standard_normal(4000))
    for x, r in ((quantised, 0.25), (smooth, 0.2 * np.std(smooth))):
        n = x.size - 2
        assert _count_sorted(x, dim, n, r) == _count_grid(x, dim, n, r)


def test_sample_entropy_white_noise_theory():
    """Gaussian white noise, r = 0.2 sigma: SampEn -> -ln(2 Phi(0.2/sqrt 2) - 1) = 2.1851."""
    x = np.random.default_rng(7).standard_normal(50_000)
    assert_allclose(sample_entropy(x, 2), 2.1851, atol=0.02)


def test_sample_entropy_regular_signals():
    """antropy docstring: pure sine 0.1633 (its numba path, same conventions); arange 0."""
    sine = np.sin(2 * np.pi * 1 * np.arange(3000) / 100)
    assert_allclose(sample_entropy(sine, 2), 0.1633, atol=5e-4)
    assert sample_entropy(np.arange(1000.0), 2) == 0


def test_sample_entropy_undefined_and_infinite():
    with pytest.warns(RuntimeWarning, match="no template pair matches at length m$"):
        assert math.isnan(sample_entropy(np.arange(10.0), 1, 0.5))
    with pytest.warns(RuntimeWarning, match="length m \\+ 1"):
        assert sample_entropy([0.0, 0.0, 1.0], 1, 0.5) == math.inf


def test_sample_entropy_default_r_is_ddof0():
    x = np.random.default_rng(3).standard_normal(2000)
    assert sample_entropy(x, 2) == sample_entropy(x, 2, 0.2 * np.std(x, ddof=0))


@pytest.mark.parametrize(
    "call",
    [
        lambda: sample_entropy([1.0, np.nan, 2.0, 3.0]),
        lambda: sample_entropy(np.ones((3, 3))),
        lambda: sample_entropy(np.ones(100)),
        lambda: sample_entropy(np.arange(10.0), m=-1),
        lambda: sample_entropy(np.arange(3.0), m=2),
        lambda: permutation_entropy([1, 2, 3], order=1),
        lambda: permutation_entropy([1, 2, 3], order=4),
        lambda: permutation_entropy(np.arange(10), delay=0),
    ],
)
def test_bad_input_raises_input_error(call):
    with pytest.raises(InputError):
        call()


@pytest.mark.slow
def test_agrees_with_antropy_on_white_noise():
    """antropy (numba path: order 2, strict <, r = 0.2 std ddof 0) within 0.01 on 20 000 samples."""
    antropy = pytest.importorskip("antropy")
    x = np.random.default_rng(11).standard_normal(20_000)
    assert_allclose(sample_entropy(x, 2), antropy.sample_entropy(x, order=2), atol=0.01)
    for order in (3, 4, 5, 6):
        assert_allclose(permutation_entropy(x, order), antropy.perm_entropy(x, order=order, normalize=True), atol=1e-9)


@pytest.mark.slow
def test_agrees_with_entropyhub():
    """EntropyHub SampEn (r given explicitly as 0.2 std ddof 0) equals ours for m = 0..3."""
    eh = pytest.importorskip("EntropyHub")
    x = np.random.default_rng(5).standard_normal(2000)
    r = 0.2 * np.std(x)
    samp, _, _ = eh.SampEn(x, m=3, r=r)
    assert_allclose(_sample_entropy_vector(x, 3, r), samp, atol=1e-9)


def test_permutation_entropy_in_blocks_equals_the_whole_signal():
    """Issue 38: a component on disk is counted a block of windows at a time, the same counts."""
    from gyrocomp.entropy import permutation_entropy, permutation_entropy_blocks

    rng = np.random.default_rng(8)
    x = np.round(rng.standard_normal(5000).cumsum(), 0)  # ties, ordered by position
    for order, delay, block in ((6, 1, 1000), (3, 4, 777), (8, 1, 999)):  # 8: 28-bit codes, counted by np.unique
        whole = permutation_entropy(x, order, delay)
        assert permutation_entropy_blocks(lambda lo, hi: x[lo:hi], x.size, order, delay, block=block) == whole
    assert permutation_entropy_blocks(lambda lo, hi: x[lo:hi], x.size, 4, 1, normalize=False, block=64) == permutation_entropy(x, 4, 1, normalize=False)
