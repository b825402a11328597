"""A causal grey-box model of the bias: element-temperature lag, a cubic, heating/cooling dT/dt, a play hysteresis, a warm-up.

Every static map (the autopilots' cubic, the papers' learned maps of
(T, dT/dt)) forgets that a gyro has state: its sensing element lags the
temperature sensor, it keeps a heating or a cooling branch, it settles
after power-on. This model carries that state, one sample at a time, with
the effect shapes of the vocabulary (:mod:`gyrocomp.effects.vocabulary`):

.. math::

    b(t) = b_0 + \\sum_{k=1}^{3} c_k z^k + g\\,\\dot T + a\\,|\\dot T| + h\\,P_w(T) + A\\,e^{-t_{on}/\\tau_w},
    \\qquad z = (T_e - T_c) / T_h,\\quad \\tau_e \\dot T_e = T - T_e

* ``thermal_lag``: the cubic is evaluated at the element temperature
  ``T_e``, a first-order lag of the measured temperature (``tau_e``);
* ``temp_rate``: a dT/dt sensitivity ``g``, or heating and cooling apart
  (``g + a`` heating, ``g - a`` cooling), with the causal dT/dt of a
  first-order filter whose time constant ``tau_r`` is fitted too (within
  ``rate_tau_s``): the gradient across the part lags the sensor, and a
  fixed filter's delay at the corners of a ramp costs more than its
  smoothing gains (:mod:`gyrocomp.effects._stateful`);
* ``hysteresis``: a play operator of width ``w`` (its output ``P_w`` in
  [-1, 1], :func:`gyrocomp.effects.shapes.hysteresis_play`) with its branch state;
* ``warmup``: ``A exp(-t_on / tau_w)``, ``t_on`` the time since power-on
  (the recording's first sample unless told otherwise).

**Which terms.** One criterion, the one ``gyrocomp diagnose`` uses: the
BIC of the block means under a white + random-walk + flicker noise model
(:mod:`gyrocomp.effects.likelihood`), the deterministic coefficients
shared by the training runs and an offset per run; forward selection adds
the term (and nonlinear parameter, on its grid) that lowers the BIC most,
while it lowers it by more than ``bic_margin``. A term is only tried at
the parameters where the training runs identify it
(:func:`gyrocomp.identifiability.separable` against the terms already in):
dT/dt in a single exponential warm-up, a hysteresis whose branch never
changes, a warm-up on a log that does not start at power-on are never
fitted, and :attr:`not_fitted_` says why.

**Several runs and gaps.** The runs' likelihoods add (independent noise
realisations); each run gets its own offset and, for the hysteresis, its
own power-on branch (unknown before the first excursion beyond the play).
Across a gap within a run the states evolve with the temperature bridged
linearly (``bridge_gaps``), so a bursty log still shows a lag or a branch;
``bridge_gaps=False`` restarts them after each gap instead.

**Compensation** (:meth:`GreyBoxDrift.stream`) is O(1) per sample: the
state is a few floats, updated in place, so chunks give the bytes of the
whole file. The offset is the mean of the training runs' offsets (a
turn-on bias the next run does not share).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy import linalg, optimize

from gyrocomp.errors import InputError
from gyrocomp.effects.shapes import first_excursion, hysteresis_branch
from gyrocomp.identifiability import Refusal, separable

__all__ = ["GreyBoxDrift", "GreyBoxStream", "TrainingRun", "TERMS"]

TERMS = ("thermal_lag", "temp_rate", "hysteresis", "warmup")
"""The model's optional terms, by their vocabulary names, in the order they are judged."""

VERSION = 1

RATE_GRID_POINTS = 6
"""Points of the log grid of the dT/dt filter's time constant (then refined)."""

SETTLE_TAUS = 5.0
"""The causal dT/dt starts at 0 (the filter cold); the first ``SETTLE_TAUS * rate_tau_s[1]`` seconds of a run
(of every segment when gaps are not bridged) take no part in the fit, so its settling is never read as an effect
(e^-5: under 1 % of the true rate is missing after them)."""


@dataclasses.dataclass(frozen=True)
class TrainingRun:
    """One training recording of one axis.

    Attributes
    ----------
    time_s, temperature_c, rate : ndarray, shape (n,)
    segments : list of slice
        Gap-free row ranges (one for a contiguous run).
    power_on_s : float or None
        Time of power-on on the run's clock [s]; None: unknown (the warm-up
        is then not identifiable from this run).
    name : str
    """

    time_s: np.ndarray
    temperature_c: np.ndarray
    rate: np.ndarray
    segments: list
    power_on_s: float | None
    name: str = "run"


