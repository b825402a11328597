"""``model.json``: one model per sensor axis under one header, and each axis' model read back.

:mod:`gyrocomp.pipeline.train` fits one axis at a time (a dict with the
artefact header, :func:`~gyrocomp.pipeline.train.train_direct`'s shape);
:func:`model_file` gathers the axes of a recording into the file
``compensate`` and ``export`` read, and :func:`axis_models` splits a file
back into one such dict per axis (a version-1 file, one model and no axes,
as one unnamed axis).
"""

from __future__ import annotations

from gyrocomp import artefacts
from gyrocomp.errors import InputError

__all__ = ["MODEL_SCHEMA", "MODEL_VERSION", "model_file", "axis_models"]

MODEL_SCHEMA = "gyrocomp.model"
MODEL_VERSION = "2.0"
"""``model.json`` version: 2 holds one model per sensor axis under ``axes``; 1 (one model, no axes) is still read."""
_HEADER_KEYS = ("schema", "gyrocomp_version", "inputs", "settings", "seed")


def model_file(axes: dict, units: dict | None = None, sensors: dict | None = None) -> dict:
    """The ``model.json`` object (version :data:`MODEL_VERSION`) of one model per sensor axis.

    Parameters
    ----------
    axes : dict of str to dict
        Axis name (the recording's column) to its model from
        :func:`train_direct` or :func:`train_parallel`, in output order.
        They share one header (inputs, settings, seed): the first's.
    units : dict of str to str, optional
        Unit of each axis' values and drift model (``deg/s``, ``m/s^2``).
    sensors : dict of str to dict, optional
        For an axis of a flight log, what the log says about its sensor
        (``stream``, ``autopilot``, ``instance``, PX4's ``device_id``:
        :func:`gyrocomp.flightlogs.read_logs`); ``export`` writes every
        instance with its own id.

    Returns
    -------
    dict
        The header and ``axes``: per axis its model without the header,
        ``unit``, and ``sensor`` when given.
    """
    first = next(iter(axes.values()))
    header = {key: first[key] for key in _HEADER_KEYS if key in first}
    header["schema"] = {"name": MODEL_SCHEMA, "version": MODEL_VERSION}
    body = {}
    for name, model in axes.items():
        body[name] = {key: value for key, value in model.items() if key not in _HEADER_KEYS}
        body[name]["unit"] = (units or {}).get(name, "deg/s")
        if name in (sensors or {}):
            body[name]["sensor"] = sensors[name]
    return {**header, "axes": body}


def axis_models(obj: dict, name: str = "model.json") -> dict:
    """Each axis' model of a ``model.json`` as a one-axis object with the header (:func:`train_direct`'s shape).

    A version-1 file (one model, no ``axes``) gives ``{None: obj}``: one axis, unnamed.

    Raises
    ------
    SchemaError
        Not a ``gyrocomp.model``, or of a newer major version.
    InputError
        Version 2 without ``axes``.
    """
    artefacts.check_header(obj, MODEL_SCHEMA, name, supported_major=int(MODEL_VERSION.split(".")[0]))
    if int(str(obj["schema"]["version"]).split(".")[0]) < 2:
        return {None: obj}
    axes = obj.get("axes")
    if not isinstance(axes, dict) or not axes or not all(isinstance(v, dict) for v in axes.values()):
        raise InputError(f"{name}: no `axes` (one model per sensor axis)")
    header = {key: obj[key] for key in _HEADER_KEYS if key in obj}
    return {axis: {**header, **entry} for axis, entry in axes.items()}
