"""``gyrocomp export``: a trained ``model.json`` as firmware parameters, a C header or plain JSON.

Public API
----------
:data:`FORMATS`
    The registry: format name to :class:`Format` (file suffix, writer).
:func:`export_model`
    A loaded model in one format: the text and a summary.
:mod:`gyrocomp.export.cubic`, :mod:`gyrocomp.export.firmware`, :mod:`gyrocomp.export.plain`, :mod:`gyrocomp.export.c`
    The polynomial in physical units, PX4 / ArduPilot parameters, the
    normalisation-free model, the C99 header.
"""

from __future__ import annotations

import dataclasses
import json
from typing import Callable

import numpy as np

from gyrocomp import units
from gyrocomp.errors import InputError
from gyrocomp.export.firmware import AXES, SENSORS

__all__ = ["Format", "FORMATS", "ExportOptions", "export_model", "reference_vectors"]


@dataclasses.dataclass(frozen=True)
class ExportOptions:
    """What a format may need beside the model.

    Attributes
    ----------
    fit_polynomial : bool
        px4 / ardupilot: fit the nearest cubic to a model the format cannot
        hold, instead of refusing it.
    axis : str
        Firmware axis (x, y, z) of a single-axis model.
    instance : int or None
        PX4 slot (0..3, default 0) or ArduPilot IMU (1..3, default 1) of a
        model not trained from a flight log (which names its own).
    device_id : int
        PX4 ``TC_G<i>_ID`` / ``TC_A<i>_ID`` of such a model.
    vectors : gyrocomp.recordings.Recording or None
        c: the recording whose first `n_vectors` samples become the test
        vectors (default: a synthetic sweep across and beyond the training ranges).
    n_vectors : int
    prefix : str
        c: prefix of the header's names.
    static_part : bool
        px4 / ardupilot: write a grey-box model's static part (its offset and
        cubic in temperature), dropping its lag, dT/dt, hysteresis and
        warm-up; the summary gives what that costs on the training runs.
    """

    fit_polynomial: bool = False
    axis: str = "x"
    instance: int | None = None
    device_id: int = 0
    vectors: object = None
    n_vectors: int = 2048
    prefix: str = "gyrocomp"
    static_part: bool = False


@dataclasses.dataclass(frozen=True)
class Format:
    """One export format: its usual file suffix, its writer ``(model, options) -> (text, summary)`` and the units it has parameters for.

    `units` is checked for every axis before writing (:func:`gyrocomp.units.check_exportable`):
    a format that adds accelerometer parameters adds ``"m/s^2"`` here.
    """

    suffix: str
    write: Callable
    units: tuple[str, ...] = ("deg/s",)


def export_model(model, fmt: str, options: ExportOptions = ExportOptions()) -> tuple[str, dict]:
    """Write a loaded model in `fmt`.

    Parameters
    ----------
    model : DriftModel or dict of str to DriftModel
        One model (:func:`gyrocomp.pipeline.load_model`), or one per axis
        (:func:`gyrocomp.pipeline.compensate.load_models`). px4 and
        ardupilot write every sensor instance into one file: an axis trained
        from a flight log goes to its own instance with its device id
        (``sensor`` in ``model.json``), any other to ``options.instance`` by
        its unit (gyro deg/s, accelerometer m/s^2). Within an instance the
        firmwares' axes x, y, z are the axes named so or ending so (``gx``,
        ``gyro_y``), else the first three in order; a single model goes to
        ``options.axis``.
        ``c`` writes one block of names per axis (prefix ``<prefix>_<axis>``),
        ``json-plain`` one model per axis under ``axes``.

    Returns
    -------
    text : str
        The file's content.
    summary : dict
        ``format``; for px4 / ardupilot ``reference`` (one line: TREF, TMIN,
        TMAX of each instance and the convention), for px4 ``zero_ids``
        (the ``TC_*_ID`` written as 0); for a fitted stand-in
        ``added_error_deg_h`` (``rms``, ``max``).

    Raises
    ------
    InputError
        An unknown format, or a model the format cannot hold (one line naming what it lacks).
    """
    if fmt not in FORMATS:
        raise InputError(f"--format {fmt!r}; choose {', '.join(FORMATS)}")
    models = dict(model) if isinstance(model, dict) else {None: model}
    if not models:
        raise InputError("export: the model holds no axis")
    for one in models.values():
        units.check_exportable(one, fmt, FORMATS[fmt].units)
    text, summary = FORMATS[fmt].write(models, options)
    return text, {"format": fmt, **summary}


