"""An independent generator of oven-test recording pairs, to benchmark `gyrocomp diagnose`.

Written from the physical descriptions of DESIGN.md ("The simulator and the
sim-to-real gap") and the oven tests of the two papers, not from
:mod:`gyrocomp.sim` or :mod:`gyrocomp.diagnose`: it imports neither, and its
temperature profiles, sensor, noise and effect shapes are its own. A pair is
one gyro on two runs of different oven profiles (the fit run climbs or
descends a staircase of soaks; the holdout cycles or ramps slowly, inside
the fit run's temperature range), each 8 h from power-on.

The gyro
--------
rate = offset (per run: turn-on repeatability) + P(T) (cubic about 25 degC)
+ white noise (angle random walk N) + the case's effect, quantised to a tenth
of the per-sample white sigma. T is the housing temperature, a first-order
lag of the chamber air; the recorded temperature is T plus the sensor's white
noise, quantised to its LSB (1/256 or 1/64 degC).

Effects
-------
Every effect of the vocabulary comes in the simulator's simple form
(category ``sim_form``) and two forms real gyros show (``real_form``); eight
effects no vocabulary name describes are ``oov``; ``none`` is the baseline
alone. :data:`FORMS` lists them, with the vocabulary name a correct diagnosis
gives (``expected``).

Amplitudes
----------
A deterministic effect's amplitude comes from its visibility ``z`` on the fit
run, drawn log-uniformly over ``[amplitude] z`` of ``independent.toml``: the
norm of its contribution after least-squares projection on the baseline
(offset + cubic in the recorded temperature), in units of the per-sample white
sigma -- the t-statistic of a regression told the exact shape. ``z`` does not
depend on the sample rate (sum of squares ~ fs, variance ~ fs). A thermal lag
scales the gyro's polynomial instead (the physical knob), capped at a
``max_slope_dps_per_c``; its realised ``z`` is recorded. Noise effects are set
by the timescale at which their Allan deviation meets the white noise's
(flicker: 0.664 B = N / sqrt(tau_c); random walk: K sqrt(tau_c / 3) =
N / sqrt(tau_c)). Changes of the noise itself are set by their ratio.

References
----------
.. [1] IEEE Std 952-1997, Annex C (Allan variance of white, flicker and
       random-walk rate noise; flicker: two-sided PSD S(f) = B^2 / (2 pi f),
       Allan deviation 0.664 B).
.. [2] N. J. Kasdin, "Discrete simulation of colored noise and stochastic
       processes and 1/f^alpha power law noise generation", Proc. IEEE 83(5),
       1995, eq. (116): the fractional-difference filter.
.. [3] I. D. Mayergoyz, *Mathematical Models of Hysteresis*, 1991: the
       Preisach model (a weighted sum of relays) and the play operator.

Usage: ``python benchmarks/independent_gen.py --seed 1 --index 3 --out DIR``
writes ``DIR/fit.parquet``, ``DIR/holdout.parquet`` and ``DIR/truth.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tomllib
from pathlib import Path
from typing import Callable

import numpy as np
from scipy import fft, signal

HERE = Path(__file__).resolve().parent
CONFIG = HERE / "independent.toml"
VOCABULARY = ("thermal_lag", "temp_rate", "hysteresis", "warmup", "rate_ramp", "periodic", "bias_instability", "rate_random_walk")
"""DESIGN.md's effect names (the only thing shared with gyrocomp)."""
TUNING_SEED = 1
"""The default seed, the first the diagnosis was tuned on (benchmarks/README.md, "Seeds")."""
CHECK_SEEDS = (1024, 1025)
"""Seeds nobody has looked at (1001-1019 were check seeds and are spent: the ledger says when)."""


def load_config(path=CONFIG) -> dict:
    """The generator's ranges (``benchmarks/independent.toml``)."""
    with open(path, "rb") as fh:
        return tomllib.load(fh)


# ---------------------------------------------------------------------------
# Physics: thermal paths, hysteresis operators, noise
# ---------------------------------------------------------------------------


def first_order_lag(x, t, tau_s):
    """Output of ``tau dy/dt = x - y`` for `x` sampled at `t`, starting in equilibrium.

    Exact for an input linear between samples (first-order-hold discretisation):
    ``y[n] = a y[n-1] + b0 x[n] + b1 x[n-1]`` with ``a = exp(-dt/tau)``,
    ``b0 = 1 - (tau/dt)(1 - a)``, ``b1 = (tau/dt)(1 - a) - a``.
    """
    dt = float(t[1] - t[0])
    a = np.exp(-dt / tau_s)
    g = tau_s / dt * (1.0 - a)
    b = np.array([1.0 - g, g - a])
    den = np.array([1.0, -a])
    y, _ = signal.lfilter(b, den, x, zi=signal.lfilter_zi(b, den) * x[0])
    return y


