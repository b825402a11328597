"""The grey-box model in the pipeline: ``train REC [REC ...] --config greybox`` and its causal compensation.

A ``greybox`` config (``configs/greybox.toml``) has a ``[pipeline]`` table
(``kind = "greybox"``) and a ``[greybox]`` table: the arguments of
:class:`gyrocomp.models.greybox.GreyBoxDrift` and ``starts_at_power_on``.
Each axis of the recordings gets its model, fitted on every training
recording at once (each its own run: an offset each, the physics shared).
``model.json`` holds, per axis, the estimator's :meth:`~GreyBoxDrift.to_dict`
under ``greybox``, its training ranges, and ``not_fitted``: the terms the
runs could not identify, with the reason.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import numpy as np

from gyrocomp import artefacts
from gyrocomp.errors import InputError
from gyrocomp.models.greybox import GreyBoxDrift, TrainingRun

__all__ = ["GreyBoxModel", "greybox_params", "train_greybox", "load_greybox"]

CONFIG_KEYS = ("starts_at_power_on",)
"""Keys of ``[greybox]`` beside the estimator's arguments."""


def greybox_params(config: dict, source: str) -> tuple[dict, bool]:
    """The estimator's arguments and ``starts_at_power_on`` from a config's ``[greybox]`` table (names checked)."""
    table = dict(config.get("greybox") or {})
    known = [p for p in inspect.signature(GreyBoxDrift).parameters]
    bad = sorted(set(table) - set(known) - set(CONFIG_KEYS))
    if bad:
        raise InputError(f"{source} [greybox]: unknown setting {', '.join(bad)}; known: {', '.join(known + list(CONFIG_KEYS))}")
    power_on = table.pop("starts_at_power_on", True)
    if not isinstance(power_on, bool):
        raise InputError(f"{source} [greybox]: starts_at_power_on = {power_on!r} should be true or false")
    return {k: tuple(v) if isinstance(v, list) else v for k, v in table.items()}, power_on


def train_greybox(runs: list, config: dict, *, source: str, seed: int | None = 0) -> dict:
    """A grey-box model per axis, each fitted on the same axis of every run.

    Parameters
    ----------
    runs : list of gyrocomp.recordings.Recording
        The training recordings, each with temperature; they must hold the same axes.
    config : dict
        A loaded ``greybox`` config.
    source : str
        The config's name, for messages and the header.
    seed : int or None
        Recorded in the header (the fit draws no random numbers).

    Returns
    -------
    models : dict of str to dict
        Per axis name, the model (:func:`gyrocomp.pipeline.model_file.model_file` gathers them).
    units : dict of str to str
    """
    params, power_on = greybox_params(config, source)
    names = runs[0].axis_names
    for rec in runs[1:]:
        if rec.axis_names != names:
            raise InputError(f"{rec.name}: axes {', '.join(rec.axis_names)} differ from {runs[0].name}'s {', '.join(names)}; train on recordings of the same axes")
    inputs = [rec.input_record() for rec in runs]
    settings = {"pipeline": config.get("pipeline", {}), "greybox": {**params, "starts_at_power_on": power_on}}
    models, units = {}, {}
    for name in names:
        axes = [rec.axis(name) for rec in runs]
        training = [
            TrainingRun(a.time_s, a.temperature_c, a.rate_dps, list(rec.segments), float(a.time_s[0]) if power_on else None, a.name)
            for rec, a in zip(runs, axes)
        ]
        estimator = GreyBoxDrift(**params).fit(training)
        header = artefacts.artefact_header("gyrocomp.model", inputs=inputs, settings=settings, seed=seed)
        models[name] = {
            **header,
            "kind": "greybox",
            "parallel": False,
            "starts_at_power_on": power_on,
            "formula": (
                "drift = offset + sum_k c_k z^k + g dT/dt + a |dT/dt| + h H_w(T) + h2 P_w2(T) + l (T_e2 - T_e) / half_range "
                "+ A exp(-t_on / tau_w) + A2 exp(-t_on / tau_w2), H_w a play or a relay of width w, P_w2 a second play, "
                "z = (T_e - centre) / half_range, tau_e dT_e/dt = T - T_e, dT/dt = (T - T_f) / tau_r (causal, tau_r fitted; "
                "s tanh(dT/dt / s) in its place where it saturates), "
                "states carried sample by sample (gyrocomp.effects._stateful)"
            ),
            "greybox": estimator.to_dict(),
            "not_fitted": estimator.not_fitted_,
            "training": {
                "temperature_c": {"min": float(min(a.temperature_c.min() for a in axes)), "max": float(max(a.temperature_c.max() for a in axes))},
                "element_temperature_c": dict(zip(("min", "max"), estimator.temperature_range_c_)),
                "temperature_rate_c_per_s": dict(zip(("min", "max"), estimator.rate_range_c_per_s_)),
                "n_samples": int(sum(a.time_s.size for a in axes)),
                "n_runs": len(axes),
                "n_segments": int(sum(len(rec.segments) for rec in runs)),
            },
        }
        models[name]["static_part"] = {"cost_deg_h": _static_cost(estimator, training)}
        units[name] = axes[0].axes[0].unit
    return models, units


