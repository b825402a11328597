"""``gyrocomp classify``: entropy and class (noise / mixed / drift) of each component."""

from pathlib import Path
from typing import Annotated, List, Optional

import typer

from gyrocomp.cli._app import app, console_for, report_errors


@app.command()
def classify(
    ctx: typer.Context,
    components: Annotated[Path, typer.Argument(help="components.parquet written by `gyrocomp decompose`.")],
    out: Annotated[str, typer.Option("--out", "-o", help="classes.json to write; - writes to stdout.")] = ...,
    entropy: Annotated[
        Optional[str],
        typer.Option("--entropy", help="permutation (Cao et al. 2021) or sample (Zhang et al. 2024); default: the config's."),
    ] = None,
    config: Annotated[
        Optional[str],
        typer.Option("--config", help="Pipeline TOML (path or name in configs/); its [classify] table is read. Default: the PE-LCD-ANFIS settings."),
    ] = None,
    overrides: Annotated[
        Optional[List[str]],
        typer.Option("--set", help="Override a setting, e.g. --set classify.sample.m=3 (repeatable)."),
    ] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG: the entropy per component with the thresholds (the papers' Fig. 10) beside the components labelled by class.")] = None,
) -> None:
    """Classify each component as noise, mixed or drift by its entropy.

    Normalised permutation entropy (thresholds 0.6 / 0.4) or sample entropy
    (0.6 / 0.1): above the upper threshold noise, below the lower one drift,
    in between (inclusive) mixed. Writes classes.json with the entropy
    settings and thresholds used.
    """
    with report_errors(ctx):
        from gyrocomp.commands import classify as stage, from_params

        options = from_params(stage.Options, ctx.params)
        settings = options.settings()
        entries = stage.to_files([components], out, options)
    _print_table(console_for(ctx, out), entries, settings)


def _print_table(console, entries, settings) -> None:
    from rich.table import Table

    label = "PE (normalised)" if settings.entropy == "permutation" else "SampEn [nats]"
    table = Table(
        title=f"{settings.entropy} entropy",
        caption=f"noise > {settings.noise_above:g} >= mixed >= {settings.drift_below:g} > drift",
    )
    table.add_column("component")
    table.add_column(label, justify="right")
    table.add_column("class")
    for e in entries:
        table.add_row(e["name"], f"{e['entropy']:.4f}", e["class"])
    console.print(table)

