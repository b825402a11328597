"""``gyrocomp batch``: run allan, compensate, run or diagnose over many recordings, incrementally, locally or on Dask."""

from pathlib import Path
from typing import Annotated, List, Optional

import typer

from gyrocomp.cli._app import app, console_for, progress, report_errors

@app.command(context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def batch(
    ctx: typer.Context,
    command: Annotated[str, typer.Argument(help="allan, compensate, run or diagnose.")],
    args: Annotated[
        List[str],
        typer.Argument(
            metavar="GLOB... [COMMAND OPTIONS]",
            help="Recordings: quoted glob patterns ('logs/**/*.parquet') or files; then any options of COMMAND.",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder of one output folder per input (named after its stem) and summary.csv / summary.parquet.")] = ...,
    workers: Annotated[Optional[int], typer.Option("--workers", help="Local worker processes (default: every core; 1 runs in this process).")] = None,
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="Address of a Dask distributed scheduler (tcp://host:8786) to run on instead; needs the dask extra.")] = None,
    model: Annotated[Optional[Path], typer.Option("--model", help="compensate: the model.json applied to every input.")] = None,
    config: Annotated[Optional[str], typer.Option("--config", help="run: the run config (e.g. compare); allan / diagnose: the TOML with an [allan] / [diagnose] table.")] = None,
) -> None:
    """Run one command over many recordings, one output folder each, skipping those already up to date.

    An input is skipped when its folder's manifest.json records the same
    input SHA-256, settings and gyrocomp version. Each folder is built
    hidden and renamed into place with its manifest written last, so an
    interrupted batch resumes without half-written outputs. A failing input
    is recorded in the summary (file and one-line error) and the rest go on.

    Exit code: 2 when inputs failed and all were bad input, 1 when another
    failure occurred, 3 when none failed but one crossed a --max-* bound.

    \b
    COMMAND OPTIONS are those of the command (see `gyrocomp COMMAND --help`):
      allan       --column --taus --max-arw --max-bias-instability --max-rrw, column options, --resample
      compensate  --mode --seed, column options, --resample (and --model here)
      run         --test TEMPLATE --seed --set, column options (and --config here); TEMPLATE may
                  hold {stem}, {name}, {dir} of each training input, e.g. --test 'test/{name}'
      diagnose    --holdout TEMPLATE (as --test) --sim, column options, --resample (and --config)
    Column options: --time-col --rate-col --temp-col --time-unit --rate-unit --temp-unit --sep --decimal --dedupe.
    """
    console = console_for(ctx)
    with report_errors(ctx):
        from gyrocomp.batch import run_batch

        patterns, rest = _split(args + list(ctx.args))
        options = _command_options(command, rest)
        files = {"model": model, "config": config}
        with progress(ctx, f"batch {command}") as update:
            result = run_batch(command, patterns, out, options=options, files=files, workers=workers, scheduler=scheduler, progress=update)
        console.print(_table(result), markup=False)
        console.print(
            f"{out}: {result.count('ok')} done, {result.count('skipped')} up to date, {result.count('failed')} failed"
            f"{f', {result.thresholds} over a threshold' if result.thresholds else ''}; summary in {out / 'summary.csv'}",
            markup=False,
            highlight=False,
        )
    if result.exit_code:
        import sys

        failed = result.count("failed")
        what = f"{failed} of {len(result.rows)} inputs failed" if failed else f"{result.thresholds} inputs crossed a threshold"
        print(f"gyrocomp: batch {command}: {what} (see {out / 'summary.csv'})", file=sys.stderr)
        raise typer.Exit(result.exit_code)


def _split(tokens: list[str]) -> tuple[list[str], list[str]]:
    """Patterns come first; the first token starting with ``-`` opens the command's options."""
    for i, token in enumerate(tokens):
        if token.startswith("-") and token != "-":
            return tokens[:i], tokens[i:]
    return tokens, []


def _command_options(command: str, tokens: list[str]) -> dict:
    """Parse COMMAND's options with COMMAND's own option definitions (names, types, checks).

    Returns only the options the user gave; a batch fills in the rest.
    """
    import copy
    import importlib

    import typer.main

    from gyrocomp.batch.jobs import get_job
    from gyrocomp.cli import app as root
    from gyrocomp.errors import InputError

    job = get_job(command)
    importlib.import_module(f"gyrocomp.cli.{command}")  # registers the command when it is not in _COMMANDS yet
    target = typer.main.get_command(root).commands[command]
    # The command itself, reduced to the options a batch passes through (Typer bundles its own click).
    parser = copy.copy(target)
    parser.params = [p for p in target.params if p.param_type_name == "option" and p.name in job.options]
    parser.add_help_option = False
    try:
        ctx = parser.make_context(f"gyrocomp batch {command}", list(tokens))
    except Exception as err:
        if not hasattr(err, "format_message"):
            raise
        raise InputError(f"batch {command}: {err.format_message()}") from None
    given = [name for name in ctx.params if ctx.get_parameter_source(name).name == "COMMANDLINE"]
    return {name: (list(ctx.params[name]) if isinstance(ctx.params[name], tuple) else ctx.params[name]) for name in given}


def _table(result, n_figures: int = 3):
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=f"gyrocomp batch {result.command} (every figure: summary.csv)")
    figures = [c for c in result.columns if c not in ("input", "output", "status", "error", "threshold", "sha256")][:n_figures]
    table.add_column("input", overflow="fold", min_width=12)
    table.add_column("status", no_wrap=True)
    table.add_column("error / threshold", max_width=36, overflow="fold")
    for head in figures:
        table.add_column(head.replace("_", " "), justify="right")
    for row in result.rows:
        table.add_row(escape(row["input"]), row["status"], escape(str(row["error"] or row["threshold"] or "")), *[_cell(row[c]) for c in figures])
    return table


def _cell(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
