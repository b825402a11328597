"""``gyrocomp decompose``: a recording's rate into components (LCD, ICEEMDAN, CEEMDAN, EMD)."""

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
    progress,
    report_errors,
)


@app.command()
def decompose(
    ctx: typer.Context,
    recording: Annotated[Path, typer.Argument(help="Recording to decompose: CSV or Parquet with time and rate (temperature kept when present).")],
    out: Annotated[Path, typer.Option("--out", help="components.parquet to write; the components.meta.json sidecar goes beside it.")],
    method: Annotated[Optional[str], typer.Option("--method", help="lcd, iceemdan, ceemdan or emd (default: the config's, else lcd).")] = None,
    ensemble: Annotated[Optional[int], typer.Option("--ensemble", help="Noise realisations of iceemdan/ceemdan (default: the config's, else 100).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the noise ensemble.")] = 0,
    workers: Annotated[int, typer.Option("--workers", help="Processes for the ensemble; the result does not depend on it.")] = 1,
    config: Annotated[Optional[str], typer.Option("--config", help="Pipeline TOML (path or name in configs/); its [decompose] table is read.")] = None,
    overrides: Annotated[Optional[List[str]], typer.Option("--set", help="Override a setting of [decompose], e.g. --set sd_stop=0.2 (repeatable).")] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG of the components stacked, fastest first.")] = None,
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
    """Decompose `rate` into components, fastest first, the residue or trend last.

    Writes components.parquet (time, rate, temperature when present, one
    column per component) and components.meta.json (per component: energy share,
    mean frequency, orthogonality index; and the reconstruction error).
    Several axes (--rate-col gx,gy,gz) go into one file: each axis under its
    own name and its components prefixed by it (gx_isc1 ... gx_trend), every
    axis decomposed alone with the same seed.
    """
    with report_errors(ctx):
        from gyrocomp.commands import decompose as stage, from_params

        options = from_params(stage.Options, ctx.params)
        with progress(ctx, f"{options.settings().method} {recording.name}") as callback:
            _, sidecar = stage.to_files([recording], out, options, progress=callback)
    _print_table(console_for(ctx), sidecar)


def _print_table(console, sidecar):
    from rich.table import Table

    name = sidecar["inputs"][0]["name"]
    for label, stats in sidecar.get("axes", {"": sidecar}).items():
        where = f"{name} [{label}]" if label else name
        table = Table(title=f"{sidecar['method']} of {where}: reconstruction error {stats['reconstruction_error']:.2e}")
        for head in ("component", "energy share", "mean freq [Hz]", "orthogonality"):
            table.add_column(head, justify="left" if head == "component" else "right")
        for c in stats["components"]:
            table.add_row(c["name"], f"{c['energy_share']:.4f}", f"{c['mean_frequency_hz']:.4g}", f"{c['orthogonality_index']:+.2e}")
        console.print(table)