@dataclasses.dataclass(frozen=True)
class _Spec:
    """Nonlinear parameters of a model: 0 or None means the term is absent."""

    tau_e: float = 0.0
    rate_form: int = 0  # 0 none, 1 one sensitivity, 2 heating and cooling apart
    width: float = 0.0
    tau_w: float = 0.0
    tau_r: float = 0.0  # the dT/dt filter's time constant, with rate_form

    def terms(self) -> list[str]:
        present = (self.tau_e > 0, self.rate_form > 0, self.width > 0, self.tau_w > 0)
        return [t for t, on in zip(TERMS, present) if on]

    def n_nonlinear(self) -> int:
        return int(self.tau_e > 0) + int(self.width > 0) + int(self.tau_w > 0) + int(self.rate_form > 0)


class GreyBoxDrift:
    """Causal grey-box drift model, fitted by the diagnosis' criterion on several runs.

    Parameters
    ----------
    degree : int, default=3
        Powers of the element temperature.
    reference_temperature : float, default=25.0
        T_ref [degC] of the reported polynomial (``coef_about_reference_``).
    rate_tau_s : tuple of float, default=(10.0, 60.0)
        (low, high) of the time constant of the causal dT/dt filter [s],
        fitted with the dT/dt term (a log grid, then refined).
    terms : tuple of str
        Candidate terms, a subset of :data:`TERMS`.
    lag_tau_s, warmup_tau_s : tuple of float
        (low, high) of the log grids of ``tau_e`` and ``tau_w`` [s].
    grid_points : int
        Points of each log grid.
    widths_c : tuple of float
        Grid of the play's width [degC].
    block_s : float
        Shortest likelihood block [s].
    max_blocks : int
        Most blocks a run is cut into (longer runs get longer blocks).
    bic_margin : float
        BIC drop a term must bring to be added.
    min_unique_variance : float
        Identifiability cut-off (:func:`gyrocomp.identifiability.separable`).
    bridge_gaps : bool
        Carry the state across a gap with the temperature bridged linearly.
    selection : {"bic", "all"}
        ``bic``: a term is added while it lowers the BIC by more than
        ``bic_margin``; ``all``: every identifiable term of `terms` is
        fitted (the terms were chosen elsewhere: ``diagnose --model-out``).

    Attributes
    ----------
    spec_ : dict
        ``tau_e_s``, ``rate_form`` (0, 1, 2), ``width_c``, ``tau_w_s``.
    coef_ : dict of str to float
        Column coefficients [deg/s per column unit]: ``z1..z3``, ``rate``,
        ``rate_abs``, ``play``, ``warmup``.
    offset_ : float
        Offset applied in compensation (mean of the runs' offsets) [deg/s].
    run_offsets_ : list of float
    centre_c_, half_range_c_ : float
        ``z = (T_e - centre) / half_range``, fixed on the training runs.
    temperature_range_c_, rate_range_c_per_s_ : list of float
        Training ranges of T_e and of the causal dT/dt.
    selection_ : list of dict
        Each forward step: the term, its parameters and the BIC drop.
    not_fitted_ : list of dict
        Terms the training runs cannot identify, with the reason.
    noise_ : dict
        The fitted noise terms (arw, bias_instability, rate_random_walk).
    """

    kind = "greybox"

    def __init__(
        self,
        degree=3,
        reference_temperature=25.0,
        rate_tau_s=(10.0, 60.0),
        terms=TERMS,
        lag_tau_s=(10.0, 14400.0),
        warmup_tau_s=(60.0, 14400.0),
        grid_points=25,
        widths_c=(0.5, 1.0, 2.0, 4.0, 8.0, 16.0),
        block_s=10.0,
        max_blocks=360,
        bic_margin=10.0,
        min_unique_variance=0.01,
        bridge_gaps=True,
        selection="bic",
    ):
        self.degree = degree
        self.reference_temperature = reference_temperature
        self.rate_tau_s = rate_tau_s
        self.terms = terms
        self.lag_tau_s = lag_tau_s
        self.warmup_tau_s = warmup_tau_s
        self.grid_points = grid_points
        self.widths_c = widths_c
        self.block_s = block_s
        self.max_blocks = max_blocks
        self.bic_margin = bic_margin
        self.min_unique_variance = min_unique_variance
        self.bridge_gaps = bridge_gaps
        self.selection = selection

    # --- contract -----------------------------------------------------------
    @classmethod
    def _param_names(cls) -> list[str]:
        import inspect

        return [p for p in inspect.signature(cls.__init__).parameters if p != "self"]

    def get_params(self, deep: bool = True) -> dict:
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params) -> "GreyBoxDrift":
        for name, value in params.items():
            if name not in self._param_names():
                raise InputError(f"GreyBoxDrift: unknown parameter {name!r}; known: {', '.join(self._param_names())}")
            setattr(self, name, value)
        return self

    def _check_params(self) -> None:
        owner = "GreyBoxDrift"
        if not (isinstance(self.degree, int) and 1 <= self.degree <= 3):
            raise InputError(f"{owner}: degree = {self.degree!r} must be 1, 2 or 3")
        unknown = [t for t in self.terms if t not in TERMS]
        if unknown:
            raise InputError(f"{owner}: unknown term(s) {', '.join(map(str, unknown))}; known: {', '.join(TERMS)}")
        for name in ("block_s", "bic_margin"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < math.inf:
                raise InputError(f"{owner}: {name} = {value!r} must be a finite number > 0")
        for name in ("lag_tau_s", "warmup_tau_s", "rate_tau_s"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi < math.inf:
                raise InputError(f"{owner}: {name} = {getattr(self, name)!r} must be (low, high) with 0 < low <= high")
        if self.selection not in ("bic", "all"):
            raise InputError(f"{owner}: selection = {self.selection!r}; choose bic or all")
        if not all(0 < w < math.inf for w in self.widths_c):
            raise InputError(f"{owner}: widths_c = {self.widths_c!r} must be finite widths > 0 degC")
        if not (isinstance(self.max_blocks, int) and self.max_blocks >= 16 and isinstance(self.grid_points, int) and self.grid_points >= 2):
            raise InputError(f"{owner}: max_blocks >= 16 and grid_points >= 2 (integers), got {self.max_blocks!r}, {self.grid_points!r}")

    # --- fitting ------------------------------------------------------------
    def fit(self, runs: list) -> "GreyBoxDrift":
        """Choose the terms and fit their coefficients on the training runs.

        Parameters
        ----------
        runs : list of TrainingRun
            One or more runs of one axis of one gyro.

        Returns
        -------
        self
        """
        self._check_params()
        if not runs:
            raise InputError("GreyBoxDrift: no training run")
        temperatures = np.concatenate([r.temperature_c for r in runs])
        lo, hi = float(temperatures.min()), float(temperatures.max())
        self.centre_c_, self.half_range_c_ = 0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-3)
        from threadpoolctl import threadpool_limits

        prepared = [_Prepared.of(run, self) for run in runs]
        with threadpool_limits(limits=1, user_api="blas"):  # small factorisations: threads only contend
            search = _Search(self, prepared)
            spec, self.selection_, self.not_fitted_ = search.run()
            beta, names, noise = search.final(spec)
        self.spec_ = {"tau_e_s": spec.tau_e, "rate_form": spec.rate_form, "width_c": spec.width, "tau_w_s": spec.tau_w, "rate_tau_s": spec.tau_r}
        n_runs = len(prepared)
        self.run_offsets_ = [float(b) for b in beta[:n_runs]]
        weights = np.array([p.duration_s for p in prepared])
        self.offset_ = float(np.average(self.run_offsets_, weights=weights))
        self.coef_ = {name: float(b) for name, b in zip(names, beta) if not name.startswith(("offset", "power_on"))}
        self.noise_ = {"arw": noise[0], "bias_instability": noise[1], "rate_random_walk": noise[2]}
        ranges = [p.ranges(self, spec) for p in prepared]
        self.temperature_range_c_ = [min(r[0] for r in ranges), max(r[1] for r in ranges)]
        self.rate_range_c_per_s_ = [min(r[2] for r in ranges), max(r[3] for r in ranges)]
        self.coef_about_reference_ = self._about_reference()
        return self

    def _about_reference(self) -> list:
        """c_0..c_degree of the cubic in (T_e - T_ref) [deg/s per degC^k], the offset in c_0."""
        z_coef = [self.offset_] + [self.coef_.get(f"z{k}", 0.0) for k in range(1, self.degree + 1)]
        # z = (T_e - c) / s = (u + d) / s with u = T_e - T_ref, d = T_ref - c
        s, d = self.half_range_c_, self.reference_temperature - self.centre_c_
        out = np.zeros(self.degree + 1)
        for k, ck in enumerate(z_coef):
            for j in range(k + 1):
                out[j] += ck * math.comb(k, j) * d ** (k - j) / s**k
        return out.tolist()

    # --- compensation ---------------------------------------------------------
    def stream(self, power_on_s: float | None = None, *, clamp: bool = True) -> "GreyBoxStream":
        """A causal compensator from a cold state (:class:`GreyBoxStream`)."""
        self._check_fitted()
        return GreyBoxStream(self, power_on_s, clamp)

    def predict(self, time_s, temperature_c, *, segments=None, power_on_s=None, clamp: bool = True) -> np.ndarray:
        """The modelled bias [deg/s] of one recording, causally, from a cold state.

        Parameters
        ----------
        time_s, temperature_c : array_like, shape (n,)
        segments : list of slice or None
            Gap-free ranges; with ``bridge_gaps=False`` the state restarts at each.
        power_on_s : float or None
            Power-on time [s]; default the first sample.
        """
        time_s = np.asarray(time_s, dtype=float)
        temperature_c = np.asarray(temperature_c, dtype=float)
        stream = self.stream(power_on_s, clamp=clamp)
        out = np.empty(time_s.size)
        for s in segments or [slice(0, time_s.size)]:
            stream.restart_if_not_bridged()
            out[s] = stream(time_s[s], temperature_c[s])
        return out

    def static(self, temperature_c) -> np.ndarray:
        """The bias [deg/s] held at each temperature long enough to settle: the offset and the cubic (T clamped
        to the training range), no rate, the play centred, the warm-up over. What firmware's cubic can hold."""
        self._check_fitted()
        z = (np.clip(np.asarray(temperature_c, dtype=float), *self.temperature_range_c_) - self.centre_c_) / self.half_range_c_
        return self.offset_ + sum(self.coef_.get(f"z{k}", 0.0) * z**k for k in range(1, self.degree + 1))

    def _check_fitted(self) -> None:
        if not hasattr(self, "coef_"):
            from gyrocomp.models._base import NotFittedError

            raise NotFittedError("this GreyBoxDrift is not fitted yet; call fit(runs) first")

    # --- JSON -----------------------------------------------------------------
    _FITTED = ("spec_", "coef_", "offset_", "run_offsets_", "centre_c_", "half_range_c_", "temperature_range_c_",
               "rate_range_c_per_s_", "selection_", "not_fitted_", "noise_", "coef_about_reference_")

    def to_dict(self) -> dict:
        params = {k: list(v) if isinstance(v, tuple) else v for k, v in self.get_params().items()}
        fitted = {name: getattr(self, name) for name in self._FITTED} if hasattr(self, "coef_") else None
        return {"kind": self.kind, "version": VERSION, "params": params, "fitted": fitted}

    @classmethod
    def from_dict(cls, d: dict, name: str = "model") -> "GreyBoxDrift":
        """Rebuild from :meth:`to_dict`; a newer version or a malformed entry is refused, named."""
        try:
            if d["kind"] != cls.kind:
                raise InputError(f"{name}: kind {d['kind']!r} is not greybox")
            if not isinstance(d["version"], int) or d["version"] > VERSION:
                raise InputError(f"{name}: greybox version {d['version']!r} is newer than this gyrocomp reads ({VERSION}); upgrade gyrocomp")
            params = {k: tuple(v) if isinstance(v, list) else v for k, v in d["params"].items()}
            model = cls(**params)
            model._check_params()
            if d["fitted"] is not None:
                for key in cls._FITTED:
                    setattr(model, key, d["fitted"][key])
                model._check_loaded(name)
        except InputError:
            raise
        except (KeyError, TypeError, ValueError) as err:
            raise InputError(f"{name}: corrupted greybox model ({type(err).__name__}: {err})") from None
        return model

    def _check_loaded(self, name: str) -> None:
        numbers = [self.offset_, self.centre_c_, self.half_range_c_, *self.coef_.values(), *self.spec_.values(),
                   *self.temperature_range_c_, *self.rate_range_c_per_s_]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in numbers):
            raise InputError(f"{name}: greybox model holds a non-finite or non-numeric parameter")
        known = {f"z{k}" for k in range(1, self.degree + 1)} | {"rate", "rate_abs", "play", "warmup"}
        bad = sorted(set(self.coef_) - known)
        if bad:
            raise InputError(f"{name}: greybox coefficient(s) {', '.join(bad)} unknown; known: {', '.join(sorted(known))}")
        spec = self.spec_
        if set(spec) != {"tau_e_s", "rate_form", "width_c", "tau_w_s", "rate_tau_s"}:
            raise InputError(f"{name}: greybox spec_ keys {sorted(spec)}; expected tau_e_s, rate_form, width_c, tau_w_s, rate_tau_s")
        if (self.half_range_c_ <= 0 or any(v < 0 for v in spec.values()) or spec["rate_form"] not in (0, 1, 2)
                or (spec["rate_form"] and not spec["rate_tau_s"] > 0)):
            raise InputError(f"{name}: greybox spec {self.spec_} out of range")


