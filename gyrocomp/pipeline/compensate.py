"""``compensate``: apply a ``model.json`` to a recording, in ``full`` or ``causal`` mode.

* ``full`` (the papers' offline parallel processing): decompose the
  recording with the model's decomposition settings, classify the
  components with the model's thresholds, denoise each class as the model's
  ``[denoise]`` says, subtract each segment's predicted drift from that
  segment, and add the segments back up (Cao et al. 2021, Fig. 5, step d:
  SG(mixed) + drift - ANFIS predictions, noise dropped; Zhang et al. 2024,
  section 3.7, step 4: TFPF(noise) + TFPF(mixed) + feature - ELM
  prediction). The temperature rate is the centred estimate. For a direct
  pipeline, ``full`` is ``rate - f(T, dT/dt)`` with the centred estimate.
* ``causal`` (what firmware runs): ``rate - f(T, dT/dt)``, with the
  one-sided estimate of dT/dt; nothing but the temperature model touches
  the rate, so a true angular rate passes unchanged. Temperature and dT/dt
  are clamped to their training ranges first (:func:`clamp_inputs`), as
  PX4 and ArduPilot clamp the temperature to their TMIN..TMAX; ``clamp=False``
  extrapolates instead.

Either way a recording that leaves a training range is reported, per input
and by how much (an :class:`ExtrapolationWarning` and ``summary["warnings"]``).

``drift_model`` is the sum of the segments' predicted drifts [deg/s].

Memory: the learners are evaluated `CHUNK_ROWS` samples at a time, and the
causal mode also runs on a stream (:class:`CausalCompensation`), whose
state is the rate estimator's last readings and a few running figures, so
``gyrocomp compensate --mode causal`` reads, compensates and writes one
chunk at a time (:mod:`gyrocomp.streaming`).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

from gyrocomp import recordings
from gyrocomp.config import bind, check_seed
from gyrocomp.errors import InputError
from gyrocomp.models._base import check_choice, check_float, finite_array, scaled_columns
from gyrocomp.pipeline.rate import CausalRate, check_described
from gyrocomp.pipeline.settings import PIPELINE_KINDS, RateSettings
from gyrocomp.streaming import CHUNK_ROWS
from gyrocomp.pipeline.model_file import axis_models
from gyrocomp.pipeline.signal_path import class_sums
from gyrocomp.pipeline.block_fit import INPUTS
from gyrocomp.pipeline.train import segment_inputs

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "COMPENSATION_SCHEMA",
    "MODES",
    "ExtrapolationWarning",
    "DriftModel",
    "CausalCompensation",
    "load_model",
    "clamp_inputs",
    "load_models",
    "compensate",
]

COMPENSATION_SCHEMA = "gyrocomp.compensation"
MODES = ("full", "causal")


class ExtrapolationWarning(UserWarning):
    """A recording leaves the temperature or temperature-rate range the model was trained on."""


@dataclasses.dataclass
class DriftModel:
    """A ``model.json`` made usable: the learners, the maps and the ranges.

    Build with :func:`load_model`; :meth:`predict` evaluates f(T, dT/dt).
    """

    obj: dict
    name: str
    kind: str
    parallel: bool
    rate: RateSettings
    learners: dict
    clip_inputs: bool
    clip_output: bool

    @property
    def temperature_range_c(self) -> tuple[float, float]:
        r = self.obj["training"]["temperature_c"]
        return float(r["min"]), float(r["max"])

    @property
    def rate_range_c_per_s(self) -> tuple[float, float]:
        r = self.obj["training"]["temperature_rate_c_per_s"]
        return float(r["min"]), float(r["max"])

    @property
    def causal_rate_range_c_per_s(self) -> tuple[float, float]:
        """dT/dt range of the training run by the causal estimator (older models: the centred one's)."""
        r = self.obj["training"].get("temperature_rate_causal_c_per_s") or self.obj["training"]["temperature_rate_c_per_s"]
        return float(r["min"]), float(r["max"])

    @property
    def uses_rate(self) -> bool:
        """Whether any segment's learner depends on dT/dt (a polynomial without its rate term does not)."""
        return any(not (learner.kind == "polynomial" and not learner.rate_term) for learner, *_ in self.learners.values())

    def inputs(self, temperature_c, fs_hz: float, *, causal: bool, bounds=None) -> np.ndarray:
        """[temperature, temperature rate] with the model's estimator (centred or causal), within each gap-free range of `bounds`."""
        return segment_inputs(temperature_c, fs_hz, self.rate, bounds, causal=causal)

    def predict(self, X: np.ndarray, *, clamp: bool | None = None) -> dict:
        """Predicted drift of each modelled segment [deg/s] for inputs `X` (n_samples, 2).

        With `clamp` (default: the model's ``clip_inputs``) each input is
        first held inside its training range (:func:`clamp_inputs`); with
        ``clip_output`` each prediction inside the range of its segment's
        training target.
        """
        X = np.asarray(X, dtype=float)
        clamp = self.clip_inputs if clamp is None else clamp
        out = {segment: np.empty(len(X)) for segment in self.learners}
        for start in range(0, len(X), CHUNK_ROWS):
            for segment, y in self._predict_rows(X[start : start + CHUNK_ROWS], clamp, start).items():
                out[segment][start : start + CHUNK_ROWS] = y
        return out

    def _predict_rows(self, X: np.ndarray, clamp: bool, start: int = 0) -> dict:
        if clamp:
            X = clamp_inputs(X, self)
        out = {}
        for segment, (learner, x_offset, x_scale, y_offset, y_scale, y_range) in self.learners.items():
            with np.errstate(over="ignore", invalid="ignore"):  # a non-finite result is refused below, naming its input
                y = learner.predict(scaled_columns(X, x_offset, x_scale)) * y_scale + y_offset
            self._check_drift(segment, y, X, start)
            out[segment] = np.clip(y, *y_range) if self.clip_output else y
        return out


    def _check_drift(self, segment: str, y: np.ndarray, X: np.ndarray, start: int) -> None:
        """Refuse a drift that is not finite or beyond what any sensor reads (:class:`gyrocomp.recordings.AxisLimits`): a model's finite but huge numbers (1e306) would overflow the compensated column."""
        unit = self.obj.get("unit", "deg/s")
        bound = recordings.AxisLimits().bound(unit)
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.abs(y) <= bound))
        if bad.size:
            i = int(bad[0])
            raise InputError(
                f"{self.name}: segment {segment} gives a drift of {float(y[i])!r} {unit} at sample {start + i} "
                f"(T = {X[i, 0]:.6g} degC, dT/dt = {X[i, 1]:.6g} degC/s), beyond +-{bound:g} {unit} (configs/recordings.toml [axes]); a corrupted model"
            )


