"""``gyrocomp export``: a model.json as PX4 / ArduPilot parameters, a C99 header or plain JSON."""

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from gyrocomp.cli._app import RateCol, RateUnit, TempCol, TempUnit, TimeCol, TimeUnit, app, console_for, report_errors


@app.command()
def export(
    ctx: typer.Context,
    model: Annotated[Path, typer.Argument(help="model.json from `gyrocomp train`.")],
    fmt: Annotated[str, typer.Option("--format", "-f", help="px4 (QGroundControl .params), ardupilot (MAVProxy / Mission Planner .parm), c (C99 header with test vectors), json-plain (physical units).")] = ...,
    out: Annotated[Path, typer.Option("--out", "-o", help="File to write (- for stdout).")] = ...,
    fit_polynomial: Annotated[bool, typer.Option("--fit-polynomial", help="px4 / ardupilot: fit the nearest cubic to a model they cannot hold (dT/dt term, network) and report the error it adds.")] = False,
    axis: Annotated[str, typer.Option("--axis", help="Firmware axis (x, y, z) of a single-axis model.")] = "x",
    instance: Annotated[Optional[int], typer.Option("--instance", help="PX4 slot TC_G<i> / TC_A<i> (0..3, default 0); ArduPilot IMU INS_TCAL<n> (1..3, default 1). A model trained from a flight log names its own instances.")] = None,
    device_id: Annotated[int, typer.Option("--device-id", help="PX4 TC_G<i>_ID / TC_A<i>_ID: the sensor's device id (CAL_GYRO<n>_ID); PX4 applies the slot to that sensor only. A model trained from a ULog carries its own.")] = 0,
    vectors: Annotated[Optional[Path], typer.Option("--vectors", help="c: recording whose first --n-vectors samples become the test vectors (default: a synthetic sweep across and beyond the training ranges).")] = None,
    n_vectors: Annotated[int, typer.Option("--n-vectors", help="c: number of test-vector samples.")] = 2048,
    prefix: Annotated[str, typer.Option("--prefix", help="c: prefix of the header's names.")] = "gyrocomp",
    static_part: Annotated[bool, typer.Option("--static-part", help="px4 / ardupilot: write a greybox model's cubic in T alone, dropping its state (lag, dT/dt, hysteresis, warm-up), and report what that costs on the training runs.")] = False,
    time_col: TimeCol = "time",
    rate_col: RateCol = "rate",
    temp_col: TempCol = "temperature",
    time_unit: TimeUnit = "s",
    rate_unit: RateUnit = "deg/s",
    temp_unit: TempUnit = "degC",
) -> None:
    """Write a trained model in a firmware's or another tool's own form.

    px4 and ardupilot hold a cubic in temperature per axis, clamped to the
    training range, for gyros (TC_G, GYR) and accelerometers (TC_A, ACC):
    every instance of the model goes into one file, and one line on stderr
    gives each one's TREF, TMIN and TMAX. A model with a dT/dt term or a
    learned network is refused, naming what the format lacks, unless
    --fit-polynomial. c runs
    the whole causal model (dT/dt in O(1) per sample, clamping, the
    networks' forward passes) with test vectors from compensate --mode causal.
    """
    with report_errors(ctx):
        from gyrocomp.commands import export as stage, from_params

        models, summary = stage.to_files([model], out, from_params(stage.Options, ctx.params))
    console = console_for(ctx, out)
    added = summary.get("added_error_deg_h")
    what = "dropping the greybox state leaves" if static_part else "the fitted cubic adds"
    where = "of 100 s means on the training runs" if static_part else "over the training range"
    note = f"; {what} {added['rms']:.3g} deg/h RMS, {added['max']:.3g} deg/h at most {where}" if added else ""
    if summary.get("zero_ids"):
        print(f"gyrocomp: warning: {', '.join(summary['zero_ids'])} = 0; set --device-id to the sensor's CAL_GYRO<n>_ID / CAL_ACC<n>_ID, "
              "PX4 applies the slot to that sensor only", file=sys.stderr)
    if "reference" in summary:
        print(f"gyrocomp: {summary['reference']}", file=sys.stderr)
    kinds = ", ".join(sorted({m.kind for m in models.values()}))
    names = list(map(str, models))
    axes = "" if list(models) == [None] else f" ({len(models)} axes: {', '.join(names) if len(names) <= 6 else f'{names[0]} ... {names[-1]}'})"
    console.print(f"{out}: {kinds} model{axes} as {fmt}{note}", markup=False, highlight=False)
