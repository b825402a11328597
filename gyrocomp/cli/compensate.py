"""``gyrocomp compensate``: apply a model.json to a recording."""

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from gyrocomp.cli._app import (
    DecimalMark,
    Dedupe,
    RateCol,
    RateUnit,
    Resample,
    Sep,
    TempCol,
    TempUnit,
    TimeCol,
    TimeUnit,
    app,
    console_for,
    progress,
    report_errors,
)


@app.command()
def compensate(
    ctx: typer.Context,
    recording: Annotated[Path, typer.Argument(help="Recording (CSV or Parquet) with time, rate and temperature.")],
    model: Annotated[Path, typer.Argument(help="model.json from `gyrocomp train`.")],
    mode: Annotated[str, typer.Option("--mode", help="causal: rate - f(T, dT/dt) only, what firmware runs (keeps a true angular rate); full: the paper's offline decompose + denoise + compensate.")] = "causal",
    out: Annotated[Path, typer.Option("--out", "-o", help="compensated.parquet (or .csv, .csv.gz, ...; - for CSV on stdout); its sidecar compensated.meta.json goes beside it.")] = ...,
    clamp: Annotated[Optional[bool], typer.Option("--clamp/--no-clamp", help="Clamp temperature and dT/dt to the training ranges, as firmware does (default in causal mode; in full mode the model's clip_inputs). --no-clamp extrapolates.", show_default=False)] = None,
    seed: Annotated[Optional[int], typer.Option("--seed", help="Seed of the decomposition in full mode (default: the training run's).")] = None,
    workers: Annotated[int, typer.Option("--workers", help="Processes for the decomposition in full mode.")] = 1,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG: bias against temperature, heating and cooling apart, before compensation (with the model) and after it; and raw and compensated rate against time with the temperature.")] = None,
    time_col: TimeCol = "time",
    rate_col: RateCol = "rate",
    temp_col: TempCol = "temperature",
    time_unit: TimeUnit = None,
    rate_unit: RateUnit = "deg/s",
    temp_unit: TempUnit = "degC",
    sep: Sep = ",",
    decimal: DecimalMark = ".",
    dedupe: Dedupe = None,
    resample: Resample = False,
) -> None:
    """Remove the learned temperature drift from a recording.

    Writes time, rate, temperature, drift_model and compensated [deg/s]; with
    several axes (--rate-col gx,gy,gz) each axis, temperature,
    <axis>_drift_model and <axis>_compensated, each axis compensated by the
    model of its name. A recording with gaps is compensated segment by
    segment (dT/dt never spans a gap; full mode of a decomposition pipeline
    decomposes each segment on its own). Gyro and accelerometer topics of a
    ULog (their own time stamps) are written to one table each,
    OUT_<topic>_<instance>.
    Warns (on stderr) when the recording leaves the model's training
    temperature or dT/dt range, and by how much; causal mode clamps both
    to those ranges unless --no-clamp. A foreign, corrupted or newer
    model.json is refused with exit code 2.
    """
    with report_errors(ctx):
        from gyrocomp.commands import compensate as stage, from_params

        options = from_params(stage.Options, ctx.params)
        with progress(ctx, f"compensate ({mode})", out) as update:
            n_samples, summaries, caught = stage.compensate_files([recording, model], out, options, progress=update)
        for warning in caught:
            print(f"gyrocomp: warning: {warning.message}", file=sys.stderr)
    console = console_for(ctx, out)
    for axis, summary in summaries.items():
        figures = summary["figures"]
        console.print(
            f"{summary.get('output', out)} [{axis}]: {figures.get('n_samples', n_samples)} samples compensated by {summary['kind']} ({mode}); "
            f"std {figures['rate_std']:.4g} -> {figures['compensated_std']:.4g} {summary['unit']}",
            markup=False,
            highlight=False,
        )
