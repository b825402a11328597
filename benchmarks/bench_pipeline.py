"""Per-stage times of `make run` (gyrocomp run configs/compare.toml on sample_data/).

Runs the same job as `make run` in a temporary folder and reads the stage
times the run records in report.json: for each method decompose, classify,
train and each compensation (test and test + injected signal, per mode),
plus the scoring and report. The reference for ratios is the cheapest
complete method in the same run, the polynomial baseline (train +
compensate): every other method's total is given as a multiple of it, so
the figures survive a loaded machine better than the seconds do.
`--quick` scores the 3-hour head of each recording instead.

Timings are noisy while other jobs share the CPU (the ICEEMDAN ensemble
dominates and scales with the load). Writes benchmarks/results/pipeline.json.
"""

import sys
import tempfile
import time
from pathlib import Path

import provenance

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def main(quick: bool) -> dict:
    from gyrocomp import artefacts, recordings
    from gyrocomp.commands import run as run_command

    train = ROOT / "sample_data" / "oven_train.parquet"
    test = ROOT / "sample_data" / "oven_test.parquet"
    with tempfile.TemporaryDirectory() as folder:
        if quick:
            paths = []
            for path in (train, test):
                rec = recordings.read_recording(path)
                paths.append(Path(folder) / path.name)
                artefacts.write_table(paths[-1], rec.data.iloc[:10800], {})
            train, test = paths
        start = time.perf_counter()
        options = run_command.Options(test=test, workers=2)
        report = run_command.to_files([ROOT / "configs" / "compare.toml", train], Path(folder) / "out", options)
        wall = time.perf_counter() - start
    methods = {}
    for m in report["methods"]:
        methods[m["name"]] = {"stages_s": m["stage_times_s"], "total_s": sum(m["stage_times_s"].values())}
    base = methods["polynomial"]["total_s"]
    for entry in methods.values():
        entry["ratio_to_polynomial"] = entry["total_s"] / base if base > 0 else None
    scored = sum(e["total_s"] for e in methods.values())
    result = {
        "quick": quick,
        "wall_s": wall,
        "scoring_and_report_s": wall - scored,
        "methods": methods,
        "samples": {"train": report["train"]["n_samples"], "test": report["test"]["n_samples"]},
        "note": "noisy: other jobs share the CPU; ratios are to the polynomial baseline measured in the same run",
    }
    return result


if __name__ == "__main__":
    out = main("--quick" in sys.argv[1:])
    for name, entry in out["methods"].items():
        stages = ", ".join(f"{k} {v:.2f}" for k, v in entry["stages_s"].items())
        print(f"{name:28s} total {entry['total_s']:7.2f} s ({entry['ratio_to_polynomial']:.0f}x polynomial): {stages}")
    print(f"wall {out['wall_s']:.1f} s, scoring and report {out['scoring_and_report_s']:.1f} s")
    provenance.write("pipeline", out)
