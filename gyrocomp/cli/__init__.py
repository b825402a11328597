"""The ``gyrocomp`` command line (a thin shell over the library).

Its modules do not postpone their annotations (no ``from __future__ import
annotations``): typer reads every command's parameters from them at each
start, and a string annotation is compiled and evaluated there, 0.05 s of
every command's CPU (``tests/test_cli.py`` checks they are objects). rich is
imported where a console is made, so ``--help`` and a ``--quiet`` command
import none of it.
"""

import importlib
import os
import signal

from gyrocomp.cli._app import STOP_SIGNALS, app, closed_pipe, raise_on_sigterm

_COMMANDS = ("simulate", "allan", "decompose", "train", "compensate", "export", "run", "batch", "diagnose", "classify")
"""Command modules of this package; each registers its commands on ``app``."""

for _name in _COMMANDS:
    importlib.import_module(f"gyrocomp.cli.{_name}")


_BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def main() -> None:
    """Console-script entry point.

    gyrocomp's linear algebra is many small solves (ELM candidates, ANFIS
    epochs, likelihoods of block means), where a second BLAS thread only
    spins: NSGA-II-ELM trains 5x faster with one. Parallel work goes to
    processes (``--workers``), so the command line asks for one BLAS thread
    unless the environment already says otherwise. This must happen before
    numpy loads.

    SIGTERM (``kill``, a cron timeout, a CI job cancelled) and SIGHUP (an
    ssh session hung up) unwind as Ctrl-C does, so no half-written
    temporary file is left behind.
    """
    for variable in _BLAS_THREAD_VARIABLES:
        os.environ.setdefault(variable, "1")
    for signum in STOP_SIGNALS:
        signal.signal(signum, raise_on_sigterm)
    try:
        app()
    except BrokenPipeError:  # stdout closed outside a command (e.g. `gyrocomp --help | head -1`)
        raise SystemExit(closed_pipe()) from None


__all__ = ["app", "main"]
