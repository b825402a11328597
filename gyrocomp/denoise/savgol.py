"""Savitzky-Golay smoothing of the mixed components (Cao et al. 2021, section II-C).

A thin wrapper over :func:`scipy.signal.savgol_filter`: the least-squares
polynomial fit of paper eqs. (17)-(20) over a sliding window of 2N + 1
samples, evaluated at the window's centre.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["savgol"]

MODES = ("interp", "mirror", "nearest", "constant", "wrap")


def savgol(x, window=51, polyorder=3, mode="interp"):
    """Savitzky-Golay smoothing of a 1-D signal.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Signal, in any unit.
    window : int, default=51
        Window length in samples, 2N + 1 in [1] eq. (17); odd, greater than
        `polyorder`, and at most ``len(x)`` in mode ``"interp"``.
    polyorder : int, default=3
        Order n of the fitted polynomial Q(z), [1] eq. (17).
    mode : {"interp", "mirror", "nearest", "constant", "wrap"}, default="interp"
        Edge handling of :func:`scipy.signal.savgol_filter`. ``"interp"``
        fits one polynomial to the first and to the last `window` samples
        and evaluates it there, so no padding is invented; a polynomial of
        degree <= `polyorder` passes unchanged everywhere.

    Returns
    -------
    ndarray, shape (n_samples,)
        The smoothed signal, in the unit of `x`.

    Raises
    ------
    InputError
        Even or too short `window`, `polyorder` >= `window`, unknown `mode`,
        or a signal shorter than `window` in mode ``"interp"``.

    References
    ----------
    .. [1] H. Cao et al., IEEE Access 9, 95180 (2021), eqs. (17)-(20).
    .. [2] A. Savitzky, M. J. E. Golay, Anal. Chem. 36, 1627 (1964).
    """
    from scipy.signal import savgol_filter

    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise InputError(f"savgol: signal must be 1-D, got shape {x.shape}")
    if mode not in MODES:
        raise InputError(f"savgol: unknown mode {mode!r}; choose one of {', '.join(MODES)}")
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1 or window % 2 == 0:
        raise InputError(f"savgol: window = {window!r} must be a positive odd integer")
    if isinstance(polyorder, bool) or not isinstance(polyorder, (int, np.integer)) or not 0 <= polyorder < window:
        raise InputError(f"savgol: polyorder = {polyorder!r} must be an integer in [0, window = {window})")
    if mode == "interp" and x.size < window:
        raise InputError(f"savgol: {x.size} samples, shorter than the window of {window} samples")
    return savgol_filter(x, int(window), int(polyorder), mode=mode)
