"""Settings of the pipeline stages this package owns: ``[pipeline]``, ``[rate]``, ``[model]``.

A pipeline config (``configs/pe-lcd-anfis.toml``, ``configs/bp.toml``, ...)
has one table per stage. This module binds the three tables that
:mod:`gyrocomp.pipeline` reads; the ``[decompose]``, ``[classify]`` and
``[denoise]`` tables belong to their stages. Defaults equal the shipped
TOML (a test checks it).

``[model]`` holds one sub-table per segment that gets a learner
(``[model.drift]``, ``[model.mixed]``); each names its ``learner`` and
passes every other key to that learner's constructor, whose signature is
the list of known keys.
"""

from __future__ import annotations

import dataclasses
import inspect

from gyrocomp.config import bind
from gyrocomp.errors import InputError

__all__ = [
    "LEARNERS",
    "SEGMENTS",
    "PipelineSettings",
    "RateSettings",
    "LearnerSpec",
    "ModelSettings",
    "SignalSettings",
    "EvaluateSettings",
    "RunSettings",
    "pipeline_settings",
    "rate_settings",
    "model_settings",
    "learner_class",
]

LEARNERS = {
    "anfis": "ANFIS",
    "elm": "ELM",
    "nsga2elm": "NSGA2ELM",
    "bp": "BPNetwork",
    "polynomial": "PolynomialDrift",
}
"""Learner names usable in ``[model.<segment>] learner = ...`` and their classes in :mod:`gyrocomp.models`."""

PIPELINE_KINDS = ("pe-lcd-anfis", "iceemdan-se-tfpf-nsga2elm", "polynomial", "firmware", "greybox", "bp", "elm", "anfis", "nsga2elm")
"""Pipeline labels ``[pipeline] kind`` may take: the two papers' pipelines and the direct comparators."""

SEGMENTS = ("drift", "mixed")
"""Segments that can carry a learner; a direct pipeline models the whole rate as ``drift``."""

MODEL_KEYS = (
    "clip_inputs", "clip_output", "max_samples", "min_temperature_span_c", "min_temperature_rate_span_c_per_s", "min_unique_variance",
    "temperature_bin_c",
)
"""Keys of the ``[model]`` table beside its segments."""


@dataclasses.dataclass(frozen=True)
class PipelineSettings:
    """The ``[pipeline]`` table.

    Parameters
    ----------
    kind : str
        Label of the pipeline in reports and in ``model.json``, one of
        :data:`PIPELINE_KINDS`.
    parallel : bool
        True: the papers' parallel processing (decompose, classify, denoise
        each class, one learner per segment). False: a direct comparator
        that models the recorded rate against (T, dT/dt), with no
        decomposition (the BP, ELM and polynomial baselines).
    """

    kind: str = "polynomial"
    parallel: bool = False

    def __post_init__(self):
        if self.kind not in PIPELINE_KINDS:
            raise InputError(f"[pipeline] kind = {self.kind!r}; known: {', '.join(PIPELINE_KINDS)}")
        if not isinstance(self.parallel, bool):
            raise InputError(f"[pipeline] parallel = {self.parallel!r} must be true or false")


@dataclasses.dataclass(frozen=True)
class RateSettings:
    """The ``[rate]`` table: the temperature-rate estimator (see :mod:`gyrocomp.pipeline.rate`).

    Parameters
    ----------
    method : {"savgol"}
        Local polynomial least-squares derivative (Savitzky-Golay).
    window_s : float
        Length of the fitting window in seconds.
    polyorder : int
        Order of the local polynomial (1: a local straight line).
    """

    method: str = "savgol"
    window_s: float = 60.0
    polyorder: int = 1

    def __post_init__(self):
        if self.method != "savgol":
            raise InputError(f"[rate] method = {self.method!r}; the only method is 'savgol'")
        if not 0 < self.window_s < float("inf"):
            raise InputError(f"[rate] window_s = {self.window_s!r} must be a finite number > 0 s")
        if not 1 <= self.polyorder <= 4:
            raise InputError(f"[rate] polyorder = {self.polyorder!r} must be in 1..4")


@dataclasses.dataclass(frozen=True)
class LearnerSpec:
    """One ``[model.<segment>]`` table: a learner name and its constructor arguments."""

    learner: str
    params: dict

    def build(self, seed: int | None = None):
        """A fresh, unfitted learner; `seed` fills its ``seed`` when the config leaves it out."""
        cls = learner_class(self.learner)
        params = dict(self.params)
        if "seed" in inspect.signature(cls).parameters and "seed" not in params:
            params["seed"] = seed
        return cls(**params)

    @property
    def normalise_inputs(self) -> bool:
        """Map the inputs' training range to [-1, 1]; not for the polynomial, whose ``reference_temperature`` is in degC."""
        return self.learner != "polynomial"

    def to_dict(self) -> dict:
        return {"learner": self.learner, **self.params}


