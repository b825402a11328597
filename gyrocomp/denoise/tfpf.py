"""Time-frequency peak filtering (Boashash & Mesbah 2004).

The noisy signal y is scaled into [a, b] cycles/sample, encoded as the
instantaneous frequency of the unit-amplitude analytic signal
z(n) = exp(j 2 pi mu sum y) (Zhang et al. 2024, section 3.3, step 1), and
recovered as the peak over frequency of the pseudo Wigner-Ville
distribution (PWVD) of z (steps 2 and 3). The lag window's length is the
knob: a long window averages the frequency estimate over more samples and
removes more noise, but bends a signal that is not linear over it.

Our discretisation keeps the filter exact for a linear signal: the phase is
the trapezoidal integral of y, so z(n + m) z*(n - m) has phase
2 pi mu * 2m * y(n) for every lag m when y is linear, and the PWVD of a
linear y peaks exactly at 2 mu y(n); the peak is refined from the FFT grid
by Newton steps on the continuous-frequency PWVD. The ends are padded by
point reflection, which also continues a line.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["tfpf"]

_NEWTON_STEPS = 4
"""Newton refinements of the PWVD peak after the FFT grid search."""

_BLOCK = 2048
"""Time instants whose PWVD is computed in one FFT call."""


def tfpf(x, window=101, *, scale=(0.05, 0.45), lag_window="hamming"):
    """Time-frequency peak filtering of a 1-D signal.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Noisy signal y(t) = x(t) + n(t) ([2] eq. (13)), in any unit.
    window : int, default=101
        Length of the PWVD lag window h(tau) in samples ([2] eq. (15)); odd,
        at least 3. Long windows smooth more, short windows preserve more.
    scale : (float, float), default=(0.05, 0.45)
        Range [a, b] the signal is mapped into, in cycles/sample, before
        frequency modulation (mu = 1 per sample). The PWVD sees twice the
        instantaneous frequency, so 0 < a < b < 0.5 keeps it alias-free;
        the margins keep the peak clear of the wrap-around at 0 and 1.
    lag_window : str, default="hamming"
        Shape of h(tau), any name :func:`scipy.signal.get_window` knows
        (symmetric). Tapering lowers the PWVD side lobes that noise can
        push above the true peak.

    Returns
    -------
    ndarray, shape (n_samples,)
        The filtered signal, mapped back to the unit of `x`.

    Raises
    ------
    InputError
        Non-finite or non-1-D `x`, an even or too short `window`, a window
        longer than twice the signal, a `scale` outside 0 < a < b < 0.5, or
        an unknown `lag_window`.

    Notes
    -----
    Steps ([1]; [2] section 3.3):

    1. y_s = a + (b - a) (y - min y) / (max y - min y);
    2. z(n) = exp(j 2 pi phi(n)), phi the trapezoidal cumulative sum of
       y_s (the discrete form of mu times the integral of y, mu = 1);
    3. W(n, f) = sum_m h(m) z(n + m) z*(n - m) exp(-j 2 pi f m),
       m = -M..M, M = (window - 1)/2: real because the kernel is Hermitian
       in m; evaluated on an FFT grid of at least 2 x window points for a
       block of instants at once, then refined to the continuous maximum
       by Newton steps on W(n, f) (maximum-likelihood IF estimate);
    4. y_s(n) estimated as f_peak / 2, and mapped back through step 1.

    A constant signal is returned unchanged.

    References
    ----------
    .. [1] B. Boashash, M. Mesbah, "Signal enhancement by time-frequency peak
       filtering", IEEE Trans. Signal Process. 52, 929 (2004).
    .. [2] Z. Zhang et al., Micromachines 15, 609 (2024), section 3.3.
    """
    from scipy.signal import get_window

    y = np.asarray(x, dtype=float)
    if y.ndim != 1:
        raise InputError(f"tfpf: signal must be 1-D, got shape {y.shape}")
    bad = np.flatnonzero(~np.isfinite(y))
    if bad.size:
        raise InputError(f"tfpf: sample {bad[0]} = {y[bad[0]]!r} is not finite")
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 3 or window % 2 == 0:
        raise InputError(f"tfpf: window = {window!r} must be an odd integer >= 3")
    a, b = (float(v) for v in scale)
    if not 0 < a < b < 0.5:
        raise InputError(f"tfpf: scale = {tuple(scale)!r} must satisfy 0 < a < b < 0.5 (cycles/sample)")
    half = (int(window) - 1) // 2
    if y.size < 2 or half > y.size - 1:
        raise InputError(f"tfpf: {y.size} samples, the window of {window} needs at least {half + 1}")
    try:
        h = get_window(lag_window, int(window), fftbins=False)
    except ValueError as err:
        raise InputError(f"tfpf: lag_window {lag_window!r}: {err}") from None
    low, high = float(y.min()), float(y.max())
    if high == low:
        return y.copy()
    scaled = a + (b - a) * (y - low) / (high - low)
    padded = np.concatenate(
        (2 * scaled[0] - scaled[half:0:-1], scaled, 2 * scaled[-1] - scaled[-2 : -half - 2 : -1])
    )
    phase = np.concatenate(([0.0], np.cumsum(0.5 * (padded[1:] + padded[:-1]))))
    estimate = np.empty(y.size)
    for first in range(0, y.size, _BLOCK):
        centres = np.arange(first, min(first + _BLOCK, y.size)) + half
        estimate[first : first + centres.size] = _peak_frequency(phase, centres, h[half:]) / 2
    return low + (estimate - a) * (high - low) / (b - a)


def _peak_frequency(phase: np.ndarray, centres: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Frequency (cycles/sample) of the PWVD maximum of exp(j 2 pi phase) at each centre.

    `h` holds h(0), h(1), ..., h(M) of the symmetric lag window.
    """
    half = h.size - 1
    lags = np.arange(1, half + 1)
    theta = 2 * np.pi * (phase[centres[:, None] + lags] - phase[centres[:, None] - lags])
    n_fft = 1 << int(np.ceil(np.log2(4 * half + 2)))
    kernel = np.zeros((centres.size, n_fft), dtype=complex)
    kernel[:, 0] = h[0] / 2
    kernel[:, 1 : half + 1] = h[1:] * np.exp(1j * theta)
    spectrum = np.fft.fft(kernel, axis=1).real  # W(n, k / n_fft) / 2
    f = np.argmax(spectrum, axis=1) / n_fft
    w_m = 2 * np.pi * lags
    for _ in range(_NEWTON_STEPS):
        arg = theta - w_m * f[:, None]
        slope = (h[1:] * w_m * np.sin(arg)).sum(axis=1)
        curvature = -(h[1:] * w_m**2 * np.cos(arg)).sum(axis=1)
        step = np.where(curvature < 0, -slope / np.where(curvature < 0, curvature, 1.0), 0.0)
        f = f + np.clip(step, -1.0 / n_fft, 1.0 / n_fft)
    return np.mod(f, 1.0)
