"""The README's headline table from ``make run`` output, and how its figures vary between runs.

    python benchmarks/readme_table.py out/report.json                 # the table, and this machine
    python benchmarks/readme_table.py A/report.json B/report.json ... # + each figure's spread

The first report gives the table (Markdown, the README's columns); the
machine line describes the machine this script runs on (CPU, cores,
Python, NumPy and its BLAS, the thread variables), so run it where
``make run`` ran. With several reports (other thread counts, other
versions, other machines) a second table gives, per method and figure,
the largest relative difference from the first report: the figures
that vary and by how much. ``--json FILE`` also writes both as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

NAMES = {
    "raw": "raw",
    "pe-lcd-anfis": "PE-LCD-ANFIS",
    "iceemdan-se-tfpf-nsga2elm": "ICEEMDAN-SE-TFPF + NSGA-II-ELM",
    "bp": "BP (MLP)",
    "elm": "ELM",
    "polynomial": "cubic polynomial + dT/dt",
    "greybox": "grey-box (lag, dT/dt, hysteresis, warm-up)",
}
"""README names of the methods of configs/compare.toml."""

FIGURES = {
    "ARW": lambda r: r["arw"]["value"],
    "bias instability": lambda r: r["bias_instability"]["value"],
    "drift std": lambda r: r["residual_drift"]["std_deg_h"],
    "drift p-p": lambda r: r["residual_drift"]["p2p_deg_h"],
    "signal kept": lambda r: r["signal"]["gain"] if r.get("signal") else None,
}
"""The table's figures, read from one row of report.json."""


def machine() -> str:
    """One line: CPU model, cores, OS, Python, NumPy and its BLAS, thread variables."""
    import numpy as np
    from threadpoolctl import threadpool_info

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    blas = ", ".join(f"{i['internal_api']} {i.get('version')}" for i in threadpool_info() if i["user_api"] == "blas")
    threads = " ".join(f"{v}={os.environ[v]}" for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS") if v in os.environ)
    return (f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, Python {platform.python_version()}, "
            f"NumPy {np.__version__} ({blas or 'BLAS unknown'}){', ' + threads if threads else ''}")


def table(report: dict) -> str:
    """The README's headline table (Markdown) from one report.json."""
    lines = [
        "| method | mode | ARW [deg/√h] | bias instability [deg/h] | residual drift std / p-p [deg/h] | injected signal kept |",
        "|---|---|---|---|---|---|",
    ]
    for row in report["rows"]:
        arw = row["arw"]["value"]
        kept = row.get("signal")
        signal = "–"
        if kept is not None:
            signal = f"{100 * kept['gain']:.0f} %"
            lost = {name: g for name, g in kept["parts"].items() if g < 0.95}
            if lost:
                signal += " (" + ", ".join(f"{_part(n)}: {100 * g:.0f} %" for n, g in lost.items()) + ")"
        arw_text = "0 (white noise removed)" if arw is not None and arw < 1e-3 else _g(arw)
        lines.append(
            f"| {NAMES.get(row['method'], row['method'])} | {row['mode'] or '–'} | {arw_text} | "
            f"{_g(row['bias_instability']['value'])} | {_g(row['residual_drift']['std_deg_h'])} / "
            f"{_g(row['residual_drift']['p2p_deg_h'])} | {signal} |"
        )
    return "\n".join(lines)


def spread(reports: list[dict]) -> dict[str, dict[str, float]]:
    """Per method (and mode) and figure: the largest |other - first| / |first| over the other reports."""
    out = {}
    first = {(r["method"], r["mode"]): r for r in reports[0]["rows"]}
    for key, row in first.items():
        label = NAMES.get(key[0], key[0]) + (f" ({key[1]})" if key[1] else "")
        out[label] = {}
        for name, get in FIGURES.items():
            ref = get(row)
            if ref is None:
                continue
            worst = 0.0
            for other in reports[1:]:
                match = next(r for r in other["rows"] if (r["method"], r["mode"]) == key)
                value = get(match)
                worst = max(worst, abs(value - ref) / abs(ref) if ref else abs(value))
            out[label][name] = worst
    return out


def spread_table(spreads: dict[str, dict[str, float]]) -> str:
    """The spreads as Markdown, in per cent."""
    names = list(FIGURES)
    lines = ["| method | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for label, figures in spreads.items():
        lines.append(f"| {label} | " + " | ".join(
            "–" if n not in figures else f"{100 * figures[n]:.1f} %" for n in names) + " |")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reports", nargs="+", type=Path, help="report.json of `make run` (the first gives the table)")
    parser.add_argument("--json", type=Path, help="also write the table, machine and spreads here")
    args = parser.parse_args(argv)
    reports = [json.loads(p.read_text()) for p in args.reports]
    text = table(reports[0])
    where = machine()
    print(text)
    print(f"\nMachine: {where}.")
    result = {"table_markdown": text, "machine": where, "reports": [str(p) for p in args.reports]}
    if len(reports) > 1:
        spreads = spread(reports)
        print(f"\nLargest relative difference from {args.reports[0]} over {len(reports) - 1} other run(s):\n")
        print(spread_table(spreads))
        result["spread"] = spreads
    if args.json:
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(result, indent=1) + "\n")
        tmp.replace(args.json)
    return 0


def _g(value) -> str:
    """Three significant figures, no exponent: 1220, 283, 45.0, 2.97."""
    if value is None:
        return "n/a"
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:#.3g}"


def _part(name: str) -> str:
    return name.replace("sine_", "").replace("hz", " Hz sine")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