def relay_sum(temperature_c, widths_c, initial):
    """Mean of direction relays: each flips to +1 after the temperature rises `w` above its last minimum, to -1 after it falls `w` below its last maximum.

    A relay holds its branch through a soak until the direction reverses by
    more than its width (DESIGN.md's hysteresis); a spread of widths is a
    Preisach-like model [3]. `initial` is each relay's branch at power-on.
    """
    temps = np.asarray(temperature_c, dtype=float).tolist()
    total = np.zeros(len(temps))
    for width, state in zip(np.broadcast_to(widths_c, np.shape(initial)), initial):
        width, state = float(width), float(state)
        anchor = temps[0]
        out = [0.0] * len(temps)
        for i, temp in enumerate(temps):
            if state > 0:
                anchor = max(anchor, temp)
                if temp < anchor - width:
                    state, anchor = -1.0, temp
            else:
                anchor = min(anchor, temp)
                if temp > anchor + width:
                    state, anchor = 1.0, temp
            out[i] = state
        total += out
    return total / len(initial)


def play_operator(temperature_c, width_c, initial):
    """Backlash (play) hysteresis [3]: ``(T - p) / (w / 2)`` in [-1, 1], p following T through a play of ``w``.

    The output moves linearly from one branch to the other over a temperature
    change of `width_c` after each reversal (a relay spread evenly over
    ``[0, w]``). `initial` in [-1, 1] is the power-on branch.
    """
    r = 0.5 * width_c
    p = temperature_c[0] - initial * r
    out = np.empty(temperature_c.size)
    for i, temp in enumerate(temperature_c):
        p = min(max(p, temp - r), temp + r)
        out[i] = (temp - p) / r
    return out


def kasdin_flicker(n, b_dps, rng):
    """Flicker rate noise of bias instability `b_dps` (two-sided PSD S(f) = B^2 / (2 pi f) [1]).

    Fractional differencing of order 1/2 [2]: white w of variance B^2 filtered
    by ``h_0 = 1, h_k = h_{k-1} (k - 1/2) / k`` (``|H|^2 = 1 / (2 sin(pi f dt))``),
    whose two-sided PSD ``var(w) / (2 pi f)`` per Hz does not depend on the
    sample step dt. Its Allan floor is ``0.664 B`` (IEEE 952 writes its PSDs
    two-sided: white rate noise N has S = N^2 and Allan variance N^2 / tau).
    """
    k = np.arange(1, n)
    h = np.concatenate(([1.0], np.cumprod((k - 0.5) / k)))
    w = rng.standard_normal(n) * b_dps
    m = fft.next_fast_len(2 * n, real=True)
    return fft.irfft(fft.rfft(w, m) * fft.rfft(h, m), m)[:n]


def gauss_markov(n, sigma, tau_s, dt, rng):
    """First-order Gauss-Markov process of stationary std `sigma` and correlation time `tau_s` (exact AR(1)), started stationary."""
    phi = np.exp(-dt / tau_s)
    e = rng.standard_normal(n) * sigma * np.sqrt(1.0 - phi**2)
    e[0] = rng.standard_normal() * sigma
    return signal.lfilter([1.0], [1.0, -phi], e)


def telegraph(t, dwell_s, rng):
    """Random telegraph signal in {-1/2, +1/2}: exponential dwell times of mean `dwell_s`, random start state."""
    duration = t[-1] - t[0] + (t[1] - t[0])
    switches = np.cumsum(rng.exponential(dwell_s, size=int(4 * duration / dwell_s) + 16))
    switches = switches[switches < duration]
    start = rng.choice([-0.5, 0.5])
    flips = np.searchsorted(switches, t - t[0], side="right")
    return np.where(flips % 2 == 0, start, -start)


# ---------------------------------------------------------------------------
# Oven profiles
# ---------------------------------------------------------------------------


def _legs_to_knots(room_c, first_soak_s, legs, duration_s):
    """Knots (time, chamber setpoint) from a room-temperature soak and legs (target, ramp degC/min, soak s)."""
    t, temp = [0.0, first_soak_s], [room_c, room_c]
    for target, rate, soak in legs:
        t.append(t[-1] + abs(target - temp[-1]) / rate * 60.0)
        temp.append(target)
        t.append(t[-1] + soak)
        temp.append(target)
    t, temp = np.array(t), np.array(temp)
    if t[-1] < duration_s:
        t, temp = np.append(t, duration_s + 1.0), np.append(temp, temp[-1])
    return t, temp


