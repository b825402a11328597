"""Deterministic bias shapes of the simulator's error model, in physical units.

Each function maps a time axis (and where needed a temperature series) to
one contribution to the gyro's bias, vectorised over the whole recording.
The names follow the effect vocabulary of DESIGN.md ("The simulator and the
sim-to-real gap"): ``thermal_lag`` (:func:`element_temperature`),
``temp_rate`` (:func:`temperature_rate`), ``hysteresis``
(:func:`hysteresis_branch`, :func:`hysteresis_play`), ``warmup``, ``rate_ramp`` and ``periodic``;
the baseline's temperature polynomial is :func:`bias_polynomial`.
`gyrocomp diagnose` fits the same shapes to real recordings.

Units: time in s, temperature in degC, rates and biases in deg/s.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from gyrocomp.errors import InputError

__all__ = [
    "bias_polynomial",
    "element_temperature",
    "temperature_rate",
    "saturating_rate",
    "hysteresis_branch",
    "hysteresis_play",
    "first_excursion",
    "warmup",
    "rate_ramp",
    "periodic",
]


def bias_polynomial(temperature_c, coefficients_dps, reference_c=25.0):
    """Bias polynomial in temperature about a reference temperature.

    ``b(T) = sum_k c_k (T - T_ref)^k`` for k = 1 .. len(coefficients), the
    temperature part of the baseline model of both papers (the constant
    offset is kept apart).

    Parameters
    ----------
    temperature_c : array_like
        Temperature [degC].
    coefficients_dps : sequence of float
        ``c_1, c_2, ...`` in deg/s/degC^k.
    reference_c : float, default=25.0
        ``T_ref`` [degC].

    Returns
    -------
    numpy.ndarray
        Bias [deg/s], 0 at ``T_ref``.

    Examples
    --------
    >>> np.round(bias_polynomial([25.0, 35.0], [1e-3, 1e-5]), 6).tolist()
    [0.0, 0.011]
    """
    dt = np.asarray(temperature_c, dtype=float) - reference_c
    coefficients = np.asarray(coefficients_dps, dtype=float)
    # Horner without the constant term: dt * (c1 + dt * (c2 + dt * c3)).
    acc = np.zeros_like(dt)
    for c in coefficients[::-1]:
        acc = acc * dt + c
    return acc * dt


def element_temperature(time_s, temperature_c, tau_s):
    """Temperature of the sensing element behind a first-order thermal lag.

    Solves ``tau dT_e/dt = T(t) - T_e`` with ``T_e(0) = T(0)`` (the element
    starts in equilibrium), discretised exactly for an input that is linear
    between samples (first-order hold): with ``a = exp(-h/tau)`` and
    ``c = tau (1 - a) / h``,
    ``T_e[k] = a T_e[k-1] + (1 - c) T[k] + (c - a) T[k-1]``,
    one :func:`scipy.signal.lfilter` call. A ramp or a piecewise-linear
    profile sampled at its corners is therefore followed without
    discretisation error.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Uniform time axis [s]; the median interval is used as ``h``.
    temperature_c : array_like, shape (n,)
        Driving (housing or chamber) temperature [degC].
    tau_s : float
        Time constant [s]; 0 returns the input unchanged.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Element temperature [degC].

    Examples
    --------
    >>> t = np.arange(0.0, 5.0)
    >>> np.round(element_temperature(t, [0, 1, 1, 1, 1], 1.0), 4).tolist()
    [0.0, 0.3679, 0.7675, 0.9145, 0.9685]
    """
    time_s, temperature_c = _check_series(time_s, temperature_c)
    if tau_s < 0:
        raise InputError(f"thermal lag: tau_s = {tau_s!r} must be >= 0")
    if tau_s == 0 or temperature_c.size < 2:
        return temperature_c.copy()
    h = _interval(time_s)
    a = np.exp(-h / tau_s)
    c = tau_s * -np.expm1(-h / tau_s) / h
    b = np.array([1.0 - c, c - a])
    den = np.array([1.0, -a])
    zi = signal.lfilter_zi(b, den) * temperature_c[0]
    out, _ = signal.lfilter(b, den, temperature_c, zi=zi)
    return out


def temperature_rate(time_s, temperature_c, smooth_s=0.0):
    """Rate of change of temperature, the regressor of ``temp_rate``.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Time [s].
    temperature_c : array_like, shape (n,)
        Temperature [degC].
    smooth_s : float, default=0.0
        0 takes central differences (:func:`numpy.gradient`), right for a
        noise-free simulated temperature. A positive value fits a
        Savitzky-Golay quadratic over a window of about `smooth_s` seconds
        (:func:`scipy.signal.savgol_filter` with ``deriv=1``), for a
        measured, noisy and quantised temperature.

    Returns
    -------
    numpy.ndarray, shape (n,)
        dT/dt [degC/s].
    """
    time_s, temperature_c = _check_series(time_s, temperature_c)
    if temperature_c.size < 2:
        return np.zeros_like(temperature_c)
    if smooth_s <= 0:
        return np.gradient(temperature_c, time_s)
    h = _interval(time_s)
    window = int(round(smooth_s / h)) | 1
    window = min(max(window, 5), temperature_c.size - (1 - temperature_c.size % 2))
    if window < 3:
        return np.gradient(temperature_c, time_s)
    return signal.savgol_filter(temperature_c, window, min(2, window - 1), deriv=1, delta=h, mode="interp")


def saturating_rate(rate_c_per_s, saturation_c_per_s):
    """A dT/dt sensitivity that saturates: ``s tanh(dT/dt / s)``, the regressor of a saturating ``temp_rate``.

    The gradient across a part grows with the ramp rate until the package's
    heat paths limit it; the response is then linear in dT/dt for slow ramps
    and bounded for fast ones. In units of the rate, so its coefficient is
    the small-ramp sensitivity, the same as a linear term's.

    Parameters
    ----------
    rate_c_per_s : array_like
        dT/dt [degC/s].
    saturation_c_per_s : float
        ``s`` [degC/s] > 0: the rate at which the response is tanh(1) = 76 %
        of the linear one.

    Returns
    -------
    numpy.ndarray
        [degC/s], of the shape of `rate_c_per_s`.

    Examples
    --------
    >>> saturating_rate([0.001, 0.01, 0.1], 0.01).round(5)
    array([0.001  , 0.00762, 0.01   ])
    """
    s = float(saturation_c_per_s)
    if not s > 0:
        raise InputError(f"saturation rate {saturation_c_per_s!r} must be > 0 degC/s")
    return s * np.tanh(np.asarray(rate_c_per_s, dtype=float) / s)


def hysteresis_branch(time_s, temperature_c, deadband_c):
    """Heating (+1) or cooling (-1) branch of a thermal hysteresis.

    The branch switches to cooling when the temperature falls `deadband_c`
    below its highest value since the last switch, and to heating when it
    rises `deadband_c` above its lowest value since then (a play operator of
    width `deadband_c`). Through a soak nothing crosses the deadband, so the
    branch of the last ramp is kept until the direction reverses. Before the
    first excursion beyond the deadband the branch is that of the first
    excursion (+1 when there is none).

    The search runs vectorised from one switch to the next (running maxima
    over geometrically growing windows), so the cost is linear in the length
    and the Python loop runs once per reversal, not per sample.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Time [s] (only checked for shape and order).
    temperature_c : array_like, shape (n,)
        Temperature [degC].
    deadband_c : float
        Width of the play [degC]; choose it above the temperature noise.

    Returns
    -------
    numpy.ndarray of float, shape (n,)
        +1.0 on the heating branch, -1.0 on the cooling branch.

    Examples
    --------
    >>> hysteresis_branch(np.arange(7.0), [20, 22, 24, 24, 23.8, 22, 22], 1.0).tolist()
    [1.0, 1.0, 1.0, 1.0, 1.0, -1.0, -1.0]
    """
    _, temperature = _check_series(time_s, temperature_c)
    if deadband_c < 0:
        raise InputError(f"hysteresis: deadband_c = {deadband_c!r} must be >= 0")
    n = temperature.size
    out = np.empty(n)
    if n == 0:
        return out
    first = first_excursion(temperature, deadband_c)
    state = 1.0 if first == n or temperature[first] > temperature[0] else -1.0
    start = 0
    while start < n:
        switch = _next_reversal(temperature, start, state, deadband_c)
        out[start:switch] = state
        start, state = switch, -state
    return out


def hysteresis_play(time_s, temperature_c, width_c, centred=None):
    """Output in [-1, 1] of a play (backlash) operator of width `width_c`: ``(T - p) / (w / 2)``, ``p`` kept within ``w / 2`` of T.

    After a reversal the output moves linearly from one branch to the other
    over a temperature change of `width_c`, then follows it; through a soak
    it holds. It is the mean of relays whose widths are spread evenly over
    ``[0, w]`` (Preisach; Krasnosel'skii & Pokrovskii [1]), the other limit
    of the two-branch relay :func:`hysteresis_branch`: it switches at the
    same reversals, and between two of them sits
    ``1 - (max T - T) / (w / 2)`` on the heating branch and
    ``-1 + (T - min T) / (w / 2)`` on the cooling one (extremes since the
    switch). Before the first excursion beyond the play
    (:func:`first_excursion`) the state at power-on is not known: the play
    starts centred, ``p = T_0`` (output 0), and from there on an unknown
    start only adds a constant (while the temperature stays within the play).

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Time [s] (only checked for shape and order).
    temperature_c : array_like, shape (n,)
        Temperature [degC].
    width_c : float
        Width of the play [degC] (> 0).
    centred : array_like, shape (n,), optional
        The centred play's output, when a compiled pass has computed it
        (:func:`gyrocomp.effects._stateful.play_start_spread`): taken up to
        the first excursion instead of the loop over those samples here.

    Returns
    -------
    numpy.ndarray of float, shape (n,)

    References
    ----------
    .. [1] M. A. Krasnosel'skii, A. V. Pokrovskii, *Systems with Hysteresis*, Springer (1989), ch. 1.

    Examples
    --------
    >>> hysteresis_play(np.arange(7.0), [20, 20.5, 22, 24, 23, 21, 21], 2.0).tolist()
    [0.0, 0.5, 1.0, 1.0, 0.0, -1.0, -1.0]
    """
    if not width_c > 0:
        raise InputError(f"hysteresis: width_c = {width_c!r} must be > 0")
    branch = hysteresis_branch(time_s, temperature_c, width_c)
    temperature = np.asarray(temperature_c, dtype=float)
    out = np.empty(temperature.size)
    half = 0.5 * width_c
    first = first_excursion(temperature, width_c)
    if centred is None:
        p = temperature[0] if temperature.size else 0.0
        for i in range(first):  # within the play of the power-on temperature: one pass, then the vectorised branches
            p = min(max(p, temperature[i] - half), temperature[i] + half)
            out[i] = (temperature[i] - p) / half
    else:
        out[:first] = centred[:first]
    switches = np.flatnonzero(np.diff(branch[first:])) + 1 + first
    edges = np.concatenate([[first], switches, [temperature.size]]).astype(int)
    for a, b in zip(edges[:-1], edges[1:]):
        if a == b:  # no excursion beyond the play at all
            continue
        seg = temperature[a:b]
        if branch[a] > 0:
            out[a:b] = 1.0 - (np.maximum.accumulate(seg) - seg) / half
        else:
            out[a:b] = -1.0 + (seg - np.minimum.accumulate(seg)) / half
    return out


def first_excursion(temperature_c, deadband_c):
    """Index of the first sample more than `deadband_c` from the power-on temperature (the length when none is).

    Before it a hysteresis has seen no excursion beyond its play, so its
    branch is the one the part was left in before power-on, which the
    recording does not show.

    >>> first_excursion(np.array([20.0, 20.2, 21.5, 23.0]), 1.0), first_excursion(np.array([20.0, 20.2]), 1.0)
    (2, 2)
    """
    temperature = np.asarray(temperature_c, dtype=float)
    beyond = np.flatnonzero(np.abs(temperature - temperature[0]) > deadband_c) if temperature.size else []
    return int(beyond[0]) if len(beyond) else int(temperature.size)


def warmup(time_s, amplitude_dps, tau_s):
    """Exponential power-on transient ``A exp(-(t - t_0) / tau)``.

    Parameters
    ----------
    time_s : array_like
        Time [s]; power-on is the first sample ``t_0``.
    amplitude_dps : float
        ``A``, the bias excess at power-on [deg/s].
    tau_s : float
        Decay time constant [s] (> 0).

    Returns
    -------
    numpy.ndarray
        Bias [deg/s].
    """
    t = np.asarray(time_s, dtype=float)
    if tau_s <= 0:
        raise InputError(f"warmup: tau_s = {tau_s!r} must be > 0")
    return amplitude_dps * np.exp(-(t - t[0]) / tau_s) if t.size else t.copy()


def rate_ramp(time_s, slope_dps_per_s):
    """Bias changing linearly with time since power-on, ``R (t - t_0)``.

    Parameters
    ----------
    time_s : array_like
        Time [s]; power-on is the first sample.
    slope_dps_per_s : float
        ``R`` [deg/s/s]; its Allan signature is ``sigma(tau) = R tau / sqrt(2)``
        (IEEE Std 952, rate ramp).

    Returns
    -------
    numpy.ndarray
        Bias [deg/s].
    """
    t = np.asarray(time_s, dtype=float)
    return slope_dps_per_s * (t - t[0]) if t.size else t.copy()


def periodic(time_s, amplitude_dps, period_s, phase_rad=0.0):
    """Sinusoidal bias interference ``A sin(2 pi t / P + phi)``, unrelated to temperature.

    Parameters
    ----------
    time_s : array_like
        Time [s] (absolute, so the phase refers to t = 0).
    amplitude_dps : float
        ``A`` [deg/s].
    period_s : float
        ``P`` [s] (> 0).
    phase_rad : float, default=0.0
        ``phi`` [rad].

    Returns
    -------
    numpy.ndarray
        Bias [deg/s].
    """
    if period_s <= 0:
        raise InputError(f"periodic: period_s = {period_s!r} must be > 0")
    t = np.asarray(time_s, dtype=float)
    return amplitude_dps * np.sin(2.0 * np.pi * t / period_s + phase_rad)


def _check_series(time_s, values):
    t = np.asarray(time_s, dtype=float)
    x = np.asarray(values, dtype=float)
    if t.ndim != 1 or t.shape != x.shape:
        raise InputError(f"time has shape {t.shape} but the temperature has shape {x.shape}; expected equal 1-D")
    return t, x


def _interval(time_s):
    dt = np.diff(time_s)
    h = float(np.median(dt))
    if not h > 0:
        raise InputError(f"time must increase; median interval {h!r} s")
    return h


def _next_reversal(temperature, start, state, deadband_c, first_window=4096):
    """First index after `start` where the branch `state` reverses (``len`` if never)."""
    n = temperature.size
    window = first_window
    while True:
        stop = min(n, start + window)
        seg = temperature[start:stop]
        if state > 0:
            crossed = np.flatnonzero(seg < np.maximum.accumulate(seg) - deadband_c)
        else:
            crossed = np.flatnonzero(seg > np.minimum.accumulate(seg) + deadband_c)
        if crossed.size:
            return start + int(crossed[0])
        if stop == n:
            return n
        window *= 2
