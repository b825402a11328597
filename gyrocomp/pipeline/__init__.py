"""Pipelines: train a drift model, compensate a recording, score the result.

The file-level stages (``gyrocomp train``, ``compensate``, ``run``) are in
:mod:`gyrocomp.commands`.

Public API
----------
:func:`train_direct`, :func:`train_parallel`
    Fit a config's learners; return the ``model.json`` object.
:func:`load_model`, :func:`compensate`
    Apply a model in ``full`` or ``causal`` mode.
:mod:`gyrocomp.pipeline.rate`
    The temperature-rate estimator (centred and causal Savitzky-Golay slope).
:mod:`gyrocomp.pipeline.evaluate`
    Residual drift of block means, signal preservation, Allan terms.
"""

from gyrocomp.pipeline.compensate import ExtrapolationWarning, compensate, load_model
from gyrocomp.pipeline.train import train_direct, train_parallel

__all__ = ["train_direct", "train_parallel", "load_model", "compensate", "ExtrapolationWarning"]
