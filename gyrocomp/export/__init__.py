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

from gyrocomp.errors import InputError

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
        PX4 slot (0..3, default 0) or ArduPilot IMU (1..3, default 1).
    device_id : int
        PX4 ``TC_G<i>_ID``.
    vectors : gyrocomp.recordings.Recording or None
        c: the recording whose first `n_vectors` samples become the test
        vectors (default: a synthetic sweep across and beyond the training ranges).
    n_vectors : int
    prefix : str
        c: prefix of the header's names.
    """

    fit_polynomial: bool = False
    axis: str = "x"
    instance: int | None = None
    device_id: int = 0
    vectors: object = None
    n_vectors: int = 2048
    prefix: str = "gyrocomp"


@dataclasses.dataclass(frozen=True)
class Format:
    """One export format: its usual file suffix and its writer ``(model, options) -> (text, summary)``."""

    suffix: str
    write: Callable


def export_model(model, fmt: str, options: ExportOptions = ExportOptions()) -> tuple[str, dict]:
    """Write a loaded model (:func:`gyrocomp.pipeline.load_model`) in `fmt`.

    Returns
    -------
    text : str
        The file's content.
    summary : dict
        ``format``, and for a fitted stand-in ``added_error_deg_h`` (``rms``, ``max``).

    Raises
    ------
    InputError
        An unknown format, or a model the format cannot hold (one line naming what it lacks).
    """
    if fmt not in FORMATS:
        raise InputError(f"--format {fmt!r}; choose {', '.join(FORMATS)}")
    text, summary = FORMATS[fmt].write(model, options)
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
        recording = recordings.recording_from_frame(frame, name="sweep")
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


def _cubics(model, options: ExportOptions, max_degree: int = 3) -> tuple[dict, dict]:
    from gyrocomp.export.cubic import exact_cubic, nearest_cubic

    if options.fit_polynomial:
        try:
            cubic = exact_cubic(model, max_degree)
        except InputError:
            cubic = nearest_cubic(model, max_degree)
    else:
        cubic = exact_cubic(model, max_degree)
    summary = {"axis": options.axis}
    if cubic.added_error_deg_h is not None:
        summary["added_error_deg_h"] = cubic.added_error_deg_h
    return {options.axis: cubic}, summary


def _px4(model, options: ExportOptions):
    from gyrocomp.export.firmware import px4_params

    cubics, summary = _cubics(model, options)
    instance = 0 if options.instance is None else options.instance
    return px4_params(cubics, instance=instance, device_id=options.device_id, source=model.name), summary


def _ardupilot(model, options: ExportOptions):
    from gyrocomp.export.firmware import ardupilot_params

    cubics, summary = _cubics(model, options)
    instance = 1 if options.instance is None else options.instance
    return ardupilot_params(cubics, instance=instance, source=model.name), summary


def _c(model, options: ExportOptions):
    from gyrocomp.export.c import c_header
    from gyrocomp.export.plain import plain_model

    vectors = reference_vectors(model, options.vectors, options.n_vectors)
    return c_header(plain_model(model, centred=True), vectors, prefix=options.prefix), {"n_vectors": len(vectors["temperature_c"])}


def _json_plain(model, options: ExportOptions):
    from gyrocomp.export.plain import plain_model

    return json.dumps(plain_model(model), indent=1) + "\n", {}


FORMATS = {
    "px4": Format(".params", _px4),
    "ardupilot": Format(".parm", _ardupilot),
    "c": Format(".h", _c),
    "json-plain": Format(".json", _json_plain),
}
"""Export formats by name."""
