"""``gyrocomp train``: fit a pipeline config's drift models and write ``model.json``."""

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
    report_errors,
)


@app.command()
def train(
    ctx: typer.Context,
    inputs: Annotated[
        List[Path],
        typer.Argument(
            help="A recording with temperature (direct pipelines: bp, elm, polynomial, firmware), several recordings of one gyro "
            "(greybox: each its own run), or components.parquet and classes.json from decompose and classify (parallel pipelines).",
            show_default=False,
        ),
    ],
    config: Annotated[str, typer.Option("--config", "-c", help="Pipeline TOML or a name in configs/ (pe-lcd-anfis, iceemdan-se-tfpf-nsga2elm, bp, elm, polynomial, firmware, greybox).")] = "pe-lcd-anfis",
    out: Annotated[Path, typer.Option("--out", "-o", help="model.json to write.")] = ...,
    seed: Annotated[int, typer.Option("--seed", help="Seed of every learner that draws random numbers.")] = 0,
    workers: Annotated[int, typer.Option("--workers", help="Processes training the axes side by side (direct pipelines); the model does not depend on it.")] = 1,
    overrides: Annotated[Optional[List[str]], typer.Option("--set", help="Override a config value, e.g. --set model.drift.epochs=20 (repeatable).")] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG: bias against temperature, heating and cooling apart, before compensation (with the model) and after it; and raw and compensated rate against time with the temperature.")] = None,
    even_temperature: Annotated[
        bool,
        typer.Option("--even-temperature", help="Weight the fit evenly over temperature: training means averaged in bins of [coverage] bin_c (configs/coverage.toml), as PX4 resamples into temperature bins."),
    ] = False,
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
    """Fit the drift models of a pipeline against temperature and temperature rate.

    Parallel pipelines (the papers) learn each classified segment: PE-LCD-ANFIS
    a 16-rule ANFIS on the drift segment and a 4-rule ANFIS on the SG-smoothed
    mixed segment; ICEEMDAN-SE-TFPF + NSGA-II-ELM an NSGA-II-tuned ELM on the
    feature segment. Direct pipelines (bp, elm, polynomial, firmware) learn the
    recorded rate itself. dT/dt is the slope of a local straight line over [rate]
    window_s. greybox fits a causal state-space model (element-temperature lag,
    cubic, heating/cooling dT/dt, play hysteresis, warm-up) on every recording
    given, each its own run, with only the terms the runs identify. A term a run
    cannot identify is left out and named in one note line. model.json holds every setting and learned number compensate needs,
    for every axis of --rate-col (gx,gy,gz or a glob: one model per axis, under
    its column's name). A recording with gaps trains on every sample of every
    segment; dT/dt never spans a gap, and a decomposition pipeline
    decomposes each segment on its own. A run whose temperature is quantised
    (whole degrees), spans under 10 degC or never ramps is named in one warning
    line each (thresholds in configs/coverage.toml).
    """
    with report_errors(ctx):
        from gyrocomp.commands import from_params, train as stage

        model = stage.to_files(inputs, out, from_params(stage.Options, ctx.params))
    console = console_for(ctx, out)
    for axis, m in model["axes"].items():
        t = m["training"]
        if m["kind"] == "greybox":
            fits = greybox_line(m["greybox"]["fitted"])
        else:
            fits = ", ".join(f"{seg}: {e['learner']['kind']} rmse {e['train_rmse_dps']:.3g} {m['unit']}" for seg, e in m["segments"].items())
        console.print(
            f"{out} [{axis}]: {m['kind']} trained on {t['n_samples']} samples in {t['n_segments']} segment(s), "
            f"{t['temperature_c']['min']:.1f} to {t['temperature_c']['max']:.1f} degC; {fits}",
            markup=False,
            highlight=False,
        )
    for line in not_fitted_notes(model):
        typer.echo(f"gyrocomp: note: {line}", err=True)


def not_fitted_notes(model: dict) -> list[str]:
    """One line per term a model left out, naming the axes it was left out of (``not_fitted`` of each segment)."""
    axes_of: dict[str, list[str]] = {}
    for axis, m in model["axes"].items():
        refusals = m.get("not_fitted", []) + [r for segment in m.get("segments", {}).values() for r in segment.get("not_fitted", [])]
        for refusal in refusals:
            axes_of.setdefault(refusal["reason"], []).append(axis)
    return [f"[{', '.join(dict.fromkeys(axes))}] {reason}" for reason, axes in axes_of.items()]


def greybox_line(fitted: dict) -> str:
    """The selected terms of a grey-box model and their parameters, in one line."""
    spec = fitted["spec_"]
    parts = []
    if spec["tau_e_s"]:
        parts.append(f"thermal_lag tau {spec['tau_e_s']:.4g} s")
    if spec.get("tau_e2_s"):
        parts.append(f"second_lag tau {spec['tau_e2_s']:.4g} s ({spec.get('second_lag_path', 'parallel')})")
    if spec["rate_form"]:
        saturation = spec.get("rate_saturation_c_per_s", 0.0)
        parts.append("temp_rate" + (" heating/cooling apart" if spec["rate_form"] == 2 else "") + f" (filter {spec['rate_tau_s']:.3g} s"
                     + (f", saturating at {60 * saturation:.3g} degC/min" if saturation else "") + ")")
    if spec["width_c"]:
        parts.append(f"hysteresis {spec.get('hysteresis_operator', 'play')} width {spec['width_c']:.3g} degC"
                     + (f" and play width {spec['width2_c']:.3g} degC" if spec.get("width2_c") else ""))
    if spec["tau_w_s"]:
        parts.append(f"warmup tau {spec['tau_w_s']:.4g} s" + (f" and {spec['tau_w2_s']:.4g} s" if spec.get("tau_w2_s") else ""))
    return "greybox: cubic in T_e" + "".join(f" + {p}" for p in parts)

