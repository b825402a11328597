"""Pipelines end to end: train a drift model, compensate a recording, compare methods.

Public API
----------
:func:`train_direct`, :func:`train_parallel`
    Fit a config's learners; return the ``model.json`` object.
:func:`load_model`, :func:`compensate`
    Apply a model in ``full`` or ``causal`` mode.
:func:`compensate_to_files`
    Read a recording and a model, compensate, write the artefacts (the CLI's sequence).
:func:`run`
    The whole chain for several methods, scored on a held-out run, with the report.
:mod:`gyrocomp.pipeline.rate`
    The temperature-rate estimator (centred and causal Savitzky-Golay slope).
:mod:`gyrocomp.pipeline.evaluate`
    Residual drift of block means, signal preservation, Allan terms.
"""

from gyrocomp.pipeline.compensate import ExtrapolationWarning, compensate, load_model
from gyrocomp.pipeline.run import compensate_to_files, run
from gyrocomp.pipeline.train import train_direct, train_parallel

__all__ = ["train_direct", "train_parallel", "load_model", "compensate", "ExtrapolationWarning", "run", "compensate_to_files"]
