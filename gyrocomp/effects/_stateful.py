"""The grey-box model's state update (numba): element temperatures, causal dT/dt, play and relay, one sample at a time.

One pass over the samples carries the states, each the exact solution of
its ordinary differential equation (or operator) for a temperature that is
linear between samples (first-order hold), whatever the interval between
them:

* the element temperature ``tau_e dT_e/dt = T - T_e`` (the same
  discretisation as :func:`gyrocomp.effects.shapes.element_temperature`:
  ``T_e <- a T_e + (1 - c) T + (c - a) T_prev``, ``a = exp(-h / tau)``,
  ``c = tau (1 - a) / h``); a second element temperature of another
  time constant likewise, a lag of T (two paths for the heat, in parallel)
  or of ``T_e`` (two stages in series: the die inside the package inside
  the housing; the hold then takes ``T_e`` linear between samples, exact
  to second order in ``h / tau``);
* a filtered temperature of time constant ``tau_r`` in the same way, whose
  derivative ``(T - T_f) / tau_r`` is the causal dT/dt (a first-order
  smoothed derivative: what firmware can compute, with no look-ahead);
* the play operator's centre ``p``, held within ``w / 2`` of T
  (:func:`gyrocomp.effects.shapes.hysteresis_play`); over a linear stretch the
  clamp at its end is exact, the input being monotone between samples; a
  second play of another width likewise (two plays: the first terms of a
  Prandtl-Ishlinskii sum, a spread of widths); the hysteresis may switch on
  ``T_e`` instead of T (the element's own temperature, at its samples);
* or, in its place, a direction relay of width ``w``
  (:func:`gyrocomp.effects.shapes.hysteresis_branch`): +1 once the
  temperature has risen ``w`` above its lowest value since the last switch,
  -1 once it has fallen ``w`` below its highest, 0 before the first such
  excursion (the branch the part was left in before power-on is unknown).

A gap in the time stamps is one long interval: the temperature is bridged
linearly and the states evolve through it (the input, never its rate, is
bridged). The state is a float64 array of :data:`N_STATE` entries, updated
in place, so a recording fed in chunks gives the bytes of the whole file
at once. Imported lazily; numba caches the machine code beside this file.
"""

from __future__ import annotations

import math

import numba
import numpy as np

N_STATE = 11
"""State entries: started flag, previous time, previous temperature, T_e, T_f, play centre, relay branch,
highest and lowest temperature since the relay's last switch, second T_e, second play centre."""


@numba.njit(cache=True, error_model="numpy")
def _weights(h, tau):
    """``(a, c)`` of one first-order-hold step of ``tau dx/dt = T - x`` over `h` seconds (tau 0: ``x = T``, a = c = 0)."""
    if tau <= 0.0:
        return 0.0, 0.0
    return math.exp(-h / tau), tau * -math.expm1(-h / tau) / h


@numba.njit(cache=True, error_model="numpy")
def _hold(state_value, previous, current, a, c):
    """``a x + (1 - c) T + (c - a) T_prev``: one step of the lag with the weights of :func:`_weights`."""
    return a * state_value + (1.0 - c) * current + (c - a) * previous


@numba.njit(cache=True, error_model="numpy")
def _relay(state, T, width):
    """One step of the direction relay of `width` [degC] (state entries 6-8); its branch."""
    if state[6] >= 0.0 and state[7] - T > width:  # fell `width` below the highest: cooling
        state[6] = -1.0
        state[8] = T
    elif state[6] <= 0.0 and T - state[8] > width:  # rose `width` above the lowest: heating
        state[6] = 1.0
        state[7] = T
    state[7] = max(state[7], T)
    state[8] = min(state[8], T)
    return state[6]


@numba.njit(cache=True, error_model="numpy")
def advance(time_s, temperature_c, state, tau_e, tau_r, half_width, relay, tau_e2, series, half_width2, on_element, out):
    """Columns ``T_e``, ``dT/dt``, hysteresis output, second ``T_e``, second play output of each sample into `out` (n, 5);
    `state` updated in place.

    Parameters
    ----------
    time_s, temperature_c : ndarray, shape (n,)
    state : ndarray, shape (N_STATE,)
        Zeros for a cold start: the first sample sets T_e = T_f = p = T
        (the element in equilibrium, no rate, the play centred, the relay's
        branch unknown).
    tau_e, tau_r, tau_e2 : float
        Element, rate-filter and second element time constants [s] (0: no lag).
    half_width : float
        Half the hysteresis width [degC] (0: no hysteresis, output 0).
    relay : bool
        The hysteresis is a relay (output -1, 0, +1) rather than a play
        (output ``(T - p) / (w / 2)`` in [-1, 1]).
    series : bool
        The second element temperature lags ``T_e`` (in series), not T.
    half_width2 : float
        Half the width of a second play [degC] (0: none, output 0).
    on_element : bool
        The hysteresis (and the second play) switch on ``T_e``, not on T.
    out : ndarray, shape (n, 5)
    """
    h_weights = -1.0  # the step the weights below are for: a uniform log computes them once, not per sample
    a_e = c_e = a_r = c_r = a_2 = c_2 = 0.0
    for i in range(time_s.shape[0]):
        t = time_s[i]
        T = temperature_c[i]
        if state[0] == 0.0:
            state[0] = 1.0
            state[3] = T
            state[4] = T
            state[5] = T
            state[6] = 0.0
            state[7] = T
            state[8] = T
            state[9] = T
            state[10] = T
        else:
            h = t - state[1]
            if h != h_weights:
                a_e, c_e = _weights(h, tau_e)
                a_r, c_r = _weights(h, tau_r)
                a_2, c_2 = _weights(h, tau_e2)
                h_weights = h
            previous_e = state[3]
            state[3] = _hold(state[3], state[2], T, a_e, c_e)
            state[4] = _hold(state[4], state[2], T, a_r, c_r)
            if series:
                state[9] = _hold(state[9], previous_e, state[3], a_2, c_2)
            else:
                state[9] = _hold(state[9], state[2], T, a_2, c_2)
        x = state[3] if on_element else T  # the hysteresis' input
        state[5] = min(max(state[5], x - half_width), x + half_width)
        state[10] = min(max(state[10], x - half_width2), x + half_width2)
        state[1] = t
        state[2] = T
        out[i, 0] = state[3]
        out[i, 1] = (T - state[4]) / tau_r
        if half_width <= 0.0:
            out[i, 2] = 0.0
        elif relay:
            out[i, 2] = _relay(state, x, 2.0 * half_width)
        else:
            out[i, 2] = (x - state[5]) / half_width
        out[i, 3] = state[9]
        out[i, 4] = (x - state[10]) / half_width2 if half_width2 > 0.0 else 0.0