class CausalCompensation:
    """Causal compensation of one axis of a stream: call it on consecutive chunks, then :meth:`summary`.

    Parameters
    ----------
    model : DriftModel
    fs_hz : float
        Sample rate [Hz].
    name : str
        The recording's name, for messages.
    clamp : bool
        Clamp temperature and dT/dt to the training ranges (:func:`clamp_inputs`).

    Notes
    -----
    Chunks of `CHUNK_ROWS` samples, counted from the start, give the bytes
    of :func:`compensate` on the whole recording when it is longer than
    the rate window: the rate estimator lays its sums out from the start
    whatever the chunks (:class:`gyrocomp.pipeline.rate.CausalRate`), and
    the learners evaluate the same rows together.
    """

    def __init__(self, model: DriftModel, fs_hz: float, name: str, *, clamp: bool = True):
        self.model = model
        self.name = name
        self.clamp = bool(clamp)
        if model.kind == "greybox":  # its own states: element temperature, causal dT/dt, play, time since power-on
            self._greybox = model.stream(clamp=self.clamp)
            self._seen = _Seen(model, ("temperature",))
        else:
            self._rate = CausalRate(model.rate, fs_hz)
            self._seen = _Seen(model, causal=True)

    def __call__(self, rate, temperature, time_s=None) -> tuple[np.ndarray, np.ndarray]:
        """``drift_model`` and ``compensated`` [deg/s] of the chunk (a grey-box model needs its `time_s`)."""
        temperature = np.asarray(temperature, dtype=float)
        rate = np.asarray(rate, dtype=float)
        if self.model.kind == "greybox":
            self._seen.add(temperature[:, None])
            drift = self._greybox(time_s, temperature)
            return drift, rate - drift
        X = np.array([temperature, self._rate(temperature)]).T  # Fortran order: each column contiguous
        self._seen.add(X)
        drift = np.sum(list(self.model.predict(X, clamp=self.clamp).values()), axis=0)
        return drift, rate - drift

    def summary(self) -> dict:
        """Mode, kind, clamping, the ranges met and any extrapolation (issued as :class:`ExtrapolationWarning`)."""
        summary = {"mode": "causal", "kind": self.model.kind, "parallel": self.model.parallel, "clamp": self.clamp}
        summary["ranges"], summary["warnings"] = _ranges(self.name, self._seen, self.model, self.clamp)
        return summary