def staircase(lo, hi, room, rate, step, first_soak, duration_s, descending):
    """Setpoints of a staircase oven test: to one extreme, soaks every `step` degC to the other, back to room.

    The soak length fills the run; below 15 min (or a twentieth of a short run) the steps grow,
    then the ramps quicken up to 10 degC/min.
    """
    tail = min(1200.0, 0.05 * duration_s)
    min_soak = min(900.0, 0.05 * duration_s)
    while True:
        levels = np.arange(hi, lo - 1e-9, -step) if descending else np.arange(lo, hi + 1e-9, step)
        if abs(levels[-1] - (lo if descending else hi)) > 1e-9:
            levels = np.append(levels, lo if descending else hi)
        path = np.concatenate(([room], levels, [room]))
        ramp_s = np.abs(np.diff(path)).sum() / rate * 60.0
        soak = (duration_s - first_soak - ramp_s - tail) / levels.size
        if soak >= min_soak or rate > 10.0:
            break
        if levels.size > 2:
            step *= 1.2  # fewer, longer soaks
        else:
            rate *= 1.2  # two levels left: ramp faster (a short run is cut where it ends)
    soak = max(soak, min_soak)
    legs = [(float(v), rate, soak) for v in levels] + [(room, rate, tail)]
    return _legs_to_knots(room, first_soak, legs, duration_s)


def cycles(lo, hi, room, rate, dwell, first_soak, duration_s, heat_first):
    """Setpoints of thermal cycling between `lo` and `hi` with a dwell at each extreme until the run ends."""
    order = [hi, lo] if heat_first else [lo, hi]
    legs = [(order[i % 2], rate, dwell) for i in range(64)]
    return _legs_to_knots(room, first_soak, legs, duration_s)


def ramp_soak(lo, hi, room, rate, first_soak, duration_s, heat_first):
    """Setpoints of a slow ramp to one extreme, a soak, a slow ramp to the other, a soak, and back to room.

    The ramps take at most three quarters of the run (faster than `rate` if need be).
    """
    a, b = (hi, lo) if heat_first else (lo, hi)
    travel_c = abs(a - room) + abs(b - a) + abs(room - b)
    rate = max(rate, travel_c / (0.75 * (duration_s - first_soak)) * 60.0)  # both extremes within the run
    ramp_s = travel_c / rate * 60.0
    soak = max(600.0, (duration_s - first_soak - ramp_s) / 3.0)
    legs = [(a, rate, soak), (b, rate, soak), (room, rate, soak)]
    return _legs_to_knots(room, first_soak, legs, duration_s)


# ---------------------------------------------------------------------------
# Effect forms
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Form:
    """One form of one effect.

    Attributes
    ----------
    effect, form : str
        The effect (a vocabulary name, or an out-of-vocabulary one) and its form.
    category : str
        ``sim_form``, ``real_form`` or ``oov``.
    kind : str
        ``shape`` (a deterministic bias scaled to the drawn ``z``), ``lag``
        (the polynomial of a lagged element temperature), ``noise`` (an
        additive random bias at its own level) or ``sigma`` (a change of the
        white noise's level).
    spec : dict
        The form's parameters and where their ranges are (:meth:`Draw.params`).
    make : callable(RunState, dict) -> ndarray
        The unit shape (``shape``), the element temperature (``lag``), the
        bias (``noise``) or the white sigma's multiplier (``sigma``).
    """

    effect: str
    form: str
    category: str
    kind: str
    spec: dict
    make: Callable

    @property
    def key(self):
        return f"{self.effect}/{self.form}"

    @property
    def expected(self):
        """The vocabulary names a correct diagnosis selects."""
        return [self.effect] if self.effect in VOCABULARY else []


@dataclasses.dataclass
class RunState:
    """One run as the effects see it: `span_c` is the fit run's setpoint range, `shared_span_c` the holdout's (inside it)."""

    role: str
    t: np.ndarray
    housing_c: np.ndarray
    rate_c_per_s: np.ndarray
    fs_hz: float
    arw: float
    span_c: tuple
    shared_span_c: tuple
    rng: np.random.Generator

    @property
    def duration_s(self):
        return float(self.t[-1] - self.t[0] + 1.0 / self.fs_hz)


class Draw:
    """Draws from the config's ranges: log-uniform when both ends are positive, uniform otherwise."""

    def __init__(self, rng):
        self.rng = rng

    def __call__(self, pair, signed=False):
        lo, hi = pair
        x = np.exp(self.rng.uniform(np.log(lo), np.log(hi))) if lo > 0 and hi > 0 else self.rng.uniform(lo, hi)
        return float(x * self.rng.choice([-1.0, 1.0])) if signed else float(x)

    def sign(self):
        return float(self.rng.choice([-1.0, 1.0]))

    def per_run(self, pair):
        return {"fit": self(pair), "holdout": self(pair)}

    def params(self, spec, cfg):
        """Parameters from a spec ``{name: "section.key"}``: a ``~`` prefix draws one value per run,
        ``^`` takes the inverse half of the time, ``=`` copies the config value."""
        out = {}
        for name, source in spec.items():
            flag = source[0] if source[0] in "~^=" else ""
            section, key = source.lstrip("~^=").split(".")
            value = cfg[section][key]
            if flag == "=":
                out[name] = value
            elif flag == "~":
                out[name] = self.per_run(value)
            else:
                x = self(value)
                out[name] = 1.0 / x if flag == "^" and self.rng.uniform() < 0.5 else x
        return out


