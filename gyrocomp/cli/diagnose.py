"""``gyrocomp diagnose``: where the sim-to-real gap lies and which effect causes it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from gyrocomp.cli._app import (
    RateCol,
    RateUnit,
    Resample,
    TempCol,
    TempUnit,
    TimeCol,
    TimeUnit,
    app,
    column_spec,
    console_for,
    progress,
    report_errors,
)


@app.command()
def diagnose(
    ctx: typer.Context,
    fit: Annotated[Path, typer.Argument(help="Recording to calibrate on (CSV or Parquet); temperature optional.")],
    out: Annotated[Path, typer.Option("--out", help="report.json to write (schema gyrocomp.diagnosis); - for stdout.")],
    holdout: Annotated[
        Optional[Path], typer.Option("--holdout", help="A second run of the same gyro: checks each effect and gives the held-out gap.")
    ] = None,
    sim: Annotated[
        Optional[Path],
        typer.Option("--sim", help="Start from this simulator config: its enabled effects join the baseline (refitted)."),
    ] = None,
    config: Annotated[str, typer.Option("--config", help="TOML with a [diagnose] table.")] = "diagnose",
    plot: Annotated[Optional[Path], typer.Option("--plot", help="gap.png: gap by regime and timescale, before/after.")] = None,
    markdown: Annotated[Optional[Path], typer.Option("--markdown", help="report.md to write.")] = None,
    time_col: TimeCol = "time",
    rate_col: RateCol = "rate",
    temp_col: TempCol = "temperature",
    time_unit: TimeUnit = "s",
    rate_unit: RateUnit = "deg/s",
    temp_unit: TempUnit = "degC",
    resample: Resample = False,
) -> None:
    """Calibrate the baseline simulator (offset + cubic in temperature + white noise) on FIT,
    name the unmodelled effects that explain the rest, and show where the gap lies and how
    far it shrinks on the held-out run."""
    with report_errors(ctx):
        from pathlib import Path as _Path

        from gyrocomp import io
        from gyrocomp.config import settings_dict
        from gyrocomp.diagnose import diagnose as run_diagnosis
        from gyrocomp.diagnose import get_config
        from gyrocomp.diagnose.report import plot_gap, summary_table, to_json, to_markdown

        columns = column_spec(time_col, rate_col, temp_col, time_unit, rate_unit, temp_unit)
        settings = get_config(config)
        fit_rec = io.read_recording(fit, columns, resample=resample, min_samples=64)
        hold_rec = io.read_recording(holdout, columns, resample=resample, min_samples=64) if holdout else None
        start = ()
        if sim is not None:
            from gyrocomp.sim.model import load_sim_config

            start = tuple(load_sim_config(sim).gyro.active_effects())
        with progress(ctx, "diagnose: fitting candidates", out) as update:
            body = run_diagnosis(fit_rec, hold_rec, settings, start_effects=start, callback=update)
        inputs = [fit_rec.input_record()] + ([hold_rec.input_record()] if hold_rec else [])
        report = to_json(body, inputs=inputs, settings=settings_dict(settings))
        io.write_json(out, report)
        if markdown is not None:
            with io.atomic_path(markdown) as tmp:
                _Path(tmp).write_text(to_markdown(report), encoding="utf-8")
        if plot is not None:
            plot_gap(report, plot)
        console_for(ctx, out).print(summary_table(report))
