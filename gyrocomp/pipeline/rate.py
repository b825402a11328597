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
  last window (as :func:`scipy.signal.savgol_filter`, ``mode="interp"``).
* ``causal`` (``compensate --mode causal``): the polynomial is evaluated at
  the window's newest sample, so the estimate at time t uses readings up to
  t only: a fixed FIR filter, ``rate[t] = sum_k c[k] T[t - W + 1 + k]``,
  whose coefficients ``c`` (:func:`causal_coefficients`) are stored in
  ``model.json``. For a straight line its slope equals the centred slope
  delayed by ``(W - 1) / 2`` samples. Before the window has filled, it is
  primed with the first reading (the estimate starts at 0 and reaches the
  full slope after one window).

Linear time
-----------
A direct FIR costs W multiplications a sample (60 000 at 1 kHz). Both forms
are computed instead from the window's moments, so the cost per sample does
not depend on W. With ``u_j = (j - kbar) / kbar``, ``kbar = (W - 1) / 2``,
the position of sample ``j = 0 .. W-1`` of the window scaled to [-1, 1], the
least-squares polynomial of order p has coefficients ``G^-1 M`` where
``M_r = sum_j u_j^r T_j`` are the window's moments and ``G_rs = sum_j
u_j^(r+s)``; its derivative at ``u_e`` (1 causal, 0 centred) is therefore
``rate = sum_r a_r M_r`` with ``a = G^-1 g``, ``g_r = r u_e^(r-1) fs / kbar``
(:func:`moment_weights`). Any constant can be taken from T first: a
derivative filter's coefficients sum to zero.

Here the outputs go in rows of W, and the moments of every window of a row
are differences of prefix sums over the 2W - 1 readings the row covers:
every sum starts afresh in each row, so rounding does not grow with the
recording's length, and the cost is about twice that of the sums
themselves. A stream is processed chunk by chunk with the last W - 1
readings carried over (:class:`CausalRate`).

Firmware runs the same thing one sample at a time. For ``polyorder = 1``
(every shipped config) the estimate is ``rate[t] = A * N[t]`` with
``A = 12 fs / (W (W^2 - 1))`` [1/s], ``N[t] = sum_{j<W} (j - kbar) T[t - W + 1 + j]``
and, with ``S[t] = sum_{j<W} T[t - W + 1 + j]``, the recursion

    N[t] = N[t-1] - S[t-1] + kbar T[t] + (kbar + 1) T[t-W]
    S[t] = S[t-1] + T[t] - T[t-W]

State: a ring buffer of the last W readings (primed with the first reading,
so ``N = 0`` and ``S = W T_0`` at start), N and S. Each update adds and
removes, so rounding would random-walk over 10^8 samples; a second pair
``(N', S')`` summed afresh, ``N' += (k - kbar) T[t]``, ``S' += T[t]`` for
``k = 0 .. W-1``, replaces ``(N, S)`` every W samples (it then holds exactly
the current window), which bounds the error to W updates whatever the
recording's length, at O(1) per sample. Taking the first reading from T
(``T - T_0``) keeps the sums small. :func:`describe` stores W, kbar and A.

References
----------
.. [1] A. Savitzky, M. J. E. Golay, "Smoothing and differentiation of data
   by simplified least squares procedures", Anal. Chem. 36, 1627 (1964).