def _cycle_fraction(run, p):
    return np.mod(run.t / p["period_s"] + p["phase_rad"][run.role] / (2 * np.pi), 1.0)


def _grid_1s(run, fn):
    """Evaluate a history-dependent operator of the housing temperature on a 1 s grid (temperature moves slowly) and hold it."""
    step = max(1, int(round(run.fs_hz)))
    coarse = fn(run.housing_c[::step])
    return np.repeat(coarse, step)[: run.t.size]


def _noise_level_flicker(run, p):
    """B [deg/s] whose Allan floor 0.664 B meets the white line at ``cross_s``."""
    return run.arw / np.sqrt(p["cross_s"]) / 0.664


def _noise_level_rw(run, p):
    """K [deg/s/sqrt(s)] whose Allan line K sqrt(tau/3) meets the white line at ``cross_s``."""
    return np.sqrt(3.0) * run.arw / p["cross_s"]


_GM_PEAK = 0.437 * np.sqrt(2.0)
"""Peak Allan deviation of a first-order Gauss-Markov process over its stationary std sigma (at tau = 1.89 T_c): 0.437 q sqrt(T_c) with sigma = q sqrt(T_c / 2)."""


def _markov_flicker(run, p):
    sigma = 0.664 * _noise_level_flicker(run, p) / _GM_PEAK
    return gauss_markov(run.t.size, sigma, p["tau_s"], 1.0 / run.fs_hz, run.rng)


def _decade_flicker(run, p):
    sigma = 0.664 * _noise_level_flicker(run, p) / _GM_PEAK / np.sqrt(2.0)
    return sum(gauss_markov(run.t.size, sigma, tau, 1.0 / run.fs_hz, run.rng) for tau in p["taus_s"])


def _random_walk(run, p):
    k = _noise_level_rw(run, p)
    return np.cumsum(run.rng.standard_normal(run.t.size) * k * np.sqrt(1.0 / run.fs_hz))


def _markov_walk(run, p):
    k = _noise_level_rw(run, p)
    return gauss_markov(run.t.size, k * np.sqrt(p["tau_s"] / 2.0), p["tau_s"], 1.0 / run.fs_hz, run.rng)


def _jump_walk(run, p):
    k = _noise_level_rw(run, p)
    rate = p["jumps_per_h"] / 3600.0
    n_jumps = run.rng.poisson(rate * run.duration_s)
    times = np.sort(run.rng.uniform(0.0, run.duration_s, n_jumps))
    sizes = run.rng.standard_normal(n_jumps) * k / np.sqrt(rate)
    level = np.concatenate(([0.0], np.cumsum(sizes)))
    return level[np.searchsorted(times, run.t, side="right")]


def _chirp_shape(run, p):
    T, r = run.duration_s, p["ratio"]
    phase = 2 * np.pi * T / (p["period_s"] * (r - 1.0)) * np.log1p((r - 1.0) * run.t / T)
    return np.sin(phase + p["phase_rad"][run.role])


def _arw_sigma(run, p):
    lo, hi = run.span_c
    return 1.0 + p["growth"] * np.clip((run.housing_c - lo) / (hi - lo), 0.0, 1.0)


def _lagged(r, p, *names):
    return [first_order_lag(r.housing_c, r.t, p[n]) for n in names]


def _relays(r, p):
    lo, hi = sorted([p["narrowest_c"], p["widest_c"]])
    widths = np.geomspace(lo, max(hi, 2.0 * lo), p["relays"])
    initial = np.where(np.linspace(-1, 1, widths.size) < p["initial"][r.role], 1.0, -1.0)
    return _grid_1s(r, lambda x: relay_sum(x, widths, initial))


def _in_shared_span(r, fraction):
    lo, hi = r.shared_span_c
    return lo + fraction * (hi - lo)


def _after(r, p, key="time_fraction"):
    return r.t >= p[key][r.role] * r.duration_s


_PERIODIC = {"period_s": "forms.period_s", "phase_rad": "~forms.phase_rad"}
_WIDTH = {"width_c": "forms.hysteresis_width_c", "initial": "~forms.initial_branch"}