def load_model(obj: dict, name: str = "model.json") -> DriftModel:
    """Check a one-axis ``model.json`` object (or the model of one axis) and rebuild its learners.

    Raises
    ------
    SchemaError
        Not a ``gyrocomp.model`` or of a newer major version.
    InputError
        Several axes (:func:`load_models` reads them), a missing or
        malformed entry (named), or a learner that does not rebuild.
    """
    (axis, one), *more = axis_models(obj, name).items()
    if more:
        names = ", ".join([axis, *(a for a, _ in more)])
        raise InputError(f"{name}: holds a model per axis ({names}); load them with load_models")
    return _drift_model(one, name if axis is None else f"{name} axis {axis}")


def load_models(obj: dict, name: str = "model.json") -> dict:
    """The model of every axis of a ``model.json`` object (either version).

    Returns
    -------
    dict of str to DriftModel
        By axis name, in the file's order; a version-1 file (one model, no
        axes) gives one entry whose key is ``None``.

    Raises
    ------
    SchemaError, InputError
        As :func:`load_model`.
    """
    return {axis: _drift_model(one, name if axis is None else f"{name} axis {axis}") for axis, one in axis_models(obj, name).items()}


def _drift_model(obj: dict, name: str):
    """A :class:`DriftModel`, or a :class:`~gyrocomp.pipeline.greybox.GreyBoxModel` for ``kind = "greybox"``."""
    from gyrocomp import models

    if isinstance(obj, dict) and obj.get("kind") == "greybox":
        from gyrocomp.pipeline.greybox import load_greybox

        return load_greybox(obj, name)

    try:
        rate_table = {k: obj["rate_estimator"][k] for k in ("method", "window_s", "polyorder")}
        rate = bind(RateSettings, rate_table, f"{name} rate_estimator")
        check_described(obj["rate_estimator"], rate, name)
        learners = {}
        for segment, entry in obj["segments"].items():
            where = f"{name}: segment {segment}"
            offset = finite_array(where, "input_offset", entry["input_offset"], ndim=1)
            scale = finite_array(where, "input_scale", entry["input_scale"], ndim=1)
            if offset.shape != (len(INPUTS),) or scale.shape != (len(INPUTS),) or not np.all(scale > 0):
                raise InputError(f"{where} needs {len(INPUTS)} input offsets and positive scales")
            if not isinstance(entry["learner"], dict) or entry["learner"].get("fitted") is None:
                raise InputError(f"{where}: the learner holds no fitted parameters")
            learner = models.from_dict(entry["learner"])
            y_offset = check_float(where, "output_offset", entry["output_offset"], -np.inf)
            y_scale = check_float(where, "output_scale", entry["output_scale"], 0.0, low_open=True)
            y_range = _finite_range(where, "output_min/output_max", entry["output_min"], entry["output_max"])
            learners[segment] = (learner, offset, scale, y_offset, y_scale, y_range)
        for key in ("temperature_c", "temperature_rate_c_per_s"):
            recordings.check_training_range(name, key, *_finite_range(f"{name}: training", key, obj["training"][key]["min"], obj["training"][key]["max"]))
        kind = check_choice(name, "kind", obj["kind"], PIPELINE_KINDS)
        parallel, *clips = (_flag(name, key, obj[key]) for key in ("parallel", "clip_inputs", "clip_output"))
        if parallel:  # full mode decomposes with it
            check_seed(obj.get("settings", {}).get("decompose_seed"), f"{name}: settings.decompose_seed")
    except InputError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as err:
        raise InputError(f"{name}: corrupted model ({type(err).__name__}: {err})") from None
    if not learners:
        raise InputError(f"{name}: no fitted segment")
    return DriftModel(obj, name, kind, parallel, rate, learners, *clips)


def clamp_inputs(X: np.ndarray, model: DriftModel) -> np.ndarray:
    """Hold temperature [degC] and dT/dt [degC/s] inside the model's training ranges.

    Firmware does the same with the temperature (PX4 ``TC_G<i>_TMIN/TMAX``,
    ArduPilot ``INS_TCAL<n>_TMIN/TMAX``): outside the calibrated range the
    correction stays at its value at the edge instead of following the
    polynomial out.

    Parameters
    ----------
    X : ndarray, shape (n_samples, 2)
        Columns temperature [degC] and temperature rate [degC/s].
    model : DriftModel

    Returns
    -------
    ndarray, shape (n_samples, 2)
    """
    out = np.empty(X.shape, order="F")  # each column contiguous (:func:`~gyrocomp.models._base.scaled_columns`)
    for column, (low, high) in enumerate((model.temperature_range_c, model.rate_range_c_per_s)):
        np.clip(X[:, column], low, high, out=out[:, column])
    return out


