"""ICEEMDAN and CEEMDAN: reconstruction, tones, reproducibility, residual noise."""

import numpy as np
import pytest

from gyrocomp.decompose import DecomposeSettings, decompose
from gyrocomp.decompose.ceemdan import ceemdan
from gyrocomp.decompose.emd import Sifting
from gyrocomp.decompose.iceemdan import iceemdan


@pytest.mark.parametrize(
    "method, stop, max_sift",
    [("iceemdan", "fixed", 10), ("ceemdan", "rilling", 2000)],
)
def test_reconstruction_and_tones(method, stop, max_sift, tones, best_correlation):
    """ICEEMDAN under the shipped sifting (10 fixed); CEEMDAN under Torres' (Rilling, emd.m bound 2000).

    CEEMDAN with 10 fixed siftings puts the slow tone in one mode only at
    correlation 0.90: its modes are first IMFs of noisy signals, which
    fixed sifting leaves less converged than ICEEMDAN's local means.

    A statistic over 6 ensemble seeds, not one: measured here, the fast tone's
    best correlation is 0.98-0.994 for both, the slow tone's 0.934-0.979 (median
    0.964) for ICEEMDAN and 0.949-0.985 (median 0.98) for CEEMDAN; one seed
    alone would pass or fail 0.95 by its draw.
    """
    x, (fast, slow) = tones
    settings = DecomposeSettings(method=method, ensemble=10, stop=stop, max_sift=max_sift)
    fast_r, slow_r = [], []
    for seed in range(6):
        d = decompose(x, settings, seed=seed)
        assert d.names[-1] == "residue" and d.names[0] == "imf1"
        assert np.max(np.abs(d.components.sum(0) - x)) <= 1e-9 * np.max(np.abs(x))
        fast_r.append(best_correlation(d.components[:-1], fast))
        slow_r.append(best_correlation(d.components[:-1], slow))
    assert np.median(fast_r) > 0.95 and min(fast_r) > 0.9, np.round(fast_r, 4)
    assert np.median(slow_r) > 0.95 and min(slow_r) > 0.9, np.round(slow_r, 4)


def test_same_bytes_with_one_or_two_workers():
    """Fixed blocks and per-realisation seeds: 1 or 2 processes give the same bytes.

    Exact within one machine (the workers run the same build on the same CPU); another CPU
    or BLAS may differ in the last bits, so no byte value is ever compared across machines.
    """
    x = np.random.default_rng(5).standard_normal(300).cumsum()
    one = iceemdan(x, ensemble=20, seed=9, workers=1, max_imfs=4)
    two = iceemdan(x, ensemble=20, seed=9, workers=2, max_imfs=4)
    assert one.tobytes() == two.tobytes()
    assert iceemdan(x, ensemble=20, seed=10, max_imfs=4).tobytes() != one.tobytes()


def test_less_residual_noise_than_ceemdan():
    """Colominas et al. (2014), section 4: ICEEMDAN's modes carry less residual noise.

    Colominas-style test: a pure tone (period 32 samples, 512 samples).
    The energy outside the tone's mode is residual noise (and spurious
    modes); ICEEMDAN must leave less of it than CEEMDAN under the same
    ensemble (20 realisations, eps_0 = 0.2, same seed) and the paper's
    sifting (Rilling's stop, ``emd.m`` bound 2000). With 10 fixed siftings
    the claim does not hold on this signal (CEEMDAN's leftover is lower).

    Over 8 seeds, not one: measured here, ICEEMDAN leaves 0.0022-0.0087 (mean
    0.0053) and CEEMDAN 0.0026-0.026 (mean 0.0092); ICEEMDAN is lower on 5 of
    the 8 seeds, so a one-seed comparison is nearly a coin toss. What holds is
    the paper's point: ICEEMDAN avoids CEEMDAN's bad realisations (the mean and
    the worst case).
    """
    t = np.arange(512)
    x = np.sin(2 * np.pi * t / 32)

    def leftover(c):
        k = int(np.argmax([abs(np.corrcoef(m, x)[0, 1]) if np.std(m) > 0 else 0 for m in c]))
        return float(np.sum((x - c[k]) ** 2) / np.sum(x ** 2))

    paper = Sifting(stop="rilling", max_sift=2000)
    improved = [leftover(iceemdan(x, ensemble=20, seed=s, sifting=paper)) for s in range(8)]
    original = [leftover(ceemdan(x, ensemble=20, seed=s, sifting=paper)) for s in range(8)]
    assert np.mean(improved) < np.mean(original), (np.round(improved, 4), np.round(original, 4))
    assert max(improved) < max(original), (np.round(improved, 4), np.round(original, 4))


def test_residue_has_few_extrema():
    from gyrocomp.decompose.emd import count_extrema

    for seed in range(4):  # measured over 8 seeds: 0-2 residue extrema, 7-8 modes
        x = np.random.default_rng(2 + seed).standard_normal(512)
        c = iceemdan(x, ensemble=10, seed=seed)
        assert count_extrema(c[-1][None])[0] < 3
        assert abs(c.shape[0] - 1 - np.log2(512)) <= 3  # about log2(N) modes (REFERENCES 2.8)


def test_monotonic_input_is_all_residue():
    x = np.linspace(0.0, 1.0, 100) ** 2
    assert iceemdan(x, ensemble=5).shape == (1, 100)