@dataclasses.dataclass(frozen=True)
class ModelSettings:
    """The ``[model]`` table: a :class:`LearnerSpec` per segment that carries a learner.

    Parameters
    ----------
    segments : dict of str to LearnerSpec
        ``drift`` and, in parallel pipelines, optionally ``mixed``.
    clip_inputs : bool
        Hold each input at the edge of its training range before the
        learners see it (``[model] clip_inputs``): a learner is then never
        asked to extrapolate, its prediction beyond the range is that at the
        edge. False lets the model's own form extrapolate, right for a
        polynomial with a physical temperature-rate term.
    clip_output : bool
        Hold each segment's predicted drift inside the range of that
        segment's training target. The box of input ranges does not stop a
        learner from meeting a combination it never saw (a heating ramp at
        -35 degC when training only cooled there); with few rules firing on
        few samples, ANFIS consequents then predict drifts of tens of deg/s.
    max_samples : int
        Train on at most this many samples: longer runs are reduced to the
        means of consecutive blocks of ``ceil(n / max_samples)`` samples
        (inputs and targets alike; the drift varies over minutes, the
        blocks last seconds). 0 trains on every sample.
    min_temperature_span_c : float
        Refuse to train when the training temperature spans less [degC]: a
        run that never left one temperature has no drift to learn, and the
        powers of (T - T_ref) and dT/dt (round-off about zero) make the
        least-squares problem rank-deficient (a polynomial fitted on a
        constant-temperature run had a dT/dt coefficient of -4.9e15).
    min_temperature_rate_span_c_per_s : float
        Likewise for the spread of dT/dt [degC/s]: a run that only ramped at
        one rate cannot tell a dT/dt sensitivity from the offset. Not
        checked for a polynomial, which leaves such a term out instead.
    min_unique_variance : float
        Least share ``1 - R^2`` of a term's variation over the training
        block means that the terms before it must leave unexplained for the
        term to be fitted (:mod:`gyrocomp.identifiability`): 0.01, a
        variance inflation factor of 100.
    temperature_bin_c : float
        0, or the width [degC] of the bins within which the training block
        means are averaged before the fit, so that every degree weighs the
        same (:func:`gyrocomp.pipeline.coverage.even_over_temperature`;
        ``train --even-temperature``).
    """

    segments: dict
    clip_inputs: bool = True
    clip_output: bool = True
    max_samples: int = 2000
    min_temperature_span_c: float = 2.0
    min_temperature_rate_span_c_per_s: float = 1e-4
    min_unique_variance: float = 0.01
    temperature_bin_c: float = 0.0

    def to_dict(self) -> dict:
        head = {
            "clip_inputs": self.clip_inputs,
            "clip_output": self.clip_output,
            "max_samples": self.max_samples,
            "min_temperature_span_c": self.min_temperature_span_c,
            "min_temperature_rate_span_c_per_s": self.min_temperature_rate_span_c_per_s,
            "min_unique_variance": self.min_unique_variance,
            **({"temperature_bin_c": self.temperature_bin_c} if self.temperature_bin_c else {}),  # absent: models trained before it keep their bytes
        }
        return {**head, **{name: spec.to_dict() for name, spec in self.segments.items()}}


def pipeline_settings(config: dict, source: str) -> PipelineSettings:
    """Bind the ``[pipeline]`` table of a loaded config."""
    return bind(PipelineSettings, config.get("pipeline"), f"{source} [pipeline]")


def rate_settings(config: dict, source: str) -> RateSettings:
    """Bind the ``[rate]`` table of a loaded config (all defaults when absent)."""
    return bind(RateSettings, config.get("rate"), f"{source} [rate]")