"""

from __future__ import annotations

import math

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.pipeline.settings import RateSettings

__all__ = [
    "CausalRate",
    "temperature_rate",
    "CentredRate",
    "check_temperature",
    "model_inputs",
    "window_samples",
    "causal_coefficients",
    "moment_weights",
    "describe",
]

BLOCK_SAMPLES = 1 << 18
"""Readings summed in one go (rows of 2W - 1 readings; 2 MB per temporary)."""


class CausalRate:
    """The causal estimator over a stream: call it on consecutive chunks of temperature.

    Parameters
    ----------
    settings : RateSettings
    fs_hz : float
        Sample rate [Hz].
    n_samples : int, optional
        Length of the whole recording when known: a window longer than
        the recording shrinks to fit it (:func:`window_samples`).

    Notes
    -----
    The state is the readings since the start of the current row of the
    moment sums (at most 2W - 2, primed with the first one). Rows are laid
    out from the start of the recording whatever the chunks, so chunking
    does not change a single bit of the result.

    Examples
    --------
    >>> estimator = CausalRate(RateSettings(window_s=5.0), 1.0)
    >>> ramp = 20.0 + 0.5 * np.arange(10.0)
    >>> np.round(np.concatenate([estimator(ramp[:3]), estimator(ramp[3:])]), 12)
    array([0.  , 0.1 , 0.25, 0.4 , 0.5 , 0.5 , 0.5 , 0.5 , 0.5 , 0.5 ])
    """

    def __init__(self, settings: RateSettings, fs_hz: float, n_samples: int | None = None):
        self.window = window_samples(settings, fs_hz, n_samples)
        order = min(settings.polyorder, self.window - 1)
        self.weights = moment_weights(self.window, order, fs_hz, self.window - 1)
        self._history = None
        self._emitted = 0

    def __call__(self, temperature_c) -> np.ndarray:
        """Rate [degC/s] at each reading of the chunk, from it and the readings before."""
        temperature = check_temperature(temperature_c, minimum=1)
        w = self.window
        if self._history is None:
            self._history = np.full(w - 1, temperature[0])
        # the primed series P (W - 1 first readings, then the recording): output o reads P[o : o + W];
        # the history is P from the start of the row of the next output on
        first_row = (self._emitted // w) * w
        joined = np.concatenate([self._history, temperature])
        rates = _windowed(joined, w, self.weights)[self._emitted - first_row :]
        self._emitted += len(temperature)
        self._history = joined[(self._emitted // w) * w - first_row :].copy()
        return rates


def temperature_rate(
    temperature_c,
    fs_hz: float,
    settings: RateSettings = RateSettings(),
    *,
    causal: bool = False,
) -> np.ndarray:
    """Estimate dT/dt by a local least-squares polynomial, in O(1) per sample.

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
        Temperature rate [degC/s]; equal to the FIR of
        :func:`causal_coefficients` (causal) or to
        :func:`scipy.signal.savgol_filter` (centred) to rounding.

    Examples
    --------
    >>> t = np.arange(600.0)
    >>> rate = temperature_rate(np.round(0.01 * t * 16) / 16, 1.0)  # 1/16 degC steps
    >>> bool(np.allclose(rate[30:-30], 0.01, atol=1e-3))
    True
    """
    temperature = check_temperature(temperature_c, minimum=2)
    if causal:
        return CausalRate(settings, fs_hz, temperature.size)(temperature)
    return CentredRate(temperature, fs_hz, settings).rows(0, temperature.size)


class CentredRate:
    """The centred estimate of :func:`temperature_rate` over a series, taken a run of samples at a time, bit for bit.

    The moment sums are laid out in rows of W counted from the series'
    start (:func:`_windowed`), and :meth:`rows` sums exactly the rows that
    cover the samples asked for, as for the whole series; so a long
    recording can be taken a run at a time, with temporaries of the run's
    size (training on block means, :func:`gyrocomp.pipeline.train`).

    Parameters
    ----------
    temperature : ndarray, shape (n_samples,)
        The whole series [degC] (checked by :func:`check_temperature`).
    fs_hz : float
    settings : RateSettings
    """

    def __init__(self, temperature: np.ndarray, fs_hz: float, settings: RateSettings):
        self.temperature = temperature
        self.window = window_samples(settings, fs_hz, temperature.size)
        order = min(settings.polyorder, self.window - 1)
        self.weights = moment_weights(self.window, order, fs_hz, self.window // 2)
        # the edges: the derivative of the fit to the first (last) window, as savgol_filter(mode="interp")
        self.edges = [np.polyder(np.polyfit(np.arange(self.window), w, order)) * fs_hz for w in (temperature[: self.window], temperature[-self.window :])]

    def rows(self, start: int, stop: int) -> np.ndarray:
        """Rate [degC/s] at samples ``start .. stop - 1`` (``0 <= start < stop <= n_samples``)."""
        size, n = self.temperature.size, self.window
        half = n // 2
        out = np.empty(stop - start)
        lo, hi = max(start, half), min(stop, size - half)
        if hi > lo:  # output o reads temperature[o : o + n] and sits at sample o + half
            first_row = (lo - half) // n * n
            rates = _windowed(self.temperature[first_row : hi - half + n - 1], n, self.weights)
            out[lo - start : hi - start] = rates[lo - half - first_row :]
        for coefficients, samples, origin in (
            (self.edges[0], np.arange(start, min(stop, half)), 0),
            (self.edges[1], np.arange(max(start, size - half), stop), size - n),
        ):
            if samples.size:
                out[samples - start] = np.polyval(coefficients, samples - origin)
        return out


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

    ``rate[t] = coefficients @ T[t - W + 1 : t + 1]``, ``c_j = sum_r a_r u_j^r``
    (:func:`moment_weights`): the Savitzky-Golay derivative at the newest
    sample, :func:`scipy.signal.savgol_coeffs` with ``pos = W - 1``, computed
    on the centred and scaled positions u (scipy's unscaled Vandermonde
    loses 1e-12 relative at W = 60 001 for a line and 1e-6 for a quartic).
    """
    n = window_samples(settings, fs_hz, n_samples)
    order = min(settings.polyorder, n - 1)
    kbar = (n - 1) / 2.0
    u = (np.arange(n) - kbar) / kbar
    return (u[:, None] ** np.arange(order + 1)) @ moment_weights(n, order, fs_hz, n - 1)


