"""``gyrocomp simulate``: a recording from a gyro error model and an oven profile."""

from pathlib import Path
from typing import Annotated, List, Optional

import typer

from gyrocomp.cli._app import TempCol, app, console_for, progress, report_errors

@app.command()
def simulate(
    ctx: typer.Context,
    config: Annotated[
        Optional[Path],
        typer.Argument(help="Simulation TOML ([run], [gyro], [profile], [reference]) or a name in configs/sample/. Default: the papers' oven test on configs/gyro/default.toml."),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Recording to write: .parquet (with the truth in its metadata) or .csv; - writes CSV to stdout.")] = ...,
    profile: Annotated[
        Optional[str],
        typer.Option("--profile", help="Profile TOML (path or name in configs/profiles/, e.g. oven-reverse), or a .csv/.parquet recording whose measured temperature drives the run."),
    ] = None,
    seed: Annotated[Optional[int], typer.Option("--seed", help="Seed of every random draw (beats run.seed).")] = None,
    fs: Annotated[Optional[float], typer.Option("--fs", help="Sample rate in Hz (beats run.fs_hz).")] = None,
    overrides: Annotated[
        Optional[List[str]],
        typer.Option("--set", help="Override a setting, e.g. --set gyro.thermal_lag.tau_s=600 (repeatable)."),
    ] = None,
    truth_columns: Annotated[
        Optional[bool],
        typer.Option("--truth-columns/--no-truth-columns", help="Add a truth_* column per contribution (truth_drift, truth_noise, ...)."),
    ] = None,
    temp_col: TempCol = "temperature",
) -> None:
    """Simulate an oven-test recording: time [s], rate [deg/s], temperature [degC].

    The gyro is the papers' baseline (offset + cubic in temperature + ARW
    white noise) plus the effects switched on in [gyro.*]: thermal_lag,
    temp_rate, hysteresis, warmup, rate_ramp, periodic, bias_instability,
    rate_random_walk. The same config and seed give the same bytes.
    """
    with report_errors(ctx):
        from gyrocomp.commands import from_params, simulate as stage

        with progress(ctx, "simulating", out) as update:
            frame, header, cfg = stage.to_files([] if config is None else [config], out, from_params(stage.Options, ctx.params), progress=update)
    console = console_for(ctx, out)
    truth = header["truth"]
    effects = ", ".join(truth["active_effects"]) or "none (baseline only)"
    console.print(
        f"{out}: {truth['n_samples']} samples at {truth['fs_hz']:g} Hz "
        f"({truth['duration_s'] / 3600:.2f} h), seed {cfg.run.seed}, gyro {truth['gyro']!r}; effects: {effects}",
        markup=False,
        highlight=False,
    )
