"""The temperature rate dT/dt [degC/s] from a noisy, quantised temperature sensor.

Both papers feed their learners "temperature and temperature change rate"
(Cao et al. 2021, section IV-B) without saying how the rate is obtained. A
first difference of a sensor quantised to, say, 1/16 degC at 1 Hz is
mostly quantisation noise (±0.06 degC/s steps on a ramp of 0.003 degC/s),
so gyrocomp estimates the rate as the slope of a least-squares polynomial
fitted over a window of tens of seconds: the Savitzky-Golay derivative [1]_.
For a straight-line fit (``polyorder = 1``) over ``W`` samples the slope's
standard deviation is ``sigma_T * sqrt(12 / (W (W**2 - 1))) * fs`` [degC/s],
with ``sigma_T = q / sqrt(12)`` for a quantisation step ``q``; 60 samples
of a 1/16 degC sensor at 1 Hz give 4e-5 degC/s.

Two forms, with the same window and order:

* ``centred`` (training, and ``compensate --mode full``): the polynomial is
  evaluated at the window's centre; the edges use a fit to the first or
  last window (:func:`scipy.signal.savgol_filter`, ``mode="interp"``).
* ``causal`` (``compensate --mode causal``): the polynomial is evaluated at
  the window's newest sample, so the estimate at time t uses readings up to
  t only: a fixed FIR filter, ``rate[t] = sum_k c[k] T[t - W + 1 + k]``,
  whose coefficients ``c`` (:func:`causal_coefficients`) firmware can run.
  For a straight line its slope equals the centred slope delayed by
  ``(W - 1) / 2`` samples. Before the window has filled, it is primed with
  the first reading (the estimate starts at 0 and reaches the full slope
  after one window).

References
----------
.. [1] A. Savitzky, M. J. E. Golay, "Smoothing and differentiation of data
   by simplified least squares procedures", Anal. Chem. 36, 1627 (1964).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.pipeline.settings import RateSettings

__all__ = ["temperature_rate", "model_inputs", "window_samples", "causal_coefficients", "describe"]


def temperature_rate(
    temperature_c,
    fs_hz: float,
    settings: RateSettings = RateSettings(),
    *,
    causal: bool = False,
) -> np.ndarray:
    """Estimate dT/dt by a local least-squares polynomial.

    Parameters
    ----------
    temperature_c : array_like, shape (n_samples,)
        Measured temperature [degC], uniformly sampled.
    fs_hz : float
        Sample rate [Hz].
    settings : RateSettings
        Window length [s] and polynomial order.
    causal : bool, default=False
        Use only past and present readings (see the module notes).

    Returns
    -------
    ndarray, shape (n_samples,)
        Temperature rate [degC/s].

    Examples
    --------
    >>> t = np.arange(600.0)
    >>> rate = temperature_rate(np.round(0.01 * t * 16) / 16, 1.0)  # 1/16 degC steps
    >>> bool(np.allclose(rate[30:-30], 0.01, atol=1e-3))
    True
    """
    temperature = np.asarray(temperature_c, dtype=float)
    if temperature.ndim != 1 or temperature.size < 2:
        raise InputError(f"temperature: expected a 1-D series of at least 2 samples, got shape {temperature.shape}")
    if not np.isfinite(temperature).all():
        raise InputError("temperature: contains NaN or infinite values")
    n = window_samples(settings, fs_hz, temperature.size)
    order = min(settings.polyorder, n - 1)
    if causal:
        coefficients = causal_coefficients(settings, fs_hz, temperature.size)
        primed = np.concatenate([np.full(n - 1, temperature[0]), temperature])
        return np.convolve(primed, coefficients[::-1], mode="valid")
    from scipy.signal import savgol_filter

    return savgol_filter(temperature, n, order, deriv=1, delta=1.0 / fs_hz, mode="interp")


def model_inputs(temperature_c, fs_hz: float, settings: RateSettings = RateSettings(), *, causal: bool = False) -> np.ndarray:
    """The learners' inputs: columns [temperature degC, temperature rate degC/s].

    Returns
    -------
    ndarray, shape (n_samples, 2)
    """
    temperature = np.asarray(temperature_c, dtype=float)
    return np.column_stack([temperature, temperature_rate(temperature, fs_hz, settings, causal=causal)])


def window_samples(settings: RateSettings, fs_hz: float, n_samples: int | None = None) -> int:
    """Odd window length in samples: ``window_s * fs_hz`` rounded to odd, shrunk to fit the recording."""
    if not fs_hz > 0:
        raise InputError(f"sample rate {fs_hz!r} Hz must be > 0")
    n = int(round(settings.window_s * fs_hz))
    n = max(n, settings.polyorder + 2)
    if n % 2 == 0:
        n += 1
    if n_samples is not None and n > n_samples:
        n = n_samples if n_samples % 2 else n_samples - 1
    if n < 2:
        raise InputError(f"temperature rate: a window of {n} sample(s) cannot give a slope")
    return n


def causal_coefficients(settings: RateSettings, fs_hz: float, n_samples: int | None = None) -> np.ndarray:
    """FIR coefficients of the causal estimator, oldest sample first [1/s].

    ``rate[t] = coefficients @ T[t - W + 1 : t + 1]``.
    """
    from scipy.signal import savgol_coeffs

    n = window_samples(settings, fs_hz, n_samples)
    order = min(settings.polyorder, n - 1)
    return savgol_coeffs(n, order, deriv=1, delta=1.0 / fs_hz, pos=n - 1, use="dot")


def describe(settings: RateSettings, fs_hz: float) -> dict:
    """The estimator as stored in ``model.json``: settings, window at `fs_hz`, causal FIR coefficients."""
    return {
        "method": settings.method,
        "window_s": settings.window_s,
        "polyorder": settings.polyorder,
        "fs_hz": float(fs_hz),
        "window_samples": window_samples(settings, fs_hz),
        "causal_coefficients": causal_coefficients(settings, fs_hz).tolist(),
    }
