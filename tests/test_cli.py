"""The command line as a whole: help on every command, version, start-up cost."""

from __future__ import annotations

import inspect
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from gyrocomp import __version__
from gyrocomp.cli import app

runner = CliRunner()


def _commands():
    import typer.main

    group = typer.main.get_command(app)
    return sorted(group.commands)


def test_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.stdout.strip() == f"gyrocomp {__version__}"


def test_version_matches_the_package_metadata():
    from importlib.metadata import version

    assert version("gyrocomp") == __version__


@pytest.mark.parametrize("command", _commands())
def test_every_command_has_help(command):
    result = runner.invoke(app, [command, "--help"])
    assert result.exit_code == 0
    group_help = runner.invoke(app, ["--help"]).stdout
    assert command in group_help
    assert len(result.stdout.strip().splitlines()) > 3


def test_start_up_imports_no_heavy_module():
    """`gyrocomp --help` must stay fast: no numeric stack at import time, nor rich (made where a table is printed) or pydantic."""
    code = (
        "import sys, gyrocomp.cli\n"
        "heavy = [m for m in ('numpy', 'pandas', 'scipy', 'matplotlib', 'sklearn', 'pyarrow', 'rich', 'pydantic') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_commands_annotations_are_evaluated_when_defined():
    """typer reads every command's parameters at each start; string annotations would be compiled and evaluated there.

    Without ``from __future__ import annotations`` in ``gyrocomp/cli`` the
    annotations are objects made when the module is imported (from its
    byte code), so building the command group compiles none of them.
    """
    import typer.main

    group = typer.main.get_command(app)
    assert len(group.commands) == len(_commands()) >= 10
    for name, command in group.commands.items():
        hints = inspect.unwrap(command.callback).__annotations__
        strings = [key for key, hint in hints.items() if isinstance(hint, str)]
        assert not strings, f"gyrocomp {name}: annotations {strings} are strings (from __future__ import annotations in its cli module?)"


def test_unknown_command_is_a_usage_error():
    result = runner.invoke(app, ["frobnicate"])
    assert result.exit_code == 2


def test_main_asks_for_one_blas_thread_unless_told_otherwise(monkeypatch):
    import gyrocomp.cli as cli

    monkeypatch.setattr(cli, "app", lambda: None)
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    cli.main()
    import os

    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    assert os.environ["OMP_NUM_THREADS"] == "2"
