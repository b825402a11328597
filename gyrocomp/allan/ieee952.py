"""The IEEE Std 952 gyro noise model: five terms, their Allan variance, spectra and units.

One home for the model that :mod:`gyrocomp.allan` fits, :mod:`gyrocomp.effects.noise`
draws, :mod:`gyrocomp.diagnose` scores and :mod:`gyrocomp.pipeline.evaluate`
reads off. In the library's SI-like units (rate in deg/s, time in s) the
Allan variance of the five terms is ([1]_ eq. (C.16), Table C.1)

    sigma^2(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2

========================  ======  ===============  ==================  ================
term                      symbol  library unit     datasheet unit      factor
========================  ======  ===============  ==================  ================
quantization              Q       deg              deg                 1
angle random walk         N       deg/sqrt(s)      deg/sqrt(h)         60
bias instability          B       deg/s            deg/h               3600
rate random walk          K       deg/s/sqrt(s)    deg/h/sqrt(h)       3600 * 60
rate ramp                 R       deg/s/s          deg/h/h             3600^2
========================  ======  ===============  ==================  ================

(datasheet value = factor x library value). The two-sided rate spectra of
N, B and K are ``N^2``, ``B^2 / (2 pi f)`` and ``K^2 / (2 pi f)^2`` ([1]_
Table C.1), and the flat part of the flicker curve sits at ``sqrt(2 ln 2 /
pi) B = 0.664 B``, which is where the classic read-off takes B.

References
----------
.. [1] IEEE Std 952-1997, "IEEE Standard Specification Format Guide and Test
       Procedure for Single-Axis Interferometric Fiber Optic Gyros", Annex C.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "FLICKER_AVAR",
    "FLICKER_FLOOR",
    "MARKOV_PEAK_AVAR",
    "MARKOV_PEAK_TAU",
    "DPS_TO_DPH",
    "SQRT_S_PER_SQRT_H",
    "TERMS",
    "UNITS",
    "FACTORS",
    "avar_basis",
    "avar",
    "psd_two_sided",
    "markov_avar",
    "to_datasheet",
    "from_datasheet",
]

FLICKER_AVAR = 2.0 * math.log(2.0) / math.pi
"""Allan variance of flicker rate noise per unit B^2, 2 ln 2 / pi ([1]_ Table C.1)."""

FLICKER_FLOOR = math.sqrt(FLICKER_AVAR)
"""sigma_min / B of flicker rate noise, sqrt(2 ln 2 / pi) = 0.6643."""

MARKOV_PEAK_AVAR = 0.38113865810245
"""Largest Allan variance of exponentially correlated (Markov) rate noise per unit stationary variance
(:func:`markov_avar`, reached at ``tau = 1.8926 T_c``): its Allan deviation peaks at ``0.6174 sigma``."""

MARKOV_PEAK_TAU = 1.8926177925018735
"""``tau / T_c`` at which the Allan variance of Markov rate noise peaks."""

DPS_TO_DPH = 3600.0
"""deg/s to deg/h."""

SQRT_S_PER_SQRT_H = 60.0
"""sqrt(3600 s / 1 h): deg/sqrt(s) to deg/sqrt(h)."""

TERMS = ("quantization", "arw", "bias_instability", "rrw", "rate_ramp")
"""The five terms in the order of the Allan-variance model."""

UNITS = {
    "quantization": "deg",
    "arw": "deg/sqrt(h)",
    "bias_instability": "deg/h",
    "rrw": "deg/h/sqrt(h)",
    "rate_ramp": "deg/h/h",
}
"""Datasheet unit of each term."""

FACTORS = {
    "quantization": 1.0,
    "arw": SQRT_S_PER_SQRT_H,
    "bias_instability": DPS_TO_DPH,
    "rrw": DPS_TO_DPH * SQRT_S_PER_SQRT_H,
    "rate_ramp": DPS_TO_DPH**2,
}
"""Datasheet value over library value of each term."""


def avar_basis(tau_s) -> np.ndarray:
    """The Allan variance of each term per unit coefficient squared, shape (n_tau, 5).

    Columns ``3 / tau^2``, ``1 / tau``, ``2 ln 2 / pi``, ``tau / 3``,
    ``tau^2 / 2`` (the order of :data:`TERMS`), tau in seconds.
    """
    t = np.asarray(tau_s, dtype=float)
    return np.column_stack([3.0 / t**2, 1.0 / t, FLICKER_AVAR * np.ones_like(t), t / 3.0, t**2 / 2.0])


def avar(tau_s, quantization=0.0, arw=0.0, bias_instability=0.0, rrw=0.0, rate_ramp=0.0) -> np.ndarray:
    """Allan variance [(deg/s)^2] of the five-term model, coefficients in library units.

    Examples
    --------
    >>> float(avar(1.0, arw=1.0 / 60.0) ** 0.5 * 60.0)  # N = 1 deg/sqrt(h) reads 1 deg/sqrt(h) at 1 s
    1.0
    """
    t = np.asarray(tau_s, dtype=float)
    coefficients = np.array([quantization, arw, bias_instability, rrw, rate_ramp], dtype=float)
    return (avar_basis(t.ravel()) @ coefficients**2).reshape(t.shape)


def psd_two_sided(f_hz, arw=0.0, bias_instability=0.0, rrw=0.0) -> np.ndarray:
    """Two-sided rate spectrum [(deg/s)^2/Hz] of N, B and K at `f_hz` > 0 (library units)."""
    f = np.asarray(f_hz, dtype=float)
    return arw**2 + bias_instability**2 / (2.0 * np.pi * f) + rrw**2 / (2.0 * np.pi * f) ** 2


def markov_avar(tau_s, correlation_s) -> np.ndarray:
    """Allan variance of exponentially correlated (first-order Gauss-Markov) rate noise of unit variance.

    ``2 (T_c / tau) [1 - (T_c / (2 tau)) (3 - 4 e^(-tau/T_c) + e^(-2 tau/T_c))]``
    ([1]_ Table C.1, "exponentially correlated (Markov) noise", written with
    the stationary variance ``sigma^2 = q_c^2 T_c / 2``): ``2 tau / (3 T_c)``,
    a rate random walk's slope, for ``tau << T_c``; ``2 T_c / tau``, a white
    noise's, for ``tau >> T_c``; :data:`MARKOV_PEAK_AVAR` at ``tau = 1.89 T_c``.

    Examples
    --------
    >>> round(float(markov_avar(MARKOV_PEAK_TAU * 100.0, 100.0)), 6) == round(MARKOV_PEAK_AVAR, 6)
    True
    >>> round(float(markov_avar(1e-6, 1.0) / 1e-6), 4)  # 2 / 3 at the short end
    0.6667
    """
    x = np.asarray(tau_s, dtype=float) / correlation_s
    short = x < 1e-3
    xs = np.where(short, 1.0, x)
    long = 2.0 / xs * (1.0 - (-np.expm1(-xs)) * (3.0 - np.exp(-xs)) / (2.0 * xs))
    return np.where(short, 2.0 * x / 3.0 - x * x / 2.0, long)


def to_datasheet(term: str, value):
    """A term's value from library to datasheet units (see the module table)."""
    return value * FACTORS[term]


def from_datasheet(term: str, value):
    """A term's value from datasheet to library units."""
    return value / FACTORS[term]
