"""``gyrocomp run``: train, compensate and score every method of a run config; write the comparison report."""

from pathlib import Path
from typing import Annotated, List, Optional

import typer

from gyrocomp.cli._app import (
    DecimalMark,
    Dedupe,
    RateCol,
    RateUnit,
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
def run(
    ctx: typer.Context,
    config: Annotated[str, typer.Argument(help="Run config (configs/compare.toml, or a name in configs/) listing the methods to compare.")],
    train_rec: Annotated[Path, typer.Argument(help="Training recording with temperature.")],
    test: Annotated[Optional[Path], typer.Option("--test", help="Held-out recording to score on (without it the training run is scored, and the report says so).")] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for every artefact and report.md, report.png, report.json.")] = ...,
    seed: Annotated[int, typer.Option("--seed", help="Seed of every random step.")] = 0,
    workers: Annotated[int, typer.Option("--workers", help="Processes for the decompositions.")] = 1,
    overrides: Annotated[Optional[List[str]], typer.Option("--set", help="Override a run-config value, e.g. --set 'run.methods=[\"polynomial\"]' (repeatable).")] = None,
    time_col: TimeCol = "time",
    rate_col: RateCol = "rate",
    temp_col: TempCol = "temperature",
    time_unit: TimeUnit = None,
    rate_unit: RateUnit = "deg/s",
    temp_unit: TempUnit = "degC",
    sep: Sep = ",",
    decimal: DecimalMark = ".",
    dedupe: Dedupe = None,
) -> None:
    """The whole chain for each method: decompose, classify, train, compensate (full and causal), score.

    Scores on the test run: ARW and bias instability (Allan read-offs),
    residual temperature drift (std and peak-to-peak of 100 s means, deg/h),
    signal preservation (a known angular rate added to the test run before
    processing: share kept, RMS error), training and per-stage times.
    Several axes (--rate-col gx,gy,gz): every method on each axis alone, the
    report rows naming their axis, artefacts under OUT/<axis>/<method>/.
    """
    with report_errors(ctx):
        from gyrocomp.commands import from_params, run as stage

        with progress(ctx, "run") as update:
            report = stage.to_files(
                [config, train_rec], out, from_params(stage.Options, ctx.params), progress=lambda name, done, total: update(done, total, name)
            )
    _print(console_for(ctx), report, out)


def _print(console, report: dict, out: Path) -> None:
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(f"{out}/report.md (test run {report['test']['name']})"))
    several = len(report.get("axes", ())) > 1
    for column in ("method", "mode", "ARW deg/sqrt(h)", "bias inst. deg/h", "drift std deg/h", "drift p-p deg/h", "signal kept", "train s"):
        table.add_column(column)
    for row in report["rows"]:
        kept = row.get("signal")
        table.add_row(
            escape(f"{row['method']} [{row['axis']}]" if several else row["method"]),  # a name is text, never console markup
            row["mode"] or "-",
            f"{row['arw']['value']:.3g}",
            f"{row['bias_instability']['value']:.3g}",
            f"{row['residual_drift']['std_deg_h']:.3g}",
            f"{row['residual_drift']['p2p_deg_h']:.3g}",
            "-" if kept is None else f"{100 * kept['gain']:.0f}%",
            "-" if row["train_time_s"] is None else f"{row['train_time_s']:.1f}",
        )
    console.print(table)
    for text in report["findings"]:
        console.print(f"- {text}", markup=False, highlight=False)
    console.print(f"total {report['total_time_s']:.1f} s", markup=False)