def reference_vectors(model, recording=None, n: int = 2048) -> dict:
    """Inputs and the outputs of causal compensation for them, the C header's test vectors.

    With no recording: `n` samples at the model's rate of a temperature
    swinging 10 % beyond the training range (quantised to 1/16 degC, as
    sensors are) at up to twice the training dT/dt, so clamping shows, and
    a rate of a few tenths of deg/s.
    """
    import warnings

    from gyrocomp import recordings
    from gyrocomp.pipeline.compensate import ExtrapolationWarning, compensate

    if not 1 <= n:
        raise InputError(f"export --n-vectors {n}: must be >= 1")
    recordings.check_length("export_max_vectors", n, f"export --n-vectors {n}")
    if recording is None:
        (t_lo, t_hi), (r_lo, r_hi) = model.temperature_range_c, model.rate_range_c_per_s
        fs = float(model.obj["fs_hz"])
        k = np.arange(n)
        mid, half = 0.5 * (t_lo + t_hi), 0.55 * (t_hi - t_lo)
        fastest = 2.0 * max(abs(r_lo), abs(r_hi), 1e-6)
        period = max(2 * np.pi * half / fastest * fs, n / 8)  # samples
        temperature = np.round((mid + half * np.sin(2 * np.pi * k / period - np.pi / 2)) * 16) / 16
        import pandas as pd

        frame = pd.DataFrame({"time": k / fs, "rate": 0.3 * np.sin(2 * np.pi * 7 * k / n), "temperature": temperature})
        # time in seconds by declaration: a long sweep at a slow rate is no implausible time base
        recording = recordings.recording_from_frame(frame, name="sweep", columns=recordings.ColumnSpec(time_unit="s"))
    else:
        recording = recordings.recording_from_frame(recording.data.iloc[:n].reset_index(drop=True), name=recording.name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)  # leaving the ranges is the point of the vectors
        frame, _ = compensate(recording, model, "causal")
    X = model.inputs(frame["temperature"].to_numpy(), recording.fs_hz, causal=True)
    return {
        "temperature_c": frame["temperature"].to_numpy(),
        "rate_dps": frame["rate"].to_numpy(),
        "temperature_rate_c_per_s": X[:, 1],
        "drift_dps": frame["drift_model"].to_numpy(),
        "compensated_dps": frame["compensated"].to_numpy(),
    }


def _firmware_axes(models: dict, options: ExportOptions) -> dict:
    """Firmware axis letter of each model axis of one sensor (see :func:`export_model`)."""
    if len(models) == 1:
        name = next(iter(models))
        low = str(name).lower()
        return {name: low[-1] if low[-1:] in AXES and "sensor" in models[name].obj else options.axis}
    if len(models) > 3:
        raise InputError(f"export: {len(models)} axes of one sensor ({', '.join(map(str, models))}); a firmware sensor has x, y and z")
    letters = {}
    for index, name in enumerate(models):
        low = str(name).lower()
        letters[name] = low if low in AXES else (low[-1] if low[-1:] in AXES else None)
    if None in letters.values() or len(set(letters.values())) != len(letters):
        letters = {name: AXES[index] for index, name in enumerate(models)}
    return letters