def _static_cost(estimator: GreyBoxDrift, runs: list, block_s: float = 100.0) -> dict:
    """What the offset and cubic at the measured temperature alone (firmware parameters) leave of the whole model on the training runs.

    RMS and largest absolute value [deg/h] of the 100 s means (DESIGN.md's
    residual-drift convention) of the whole model minus its static part.
    """
    lost = []
    for run in runs:
        whole = estimator.predict(run.time_s, run.temperature_c, segments=run.segments)
        static = estimator.static(run.temperature_c)
        per_block = max(1, int(round(block_s / float(np.median(np.diff(run.time_s))))))
        k = run.time_s.size // per_block
        lost.append((whole - static)[: k * per_block].reshape(k, per_block).mean(axis=1) * 3600.0)
    lost = np.concatenate(lost)
    return {"rms": float(np.sqrt(np.mean(lost**2))), "max": float(np.max(np.abs(lost)))}


@dataclasses.dataclass
class GreyBoxModel:
    """A ``greybox`` model of one axis read from ``model.json``: what :mod:`gyrocomp.pipeline.compensate` needs."""

    obj: dict
    name: str
    estimator: GreyBoxDrift
    starts_at_power_on: bool
    kind: str = "greybox"
    parallel: bool = False

    @property
    def temperature_range_c(self) -> tuple[float, float]:
        r = self.obj["training"]["temperature_c"]
        return float(r["min"]), float(r["max"])

    def static(self, temperature_c) -> np.ndarray:
        """The settled bias [deg/s] at each temperature (:meth:`GreyBoxDrift.static`)."""
        return self.estimator.static(temperature_c)

    def inputs(self, temperature_c, fs_hz: float, *, causal: bool, bounds=None) -> np.ndarray:
        """[T, dT/dt] by the static models' estimator (:func:`gyrocomp.pipeline.train.segment_inputs`), for plots' heating and cooling branches."""
        from gyrocomp.pipeline.settings import RateSettings
        from gyrocomp.pipeline.train import segment_inputs

        return segment_inputs(temperature_c, fs_hz, RateSettings(), bounds, causal=causal)

    def drift(self, time_s, temperature_c, *, bounds=None, clamp: bool = True) -> np.ndarray:
        """The modelled bias [deg/s] of a recording, causally; a gapped one by its segments (bridged by default)."""
        return self.estimator.predict(time_s, temperature_c, segments=bounds, clamp=clamp)

    def stream(self, clamp: bool = True):
        """A causal compensator carrying the state across chunks (:class:`~gyrocomp.models.greybox.GreyBoxStream`)."""
        return self.estimator.stream(clamp=clamp)


def load_greybox(obj: dict, name: str) -> GreyBoxModel:
    """Check and rebuild a ``greybox`` axis model; a malformed one is refused, named."""
    try:
        estimator = GreyBoxDrift.from_dict(obj["greybox"], name)
        if estimator.to_dict()["fitted"] is None:
            raise InputError(f"{name}: the greybox model holds no fitted parameters")
        power_on = obj["starts_at_power_on"]
        if not isinstance(power_on, bool):
            raise InputError(f"{name}: `starts_at_power_on` must be true or false, got {power_on!r}")
        lo, hi = (float(obj["training"]["temperature_c"][k]) for k in ("min", "max"))
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise InputError(f"{name}: training temperature range {lo}..{hi} is not a finite range")
    except InputError:
        raise
    except (KeyError, TypeError, ValueError) as err:
        raise InputError(f"{name}: corrupted model ({type(err).__name__}: {err})") from None
    return GreyBoxModel(obj, name, estimator, power_on)