FORMS = {
    f.key: f
    for f in [
        Form("thermal_lag", "first_order", "sim_form", "lag", {"tau_s": "forms.lag_tau_s"},
             lambda r, p: first_order_lag(r.housing_c, r.t, p["tau_s"])),
        Form("thermal_lag", "two_parallel_lags", "real_form", "lag",
             {"fast_tau_s": "forms.lag_fast_tau_s", "slow_tau_s": "forms.lag_slow_tau_s", "fast_weight": "forms.lag_fast_weight"},
             lambda r, p: np.dot([p["fast_weight"], 1 - p["fast_weight"]], _lagged(r, p, "fast_tau_s", "slow_tau_s"))),
        Form("thermal_lag", "two_lags_in_series", "real_form", "lag",
             {"fast_tau_s": "forms.lag_fast_tau_s", "slow_tau_s": "forms.lag_slow_tau_s"},
             lambda r, p: first_order_lag(_lagged(r, p, "fast_tau_s")[0], r.t, p["slow_tau_s"])),
        Form("temp_rate", "linear", "sim_form", "shape", {}, lambda r, p: r.rate_c_per_s),
        Form("temp_rate", "heating_cooling_asymmetric", "real_form", "shape", {"heating_over_cooling": "^forms.rate_asymmetry"},
             lambda r, p: np.where(r.rate_c_per_s > 0, p["heating_over_cooling"], 1.0) * r.rate_c_per_s),
        Form("temp_rate", "saturating", "real_form", "shape", {"half_saturation_c_per_min": "forms.rate_saturation_c_per_min"},
             lambda r, p: np.tanh(r.rate_c_per_s * 60.0 / p["half_saturation_c_per_min"])),
        Form("hysteresis", "two_branch_relay", "sim_form", "shape", _WIDTH,
             lambda r, p: _grid_1s(r, lambda x: relay_sum(x, [p["width_c"]], [1.0 if p["initial"][r.role] >= 0 else -1.0]))),
        Form("hysteresis", "preisach_width_spread", "real_form", "shape",
             {"narrowest_c": "forms.hysteresis_width_c", "widest_c": "forms.hysteresis_width_c", "relays": "=forms.preisach_relays",
              "initial": "~forms.initial_branch"}, _relays),
        Form("hysteresis", "play_operator", "real_form", "shape", _WIDTH,
             lambda r, p: _grid_1s(r, lambda x: play_operator(x, p["width_c"], p["initial"][r.role]))),
        Form("warmup", "single_exponential", "sim_form", "shape", {"tau_s": "forms.warmup_tau_s"}, lambda r, p: np.exp(-r.t / p["tau_s"])),
        Form("warmup", "two_time_constants", "real_form", "shape",
             {"fast_tau_s": "forms.warmup_fast_tau_s", "slow_tau_s": "forms.warmup_slow_tau_s", "fast_weight": "forms.warmup_fast_weight"},
             lambda r, p: p["fast_weight"] * np.exp(-r.t / p["fast_tau_s"]) + (1 - p["fast_weight"]) * np.exp(-r.t / p["slow_tau_s"])),
        Form("warmup", "stretched_exponential", "real_form", "shape", {"tau_s": "forms.warmup_tau_s", "beta": "forms.warmup_stretch"},
             lambda r, p: np.exp(-((r.t / p["tau_s"]) ** p["beta"]))),
        Form("rate_ramp", "linear", "sim_form", "shape", {}, lambda r, p: r.t / r.duration_s),
        Form("rate_ramp", "logarithmic_aging", "real_form", "shape", {"tau_s": "forms.ramp_log_tau_s"},
             lambda r, p: np.log1p(r.t / p["tau_s"])),
        Form("rate_ramp", "power_law", "real_form", "shape", {"power": "^forms.ramp_power"},
             lambda r, p: (r.t / r.duration_s) ** p["power"]),
        Form("periodic", "sinusoid", "sim_form", "shape", _PERIODIC,
             lambda r, p: np.sin(2 * np.pi * r.t / p["period_s"] + p["phase_rad"][r.role])),
        Form("periodic", "square_wave", "real_form", "shape", _PERIODIC | {"duty": "forms.square_duty"},
             lambda r, p: (_cycle_fraction(r, p) < p["duty"]) - p["duty"]),
        Form("periodic", "sawtooth", "real_form", "shape", _PERIODIC, lambda r, p: _cycle_fraction(r, p) - 0.5),
        Form("periodic", "pulse_train", "real_form", "shape", _PERIODIC | {"width": "forms.pulse_width"},
             lambda r, p: (_cycle_fraction(r, p) < p["width"]) - p["width"]),
        Form("bias_instability", "flicker", "sim_form", "noise", {"cross_s": "noise_terms.flicker_cross_s"},
             lambda r, p: kasdin_flicker(r.t.size, _noise_level_flicker(r, p), r.rng)),
        Form("bias_instability", "gauss_markov", "real_form", "noise",
             {"cross_s": "noise_terms.flicker_cross_s", "tau_s": "noise_terms.markov_tau_s"}, _markov_flicker),
        Form("bias_instability", "markov_decades", "real_form", "noise",
             {"cross_s": "noise_terms.flicker_cross_s", "taus_s": "=noise_terms.markov_decades_s"}, _decade_flicker),
        Form("rate_random_walk", "random_walk", "sim_form", "noise", {"cross_s": "noise_terms.random_walk_cross_s"}, _random_walk),
        Form("rate_random_walk", "long_gauss_markov", "real_form", "noise",
             {"cross_s": "noise_terms.random_walk_cross_s", "tau_s": "noise_terms.rw_markov_tau_s"}, _markov_walk),
        Form("rate_random_walk", "compound_poisson_jumps", "real_form", "noise",
             {"cross_s": "noise_terms.random_walk_cross_s", "jumps_per_h": "noise_terms.rw_jump_rate_per_h"}, _jump_walk),
        Form("bias_step", "mode_hop", "oov", "shape", {"time_fraction": "~outside.step_time"}, lambda r, p: _after(r, p) - 0.5),
        Form("drifting_tone", "chirp", "oov", "shape",
             {"period_s": "outside.chirp_period_s", "ratio": "outside.chirp_ratio", "phase_rad": "~forms.phase_rad"}, _chirp_shape),
        Form("transient", "gaussian_bump", "oov", "shape", {"width_s": "outside.transient_width_s", "time_fraction": "~outside.transient_time"},
             lambda r, p: np.exp(-0.5 * ((r.t - p["time_fraction"][r.role] * r.duration_s) / p["width_s"]) ** 2)),
        Form("activity_dip", "gaussian_in_temperature", "oov", "shape",
             {"position": "outside.dip_position", "width_c": "outside.dip_width_c"},
             lambda r, p: np.exp(-0.5 * ((r.housing_c - _in_shared_span(r, p["position"])) / p["width_c"]) ** 2)),
        Form("temperature_jump", "bias_discontinuity", "oov", "shape", {"position": "outside.jump_position"},
             lambda r, p: (r.housing_c >= _in_shared_span(r, p["position"])) - 0.5),
        Form("telegraph_noise", "popcorn", "oov", "shape", {"dwell_s": "outside.telegraph_dwell_s"},
             lambda r, p: telegraph(r.t, p["dwell_s"], r.rng)),
        Form("arw_vs_temperature", "linear_growth", "oov", "sigma", {"growth": "outside.arw_growth"}, _arw_sigma),
        Form("noise_step", "variance_step", "oov", "sigma",
             {"ratio": "outside.variance_step_ratio", "time_fraction": "~outside.variance_step_time"},
             lambda r, p: np.where(_after(r, p), p["ratio"], 1.0)),
    ]
}
"""Every form, keyed ``effect/form``."""
NONE = "none/baseline"


