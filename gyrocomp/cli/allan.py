"""``gyrocomp allan``: overlapping Allan deviation, IEEE Std 952 terms, plot, CI thresholds."""

from pathlib import Path
from typing import Annotated, List, Optional

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
    report_errors,
    state,
)


@app.command()
def allan(
    ctx: typer.Context,
    recordings: Annotated[List[str], typer.Argument(help="CSV or Parquet recordings; - reads CSV from stdin.")],
    out: Annotated[Path, typer.Option("--out", help="allan.json to write; - writes it to stdout.")],
    column: Annotated[str, typer.Option("--column", help="Column to analyse (after mapping): rate, or e.g. compensated.")] = "rate",
    taus: Annotated[
        Optional[str],
        typer.Option("--taus", help="octave, decade, all, or comma-separated seconds (default from the config: octave)."),
    ] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG of the curves, bands and fitted terms.")] = None,
    config: Annotated[str, typer.Option("--config", help="TOML with an [allan] table.")] = "allan",
    max_arw: Annotated[Optional[float], typer.Option("--max-arw", help="Exit 3 when a series' ARW read-off exceeds this [deg/sqrt(h)].")] = None,
    max_bias_instability: Annotated[
        Optional[float], typer.Option("--max-bias-instability", help="Exit 3 when B (minimum/0.664) exceeds this [deg/h].")
    ] = None,
    max_rrw: Annotated[Optional[float], typer.Option("--max-rrw", help="Exit 3 when a series' RRW read-off exceeds this [deg/h/sqrt(h)].")] = None,
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
    segments: Annotated[
        bool, typer.Option("--segments", help="Also write each gap-free segment's series after the one pooled over them.")
    ] = False,
    detrend_temperature: Annotated[
        bool, typer.Option("--detrend-temperature", help="Remove a least-squares cubic in temperature from each axis first.")
    ] = False,
) -> None:
    """Allan deviation of each recording, with confidence bands and IEEE noise terms.

    Every axis of --rate-col (gx,gy,gz or a glob) is a series of its own,
    named by its column; all series share one plot. A recording with gaps
    gives one series per axis: the segments' Allan variances averaged at
    each tau, weighted by their terms (--segments adds each segment's).
    With a temperature column, a rise of the curve beyond its minimum that
    follows temperature is said in one line, and rrw and rate_ramp are then
    not identified.

    Writes allan.json (and the plot) first, then checks the --max-* bounds,
    which compare the classic read-offs (N at 1 s, B = minimum/0.664, K at
    3 s) and exit 3 naming the series and the figure.
    """
    from gyrocomp.commands import allan as stage, from_params

    with report_errors(ctx):
        options = from_params(stage.Options, ctx.params)
        series = stage.to_files(recordings, out, options)
        if not state(ctx).quiet:  # the table (and the console, rich's) only made to be printed
            console_for(ctx, out).print(_table(series))
        stage.check(series, options)


def _table(series):
    from rich.markup import escape
    from rich.table import Table

    table = Table(title="IEEE Std 952 noise terms (fit +- 1 sigma; read-off)")
    for head in ("series", "term", "fit", "unit", "identified", "read-off"):
        table.add_column(head)
    for s in series:
        for key, term in s.terms.items():
            readoff = term.get("readoff")
            table.add_row(
                escape(s.name if s.column == "rate" else f"{s.name} [{s.column}]"),  # a name is text, never console markup
                key,
                f"{term['value']:.4g} +- {term['sigma']:.2g}",
                term["unit"],
                "yes" if term["identified"] else "no",
                "" if readoff is None else f"{readoff:.4g}",
            )
    return table
