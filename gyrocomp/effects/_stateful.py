"""The grey-box model's state update (numba): element temperature, causal dT/dt and play, one sample at a time.

One pass over the samples carries four states, each the exact solution of
its ordinary differential equation for a temperature that is linear
between samples (first-order hold), whatever the interval between them:

* the element temperature ``tau_e dT_e/dt = T - T_e`` (the same
  discretisation as :func:`gyrocomp.effects.shapes.element_temperature`:
  ``T_e <- a T_e + (1 - c) T + (c - a) T_prev``, ``a = exp(-h / tau)``,
  ``c = tau (1 - a) / h``);
* a filtered temperature of time constant ``tau_r`` in the same way, whose
  derivative ``(T - T_f) / tau_r`` is the causal dT/dt (a first-order
  smoothed derivative: what firmware can compute, with no look-ahead);
* the play operator's centre ``p``, held within ``w / 2`` of T
  (:func:`gyrocomp.effects.shapes.hysteresis_play`); over a linear stretch the
  clamp at its end is exact, the input being monotone between samples.

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

N_STATE = 6
"""State entries: started flag, previous time, previous temperature, T_e, T_f, play centre."""


@numba.njit(cache=True, error_model="numpy")
def _hold(state_value, previous, current, h, tau):
    """One first-order-hold step of ``tau dx/dt = T - x`` over `h` seconds (tau 0: x = T)."""
    if tau <= 0.0:
        return current
    a = math.exp(-h / tau)
    c = tau * -math.expm1(-h / tau) / h
    return a * state_value + (1.0 - c) * current + (c - a) * previous


@numba.njit(cache=True, error_model="numpy")
def advance(time_s, temperature_c, state, tau_e, tau_r, half_width, out):
    """Columns ``T_e``, ``dT/dt``, play output of each sample into `out` (n, 3); `state` updated in place.

    Parameters
    ----------
    time_s, temperature_c : ndarray, shape (n,)
    state : ndarray, shape (N_STATE,)
        Zeros for a cold start: the first sample sets T_e = T_f = p = T
        (the element in equilibrium, no rate, the play centred).
    tau_e, tau_r : float
        Element and rate-filter time constants [s] (tau_e 0: no lag).
    half_width : float
        Half the play's width [degC] (0: no play, output 0).
    out : ndarray, shape (n, 3)
    """
    for i in range(time_s.shape[0]):
        t = time_s[i]
        T = temperature_c[i]
        if state[0] == 0.0:
            state[0] = 1.0
            state[3] = T
            state[4] = T
            state[5] = T
        else:
            h = t - state[1]
            state[3] = _hold(state[3], state[2], T, h, tau_e)
            state[4] = _hold(state[4], state[2], T, h, tau_r)
            state[5] = min(max(state[5], T - half_width), T + half_width)
        state[1] = t
        state[2] = T
        out[i, 0] = state[3]
        out[i, 1] = (T - state[4]) / tau_r
        out[i, 2] = (T - state[5]) / half_width if half_width > 0.0 else 0.0


def new_state() -> np.ndarray:
    """A cold state (:func:`advance`)."""
    return np.zeros(N_STATE)
