"""Complete ensemble EMD with adaptive noise (CEEMDAN), Torres et al. (2011).

Kept beside :mod:`~gyrocomp.decompose.iceemdan` so that the comparison of
Colominas et al. (2014) can be made. As the authors' ``ceemdan.m``:

1. ``x`` is divided by its standard deviation (ddof 1).
2. Mode 1 is ``<IMF1(x + eps_0 w_i)>`` ([1]_ eq. (3)), and ``r_1 = x - mode 1``.
3. Mode k+1 is ``<IMF1(r_k + eps_k E_k(w_i))>`` with
   ``eps_k = eps_0 std(r_k)`` ([1]_ eq. (5); ``E_k`` divided by its std
   first with `constant_snr`), and ``r_{k+1} = r_k - mode k+1``.
4. Stop when the residue has fewer than three extrema.

A row with fewer than three extrema has no first IMF (zero), where
``emd.m`` would return the row itself; the stop rule keeps such rows out of
every stage but the noise-free one.

References
----------
.. [1] M. E. Torres, M. A. Colominas, G. Schlotthauer, P. Flandrin, "A
   complete ensemble empirical mode decomposition with adaptive noise",
   Proc. IEEE ICASSP 2011, 4144-4147.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from gyrocomp.decompose.emd import Sifting, count_extrema
from gyrocomp.decompose.iceemdan import Ensemble, _stages

__all__ = ["ceemdan"]


def ceemdan(
    x,
    *,
    ensemble: int = 100,
    noise_strength: float = 0.2,
    constant_snr: bool = False,
    sifting: Sifting = Sifting(),
    max_imfs: int = 30,
    seed: int = 0,
    workers: int = 1,
    callback: Callable[[int, int], None] | None = None,
) -> np.ndarray:
    """CEEMDAN of a 1-D signal; parameters as :func:`~gyrocomp.decompose.iceemdan.iceemdan`.

    Returns
    -------
    ndarray, shape (k + 1, n_samples)
        Modes, fastest first, and the residue last.
    """
    x = np.asarray(x, dtype=float)
    scale = float(np.std(x, ddof=1))
    if count_extrema(x[None])[0] < 3 or scale == 0.0 or max_imfs < 1:
        return x[None].copy()
    with Ensemble(ensemble, x.size, seed, workers, sifting) as noise:
        return _stages(noise, x / scale, scale, noise_strength, constant_snr, max_imfs, ensemble, callback, op="imf")
