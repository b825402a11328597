"""``gyrocomp simulate``: a recording from a gyro error model and an oven profile."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, List, Optional

import typer

from gyrocomp.cli._app import TempCol, app, console_for, progress, report_errors

_RECORDING_SUFFIXES = (".csv", ".parquet", ".pq")


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
    assignments: Annotated[
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
        from gyrocomp import io, sim
        from gyrocomp.cli._app import column_spec

        recording = None
        profile_config = profile
        if profile is not None and Path(profile).suffix.lower() in _RECORDING_SUFFIXES:
            spec = column_spec("time", "rate", temp_col, "s", "deg/s", "degC")
            recording = io.read_recording(profile, spec, require_temperature=True, resample=True)
            profile_config = None
        cfg = sim.load_sim_config(
            config,
            profile=profile_config,
            overrides=assignments or (),
            seed=seed,
            fs_hz=fs,
            truth_columns=truth_columns,
        )
        with progress(ctx, "simulating", out) as update:
            frame, header = sim.run(cfg, temperature_from=recording, progress=update)
            io.write_table(out, frame, header)
    console = console_for(ctx, out)
    truth = header["truth"]
    effects = ", ".join(truth["active_effects"]) or "none (baseline only)"
    console.print(
        f"{out}: {truth['n_samples']} samples at {truth['fs_hz']:g} Hz "
        f"({truth['duration_s'] / 3600:.2f} h), seed {cfg.run.seed}, gyro {truth['gyro']!r}; effects: {effects}",
        markup=False,
        highlight=False,
    )
