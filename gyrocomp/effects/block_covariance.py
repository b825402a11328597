"""Block-mean covariances of the noise terms' Gauss-Markov parts (:mod:`gyrocomp.effects.likelihood`'s ``C_f`` and Markov form).

A first-order Gauss-Markov process averaged over blocks of ``T_b`` seconds
has a closed-form block-mean covariance (:func:`markov_block_covariance`);
flicker is a sum of such processes, three per decade
(:func:`flicker_block_covariance`, Keshner 1982).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.allan.ieee952 import FLICKER_AVAR

__all__ = ["block_lags", "markov_block_covariance", "markov_amplitude", "flicker_block_covariance"]


def block_lags(n_blocks, block_s, centres=None):
    """Distances between blocks in blocks, ``|i - j|`` (with block `centres` [s]: their distance over ``T_b``)."""
    if centres is None:
        return np.abs(np.subtract.outer(np.arange(n_blocks), np.arange(n_blocks))).astype(float)
    return np.abs(np.subtract.outer(centres, centres)) / block_s


def markov_block_covariance(lag, block_s, correlation_s):
    """Block-mean covariance of a unit-variance Gauss-Markov process at block distances `lag` (:func:`block_lags`).

    A process with autocovariance ``exp(-|u| / T)`` has, with ``a = T_b / T``,
    block-mean variance ``2 (a - 1 + e^-a) / a^2`` and covariance
    ``(1 - e^-a)^2 e^-(h-1)a / a^2`` at a lag of ``h >= 1`` blocks.
    """
    a = block_s / correlation_s
    diag = 2.0 * (a - 1.0 + np.exp(-a)) / a**2
    off = (-np.expm1(-a)) ** 2 / a**2 * np.exp(-(np.maximum(lag, 1.0) - 1.0) * a)
    return np.where(lag == 0, diag, off)


def markov_amplitude(block_s, correlation_s):
    """``A`` with :func:`markov_block_covariance` ``= A exp(-|t_i - t_j| / T)`` between distinct blocks (centres ``t``).

    ``(1 - e^-a)^2 e^a / a^2 = (2 sinh(a / 2) / a)^2``, ``a = T_b / T``.
    """
    a = block_s / np.asarray(correlation_s, dtype=float)
    return (2.0 * np.sinh(0.5 * a) / a) ** 2


def flicker_block_covariance(lag, block_s, per_decade=3):
    """Block-mean covariance of unit-``B`` flicker at block distances `lag`, as a sum of Gauss-Markov processes.

    Time constants run three per decade from ``T_b / 10`` to ``L / (2 pi)``:
    the 1/f spectrum is modelled from the recording's lowest frequency
    ``1 / L`` up (as :func:`gyrocomp.effects.noise.flicker` synthesises it), so
    that flicker does not borrow the random walk's power below ``1 / L``
    (``L`` the span the blocks cover). Each process's block-mean covariance
    is :func:`markov_block_covariance`, all of one variance.

    Returns
    -------
    cov : ndarray, shape (n_blocks, n_blocks)
    correlation_s : ndarray
        The processes' time constants ``T`` [s].
    scale : float
        `cov` is `scale` times the sum of the processes' unit covariances.
    """
    n_blocks = lag.shape[0]
    length = (float(lag[0, -1]) + 1.0) * block_s
    exponents = np.arange(
        np.floor(per_decade * np.log10(block_s / 10.0)), np.ceil(per_decade * np.log10(length / (2.0 * np.pi))) + 1
    )
    tcs = 10.0 ** (exponents / per_decade)
    cov = np.zeros((n_blocks, n_blocks))
    for tc in tcs:
        cov += markov_block_covariance(lag, block_s, tc)
    # Allan variance at T_b: var - cov(lag 1), averaged over the blocks.
    avar = np.mean(np.diag(cov)) - np.mean(np.diag(cov, 1)) if n_blocks > 1 else np.mean(np.diag(cov))
    scale = FLICKER_AVAR / avar
    return cov * scale, tcs, scale