def moment_weights(window: int, order: int, fs_hz: float, position: float) -> np.ndarray:
    """Weights a with ``rate = sum_r a_r M_r``, ``M_r = sum_j u_j^r T_j`` (see the module notes).

    Parameters
    ----------
    window : int
        W, samples in the window.
    order : int
        p, order of the local polynomial.
    fs_hz : float
        Sample rate [Hz].
    position : float
        Sample of the window (0 .. W-1) where the derivative is taken:
        W - 1 causal, (W - 1) / 2 centred.

    Returns
    -------
    ndarray, shape (order + 1,)
        ``G^-1 g`` [1/s].
    """
    kbar = (window - 1) / 2.0
    u = (np.arange(window) - kbar) / kbar
    powers = np.arange(order + 1)
    vandermonde = u[:, None] ** powers
    u_e = (position - kbar) / kbar
    g = np.array([r * u_e ** (r - 1) if r else 0.0 for r in powers]) * fs_hz / kbar
    return np.linalg.solve(vandermonde.T @ vandermonde, g)


def describe(settings: RateSettings, fs_hz: float) -> dict:
    """The estimator as stored in ``model.json``.

    Settings, the window at `fs_hz`, the causal FIR coefficients, and the
    constants of the O(1) recursion (module notes): ``kbar`` and
    ``slope_gain`` A [1/s] for ``polyorder = 1``, the moment weights for any order.
    """
    n = window_samples(settings, fs_hz)
    order = min(settings.polyorder, n - 1)
    kbar = (n - 1) / 2.0
    return {
        "method": settings.method,
        "window_s": settings.window_s,
        "polyorder": settings.polyorder,
        "fs_hz": float(fs_hz),
        "window_samples": n,
        "causal_coefficients": causal_coefficients(settings, fs_hz).tolist(),
        "recursion": {
            "kbar": kbar,
            "slope_gain": 12.0 * float(fs_hz) / (n * (n * n - 1.0)),
            "moment_weights": moment_weights(n, order, fs_hz, n - 1).tolist(),
        },
    }