# ---------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------


def case_plan(seed, cfg=None, *, speed_twins=1):
    """The cases of one seed: every form once, four effect-free pairs, and `speed_twins` pairs drawn at 2 Hz and at 100 Hz.

    The speed twins are the same drawn case (same gyro, profiles and effect)
    at the two rates, so their time ratio is the issue's speed figure.
    """
    cfg = cfg or load_config()
    keys = list(FORMS) + [NONE] * 4
    cases = [draw_case(seed, i, key, cfg=cfg) for i, key in enumerate(keys)]
    rng = np.random.default_rng([seed, 7919])
    twins = [NONE] + [k for k in FORMS if FORMS[k].category == "sim_form"]
    for j in range(speed_twins):
        key = twins[0] if j == 0 else twins[int(rng.integers(1, len(twins)))]
        base = draw_case(seed, len(keys) + j, key, cfg=cfg)
        for fs in (2.0, 100.0):
            cases.append(base | {"fs_hz": fs, "twin": len(keys) + j})
    return cases


def draw_case(seed, index, key, cfg=None, *, fs_hz=None, duration_s=None):
    """The hidden truth of one pair: gyro, profiles, sample rate, the effect form and its parameters (JSON)."""
    cfg = cfg or load_config()
    rng = np.random.default_rng([seed, index])
    d = Draw(rng)
    run, tc, gc = cfg["run"], cfg["temperature"], cfg["gyro"]
    if fs_hz is None:
        fs_hz = float(rng.choice(run["rates_hz"], p=np.array(run["rate_weights"]) / np.sum(run["rate_weights"])))
    duration_s = float(duration_s or run["duration_s"])
    lo, hi, room = d(tc["low_c"]), d(tc["high_c"]), d(tc["room_c"])
    inset = [d(tc["holdout_inset"]) * (hi - lo) for _ in range(2)]
    hold_lo, hold_hi = lo + inset[0], hi - inset[1]
    profiles = {
        "fit": {"shape": "staircase", "low_c": lo, "high_c": hi, "room_c": room, "ramp_c_per_min": d(tc["ramp_c_per_min"]),
                "step_c": d(tc["step_c"]), "first_soak_s": d(tc["first_soak_s"]), "descending": bool(rng.uniform() < 0.5)},
        "holdout": {"low_c": hold_lo, "high_c": hold_hi, "room_c": room, "first_soak_s": d(tc["first_soak_s"]),
                    "heat_first": bool(rng.uniform() < 0.5)},
    }
    if rng.uniform() < 0.5:
        profiles["holdout"] |= {"shape": "cycles", "ramp_c_per_min": d(tc["ramp_c_per_min"]), "dwell_s": d(tc["cycle_dwell_s"])}
    else:
        profiles["holdout"] |= {"shape": "ramp_soak", "ramp_c_per_min": d(tc["slow_ramp_c_per_min"])}
    gyro = {
        "arw_deg_per_sqrt_h": d(gc["arw_deg_per_sqrt_h"]),
        "offset_dps": d(gc["offset_dps"]),
        "turn_on_dps": [d(gc["turn_on_dps"]) * d.sign() for _ in range(2)],
        "reference_c": gc["reference_c"],
        "coefficients": [d(gc["c1_dps_per_c"], True), d(gc["c2_dps_per_c2"], True), d(gc["c3_dps_per_c3"], True)],
        "housing_tau_s": d(tc["housing_tau_s"]),
        "sensor_noise_c": d(tc["sensor_noise_c"]),
        "sensor_lsb_c": float(rng.choice(tc["sensor_lsb_c"])),
    }
    case = {
        "seed": seed, "index": index, "key": key, "fs_hz": fs_hz, "duration_s": duration_s,
        "profiles": profiles, "gyro": gyro, "z_target": d(cfg["amplitude"]["z"]),
    }
    if key == NONE:
        return case | {"category": "none", "effect": "none", "form": "baseline", "expected": [], "params": {}}
    form = FORMS[key]
    params = d.params(form.spec, cfg)
    return case | {"category": form.category, "effect": form.effect, "form": form.form, "expected": form.expected,
                   "params": params, "sign": d.sign()}


