"""The Typer application, its global options, and the one place errors become exit codes.

Command modules (``gyrocomp/cli/<command>.py``) decorate functions with
``@app.command()``; each parses, calls one library function, writes
atomically and prints. Heavy imports happen inside the command bodies so
that ``gyrocomp --help`` stays fast.
"""

import contextlib
import dataclasses
import os
import signal
import sys
import time
import traceback
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Callable, Iterator, Optional

import typer

from gyrocomp import __version__

if TYPE_CHECKING:  # rich is imported where a console is made: `--help` and a `--quiet` command need none
    from rich.console import Console

class _Group(typer.core.TyperGroup):
    """The command group; the global flags (:data:`GLOBAL_FLAGS`) are accepted after the sub-command too.

    ``gyrocomp allan x.csv --out a.json --quiet`` is read as
    ``gyrocomp --quiet allan x.csv --out a.json``: a flag found after the
    sub-command's name (and before a ``--``) is moved in front of it.
    """

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        return super().parse_args(ctx, globals_first(args))


GLOBAL_FLAGS = ("--quiet", "-q", "--debug")
"""Options of the whole program that no sub-command defines, so they may follow it."""


def globals_first(args: list[str]) -> list[str]:
    """`args` with the :data:`GLOBAL_FLAGS` that follow the sub-command moved before it."""
    command = next((i for i, a in enumerate(args) if not a.startswith("-")), len(args))
    end = args.index("--") if "--" in args[command:] else len(args)
    moved = [a for a in args[command + 1 : end] if a in GLOBAL_FLAGS]
    kept = [a for a in args[command + 1 : end] if a not in GLOBAL_FLAGS]
    return [*args[:command], *moved, *args[command : command + 1], *kept, *args[end:]]


app = typer.Typer(
    cls=_Group,
    name="gyrocomp",
    help="Temperature-drift compensation and Allan-variance scoring of MEMS gyroscope oven-test logs.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


_LOG_WIDTH = 160
"""Table width when output goes to a file or pipe rather than a terminal."""


@dataclasses.dataclass
class State:
    """Global options, passed to commands through the Typer context."""

    quiet: bool = False
    debug: bool = False


def _version(value: bool) -> None:
    if value:
        print(f"gyrocomp {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    ctx: typer.Context,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Print no tables or progress.")] = False,
    debug: Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")] = False,
    version: Annotated[
        Optional[bool],
        typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit."),
    ] = None,
) -> None:
    ctx.obj = State(quiet=quiet, debug=debug)


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where the program is so that it unwinds as Ctrl-C does; `signum` says which."""

    def __init__(self, signum: int = signal.SIGTERM):
        super().__init__(signum)
        self.signum = signum


STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals that end a run the way Ctrl-C does: ``kill`` (and a cron timeout, a cancelled CI job), and an ssh session hung up."""


def raise_on_sigterm(signum, frame) -> None:
    """Handler of :data:`STOP_SIGNALS`: unwind (atomic writes remove their temporary files), then exit 128 + the signal (143, 129)."""
    raise Terminated(signum)


def state(ctx: typer.Context) -> State:
    """The global options of this invocation."""
    return ctx.obj if isinstance(ctx.obj, State) else State()


def console_for(ctx: typer.Context, out: Path | str | None = None) -> "Console":
    """Where tables and progress go: stderr when stdout carries data (``--out -``)."""
    from rich.console import Console

    st = state(ctx)
    to_stderr = str(out) == "-"
    console = Console(stderr=to_stderr, quiet=st.quiet, soft_wrap=False)
    if not console.is_terminal:
        console.width = _LOG_WIDTH  # a log file or pipe: do not squeeze tables to 80 columns
    return console


SIGPIPE_EXIT = 141
"""Exit code when the reader of stdout went away (``| head``): 128 + SIGPIPE, as a shell reports a tool SIGPIPE ended."""


def closed_pipe() -> int:
    """After a :class:`BrokenPipeError` on stdout: point stdout at /dev/null, return :data:`SIGPIPE_EXIT`.

    The reader (``head``) has all it asked for, so this is no error: no
    message, no traceback, and no second BrokenPipeError when Python
    flushes stdout at exit.
    """
    devnull = os.open(os.devnull, os.O_WRONLY)
    with contextlib.suppress(OSError, ValueError):
        os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
    return SIGPIPE_EXIT


@contextlib.contextmanager
def report_errors(ctx: typer.Context) -> Iterator[None]:
    """Turn a library error into one line on stderr and its exit code.

    Exit codes: 2 bad input or usage, 3 a CI threshold crossed, 1 anything
    else; 130 on Ctrl-C and 143 on SIGTERM (:class:`Terminated`), after the
    atomic writes under way have removed their temporary files. With
    ``--debug`` the traceback is printed too, and the exit code stays.
    """
    from gyrocomp.errors import GyrocompError

    try:
        with _print_notes():
            yield
    except typer.Exit:
        raise
    except BrokenPipeError:
        raise typer.Exit(closed_pipe())
    except KeyboardInterrupt as err:
        words = {signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}
        print(f"gyrocomp: {words.get(getattr(err, 'signum', None), 'interrupted')}", file=sys.stderr)
        raise typer.Exit(128 + getattr(err, "signum", signal.SIGINT))
    except Exception as err:
        code = err.exit_code if isinstance(err, GyrocompError) else 1
        if state(ctx).debug:
            traceback.print_exc()
        message = str(err).strip().replace("\n", " ") or type(err).__name__
        if not isinstance(err, GyrocompError):
            message = f"{type(err).__name__}: {message}"
        print(f"gyrocomp: {message}", file=sys.stderr)
        raise typer.Exit(code)


