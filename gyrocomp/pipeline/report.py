"""The comparison report of ``gyrocomp run``: ``report.json``, ``report.md`` and ``report.png``.

The findings are written from the numbers, not from the papers' claims:
every method is set against the raw test run and against the industry
baseline (the polynomial), and the share of an injected angular rate that
each pipeline destroys is stated in words.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from gyrocomp import artefacts
from gyrocomp.plots import method_label

__all__ = ["BASELINE", "findings", "write", "markdown"]

BASELINE = "polynomial"
"""The method every other one is compared with (DESIGN.md, "Honest evaluation")."""


def findings(report: dict) -> list[str]:
    """Plain statements from the scores: improvements, where a pipeline loses to the baseline, signal destroyed."""
    out = []
    if not report["test"]["held_out"]:
        out.append("No test run was given: every score below is on the TRAINING run, so nothing was held out.")
    several = _several(report)
    for axis in dict.fromkeys(r.get("axis") for r in report["rows"]):
        out += _axis_findings(report, [r for r in report["rows"] if r.get("axis") == axis], several)
    for method in report["methods"]:
        name = method_label({"method": method["name"], "mode": None, "axis": method.get("axis")}, several)
        if method.get("overrides"):
            out.append(f"{name} ran with changed settings: {', '.join(method['overrides'])}.")
        for message in sorted(set(method.get("warnings", []))):
            out.append(f"{name}: {message}")
    return out


def _several(report: dict) -> bool:
    """Whether the report scores several axes (its rows then name the axis in every label)."""
    return len(report.get("axes", ())) > 1


def _axis_findings(report: dict, rows: list, several: bool) -> list[str]:
    """The findings of one axis' rows (its raw row and its baseline are the axis' own)."""
    raw = next(r for r in rows if r["method"] == "raw")
    base = next((r for r in rows if r["method"] == BASELINE), None)
    out = []
    for row in rows:
        if row["method"] == "raw":
            continue
        label = method_label(row, several)
        drift, raw_drift = row["residual_drift"]["std_deg_h"], raw["residual_drift"]["std_deg_h"]
        out.append(
            f"{label}: residual drift (std of {row['residual_drift']['block_s']:g} s means) "
            f"{_f(raw_drift)} -> {_f(drift)} deg/h ({_ratio(raw_drift, drift)}); "
            f"ARW {_f(raw['arw']['value'])} -> {_f(row['arw']['value'])} deg/sqrt(h), "
            f"bias instability {_f(raw['bias_instability']['value'])} -> {_f(row['bias_instability']['value'])} deg/h."
        )
        kept = row.get("signal")
        if kept is not None:
            lost = [f"{name} {_pct(1 - g)}" for name, g in kept["parts"].items() if 1 - g > 0.05]
            text = f"{label} destroys {_pct(kept['destroyed'])} of the injected angular rate (RMS error {_f(kept['rms_error_dps'])} deg/s"
            text += f"; lost per part: {', '.join(lost)})." if lost else ")."
            out.append(text)
        if base is not None and row["method"] != BASELINE:
            worse = []
            if drift > base["residual_drift"]["std_deg_h"]:
                worse.append(f"residual drift {_f(drift)} vs {_f(base['residual_drift']['std_deg_h'])} deg/h")
            if row["residual_drift"]["p2p_deg_h"] > base["residual_drift"]["p2p_deg_h"]:
                worse.append(f"drift peak-to-peak {_f(row['residual_drift']['p2p_deg_h'])} vs {_f(base['residual_drift']['p2p_deg_h'])} deg/h")
            tolerance = 1.5 * base["signal"]["rms_error_dps"] + 0.01 * report["signal"]["rms_dps"] if base.get("signal") else None
            if kept is not None and tolerance is not None and kept["rms_error_dps"] > tolerance:
                worse.append(f"signal RMS error {_f(kept['rms_error_dps'])} vs {_f(base['signal']['rms_error_dps'])} deg/s")
            if worse:
                out.append(f"{label} does WORSE than the {BASELINE} baseline: {'; '.join(worse)}.")
    return out


def write(folder: str | os.PathLike, report: dict) -> None:
    """Write ``report.json``, ``report.md`` and ``report.png`` into `folder` (atomically)."""
    folder = Path(folder)
    artefacts.write_json(folder / "report.json", report)
    with artefacts.atomic_path(folder / "report.md") as tmp:
        Path(tmp).write_text(markdown(report), encoding="utf-8")
    from gyrocomp import plots

    plots.save(plots.report_figure(report), folder / "report.png")


def markdown(report: dict) -> str:
    """The report as Markdown: inputs, the score table, findings, signal survival per part, stage times."""
    train, test = report["train"], report["test"]
    lines = [
        "# gyrocomp comparison report",
        "",
        f"Training run: `{train['name']}` ({train['n_samples']} samples at {train['fs_hz']:g} Hz, "
        f"{train['temperature_c'][0]:.1f} to {train['temperature_c'][1]:.1f} degC).  ",
        f"Test run: `{test['name']}` ({test['n_samples']} samples, {test['temperature_c'][0]:.1f} to "
        f"{test['temperature_c'][1]:.1f} degC){'' if test['held_out'] else ' -- NOT held out: this is the training run'}.  ",
        f"Injected angular rate for signal preservation: {', '.join(report['signal']['parts'])} "
        f"(RMS {report['signal']['rms_dps']:.3g} deg/s), added to the test run before processing.",
        "",
        "| method | mode | ARW [deg/sqrt(h)] | bias instability [deg/h] | residual drift std [deg/h] | "
        "residual drift p-p [deg/h] | signal kept | signal RMS error [deg/s] | training [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    several = _several(report)
    for row in report["rows"]:
        kept = row.get("signal")
        lines.append(
            f"| {_method_cell(row, several)} | {row['mode'] or '-'} | {_f(row['arw']['value'])}{_src(row['arw'])} | "
            f"{_f(row['bias_instability']['value'])}{_src(row['bias_instability'])} | "
            f"{_f(row['residual_drift']['std_deg_h'])} | {_f(row['residual_drift']['p2p_deg_h'])} | "
            f"{'-' if kept is None else _pct(kept['gain'])} | {'-' if kept is None else _f(kept['rms_error_dps'])} | "
            f"{_seconds(row['train_time_s'])} |"
        )
    lines += [
        "",
        "ARW and bias instability are IEEE Std 952 read-offs of the Allan curve (ARW at tau = 1 s on the "
        "-1/2 line, bias instability = first minimum / 0.664), as both papers report them; `*` marks a "
        "value from the five-term fit where the curve has no such line. Residual drift: std and "
        f"peak-to-peak of the {report['rows'][0]['residual_drift']['block_s']:g} s means of the output. "
        "Signal kept: least-squares gain of (output with the injected rate - output without) on the injected rate.",
        "",
        "## Findings",
        "",
    ]
    lines += [f"- {text}" for text in report["findings"]]
    parts = report["signal"]["parts"]
    lines += ["", "## Signal survival per part", "", "| method | mode | " + " | ".join(parts) + " |", "|---|---|" + "---|" * len(parts)]
    for row in report["rows"]:
        if row.get("signal"):
            lines.append(f"| {_method_cell(row, several)} | {row['mode']} | " + " | ".join(_pct(row["signal"]["parts"][p]) for p in parts) + " |")
    lines += ["", "## Stage times [s]", "", "| method | stage | time |", "|---|---|---|"]
    for method in report["methods"]:
        for stage, seconds in method["stage_times_s"].items():
            lines.append(f"| {_method_cell({'method': method['name'], 'axis': method.get('axis')}, several)} | {stage} | {seconds:.2f} |")
    lines += ["", f"Total: {report.get('total_time_s', float('nan')):.1f} s.", ""]
    return "\n".join(lines)


def _method_cell(row: dict, several: bool) -> str:
    return f"{row['method']} [{row['axis']}]" if several and row.get("axis") is not None else row["method"]


def _seconds(value) -> str:
    return "-" if value is None else f"{value:.1f}"


def _src(term: dict) -> str:
    return "*" if term.get("source") == "fit" else ""


def _f(value) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:.3g}"


def _pct(share: float) -> str:
    return f"{100 * share:.0f}%".replace("-0%", "0%")


def _ratio(before: float, after: float) -> str:
    if after <= 0:
        return "removed"
    factor = before / after
    return f"{factor:.1f}x lower" if factor >= 1 else f"{1 / factor:.1f}x HIGHER"