def _finite_range(where: str, what: str, low, high) -> tuple[float, float]:
    """(low, high) as finite floats with low <= high."""
    low = check_float(where, f"{what} min", low, -np.inf)
    high = check_float(where, f"{what} max", high, low)
    return low, high


def _flag(name: str, key: str, value) -> bool:
    """A JSON boolean; a string such as ``"no"`` is refused, not read as true."""
    if not isinstance(value, bool):
        raise InputError(f"{name}: `{key}` must be true or false, got {value!r}")
    return value


def compensate(
    recording: recordings.Recording,
    model: DriftModel,
    mode: str = "causal",
    *,
    clamp: bool | None = None,
    seed: int | None = None,
    workers: int = 1,
    callback=None,
    bounds=None,
) -> tuple[pd.DataFrame, dict]:
    """Compensate a recording with a trained model.

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        One axis in ``rate``, with ``temperature``.
    model : DriftModel
        From :func:`load_model`.
    mode : {"full", "causal"}
        See the module notes.
    clamp : bool or None
        Clamp temperature and dT/dt to the training ranges before the model
        (:func:`clamp_inputs`). Default: True in ``causal`` mode, the
        model's ``clip_inputs`` in ``full`` mode. False extrapolates.
    seed : int or None
        Seed of the decomposition in ``full`` mode; default the seed the
        training run was decomposed with.
    workers : int
        Processes for the decomposition.
    callback : callable(done, total) or None
        Progress of the decomposition.
    bounds : sequence of slice or None
        Row ranges sampled without a gap (``None``: one). The temperature
        rate is estimated within each, never across a gap; ``full`` mode of
        a parallel pipeline decomposes, classifies and denoises each on its
        own (:func:`~gyrocomp.pipeline.signal_path.class_sums`).

    Returns
    -------
    frame : pandas.DataFrame
        ``time``, ``rate``, ``temperature``, ``drift_model``, ``compensated``.
    summary : dict
        Mode, kind, the ranges met and any extrapolation (also issued as an
        :class:`ExtrapolationWarning`), and the classes found in ``full`` mode.
    """
    if mode not in MODES:
        raise InputError(f"--mode {mode!r}; choose full or causal")
    data = recording.data
    if "temperature" not in data.columns:
        raise InputError(f"{recording.name}: no `temperature` column; the drift model needs it")
    temperature = data["temperature"].to_numpy(dtype=float)
    rate = data["rate"].to_numpy(dtype=float)
    if model.kind == "greybox":  # causal by construction: full mode is the same model
        clamp = True if clamp is None else clamp
        drift_model = model.drift(data["time"].to_numpy(dtype=float), temperature, bounds=bounds, clamp=clamp)
        summary = {"mode": mode, "kind": model.kind, "parallel": False, "clamp": bool(clamp), "bridge_gaps": model.estimator.bridge_gaps}
        summary["ranges"], summary["warnings"] = _ranges(recording.name, _Seen(model, ("temperature",)).add(temperature[:, None]), model, clamp)
        compensated = rate - drift_model
    else:
        drift_model, compensated, summary = _compensate_static(recording, model, mode, clamp, seed, workers, callback, bounds, temperature, rate)
    import pandas as pd  # here: the causal stream does without it (half a second of import)

    frame = pd.DataFrame(
        {
            "time": data["time"].to_numpy(dtype=float),
            "rate": rate,
            "temperature": temperature,
            "drift_model": drift_model,
            "compensated": compensated,
        }
    )
    return frame, summary


def _compensate_static(recording, model: DriftModel, mode, clamp, seed, workers, callback, bounds, temperature, rate):
    """``drift_model``, ``compensated`` and the summary of a static map of (T, dT/dt) (:func:`compensate`)."""
    X = model.inputs(temperature, recording.fs_hz, causal=(mode == "causal"), bounds=bounds)
    if clamp is None:
        clamp = True if mode == "causal" else model.clip_inputs
    predicted = model.predict(X, clamp=clamp)
    drift_model = np.sum(list(predicted.values()), axis=0)
    summary = {"mode": mode, "kind": model.kind, "parallel": model.parallel, "clamp": bool(clamp)}
    summary["ranges"], summary["warnings"] = _ranges(recording.name, _Seen(model, causal=mode == "causal").add(X), model, clamp)
    if mode == "full" and model.parallel:
        if seed is None:
            seed = model.obj.get("settings", {}).get("decompose_seed")
        parts, classes = _parallel_segments(recording, model, seed, workers, callback, bounds)
        summary["decompose_seed"] = seed
        compensated = sum(parts.values()) - drift_model
        if len(classes) == 1:
            summary["classes"] = classes[0]
        else:
            summary["segment_classes"] = classes
    else:
        compensated = rate - drift_model
    return drift_model, compensated, summary


