"""Test signals of the decomposition tests."""

import numpy as np
import pytest


@pytest.fixture
def tones():
    """Two tones (periods 16 and 128 samples, an octave-band apart) on a linear trend, 1500 samples."""
    t = np.arange(1500)
    fast = np.sin(2 * np.pi * t / 16)
    slow = np.sin(2 * np.pi * t / 128)
    return fast + slow + t / t.size, (fast, slow)


@pytest.fixture
def best_correlation():
    """Largest |correlation| of a tone with one of the components."""

    def best(components, tone):
        return max(abs(np.corrcoef(c, tone)[0, 1]) for c in components if np.std(c) > 0)

    return best