def chamber(profile, duration_s):
    """Knots (time, setpoint) of a drawn profile."""
    p = profile
    if p["shape"] == "staircase":
        return staircase(p["low_c"], p["high_c"], p["room_c"], p["ramp_c_per_min"], p["step_c"], p["first_soak_s"], duration_s, p["descending"])
    if p["shape"] == "cycles":
        return cycles(p["low_c"], p["high_c"], p["room_c"], p["ramp_c_per_min"], p["dwell_s"], p["first_soak_s"], duration_s, p["heat_first"])
    return ramp_soak(p["low_c"], p["high_c"], p["room_c"], p["ramp_c_per_min"], p["first_soak_s"], duration_s, p["heat_first"])


EXTREME_BRANCH = 1.5
"""A power-on state beyond either end of ``initial_branch``: every relay of a spread on one branch (its threshold
comparison is strict at 1), a play clamped at its end, a relay on the branch of its sign."""


def generate_pair(case, cfg=None, power_on_oracle=False):
    """The fit and holdout recordings of a case, and what was realised.

    With `power_on_oracle`, a hysteresis case's `realised` also holds
    ``power_on_unknown_dps``: on the holdout, the effect less the same effect
    started midway between its two extreme power-on branches (the mean of the
    two). It is what a compensator that knows the form, its width and its
    amplitude exactly, but not the branch the part powered on in, still leaves
    (the midway start is its least-squares guess when the branch is equally
    likely either way): no feed-forward model of the temperature can remove it.

    Returns
    -------
    runs : dict
        ``{"fit": {...}, "holdout": {...}}``, each with ``time`` [s], ``rate``
        [deg/s] and ``temperature`` [degC] arrays.
    realised : dict
        ``z`` (the effect's visibility on the fit run), ``amplitude`` (the
        scale applied to the unit shape, deg/s; for a lag the polynomial's
        scale), noise levels, and each run's temperature span.
    """
    cfg = cfg or load_config()
    g = case["gyro"]
    arw = g["arw_deg_per_sqrt_h"] / 60.0
    sigma = arw * np.sqrt(case["fs_hz"])
    states, measured = {}, {}
    fit_span = (case["profiles"]["fit"]["low_c"], case["profiles"]["fit"]["high_c"])
    shared_span = (case["profiles"]["holdout"]["low_c"], case["profiles"]["holdout"]["high_c"])
    for i, role in enumerate(("fit", "holdout")):
        rng = np.random.default_rng([case["seed"], case["index"], i + 1])
        n = int(round(case["duration_s"] * case["fs_hz"]))
        t = np.arange(n) / case["fs_hz"]
        knots_t, knots_c = chamber(case["profiles"][role], case["duration_s"])
        housing = first_order_lag(np.interp(t, knots_t, knots_c), t, g["housing_tau_s"])
        lsb = g["sensor_lsb_c"]
        measured[role] = np.round((housing + rng.standard_normal(n) * g["sensor_noise_c"]) / lsb) * lsb
        states[role] = RunState(role, t, housing, np.gradient(housing, t), case["fs_hz"], arw, fit_span, shared_span, rng)
    bias = {role: _polynomial(s.housing_c, g) for role, s in states.items()}
    scale = {role: np.ones_like(s.t) for role, s in states.items()}
    realised = {"sigma_per_sample_dps": sigma, "span_c": {r: [float(m.min()), float(m.max())] for r, m in measured.items()}}
    form = FORMS.get(case["key"])
    if form is not None:
        made = {role: form.make(s, case["params"]) for role, s in states.items()}
        if form.kind == "shape":
            a = case["sign"] * case["z_target"] * sigma / _visible_norm(made["fit"], measured["fit"], g)
            for role in bias:
                bias[role] = bias[role] + a * made[role]
            realised |= {"z": case["z_target"], "amplitude": float(a)}
        elif form.kind == "lag":
            s = _lag_scale(made["fit"], states["fit"].housing_c, measured["fit"], g, case["z_target"] * sigma, cfg)
            for role in bias:
                bias[role] = s * _polynomial(made[role], g)
            z = np.linalg.norm(_project_out(s * _polynomial(made["fit"], g), measured["fit"], g)) / sigma
            realised |= {"z": float(z), "amplitude": float(s)}
        elif form.kind == "noise":
            for role in bias:
                bias[role] = bias[role] + made[role]
            level = (_noise_level_flicker if form.effect == "bias_instability" else _noise_level_rw)(states["fit"], case["params"])
            realised |= {"cross_s": case["params"]["cross_s"], "level": float(level)}
        else:
            scale = made
    runs = {}
    for i, (role, s) in enumerate(states.items()):
        rate = g["offset_dps"] + g["turn_on_dps"][i] + bias[role] + s.rng.standard_normal(s.t.size) * sigma * scale[role]
        lsb = cfg["gyro"]["rate_lsb_fraction"] * sigma
        runs[role] = {"time": s.t, "rate": np.round(rate / lsb) * lsb, "temperature": measured[role]}
    if power_on_oracle and form is not None and form.kind == "shape" and "initial" in case["params"]:
        extremes = [form.make(states["holdout"], {**case["params"], "initial": {**case["params"]["initial"], "holdout": branch}})
                    for branch in (-EXTREME_BRANCH, EXTREME_BRANCH)]
        realised["power_on_unknown_dps"] = realised["amplitude"] * (made["holdout"] - 0.5 * (extremes[0] + extremes[1]))
    return runs, realised