class GreyBoxStream:
    """Causal compensation state of a :class:`GreyBoxDrift`: call on consecutive chunks of (time, temperature).

    The state is the kernel's six floats (:mod:`gyrocomp.effects._stateful`)
    and the power-on time; each call returns the chunk's modelled bias [deg/s].
    """

    def __init__(self, model: GreyBoxDrift, power_on_s: float | None, clamp: bool):
        from gyrocomp.effects._stateful import new_state

        self.model = model
        self.power_on_s = power_on_s
        self.clamp = clamp
        self.state = new_state()

    def restart_if_not_bridged(self) -> None:
        """Before a segment after a gap: a cold element, filter and play unless the model bridges gaps."""
        if not self.model.bridge_gaps:
            self.state[:] = 0.0

    def __call__(self, time_s, temperature_c) -> np.ndarray:
        time_s = np.ascontiguousarray(time_s, dtype=float)
        temperature_c = np.ascontiguousarray(temperature_c, dtype=float)
        if self.power_on_s is None and time_s.size:
            self.power_on_s = float(time_s[0])
        m = self.model
        spec = _Spec(m.spec_["tau_e_s"], m.spec_["rate_form"], m.spec_["width_c"], m.spec_["tau_w_s"], m.spec_["rate_tau_s"])
        raw = _kernel(time_s, temperature_c, self.state, spec)
        if self.clamp:  # the cubic is held at the edge of its range, as firmware holds TMIN..TMAX; dT/dt is linear and extrapolates
            np.clip(raw[:, 0], *m.temperature_range_c_, out=raw[:, 0])
        columns = _columns(raw, time_s, spec, self.power_on_s, m.centre_c_, m.half_range_c_, m.degree)
        out = np.full(time_s.size, m.offset_)
        for name, column in columns.items():
            out += m.coef_.get(name, 0.0) * column
        return out