@numba.njit(cache=True, error_model="numpy")
def play_start_spread(x, restart, half_width, out):
    """What an unknown power-on state adds to a play's output: the play started on either branch less the play
    started centred (the model's start, :func:`advance`), into `out` (n, 2).

    Column 0 is the play started at ``p = x_0 - w / 2`` (output +1, the
    heating branch), column 1 at ``p = x_0 + w / 2`` (output -1), each less
    the centred play. Both are 0 once the input has moved a whole width one
    way (the three plays then agree), and while no play is clamped they are
    the constants +1 and -1. A start in between is, within a quarter of the
    amplitude, a weighted sum of the two (exact at either branch, and while
    no play is clamped): the start is unknown, so a fit takes both columns
    with free coefficients rather than the one constant that holds only
    while the temperature stays within the play. A third column of `out`,
    if any, takes the centred play's own output ``(x - p) / (w / 2)``
    (:func:`gyrocomp.effects.shapes.hysteresis_play` before the first
    excursion, in this pass).

    Parameters
    ----------
    x : ndarray, shape (n,)
        The play's input (T or ``T_e``) [degC].
    restart : ndarray of bool, shape (n,)
        Samples at which the play restarts centred (the first; after a gap, when gaps are not bridged).
    half_width : float
        Half the play's width [degC] (> 0).
    out : ndarray, shape (n, 2) or (n, 3)
    """
    high = low = centre = 0.0
    for i in range(x.shape[0]):
        v = x[i]
        if restart[i]:
            high, low, centre = v - half_width, v + half_width, v
        high = min(max(high, v - half_width), v + half_width)
        low = min(max(low, v - half_width), v + half_width)
        centre = min(max(centre, v - half_width), v + half_width)
        out[i, 0] = (centre - high) / half_width
        out[i, 1] = (centre - low) / half_width
        if out.shape[1] > 2:
            out[i, 2] = (v - centre) / half_width


def new_state() -> np.ndarray:
    """A cold state (:func:`advance`)."""
    return np.zeros(N_STATE)


@numba.njit(cache=True, error_model="numpy")
def evaluate(raw, time_s, coef, centre, half, lo, hi, power_on_s, tau_w, tau_w2, rate_sat, element, out):
    """The drift [deg/s] of each sample from :func:`advance`'s columns, in one pass (no temporaries).

    ``out = b0 + ((c3 z + c2) z + c1) z + g r + a |r| + h H + l (T_e2 - T_e) / half
    + A exp(-t_on / tau_w) + A2 exp(-t_on / tau_w2) + h2 H2``, ``z = (clip(T_e, lo, hi) - centre) / half``
    (``T_e`` the column `element` of `raw`: 3, the second stage, for two lags in series),
    ``r`` the causal dT/dt or, with ``rate_sat`` > 0, ``rate_sat tanh(dT/dt / rate_sat)``
    (:func:`gyrocomp.effects.shapes.saturating_rate`),
    ``H2`` the second play's output,
    ``coef = (b0, c1, c2, c3, g, a, h, l, A, A2, h2)`` (0 for an absent term; ``tau_w`` 0: no warm-up).

    Parameters
    ----------
    raw : ndarray, shape (n, 5)
        ``T_e``, dT/dt, hysteresis output, second ``T_e``, second play output.
    time_s : ndarray, shape (n,)
    coef : ndarray, shape (11,)
    centre, half, lo, hi : float
        The cubic's scaling and its clamp [degC] (-inf, inf: none).
    power_on_s, tau_w, tau_w2 : float
        Power-on time and warm-up time constants [s].
    rate_sat : float
        Saturation rate of the dT/dt sensitivity [degC/s] (0: linear).
    element : int
        Column of `raw` the cubic is evaluated at: 0 (``T_e``), or 3 (two lags in series; ``l`` is then 0).
    out : ndarray, shape (n,)
    """
    for i in range(time_s.shape[0]):
        te = raw[i, element]
        z = (min(max(te, lo), hi) - centre) / half
        r = raw[i, 1]
        if rate_sat > 0.0:
            r = rate_sat * math.tanh(r / rate_sat)
        value = coef[0] + ((coef[3] * z + coef[2]) * z + coef[1]) * z + coef[4] * r + coef[5] * abs(r) + coef[6] * raw[i, 2]
        value += coef[7] * (raw[i, 3] - te) / half + coef[10] * raw[i, 4]
        if tau_w > 0.0:
            on = time_s[i] - power_on_s
            value += coef[8] * math.exp(-on / tau_w)
            if tau_w2 > 0.0:
                value += coef[9] * math.exp(-on / tau_w2)
        out[i] = value
