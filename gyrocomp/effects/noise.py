"""Gyro rate-noise generators with IEEE Std 952-1997 parameters.

Each generator returns ``n`` samples of rate noise in **deg/s** at the
sample rate `fs_hz`, from the noise term in the unit a datasheet quotes:

=======================  ==================  ===========  ====================
generator                parameter           unit         Allan deviation
=======================  ==================  ===========  ====================
:func:`white`            ARW, ``N``          deg/sqrt(h)  ``N / sqrt(tau)``
:func:`flicker`          bias instab., ``B`` deg/h        floor ``0.664 B``
:func:`markov`           ``B``, ``T_c``      deg/h, s     peak ``0.664 B``
:func:`random_walk`      RRW, ``K``          deg/h/sqrt(h) ``K sqrt(tau / 3)``
=======================  ==================  ===========  ====================

(IEEE Std 952-1997 Annex C; REFERENCES.md 2.2 and 2.9.) Every generator
draws from the :class:`numpy.random.Generator` it is given, so a seed fixes
the bytes.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sp_fft
from scipy import signal

from gyrocomp.allan.ieee952 import DPS_TO_DPH, FLICKER_AVAR, MARKOV_PEAK_AVAR, SQRT_S_PER_SQRT_H
from gyrocomp.errors import InputError

__all__ = ["white", "flicker", "markov", "random_walk", "arw_to_dps_sqrt_s", "rrw_to_dps_per_sqrt_s"]

def arw_to_dps_sqrt_s(arw):
    """Angle random walk from deg/sqrt(h) to deg/s/sqrt(Hz) (= deg/sqrt(s))."""
    return arw / SQRT_S_PER_SQRT_H


def rrw_to_dps_per_sqrt_s(rrw):
    """Rate random walk from deg/h/sqrt(h) to deg/s/sqrt(s)."""
    return rrw / (DPS_TO_DPH * SQRT_S_PER_SQRT_H)


def white(n, fs_hz, arw, rng):
    """White rate noise of angle random walk `arw`.

    The per-sample standard deviation is ``sigma = N sqrt(fs)`` with ``N``
    in deg/sqrt(s), so that the Allan deviation is ``N / sqrt(tau)`` and
    ``sigma(tau = 1 s) = N`` (REFERENCES.md 2.9).

    Parameters
    ----------
    n : int
        Number of samples.
    fs_hz : float
        Sample rate [Hz].
    arw : float
        Angle random walk ``N`` [deg/sqrt(h)].
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray, shape (n,)
        Rate noise [deg/s].
    """
    _check(n, fs_hz, arw, "arw")
    return rng.standard_normal(n) * (arw_to_dps_sqrt_s(arw) * np.sqrt(fs_hz))


def flicker(n, fs_hz, bias_instability, rng):
    """Flicker (1/f) rate noise of bias instability `bias_instability`.

    Spectral synthesis: complex Gaussian Fourier coefficients shaped to the
    power spectral density ``S(f) = B^2 / (2 pi f)`` of IEEE Std 952 (a
    two-sided density, like its ``N^2`` for white noise; one-sided it is
    ``B^2 / (pi f)``) for every frequency from ``fs / m`` to ``fs / 2`` (the
    mean is removed), then one inverse real FFT of the next fast length
    (:func:`scipy.fft.next_fast_len`), truncated to `n` samples. Its Allan variance is
    ``(2 ln 2 / pi) B^2`` for ``2 / fs << tau << n / fs``, so the floor of the
    Allan deviation is ``0.664 B`` and ``B = sigma_min / 0.664``
    (REFERENCES.md 2.2).

    Parameters
    ----------
    n : int
        Number of samples.
    fs_hz : float
        Sample rate [Hz].
    bias_instability : float
        ``B`` [deg/h].
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray, shape (n,)
        Rate noise [deg/s], zero mean over the recording.
    """
    _check(n, fs_hz, bias_instability, "bias_instability")
    if n < 2:
        return np.zeros(n)
    b_dps = bias_instability / DPS_TO_DPH
    m = sp_fft.next_fast_len(n, real=True)
    f = np.fft.rfftfreq(m, d=1.0 / fs_hz)
    amplitude = np.zeros_like(f)
    # One-sided S1(f) = B^2 / (pi f); E|X_k|^2 = S1 fs n / 2 makes the
    # one-sided periodogram 2 |X_k|^2 / (fs n) equal S1 (real and imaginary
    # parts each carry half).
    amplitude[1:] = np.sqrt(b_dps**2 / (np.pi * f[1:]) * fs_hz * m / 4.0)
    coefficients = rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)
    coefficients *= amplitude
    if m % 2 == 0:
        coefficients[-1] = coefficients[-1].real * np.sqrt(2.0)
    series = sp_fft.irfft(coefficients, m)[:n]
    return series - series.mean()


def markov(n, fs_hz, bias_instability, correlation_s, rng):
    """Exponentially correlated (first-order Gauss-Markov) bias of bias instability `bias_instability`.

    The Markov form of the bias instability (:class:`gyrocomp.effects.likelihood.NoiseModel`):
    one process of correlation time ``T_c`` whose Allan deviation peaks at
    ``0.664 B``, the flicker floor of the same ``B`` (IEEE Std 952 Annex C:
    stationary variance ``(2 ln 2 / pi) B^2 / MARKOV_PEAK_AVAR``). Drawn
    exactly as the AR(1) sequence ``x_k = phi x_(k-1) + sqrt(1 - phi^2)
    sigma e_k`` with ``phi = exp(-1 / (fs T_c))``, started stationary.

    Parameters
    ----------
    n : int
    fs_hz : float
    bias_instability : float
        ``B`` [deg/h].
    correlation_s : float
        ``T_c`` [s].
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray, shape (n,)
        Bias wander [deg/s].
    """
    _check(n, fs_hz, bias_instability, "bias_instability")
    if not correlation_s > 0.0:
        raise ValueError(f"correlation_s must be > 0 s, got {correlation_s!r}")
    sigma = bias_instability / DPS_TO_DPH * np.sqrt(FLICKER_AVAR / MARKOV_PEAK_AVAR)
    phi = np.exp(-1.0 / (fs_hz * correlation_s))
    e = rng.standard_normal(n) * (sigma * np.sqrt(-np.expm1(-2.0 / (fs_hz * correlation_s))))
    if n:
        e[0] = sigma * rng.standard_normal()
    return signal.lfilter([1.0], [1.0, -phi], e)


def random_walk(n, fs_hz, rrw, rng):
    """Random walk of the bias with rate random walk `rrw`.

    The cumulative sum of independent increments of standard deviation
    ``K / sqrt(fs)`` (``K`` in deg/s/sqrt(s)), starting from one increment
    at the first sample; its Allan variance is ``K^2 tau / 3`` and
    ``sigma(tau = 3 s) = K`` (REFERENCES.md 2.2, 2.9).

    Parameters
    ----------
    n : int
        Number of samples.
    fs_hz : float
        Sample rate [Hz].
    rrw : float
        Rate random walk ``K`` [deg/h/sqrt(h)].
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray, shape (n,)
        Bias wander [deg/s].
    """
    _check(n, fs_hz, rrw, "rrw")
    steps = rng.standard_normal(n) * (rrw_to_dps_per_sqrt_s(rrw) / np.sqrt(fs_hz))
    return np.cumsum(steps, out=steps)


def _check(n, fs_hz, value, name):
    if int(n) != n or n < 0:
        raise InputError(f"noise: n = {n!r} must be a non-negative integer")
    if not fs_hz > 0:
        raise InputError(f"noise: fs_hz = {fs_hz!r} must be > 0")
    if not value >= 0:
        raise InputError(f"noise: {name} = {value!r} must be >= 0")