def check_described(stored: dict, settings: RateSettings, name: str, rtol: float = 1e-9) -> None:
    """Refuse a stored estimator (``model.json`` ``rate_estimator``) whose constants its settings do not give.

    The FIR and recursion constants handed to firmware (:func:`describe`)
    must be what compensation runs: each is recomputed from the settings at
    the stored ``fs_hz`` and compared within `rtol` (relative to the
    largest magnitude of the field).

    Raises
    ------
    InputError
        Naming `name` and the first field that differs.
    """
    from gyrocomp.models._base import check_float

    fs_hz = check_float(f"{name}: rate_estimator", "fs_hz", stored.get("fs_hz"), 0.0, low_open=True)
    expected = describe(settings, fs_hz)
    fields = {
        "window_samples": (stored.get("window_samples"), expected["window_samples"]),
        "causal_coefficients": (stored.get("causal_coefficients"), expected["causal_coefficients"]),
        **{
            f"recursion.{key}": ((stored.get("recursion") or {}).get(key), value)
            for key, value in expected["recursion"].items()
        },
    }
    for field, (have, want) in fields.items():
        try:
            have_a, want_a = np.asarray(have, dtype=float), np.asarray(want, dtype=float)
            same = have_a.shape == want_a.shape and bool(
                np.all(np.abs(have_a - want_a) <= rtol * max(float(np.max(np.abs(want_a), initial=0.0)), 1e-300))
            )
        except (TypeError, ValueError):
            same = False
        if not same:
            raise InputError(
                f"{name}: rate_estimator.{field} is not what window_s = {settings.window_s:g} s, "
                f"polyorder = {settings.polyorder} give at {fs_hz:g} Hz (the model was edited?)"
            )


def check_temperature(temperature_c, minimum: int) -> np.ndarray:
    """`temperature_c` as a finite 1-D float array of at least `minimum` samples (else InputError)."""
    temperature = np.asarray(temperature_c, dtype=float)
    if temperature.ndim != 1 or temperature.size < minimum:
        raise InputError(f"temperature: expected a 1-D series of at least {minimum} samples, got shape {temperature.shape}")
    if not np.isfinite(temperature).all():
        raise InputError("temperature: contains NaN or infinite values")
    return temperature


def _windowed(x: np.ndarray, window: int, weights: np.ndarray) -> np.ndarray:
    """``sum_r a_r M_r`` for each full window of `x` (len(x) - W + 1 outputs).

    The outputs go in rows of W; row k reads the segment of ``L = 2W - 1``
    readings its windows cover, with positions ``v_i = (i - kbar) / kbar``
    about the segment's first window (``|v| <= 3``). Output o of the row
    has ``u = v - o / kbar``, so ``M_r = sum_s C(r, s) (-o / kbar)^(r-s)
    D_s[o]``, where ``D_s[o]``, the sum of ``v^s (T - T_row)`` over the
    window (``T_row`` the row's first reading), is a difference of two
    prefix sums along the row. An output depends on its row's readings up
    to its own, so a row cut short gives the same bits. Rows are taken a
    few at a time (`BLOCK_SAMPLES` readings): the temporaries stay small
    and every sum starts afresh in each row.
    """
    kbar = (window - 1) / 2.0
    order = len(weights) - 1
    n_out = len(x) - window + 1
    if n_out <= 0:
        return np.empty(0)
    length = 2 * window - 1
    v = (np.arange(length) - kbar) / kbar
    d = np.arange(window) / kbar
    gains = [
        sum(weights[r] * math.comb(r, s) * (-d) ** (r - s) for r in range(s, order + 1))
        for s in range(order + 1)
    ]
    out = np.empty(n_out)
    full = n_out // window
    rows = np.lib.stride_tricks.sliding_window_view(x[: full * window + window - 1], length)[::window] if full else x[:0, None]
    tail = x[full * window :]
    if len(tail) >= window:  # the last, partial row: padded with its last reading, the extra outputs dropped
        tail = np.concatenate([tail, np.full(length - len(tail), tail[-1])])[None, :]
    per_group = max(1, BLOCK_SAMPLES // length)
    groups = [rows[k : k + per_group] for k in range(0, full, per_group)]
    if tail.ndim == 2:
        groups.append(tail)
    done = 0
    for segment in groups:
        values = segment - segment[:, :1]
        total = np.zeros((len(segment), window))
        prefix = np.zeros((len(segment), length + 1))
        for s in range(order + 1):
            if s:
                values *= v
            np.cumsum(values, axis=1, out=prefix[:, 1:])
            total += (prefix[:, window:] - prefix[:, :-window]) * gains[s]
        flat = total.ravel()[: n_out - done]
        out[done : done + len(flat)] = flat
        done += len(flat)
    return out