def _parallel_segments(recording, model: DriftModel, seed, workers, callback, bounds):
    """The class sums and classes of each gap-free range (:func:`~gyrocomp.pipeline.signal_path.class_sums`), with the model's settings."""
    from gyrocomp.classify import ClassifySettings
    from gyrocomp.decompose import DecomposeSettings
    from gyrocomp.denoise import DenoiseSettings

    settings = model.obj.get("settings", {})
    name = model.name
    decompose_settings = bind(DecomposeSettings, settings.get("decompose"), f"{name} settings.decompose")
    classify_settings = bind(ClassifySettings, settings.get("classify"), f"{name} settings.classify")
    denoise_settings = bind(DenoiseSettings, settings.get("denoise"), f"{name} settings.denoise")
    return class_sums(
        recording.rate_dps, bounds, decompose_settings, classify_settings, denoise_settings,
        seed=seed, time_s=recording.time_s, name=recording.name, workers=workers, callback=callback,
    )


class _Seen:
    """Running minimum, maximum and count outside the training range of each input [T, dT/dt]."""

    def __init__(self, model: DriftModel, inputs=("temperature", "dT/dt"), *, causal: bool = False):
        """`causal`: dT/dt is judged against the training run's range by the causal estimator, the one compensating now."""
        self.inputs = inputs
        rates = () if len(inputs) < 2 else (model.causal_rate_range_c_per_s if causal else model.rate_range_c_per_s,)
        self.ranges = (model.temperature_range_c, *rates)
        self.warn_rate = len(inputs) > 1 and model.uses_rate
        self.rows = 0
        self.low, self.high = [math.inf] * len(inputs), [-math.inf] * len(inputs)
        self.outside = [0] * len(inputs)

    def add(self, X: np.ndarray) -> "_Seen":
        self.rows += len(X)
        for column, (lo, hi) in enumerate(self.ranges):
            x = X[:, column]
            self.low[column] = min(self.low[column], float(x.min()))
            self.high[column] = max(self.high[column], float(x.max()))
            self.outside[column] += int(np.count_nonzero((x < lo) | (x > hi)))
        return self


def _ranges(name: str, seen: _Seen, model: DriftModel, clamp: bool) -> tuple[dict, list[str]]:
    """Each input's range met against its training range; one warning per input that leaves it."""
    ranges, messages = {}, []
    inputs = (
        ("temperature_c", "temperature", "degC", seen.ranges[0]),
        ("temperature_rate_c_per_s", "dT/dt", "degC/s", seen.ranges[-1]),
    )[: len(seen.inputs)]
    for column, (key, label, unit, (lo, hi)) in enumerate(inputs):
        x_lo, x_hi = seen.low[column], seen.high[column]
        tolerance = 1e-9 * max(hi - lo, abs(lo), abs(hi))  # the training run itself, to rounding
        below, above = (d if d > tolerance else 0.0 for d in (lo - x_lo, x_hi - hi))
        outside = seen.outside[column] / seen.rows
        ranges[key] = {"min": x_lo, "max": x_hi, "training_min": lo, "training_max": hi,
                       "below_by": below, "above_by": above, "share_outside": outside}
        if (below == 0 and above == 0) or (column == 1 and not seen.warn_rate):
            continue  # a model with no dT/dt term does not extrapolate in dT/dt
        by = " and ".join(
            text for text in (f"{below:.3g} {unit} below" if below > 0 else "", f"{above:.3g} {unit} above" if above > 0 else "") if text
        )
        treated = "clamped to the range there" if clamp else "the model extrapolates there"
        message = (
            f"{name}: {label} {x_lo:.3g}..{x_hi:.3g} {unit} leaves the training range "
            f"[{lo:.3g}, {hi:.3g}] {unit} of {model.name} by {by} ({outside:.1%} of samples); {treated}"
        )
        warnings.warn(message, ExtrapolationWarning, stacklevel=3)
        messages.append(message)
    return ranges, messages
