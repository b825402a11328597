"""The ``gyrocomp`` command line (a thin shell over the library)."""

from __future__ import annotations

import importlib

from gyrocomp.cli._app import app

_COMMANDS = ("simulate", "allan", "decompose", "train", "compensate", "run", "batch", "diagnose", "classify")
"""Command modules of this package; each registers its commands on ``app``."""

for _name in _COMMANDS:
    importlib.import_module(f"gyrocomp.cli.{_name}")


def main() -> None:
    """Console-script entry point."""
    app()


__all__ = ["app", "main"]
