"""A causal grey-box model of the bias: element-temperature lag, a cubic, heating/cooling dT/dt, a hysteresis, a warm-up.

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
  smoothing gains (:mod:`gyrocomp.effects._stateful`); where it pays, the
  sensitivity saturates, ``dT/dt`` replaced by ``s tanh(dT/dt / s)``
  (:func:`gyrocomp.effects.shapes.saturating_rate`, ``s`` fitted within
  ``rate_saturation_c_per_s``);
* ``hysteresis``: a play operator of width ``w`` (its output ``P_w`` in
  [-1, 1], :func:`gyrocomp.effects.shapes.hysteresis_play`) with its branch state,
  or a direction relay; where it pays, a second play of another width
  (``second_hysteresis``): two terms of a Prandtl-Ishlinskii sum of plays,
  for a part whose hysteresis is spread over several widths (a Preisach
  distribution of switching temperatures); beside a lag, the hysteresis
  switches on the measured T or on ``T_e``, whichever the BIC prefers;
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

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.models._base import NotFittedError, Params
from gyrocomp.models._greybox_state import JOINS, TERMS, Spec, element_column, kernel

__all__ = ["GreyBoxDrift", "GreyBoxStream", "TrainingRun", "TERMS"]

VERSION = 4


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


class GreyBoxDrift(Params):
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
    rate_saturation_c_per_s : tuple of float, default=(0.001, 0.1)
        (low, high) of the log grid of the dT/dt saturation rate ``s``
        [degC/s] of the ``rate_saturation`` term.
    terms : tuple of str
        Candidate terms, a subset of :data:`TERMS`.
    lag_tau_s, warmup_tau_s : tuple of float
        (low, high) of the log grids of ``tau_e`` and ``tau_w`` [s].
    grid_points : int
        Points of each log grid.
    widths_c : tuple of float
        Grid of the hysteresis width [degC], for the play and for the relay (a relay gains only near its width: keep it fine).
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
        ``tau_e_s``, ``rate_form`` (0, 1, 2), ``width_c``, ``tau_w_s``,
        ``rate_tau_s``, ``hysteresis_operator``, ``tau_e2_s``, ``tau_w2_s``,
        ``rate_saturation_c_per_s``, ``width2_c`` (0: a term absent),
        ``second_lag_path`` (``parallel`` or ``series``), ``hysteresis_input``
        (``temperature`` or ``element``: the hysteresis switches on T or on T_e).
    coef_ : dict of str to float
        Column coefficients [deg/s per column unit]: ``z1..z3``, ``rate``,
        ``rate_abs``, ``play`` or ``relay``, ``play2``, ``warmup``, ``warmup2``, ``lag2``.
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
        rate_saturation_c_per_s=(0.001, 0.1),
        terms=TERMS,
        lag_tau_s=(10.0, 14400.0),
        warmup_tau_s=(60.0, 14400.0),
        grid_points=25,
        widths_c=(0.5, 0.574, 0.66, 0.758, 0.871, 1.0, 1.15, 1.32, 1.52, 1.74, 2.0, 2.3, 2.64, 3.03, 3.48, 4.0, 4.59, 5.28, 6.06, 6.96, 8.0, 9.19, 10.6, 12.1, 13.9, 16.0),
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
        self.rate_saturation_c_per_s = rate_saturation_c_per_s
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
        for name in ("lag_tau_s", "warmup_tau_s", "rate_tau_s", "rate_saturation_c_per_s"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi < math.inf:
                raise InputError(f"{owner}: {name} = {getattr(self, name)!r} must be (low, high) with 0 < low <= high")
        lone = [f"{second} needs {first}" for second, first in JOINS.items() if second in self.terms and first not in self.terms]
        if lone:
            raise InputError(f"{owner}: terms {list(self.terms)}: {'; '.join(lone)} among the terms")
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

        from gyrocomp.models._greybox_search import Prepared, Search  # scipy's optimisers: only a fit needs them

        prepared = [Prepared.of(run, self) for run in runs]
        with threadpool_limits(limits=1, user_api="blas"):  # small factorisations: threads only contend
            search = Search(self, prepared)
            spec, self.selection_, self.not_fitted_ = search.run()
            beta, names, noise = search.final(spec)
        self.spec_ = {"tau_e_s": spec.tau_e, "rate_form": spec.rate_form, "width_c": spec.width, "tau_w_s": spec.tau_w, "rate_tau_s": spec.tau_r,
                      "hysteresis_operator": "relay" if spec.relay else "play", "tau_e2_s": spec.tau_e2, "tau_w2_s": spec.tau_w2,
                      "rate_saturation_c_per_s": spec.rate_sat, "second_lag_path": "series" if spec.series else "parallel",
                      "width2_c": spec.width2, "hysteresis_input": "element" if spec.on_element and spec.tau_e else "temperature"}
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
        self.spec_ = {**_ADDED_SPEC, **self.spec_}  # an older file: a play, no second time constants, no saturation
        numbers = [self.offset_, self.centre_c_, self.half_range_c_, *self.coef_.values(),
                   *(v for k, v in self.spec_.items() if k not in _CHOICES),
                   *self.temperature_range_c_, *self.rate_range_c_per_s_]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in numbers):
            raise InputError(f"{name}: greybox model holds a non-finite or non-numeric parameter")
        known = {f"z{k}" for k in range(1, self.degree + 1)} | {"rate", "rate_abs", "play", "relay", "play2", "warmup", "warmup2", "lag2"}
        bad = sorted(set(self.coef_) - known)
        if bad:
            raise InputError(f"{name}: greybox coefficient(s) {', '.join(bad)} unknown; known: {', '.join(sorted(known))}")
        spec = self.spec_
        if set(spec) != set(_ADDED_SPEC) | {"tau_e_s", "rate_form", "width_c", "tau_w_s", "rate_tau_s"}:
            raise InputError(f"{name}: greybox spec_ keys {sorted(spec)}; expected tau_e_s, rate_form, width_c, tau_w_s, rate_tau_s, "
                             f"{', '.join(_ADDED_SPEC)}")
        numbers = {k: v for k, v in spec.items() if k not in _CHOICES}
        if (self.half_range_c_ <= 0 or any(v < 0 for v in numbers.values()) or spec["rate_form"] not in (0, 1, 2)
                or (spec["rate_form"] and not spec["rate_tau_s"] > 0) or any(spec[k] not in v for k, v in _CHOICES.items())):
            raise InputError(f"{name}: greybox spec {self.spec_} out of range")

    def spec(self) -> Spec:
        """The fitted nonlinear specification (:class:`~gyrocomp.models._greybox_state.Spec`)."""
        s = self.spec_
        return Spec(s["tau_e_s"], s["rate_form"], s["width_c"], s["tau_w_s"], s["rate_tau_s"], s["hysteresis_operator"] == "relay",
                    s["tau_e2_s"], s["tau_w2_s"], s["rate_saturation_c_per_s"], s["second_lag_path"] == "series", s["width2_c"],
                    s["hysteresis_input"] == "element")


_ADDED_SPEC = {"hysteresis_operator": "play", "tau_e2_s": 0.0, "tau_w2_s": 0.0, "rate_saturation_c_per_s": 0.0, "second_lag_path": "parallel",
               "width2_c": 0.0, "hysteresis_input": "temperature"}
"""The spec entries versions 2 (the relay, the second time constants), 3 (the saturation, lags in series) and 4
(a second play, the hysteresis switching on T_e) added, at the values an older model holds."""


_CHOICES = {"hysteresis_operator": ("play", "relay"), "second_lag_path": ("parallel", "series"), "hysteresis_input": ("temperature", "element")}
"""The spec entries that name a form, and the names they take."""


class GreyBoxStream:
    """Causal compensation state of a :class:`GreyBoxDrift`: call on consecutive chunks of (time, temperature).

    The state is the kernel's few floats (:mod:`gyrocomp.effects._stateful`)
    and the power-on time; each call returns the chunk's modelled bias [deg/s]:
    the columns of :func:`~gyrocomp.models._greybox_state.columns_of` times
    their coefficients, summed in one compiled pass
    (:func:`~gyrocomp.effects._stateful.evaluate`; the cubic by Horner's rule).
    """

    def __init__(self, model: GreyBoxDrift, power_on_s: float | None, clamp: bool):
        from gyrocomp.effects._stateful import new_state

        self.model = model
        self.power_on_s = power_on_s
        self.clamp = clamp
        self.state = new_state()
        self.element = element_column(model.spec())
        c = model.coef_
        hysteresis = c.get("relay" if model.spec_["hysteresis_operator"] == "relay" else "play", 0.0)
        self.coef = np.array([model.offset_, *(c.get(f"z{k}", 0.0) for k in (1, 2, 3)), c.get("rate", 0.0), c.get("rate_abs", 0.0),
                              hysteresis, c.get("lag2", 0.0), c.get("warmup", 0.0), c.get("warmup2", 0.0), c.get("play2", 0.0)])

    def restart_if_not_bridged(self) -> None:
        """Before a segment after a gap: a cold element, filter and play unless the model bridges gaps."""
        if not self.model.bridge_gaps:
            self.state[:] = 0.0

    def __call__(self, time_s, temperature_c) -> np.ndarray:
        time_s = np.ascontiguousarray(time_s, dtype=float)
        temperature_c = np.ascontiguousarray(temperature_c, dtype=float)
        if self.power_on_s is None and time_s.size:
            self.power_on_s = float(time_s[0])
        from gyrocomp.effects._stateful import evaluate

        m = self.model
        raw = kernel(time_s, temperature_c, self.state, m.spec())
        lo, hi = m.temperature_range_c_ if self.clamp else (-math.inf, math.inf)
        out = np.empty(time_s.size)
        evaluate(raw, time_s, self.coef, m.centre_c_, m.half_range_c_, lo, hi, self.power_on_s, m.spec_["tau_w_s"], m.spec_["tau_w2_s"],
                 m.spec_["rate_saturation_c_per_s"], self.element, out)
        return out
