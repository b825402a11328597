"""``gyrocomp compensate``: apply a model.json to a recording."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from gyrocomp.cli._app import RateCol, RateUnit, Resample, TempCol, TempUnit, TimeCol, TimeUnit, app, column_spec, console_for, progress, report_errors


@app.command()
def compensate(
    ctx: typer.Context,
    recording: Annotated[Path, typer.Argument(help="Recording (CSV or Parquet) with time, rate and temperature.")],
    model: Annotated[Path, typer.Argument(help="model.json from `gyrocomp train`.")],
    mode: Annotated[str, typer.Option("--mode", help="causal: rate - f(T, dT/dt) only, what firmware runs (keeps a true angular rate); full: the paper's offline decompose + denoise + compensate.")] = "causal",
    out: Annotated[Path, typer.Option("--out", "-o", help="compensated.parquet (or .csv; - for CSV on stdout); compensation.json goes beside it (same stem).")] = ...,
    seed: Annotated[Optional[int], typer.Option("--seed", help="Seed of the decomposition in full mode (default: the training run's).")] = None,
    workers: Annotated[int, typer.Option("--workers", help="Processes for the decomposition in full mode.")] = 1,
    time_col: TimeCol = "time",
    rate_col: RateCol = "rate",
    temp_col: TempCol = "temperature",
    time_unit: TimeUnit = "s",
    rate_unit: RateUnit = "deg/s",
    temp_unit: TempUnit = "degC",
    resample: Resample = False,
) -> None:
    """Remove the learned temperature drift from a recording.

    Writes time, rate, temperature, drift_model and compensated [deg/s].
    Warns (on stderr) when the recording leaves the model's training
    temperature range, and by how much. A foreign, corrupted or newer
    model.json is refused with exit code 2.
    """
    import warnings

    with report_errors(ctx):
        from gyrocomp import io
        from gyrocomp.pipeline.compensate import compensate as apply, load_model
        from gyrocomp.pipeline.run import write_compensation

        drift = load_model(io.read_json(model, "gyrocomp.model"), str(model))
        spec = column_spec(time_col, rate_col, temp_col, time_unit, rate_unit, temp_unit)
        rec = io.read_recording(recording, spec, require_temperature=True, min_samples=2, resample=resample)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with progress(ctx, f"compensate ({mode})", out) as update:
                frame, summary = apply(rec, drift, mode, seed=seed, workers=workers, callback=update)
        for warning in caught:
            print(f"gyrocomp: warning: {warning.message}", file=sys.stderr)
        if str(out) == "-":
            io.write_table(out, frame, {})
        else:
            write_compensation(out, frame, summary, rec, model, mode, seed)
    console = console_for(ctx, out)
    console.print(
        f"{out}: {len(frame)} samples compensated by {summary['kind']} ({mode}); "
        f"std {frame['rate'].std():.4g} -> {frame['compensated'].std():.4g} deg/s",
        markup=False,
        highlight=False,
    )