def _sensors(models: dict, options: ExportOptions) -> dict:
    """The models grouped by sensor instance: ``(sensor, instance, device id)`` to ``{axis: model}``.

    An axis trained from a flight log carries its instance and device id
    (``sensor`` in ``model.json``: :func:`gyrocomp.pipeline.model_file.model_file`);
    any other to instance None (the format's ``--instance``) and ``options.device_id``, by unit.
    """
    logged = [name for name, model in models.items() if "sensor" in model.obj]
    if logged and (options.instance is not None or options.device_id):
        given = "--instance" if options.instance is not None else "--device-id"
        raise InputError(f"export {given}: the model's instances and device ids come from its log ({logged[0]}: {models[logged[0]].obj['sensor'].get('stream')}); drop {given}")
    groups: dict = {}
    for name, model in models.items():
        sensor = SENSORS[units.model_unit(model)]
        if name in logged:
            key = (sensor, *_logged_ids(model))
        else:
            key = (sensor, None, int(options.device_id))
        groups.setdefault(key, {})[name] = model
    return groups


def _logged_ids(model) -> tuple[int, int]:
    """The instance and device id of a flight-log axis (``sensor`` in ``model.json``), checked: a hand-edited value is refused, named."""
    info = model.obj["sensor"]
    ids = tuple(info.get(key, 0) if isinstance(info, dict) else None for key in ("instance", "device_id"))
    for key, value in zip(("instance", "device_id"), ids):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise InputError(f"{model.name}: sensor {key} = {value!r}; a log's instance and device id are integers >= 0")
    return ids


def _blocks(models: dict, options: ExportOptions, default_instance: int) -> tuple[list, dict]:
    """A :class:`~gyrocomp.export.firmware.Block` per sensor instance, with each axis' cubic, and the summary."""
    from gyrocomp.export.cubic import exact_cubic, nearest_cubic
    from gyrocomp.export.firmware import Block

    blocks, added, axes = [], {}, {}
    for (sensor, instance, device_id), group in _sensors(models, options).items():
        instance = default_instance if instance is None else instance
        letters = _firmware_axes(group, options)
        cubics = {}
        for name, model in group.items():
            if model.kind == "greybox":
                cubic = _static_part(model, options)
            elif options.fit_polynomial:
                try:
                    cubic = exact_cubic(model)
                except InputError:
                    cubic = nearest_cubic(model)
            else:
                cubic = exact_cubic(model)
            cubics[letters[name]] = cubic
            label = letters[name] if len(models) <= 3 else f"{sensor}{instance}_{letters[name]}"
            axes[label] = name
            if cubic.added_error_deg_h is not None:
                added[label] = cubic.added_error_deg_h
        blocks.append(Block(sensor, instance, cubics, device_id))
    summary = {"axes": axes}
    if added:
        summary["added_error_deg_h"] = {key: max(a[key] for a in added.values()) for key in ("rms", "max")}
        summary["added_error_deg_h_by_axis"] = added
    return blocks, summary


def _static_part(model, options: ExportOptions):
    """A grey-box model's offset and cubic in T as a :class:`~gyrocomp.export.cubic.Cubic`, only with ``static_part``."""
    from gyrocomp.export.cubic import Cubic

    cost = model.obj["static_part"]["cost_deg_h"]
    e = model.estimator
    if not options.static_part:
        raise InputError(
            f"{model.name}: a greybox model holds state (lag, dT/dt, hysteresis, warm-up) that PX4 and ArduPilot parameters cannot; "
            f"--static-part writes its cubic in T alone, which leaves {cost['rms']:.3g} deg/h RMS ({cost['max']:.3g} at most) of 100 s means "
            "on the training runs; --format c keeps the whole model"
        )
    return Cubic(float(e.reference_temperature), tuple(e.coef_about_reference_), tuple(e.temperature_range_c_), {"rms": cost["rms"], "max": cost["max"]})


def _source(models: dict) -> str:
    return next(iter(models.values())).name.split(" axis ")[0]