def _polynomial(temperature_c, g):
    x = temperature_c - g["reference_c"]
    c1, c2, c3 = g["coefficients"]
    return x * (c1 + x * (c2 + x * c3))


def _baseline_design(measured_c, g):
    x = (measured_c - g["reference_c"]) / 50.0
    return np.column_stack([np.ones_like(x), x, x**2, x**3])


def _project_out(y, measured_c, g):
    """Residual of `y` after least squares on the baseline (offset + cubic in the recorded temperature)."""
    X = _baseline_design(measured_c, g)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return y - X @ coef


def _visible_norm(shape, measured_c, g):
    return float(np.linalg.norm(_project_out(shape, measured_c, g)))


def _lag_scale(element_c, housing_c, measured_c, g, target, cfg):
    """Scale of the gyro's polynomial for which the lagged element's bias has visible norm `target`, capped by the slope limit."""
    norm = _visible_norm(_polynomial(element_c, g), measured_c, g)
    x = np.linspace(housing_c.min(), housing_c.max(), 256) - g["reference_c"]
    c1, c2, c3 = g["coefficients"]
    slope = np.max(np.abs(c1 + 2 * c2 * x + 3 * c3 * x**2))
    return float(min(target / norm, cfg["gyro"]["max_slope_dps_per_c"] / slope))


def write_pair(case, directory, cfg=None, suffix="parquet"):
    """Write ``fit.<suffix>``, ``holdout.<suffix>`` (time, rate, temperature) and ``truth.json`` into `directory`; return the two paths."""
    import pandas as pd

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    runs, realised = generate_pair(case, cfg)
    paths = []
    for role, cols in runs.items():
        path = directory / f"{role}.{suffix}"
        frame = pd.DataFrame(cols)
        if suffix == "csv":
            frame.to_csv(path, index=False, float_format="%.9g")
        else:
            frame.to_parquet(path, index=False)
        paths.append(path)
    (directory / "truth.json").write_text(json.dumps(case | {"realised": realised}, indent=1) + "\n")
    return paths, realised


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=TUNING_SEED)
    parser.add_argument("--index", type=int, default=0, help="case number in the seed's plan")
    parser.add_argument("--format", choices=("parquet", "csv"), default="parquet")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    plan = case_plan(args.seed)
    if not 0 <= args.index < len(plan):
        parser.error(f"--index {args.index}: the plan of seed {args.seed} has cases 0..{len(plan) - 1}")
    case = plan[args.index]
    paths, realised = write_pair(case, args.out, suffix=args.format)
    print(f"{case['key']} ({case['category']}) at {case['fs_hz']:g} Hz -> {', '.join(map(str, paths))}; realised {realised}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