def model_settings(config: dict, source: str, parallel: bool) -> ModelSettings:
    """Read the ``[model]`` table: ``[model.drift]`` is required, ``[model.mixed]`` only in parallel pipelines.

    Raises
    ------
    InputError
        No ``[model.drift]``, an unknown segment or learner, or a key the
        learner's constructor does not take (the message lists the known ones).
    """
    table = dict(config.get("model") or {})
    if not isinstance(table.get("drift"), dict):
        raise InputError(f"{source}: needs a [model.drift] table naming its `learner`")
    clips = {key: table.pop(key, True) for key in ("clip_inputs", "clip_output")}
    for key, value in clips.items():
        if not isinstance(value, bool):
            raise InputError(f"{source} [model]: {key} = {value!r} should be true or false")
    max_samples = table.pop("max_samples", 2000)
    if isinstance(max_samples, bool) or not isinstance(max_samples, int) or max_samples < 0:
        raise InputError(f"{source} [model]: max_samples = {max_samples!r} should be an integer >= 0")
    spans = {
        key: table.pop(key, default)
        for key, default in (
            ("min_temperature_span_c", 2.0), ("min_temperature_rate_span_c_per_s", 1e-4), ("min_unique_variance", 0.01), ("temperature_bin_c", 0.0)
        )
    }
    for key, value in spans.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < float("inf"):
            raise InputError(f"{source} [model]: {key} = {value!r} should be a finite number >= 0")
    allowed = SEGMENTS if parallel else ("drift",)
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InputError(
            f"{source} [model]: unknown segment or key {', '.join(unknown)}; known: {', '.join(MODEL_KEYS)}, {', '.join(allowed)}"
        )
    segments = {}
    for segment in allowed:
        if segment not in table:
            continue
        entry = dict(table[segment])
        where = f"{source} [model.{segment}]"
        name = entry.pop("learner", None)
        if name not in LEARNERS:
            raise InputError(f"{where}: learner = {name!r}; choose one of {', '.join(LEARNERS)}")
        known = [p for p in inspect.signature(learner_class(name)).parameters if p != "self"]
        bad = sorted(set(entry) - set(known))
        if bad:
            raise InputError(f"{where}: unknown setting {', '.join(bad)} for {name}; known: {', '.join(known)}")
        segments[segment] = LearnerSpec(learner=name, params=entry)
    return ModelSettings(segments=segments, max_samples=max_samples, **clips, **spans)


def learner_class(name: str) -> type:
    """The :mod:`gyrocomp.models` class of a learner name in :data:`LEARNERS`."""
    import gyrocomp.models as models

    if name not in LEARNERS:
        raise InputError(f"unknown learner {name!r}; choose one of {', '.join(LEARNERS)}")
    return getattr(models, LEARNERS[name])


@dataclasses.dataclass(frozen=True)
class SignalSettings:
    """The ``[signal]`` table of a run config: the angular rate injected into the test run.

    Signal preservation (DESIGN.md, "Honest evaluation") adds this known
    rate to the held-out recording before any processing and measures how
    much of it each pipeline passes through.

    Parameters
    ----------
    amplitude_dps : float
        Amplitude of the steps and of each sine [deg/s].
    step_s : float
        Dwell of each step level [s]; the levels cycle 0, +A, 0, -A.
    sine_hz : tuple of float
        Sine frequencies [Hz]; each must lie below a quarter of the sample rate.
    """

    amplitude_dps: float = 0.05
    step_s: float = 1200.0
    sine_hz: tuple = (0.002, 0.01, 0.05)

    def __post_init__(self):
        if not self.amplitude_dps > 0:
            raise InputError(f"[signal] amplitude_dps = {self.amplitude_dps!r} must be > 0")
        if not self.step_s > 0:
            raise InputError(f"[signal] step_s = {self.step_s!r} must be > 0")
        if any(not f > 0 for f in self.sine_hz):
            raise InputError(f"[signal] sine_hz = {list(self.sine_hz)!r}: frequencies must be > 0")


@dataclasses.dataclass(frozen=True)
class EvaluateSettings:
    """The ``[evaluate]`` table of a run config.

    Parameters
    ----------
    block_s : float
        Length of the blocks whose means measure the residual temperature
        drift [s] (DESIGN.md: 100 s means).
    taus : str
        Averaging times of the Allan deviation (``gyrocomp.allan``'s choice).
    """

    block_s: float = 100.0
    taus: str = "octave"

    def __post_init__(self):
        if not self.block_s > 0:
            raise InputError(f"[evaluate] block_s = {self.block_s!r} must be > 0 s")


@dataclasses.dataclass(frozen=True)
class RunSettings:
    """The ``[run]`` table of a run config (``configs/compare.toml``).

    Parameters
    ----------
    methods : tuple of str
        Pipeline configs to compare (paths, or names in ``configs/``).
    modes : tuple of str
        Modes in which the parallel pipelines are scored; direct pipelines
        have a single (causal) mode.
    overrides : tuple of str
        ``method:table.key=value`` assignments applied to one method's
        config (e.g. a smaller ensemble to keep ``make run`` short); the
        report lists them.
    """

    methods: tuple = ("pe-lcd-anfis", "iceemdan-se-tfpf-nsga2elm", "bp", "elm", "polynomial", "greybox")
    modes: tuple = ("full", "causal")
    overrides: tuple = ()

    def __post_init__(self):
        if not self.methods:
            raise InputError("[run] methods is empty")
        bad = [m for m in self.modes if m not in ("full", "causal")]
        if bad or not self.modes:
            raise InputError(f"[run] modes = {list(self.modes)!r}; choose from full, causal")
        for entry in self.overrides:
            method, sep, assignment = str(entry).partition(":")
            if not sep or "=" not in assignment:
                raise InputError(f"[run] overrides entry {entry!r}: expected 'method:table.key=value'")