def _kernel(time_s, temperature_c, state, spec: _Spec) -> np.ndarray:
    """(T_e, dT/dt, play) of each sample; without a dT/dt term the filter runs at 1 s and its output is unused."""
    from gyrocomp.effects._stateful import advance

    out = np.empty((time_s.size, 3))
    advance(time_s, temperature_c, state, float(spec.tau_e), float(spec.tau_r or 1.0), 0.5 * float(spec.width), out)
    return out


def _columns(raw, time_s, spec: _Spec, power_on_s, centre, half, degree) -> dict:
    """The model's design columns of a spec from the kernel's (T_e, dT/dt, play) (no offsets)."""
    z = (raw[:, 0] - centre) / half
    columns = {f"z{k}": z**k for k in range(1, degree + 1)}
    if spec.rate_form:
        columns["rate"] = raw[:, 1]
        if spec.rate_form == 2:
            columns["rate_abs"] = np.abs(raw[:, 1])
    if spec.width:
        columns["play"] = raw[:, 2]
    if spec.tau_w:
        columns["warmup"] = np.exp(-(time_s - power_on_s) / spec.tau_w)
    return columns


@dataclasses.dataclass
class _Prepared:
    """A training run reduced for the likelihood: group means, blocks and their covariance basis."""

    run: TrainingRun
    time_s: np.ndarray
    temperature_c: np.ndarray
    segments: list
    block_of: np.ndarray  # block index of each reduced sample, -1 when in no whole block
    n_blocks: int
    block_s: float
    starts: np.ndarray
    y: np.ndarray
    duration_s: float

    @classmethod
    def of(cls, run: TrainingRun, model: GreyBoxDrift) -> "_Prepared":
        t, T, y = (np.asarray(a, dtype=float) for a in (run.time_s, run.temperature_c, run.rate))
        duration = float(sum(t[s][-1] - t[s][0] for s in run.segments))
        interval = float(np.median(np.diff(t))) if t.size > 1 else 1.0
        block_s = max(model.block_s, duration / model.max_blocks, interval)
        per_block = max(1, int(round(block_s / interval)))
        group = max(1, per_block // 10)  # ten group means a block: the shapes are slow beside that
        pb = per_block // group  # group means a block
        settle_s = SETTLE_TAUS * model.rate_tau_s[1]
        run_start = t[run.segments[0].indices(t.size)[0]]
        times, temps, rates, blocks, starts, segs = [], [], [], [], [], []
        n_blocks = offset = 0
        for number, s in enumerate(run.segments):
            lo, hi = s.indices(t.size)[:2]
            k = (hi - lo) // group
            if k == 0:
                continue
            ts, Ts, ys = (a[lo : lo + k * group].reshape(k, group).mean(axis=1) for a in (t, T, y))
            skip = int(np.searchsorted(ts, ts[0] + settle_s)) if number == 0 or not model.bridge_gaps else 0
            whole = max(k - skip, 0) // pb
            idx = np.full(k, -1)
            idx[skip : skip + whole * pb] = n_blocks + np.arange(whole * pb) // pb
            starts.extend(ts[skip : skip + whole * pb : pb] - run_start)
            n_blocks += whole
            times.append(ts), temps.append(Ts), rates.append(ys), blocks.append(idx)
            segs.append(slice(offset, offset + k))
            offset += k
        if n_blocks < 8:
            raise InputError(f"{run.name}: {n_blocks} blocks of {block_s:g} s; the grey-box model needs at least 8 (a longer run)")
        block_of = np.concatenate(blocks)
        y_all = np.concatenate(rates)
        return cls(run, np.concatenate(times), np.concatenate(temps), segs, block_of, n_blocks, per_block * interval,
                   np.asarray(starts), _block_means(y_all, block_of, n_blocks), duration)

    def raw(self, spec: _Spec, bridge: bool) -> np.ndarray:
        from gyrocomp.effects._stateful import new_state

        state = new_state()
        out = np.empty((self.time_s.size, 3))
        for s in self.segments:
            if not bridge:
                state[:] = 0.0
            out[s] = _kernel(self.time_s[s], self.temperature_c[s], state, spec)
        return out

    def power_on_column(self, width: float) -> np.ndarray:
        """1 before the first excursion beyond the play of the power-on temperature (unknown branch), else 0."""
        beyond = np.flatnonzero(np.abs(self.temperature_c - self.temperature_c[0]) > width)
        first = beyond[0] if beyond.size else self.temperature_c.size
        return (np.arange(self.temperature_c.size) < first).astype(float)

    def ranges(self, model: GreyBoxDrift, spec: _Spec) -> tuple:
        raw = self.raw(spec, model.bridge_gaps)
        return float(raw[:, 0].min()), float(raw[:, 0].max()), float(raw[:, 1].min()), float(raw[:, 1].max())


def _block_means(x: np.ndarray, block_of: np.ndarray, n_blocks: int) -> np.ndarray:
    keep = block_of >= 0
    counts = np.bincount(block_of[keep], minlength=n_blocks)
    if x.ndim == 1:
        return np.bincount(block_of[keep], weights=x[keep], minlength=n_blocks) / counts
    return np.column_stack([np.bincount(block_of[keep], weights=c[keep], minlength=n_blocks) / counts for c in x.T])


class _Search:
    """Forward selection of the terms by BIC, each tried only where the runs identify it."""

    def __init__(self, model: GreyBoxDrift, runs: list):
        from gyrocomp.effects.likelihood import NoiseBasis

        self.model = model
        self.runs = runs
        self.bases = [NoiseBasis(r.n_blocks, r.block_s, r.starts) for r in runs]
        self.n_blocks = sum(r.n_blocks for r in runs)
        self._raw = {}

    # design ---------------------------------------------------------------
    def design(self, spec: _Spec) -> tuple[list, list, list]:
        """Block-mean design of each run, full-rate design of each run and the column names (per-run columns first)."""
        m = self.model
        n_runs = len(self.runs)
        blocks, full, names = [], [], None
        for i, run in enumerate(self.runs):
            power_on = run.run.power_on_s if run.run.power_on_s is not None else run.time_s[0]
            cols = _columns(self._raw_of(i, spec), run.time_s, spec, power_on, m.centre_c_, m.half_range_c_, m.degree)
            per_run = {f"offset_{j}": np.full(run.time_s.size, float(j == i)) for j in range(n_runs)}
            if spec.width:
                per_run |= {f"power_on_{j}": run.power_on_column(spec.width) * (j == i) for j in range(n_runs)}
            columns = per_run | cols
            names = list(columns)
            X = np.column_stack(list(columns.values()))
            full.append(X)
            blocks.append(_block_means(X, run.block_of, run.n_blocks))
        return blocks, full, names

    def n_params(self, spec: _Spec, names: list, noise_free: int) -> int:
        return len(names) + spec.n_nonlinear() + noise_free

    # likelihood -------------------------------------------------------------
    def deviance(self, blocks: list, noise) -> tuple[float, np.ndarray]:
        """-2 log L with beta at its GLS estimate, the runs independent (block-diagonal covariance)."""
        from gyrocomp.effects.likelihood import NoiseModel

        model = NoiseModel(*noise)
        yw, Xw, logdet = [], [], 0.0
        for run, basis, X in zip(self.runs, self.bases, blocks):
            w = basis.whitener(model)
            yw.append(w.whiten(run.y))
            Xw.append(w.whiten(X))
            logdet += w.logdet
        yw, Xw = np.concatenate(yw), np.vstack(Xw)
        beta, *_ = linalg.lstsq(Xw, yw, cond=1e-12, lapack_driver="gelsy", check_finite=False)
        r = yw - Xw @ beta
        return float(logdet + r @ r + yw.size * np.log(2 * np.pi)), beta

    def fit_noise(self, blocks: list, start=None) -> tuple:
        """ML white, flicker and random-walk levels (log-variances by Nelder-Mead); (noise, deviance, beta)."""
        X = np.vstack(blocks)
        y = np.concatenate([r.y for r in self.runs])
        beta = np.linalg.lstsq(X, y, rcond=None)[0]
        s2 = max(float(np.mean((y - X @ beta) ** 2)), 1e-300)
        block_s = self.runs[0].block_s
        arw0 = math.sqrt(s2 * block_s)
        x0 = np.log([arw0, 0.3 * math.sqrt(s2), 0.3 * math.sqrt(s2) / math.sqrt(block_s)]) if start is None else np.log(np.maximum(start, 1e-30))
        floor = np.log(arw0) - 12.0

        def objective(v):
            noise = np.exp(np.maximum(v, floor))
            return self.deviance(blocks, noise)[0]

        result = optimize.minimize(objective, x0, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-3, "maxiter": 400})
        noise = tuple(float(v) for v in np.exp(np.maximum(result.x, floor)))
        deviance, beta = self.deviance(blocks, noise)
        return noise, deviance, beta

    def bic(self, deviance: float, k: int) -> float:
        return deviance + k * math.log(self.n_blocks)

    # identifiability ----------------------------------------------------------
    def _stacked(self, spec: _Spec) -> dict:
        """Block-mean columns of `spec` over every run, what the fit sees (offsets of runs after the first; the constant is implicit)."""
        blocks, _, names = self.design(spec)
        X = np.vstack(blocks)
        shown = {f"z{k}": ("T_e" if spec.tau_e else "T") + ("" if k == 1 else f"^{k}") for k in range(1, self.model.degree + 1)}
        return {shown.get(n, n): X[:, j] for j, n in enumerate(names) if n != "offset_0"}

    def identified(self, spec: _Spec, trial: _Spec, term: str):
        """None when the runs identify `term` at `trial` beside the columns of `spec`, else the :class:`Refusal`.

        The columns judged are those `term` adds; for the thermal lag, which
        replaces T by T_e in the cubic, the difference ``T_e - T``.
        """
        if term == "hysteresis" and not any(_reverses(r.temperature_c, trial.width) for r in self.runs):
            return Refusal(
                term, 0.0,
                f"hysteresis not fitted: the temperature never reverses by more than {trial.width:.3g} degC after its first excursion "
                "on the training runs, so the branch never changes and the play is a function of T alone; add a run that heats and cools",
            )
        base = self._stacked(spec)
        if term == "thermal_lag":
            m = self.model
            lag = [_block_means(self._raw_of(i, trial)[:, 0] - r.temperature_c, r.block_of, r.n_blocks) for i, r in enumerate(self.runs)]
            added = {"thermal_lag (T_e - T)": np.concatenate(lag)}
        else:
            added = {f"{term} ({n})": c for n, c in self._stacked(trial).items() if n not in base}
        _, refused = separable({**base, **added}, self.model.min_unique_variance)
        return next((r for r in refused if r.term in added), None)

    def _raw_of(self, i: int, spec: _Spec) -> np.ndarray:
        key = (i, spec.tau_e, spec.width, spec.tau_r)
        if key not in self._raw:
            self._raw[key] = self.runs[i].raw(_Spec(spec.tau_e, 1, spec.width, 0.0, spec.tau_r), self.model.bridge_gaps)
        return self._raw[key]

    # search -------------------------------------------------------------------
    def grids(self) -> dict:
        m = self.model
        return {
            "thermal_lag": [{"tau_e": float(v)} for v in np.geomspace(*m.lag_tau_s, m.grid_points)],
            "temp_rate": [{"rate_form": form, "tau_r": float(v)} for form in (1, 2) for v in np.geomspace(*m.rate_tau_s, RATE_GRID_POINTS)],
            "hysteresis": [{"width": float(v)} for v in m.widths_c],
            "warmup": [{"tau_w": float(v)} for v in np.geomspace(*m.warmup_tau_s, m.grid_points)],
        }

    def run(self) -> tuple[_Spec, list, list]:
        """Forward selection; the spec, the accepted steps and the terms the runs cannot identify (with reasons)."""
        m = self.model
        spec = _Spec()
        blocks, _, names = self.design(spec)
        noise, deviance, _ = self.fit_noise(blocks)
        score = self.bic(deviance, self.n_params(spec, names, 3))
        not_fitted = {}
        if "warmup" in m.terms and any(r.run.power_on_s is None for r in self.runs):
            not_fitted["warmup"] = (
                "warmup not fitted: a training run does not start at power-on and gives no power-on time, so the time since power-on is unknown"
            )
        grids = self.grids()
        for term in m.terms:  # judged against the baseline: a term no parameter of its grid separates from it
            if term in not_fitted:
                continue
            refusals = [self.identified(spec, dataclasses.replace(spec, **change), term) for change in grids[term]]
            if all(r is not None for r in refusals):
                not_fitted[term] = max(refusals, key=lambda r: r.unique).reason  # the nearest miss (the narrowest play)
        remaining = [t for t in m.terms if t not in not_fitted]
        steps = []
        while remaining:
            best = None
            for term in remaining:
                for change in grids[term]:
                    if term == "temp_rate" and change["rate_form"] <= spec.rate_form:
                        continue  # a selected sensitivity may still split into heating and cooling
                    trial = dataclasses.replace(spec, **change)
                    if self.identified(spec, trial, term) is not None:
                        continue  # not separable, at this parameter, from what the model holds
                    t_blocks, _, t_names = self.design(trial)
                    trial_score = self.bic(self.deviance(t_blocks, noise)[0], self.n_params(trial, t_names, 3))
                    if best is None or trial_score < best[0]:
                        best = (trial_score, term, trial)
            if best is None:
                break
            _, term, trial = best
            t_blocks, _, t_names = self.design(trial)
            t_noise, t_dev, _ = self.fit_noise(t_blocks, noise)
            t_score = self.bic(t_dev, self.n_params(trial, t_names, 3))
            upgrade = term == "temp_rate" and spec.rate_form > 0  # heating and cooling apart must pay, whatever `selection`
            if (m.selection == "bic" or upgrade) and score - t_score <= m.bic_margin:
                if upgrade and m.selection == "all" and len(remaining) > 1:
                    remaining.remove(term)
                    continue
                break
            steps.append({"term": term, "params": _params(trial, term), "delta_bic": float(t_score - score)})
            spec, noise, score = trial, t_noise, t_score
            if term != "temp_rate" or spec.rate_form == 2:
                remaining.remove(term)
        spec = self.refine(spec, noise)
        blocks, _, _ = self.design(spec)
        self.noise = self.fit_noise(blocks, noise)[0]
        for step in steps:
            step["params"] = _params(spec, step["term"])
        return spec, steps, [{"term": t, "reason": not_fitted[t]} for t in m.terms if t in not_fitted]

    def refine(self, spec: _Spec, noise) -> _Spec:
        """Each selected nonlinear parameter off its grid: two rounds of a bounded search of the deviance in its logarithm.

        The bounds are the grid's neighbours of the value (a factor of the
        grid's spacing either way, within the configured range), so the
        search settles the value the grid bracketed and never wanders to
        another minimum. A parameter
        at which the runs no longer identify its term is not taken.
        """
        spacing = {
            "tau_e": (self.model.lag_tau_s[1] / self.model.lag_tau_s[0]) ** (1 / (self.model.grid_points - 1)),
            "tau_w": (self.model.warmup_tau_s[1] / self.model.warmup_tau_s[0]) ** (1 / (self.model.grid_points - 1)),
            "width": max(b / a for a, b in zip(sorted(self.model.widths_c), sorted(self.model.widths_c)[1:])) if len(self.model.widths_c) > 1 else 2.0,
            "tau_r": (self.model.rate_tau_s[1] / self.model.rate_tau_s[0]) ** (1 / (RATE_GRID_POINTS - 1)),
        }
        terms = {"tau_e": "thermal_lag", "tau_w": "warmup", "width": "hysteresis", "tau_r": "temp_rate"}
        m = self.model
        ranges = {"tau_e": m.lag_tau_s, "tau_w": m.warmup_tau_s, "width": (min(m.widths_c), max(m.widths_c)), "tau_r": m.rate_tau_s}
        without = {"tau_e": {"tau_e": 0.0}, "tau_w": {"tau_w": 0.0}, "width": {"width": 0.0}, "tau_r": {"rate_form": 0, "tau_r": 0.0}}
        for _ in range(2):
            for key, factor in spacing.items():
                value = getattr(spec, key)
                if not value:
                    continue

                def deviance(log_value, key=key):
                    trial = dataclasses.replace(spec, **{key: float(np.exp(log_value))})
                    return self.deviance(self.design(trial)[0], noise)[0]

                lo, hi = ranges[key]
                bounds = (math.log(max(value / factor, lo)), math.log(min(value * factor, hi)))
                if bounds[1] - bounds[0] < 1e-9:
                    continue
                result = optimize.minimize_scalar(deviance, bounds=bounds, method="bounded", options={"xatol": 1e-3})
                trial = dataclasses.replace(spec, **{key: float(np.exp(result.x))})
                base = dataclasses.replace(spec, **without[key])
                if result.fun < deviance(math.log(value)) and self.identified(base, trial, terms[key]) is None:
                    spec = trial
        return spec

    def final(self, spec: _Spec):
        blocks, _, names = self.design(spec)
        deviance, beta = self.deviance(blocks, self.noise)
        return beta, names, self.noise


def _params(spec: _Spec, term: str) -> dict:
    return {
        "thermal_lag": {"tau_s": spec.tau_e},
        "temp_rate": {"heating_cooling_apart": spec.rate_form == 2, "filter_tau_s": spec.tau_r},
        "hysteresis": {"width_c": spec.width},
        "warmup": {"tau_s": spec.tau_w},
    }[term]


def _reverses(temperature_c, width_c) -> bool:
    """Whether the play of `width_c` changes branch after the first excursion beyond it (:func:`~gyrocomp.effects.shapes.hysteresis_branch`)."""
    first = first_excursion(temperature_c, width_c)
    branch = hysteresis_branch(np.arange(temperature_c.size, dtype=float), temperature_c, width_c)
    return bool(first < temperature_c.size and np.any(branch[first:] != branch[first]))