@contextlib.contextmanager
def _print_notes() -> Iterator[None]:
    """Print each :class:`~gyrocomp.errors.RecordingNote` (what reading a recording changed) and each other ``UserWarning`` as one line on stderr."""
    from gyrocomp.errors import RecordingNote

    with warnings.catch_warnings():
        show = warnings.showwarning

        def print_note(message, category, *args, **kwargs):
            if issubclass(category, RecordingNote):
                print(f"gyrocomp: note: {message}", file=sys.stderr)
            elif issubclass(category, UserWarning):  # one line, like an error: no source path, no code line
                text = " ".join(str(message).split())
                print(f"gyrocomp: warning: {text}", file=sys.stderr)
            else:
                show(message, category, *args, **kwargs)

        warnings.simplefilter("always", RecordingNote)
        warnings.showwarning = print_note
        yield


@contextlib.contextmanager
def progress(ctx: typer.Context, description: str, out: Path | str | None = None) -> Iterator[Callable[..., None]]:
    """Progress on stderr; yields ``callback(done, total, description=None)`` for the library.

    On a terminal, a rich progress bar. Otherwise (cron, CI, a log file) one
    line at most every :data:`LOG_EVERY_S` seconds (:class:`LogLines`), so
    a long ``run`` or ``diagnose`` shows it is alive without flooding the
    log. Nothing with ``--quiet``.
    """
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    st = state(ctx)
    console = Console(stderr=True, quiet=st.quiet)
    if not console.is_terminal:
        yield LogLines(console, description, every_s=LOG_EVERY_S)
        return
    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        disable=st.quiet,
    )
    task = bar.add_task(description, total=None)

    def update(done: int, total: int, description: str | None = None) -> None:
        bar.update(task, completed=done, total=total or None, **({} if description is None else {"description": description}))

    with bar:
        yield update


LOG_EVERY_S = 10.0
"""Fewest seconds between two progress lines when stderr is not a terminal."""


class LogLines:
    """Progress as plain lines, at most one every `every_s` seconds, and one at each new stage.

    The first comes `every_s` after the start at the earliest, so a command
    that fails at once still writes one line only, its error. After that a
    new description (the next axis, ``writing ...``) is a line at once, so
    a log shows what a long last stage is doing.

    Parameters
    ----------
    console : rich.console.Console
        Where the lines go (stderr).
    description : str
        What is progressing; a call may replace it.
    every_s : float
        Fewest seconds between two lines.
    clock : callable
        Seconds, monotonic (:func:`time.monotonic`).
    """

    def __init__(self, console: "Console", description: str, every_s: float = LOG_EVERY_S, clock: Callable[[], float] = time.monotonic):
        self.console = console
        self.description = description
        self.every_s = every_s
        self.clock = clock
        self.start = clock()
        self.last = self.start

    def __call__(self, done: int, total: int, description: str | None = None) -> None:
        changed = description is not None and description != self.description
        if description is not None:
            self.description = description
        now = self.clock()
        if now - self.last < self.every_s and not (changed and now - self.start >= self.every_s):
            return
        self.last = now
        share = f" ({100.0 * done / total:.0f}%)" if total else ""
        count = f"{done}/{total}" if total else f"{done}"
        self.console.print(f"gyrocomp: {self.description}: {count}{share}, {now - self.start:.0f} s", markup=False, highlight=False, soft_wrap=True)


# Options shared by every command that reads a recording.
TimeCol = Annotated[str, typer.Option("--time-col", help="Name of the time column.")]
RateCol = Annotated[
    str, typer.Option("--rate-col", help="Sensor axis column(s): a name, comma-separated names (gx,gy,gz) or a glob ('gyro_*').")
]
TempCol = Annotated[str, typer.Option("--temp-col", help="Temperature column(s): a name, names or a glob; the first is the temperature.")]
TimeUnit = Annotated[
    Optional[str],
    typer.Option(
        "--time-unit",
        help="Unit of the time column: s, ms, us, ns or datetime (ISO 8601). Default: seconds, "
        "refused when the sample rate or span is implausible; ISO text is read as datetimes.",
    ),
]
RateUnit = Annotated[
    str,
    typer.Option("--rate-unit", help="Unit of the axes: deg/s, deg/h, rad/s, m/s^2 or g; one, or one per --rate-col entry (deg/s,g)."),
]
TempUnit = Annotated[str, typer.Option("--temp-unit", help="Unit of the temperature column: degC or K.")]
Resample = Annotated[
    bool,
    typer.Option("--resample", help="Interpolate a jittered or gapped time axis onto a uniform grid instead of refusing it."),
]
Sep = Annotated[str, typer.Option("--sep", help="CSV field separator, e.g. ';', or tab.")]
DecimalMark = Annotated[str, typer.Option("--decimal", help="CSV decimal mark, e.g. ',' for decimal-comma files.")]
Dedupe = Annotated[
    Optional[str],
    typer.Option("--dedupe", help="Merge duplicate time stamps: first (keep the first row) or mean; default: refuse them."),
]
