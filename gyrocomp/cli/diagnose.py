"""``gyrocomp diagnose``: where the sim-to-real gap lies and which effect causes it."""

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
def diagnose(
    ctx: typer.Context,
    fit: Annotated[Path, typer.Argument(help="Recording to calibrate on (CSV or Parquet); temperature optional.")],
    out: Annotated[Path, typer.Option("--out", help="report.json to write (schema gyrocomp.diagnosis); - for stdout.")],
    holdout: Annotated[
        Optional[list[Path]],
        typer.Option(
            "--holdout",
            help="Another run of the same gyro; repeat for several. The last one takes no part in the selection and "
            "gives the held-out gap; the ones before it join FIT in the selection.",
        ),
    ] = None,
    sim: Annotated[
        Optional[Path],
        typer.Option("--sim", help="Start from this simulator config: its enabled effects join the baseline (refitted)."),
    ] = None,
    config: Annotated[str, typer.Option("--config", help="TOML with a [diagnose] table.")] = "diagnose",
    plot: Annotated[Optional[Path], typer.Option("--plot", help="gap.png: gap by regime and timescale, before/after.")] = None,
    markdown: Annotated[Optional[Path], typer.Option("--markdown", help="report.md to write.")] = None,
    model_out: Annotated[
        Optional[Path],
        typer.Option("--model-out", help="model.json to write: the greybox model of the selected effects, fitted on the selection runs, "
                     "ready for compensate and export."),
    ] = None,
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
    """Calibrate the baseline simulator (offset + cubic in temperature + white noise) on FIT,
    name the unmodelled effects that explain the rest, and show where the gap lies and how
    far it shrinks on a held-out run that took no part in the selection. Several axes (--rate-col gx,gy,gz) get a
    verdict each, against the held-out axis of the same name."""
    with report_errors(ctx):
        from gyrocomp.commands import diagnose as stage, from_params
        from gyrocomp.diagnose.report import summary_table

        options = from_params(stage.Options, ctx.params)
        with progress(ctx, "diagnose: fitting candidates", out) as update:
            report = stage.to_files([fit], out, options, progress=update)
        console = console_for(ctx, out)
        for axis, verdict in report.get("axes", {report.get("axis"): report}).items():
            table = summary_table(verdict)
            if "axes" in report:
                from rich.markup import escape

                table.title = f"{escape(f'[{axis}]')} {table.title}"  # the axis name is text, never console markup
            console.print(table)
            if "model_out" in verdict:
                m = verdict["model_out"]
                left = [*m["not_held"], *(r["term"] + " (not identifiable)" for r in m["not_fitted"])]
                if m["unexplained_structure"]:
                    left.append("the structure the residual tests flag")
                console.print(
                    f"{m['path']}: greybox model of {', '.join(m['terms']) or 'the baseline alone'}"
                    + (f"; it leaves out {', '.join(left)}" if left else ""),
                    markup=False, highlight=False,
                )