def _px4(models: dict, options: ExportOptions):
    from gyrocomp.export.firmware import px4_params

    blocks, summary = _blocks(models, options, default_instance=0 if options.instance is None else options.instance)
    text, summary["reference"] = px4_params(blocks, source=_source(models))
    summary["zero_ids"] = [f"TC_{'G' if b.sensor == 'gyro' else 'A'}{b.instance}_ID" for b in blocks if b.device_id == 0]
    return text, summary


def _ardupilot(models: dict, options: ExportOptions):
    from gyrocomp.export.firmware import ardupilot_params

    blocks, summary = _blocks(models, options, default_instance=0 if options.instance is None else options.instance - 1)
    text, summary["reference"] = ardupilot_params(blocks, source=_source(models))
    return text, summary


def _c(models: dict, options: ExportOptions):
    from gyrocomp.export.c import c_header
    from gyrocomp.export.plain import plain_model

    blocks, counts = [], {}
    prefixes = _c_prefixes(models, options.prefix)
    for name, model in models.items():
        prefix = prefixes[name]
        if model.kind == "greybox":
            from gyrocomp.export.greybox_c import greybox_header, greybox_vectors

            vectors = greybox_vectors(model, options.n_vectors)
            blocks.append(greybox_header(model, vectors, prefix=prefix))
            counts[str(name)] = len(vectors["time_s"])
            continue
        recording = options.vectors
        if recording is not None:
            names = recording.axis_names
            recording = recording.axis(name if name in names else names[0])
            units.check_compensates(model, recording.axes[0].unit, recording.name, recording.axis_names[0])
        vectors = reference_vectors(model, recording, options.n_vectors)
        blocks.append(c_header(plain_model(model, centred=True), vectors, prefix=prefix))
        counts[str(name)] = len(vectors["temperature_c"])
    return "\n".join(blocks), {"n_vectors": min(counts.values()), "prefixes": len(blocks)}


def _c_prefixes(models: dict, prefix: str) -> dict:
    """The C name prefix of each axis' block: `prefix`, or ``<prefix>_<axis>`` for several axes.

    Each must be an ASCII C identifier, and no two may differ only in case:
    the include guard and macros are the upper-cased prefix, so the second
    block would be compiled out.

    Raises
    ------
    InputError
        Naming `prefix` (``--prefix``) or the axis at fault.
    """
    if not (prefix.isascii() and prefix.isidentifier()):
        raise InputError(f"--prefix {prefix!r} is not a C identifier")
    if len(models) == 1:
        return {next(iter(models)): prefix}
    out, upper = {}, {}
    for name in models:
        full = f"{prefix}_{name}"
        if not (full.isascii() and full.isidentifier()):
            raise InputError(f"export c: axis {name!r} cannot be part of a C name ({full}); rename the axis")
        if full.upper() in upper:
            raise InputError(f"export c: axes {upper[full.upper()]!r} and {name!r} differ only in case; their blocks would share the include guard {full.upper()}_H")
        upper[full.upper()] = name
        out[name] = full
    return out


def _json_plain(models: dict, options: ExportOptions):
    from gyrocomp.export.plain import PLAIN_SCHEMA, plain_model

    if len(models) == 1:
        return json.dumps(plain_model(next(iter(models.values()))), indent=1) + "\n", {}
    body = {"schema": PLAIN_SCHEMA, "axes": {str(name): plain_model(model) for name, model in models.items()}}
    return json.dumps(body, indent=1) + "\n", {}


FORMATS = {
    "px4": Format(".params", _px4, units=tuple(units.SENSOR_UNITS)),
    "ardupilot": Format(".parm", _ardupilot, units=tuple(units.SENSOR_UNITS)),
    "c": Format(".h", _c, units=tuple(units.SENSOR_UNITS)),
    "json-plain": Format(".json", _json_plain, units=tuple(units.SENSOR_UNITS)),
}
"""Export formats by name."""
