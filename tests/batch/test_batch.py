"""``gyrocomp batch``: failures recorded, incremental re-runs, kill and resume, identical bytes across backends."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp.batch import expand_inputs, folder_names, run_batch
from gyrocomp.batch.jobs import JOBS, paired_path
from gyrocomp.batch.manifest import MANIFEST, read_manifest
from gyrocomp.cli import app

N_GOOD = 4


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> Path:
    """Four simulated 1 Hz static logs (1 h each) and one truncated Parquet file."""
    from gyrocomp import artefacts, sim

    folder = tmp_path_factory.mktemp("logs")
    gyro = sim.load_sim_config(None, profile="soak-25").gyro
    profile = sim.load_sim_config(None, profile="soak-25").profile
    for seed in range(N_GOOD):
        frame, _ = sim.simulate(gyro, profile, fs_hz=1.0, seed=seed, duration_s=3600.0)
        artefacts.write_table(folder / f"unit{seed}.parquet", frame[["time", "rate", "temperature"]], {})
    raw = (folder / "unit0.parquet").read_bytes()
    (folder / "truncated.parquet").write_bytes(raw[: len(raw) // 2])
    return folder


def _invoke(*args: str):
    return CliRunner().invoke(app, ["-q", "batch", *args])


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file() and p.name != ".batch.lock"}


def test_truncated_input_is_reported_and_the_rest_finish(logs, tmp_path):
    out = tmp_path / "out"
    result = _invoke("allan", str(logs / "*.parquet"), "--out", str(out), "--workers", "1")
    assert result.exit_code == 2, result.output  # every failure is a bad input
    summary = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert list(summary["input"]) == sorted(summary["input"])
    bad = summary[summary["input"].str.endswith("truncated.parquet")].iloc[0]
    assert bad["status"] == "failed" and "truncated.parquet" in bad["error"] and "Parquet" in bad["error"]
    good = summary[summary["status"] == "ok"]
    assert len(good) == N_GOOD
    assert good["arw_fit"].astype(float).between(0.5, 2.0).all()  # default gyro: ARW 1 deg/sqrt(h)
    for name in good["output"]:
        assert sorted(p.name for p in (out / name).iterdir()) == ["allan.json", "allan.png", MANIFEST]
    assert not (out / "truncated").exists()
    assert not [p for p in out.iterdir() if ".tmp-" in p.name]
    frame = pd.read_parquet(out / "summary.parquet")
    assert list(frame["status"]) == list(summary["status"])


def test_rerun_skips_up_to_date_and_redoes_changed_settings(logs, tmp_path):
    out = tmp_path / "out"
    run_batch("allan", [str(logs / "unit*.parquet")], out, workers=1)
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob(MANIFEST)}
    again = run_batch("allan", [str(logs / "unit*.parquet")], out, workers=1)
    assert again.count("skipped") == N_GOOD and again.exit_code == 0
    assert {p: p.stat().st_mtime_ns for p in out.rglob(MANIFEST)} == stamps
    first = pd.read_csv(out / "summary.csv")
    assert first["arw_fit"].notna().all()  # a skipped row keeps its figures
    changed = run_batch("allan", [str(logs / "unit*.parquet")], out, workers=1, options={"taus": "decade"})
    assert changed.count("ok") == N_GOOD
    assert read_manifest(out / "unit0")["settings"]["options"]["taus"] == "decade"


def test_threshold_crossed_exits_3_and_is_remembered(logs, tmp_path):
    out = tmp_path / "out"
    args = ("allan", str(logs / "unit[01].parquet"), "--out", str(out), "--workers", "1", "--max-arw", "0.01")
    assert _invoke(*args).exit_code == 3
    result = _invoke(*args)  # skipped inputs still report their crossing
    assert result.exit_code == 3
    summary = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert set(summary["status"]) == {"skipped"}
    assert summary["threshold"].str.contains("exceeds --max-arw").all()


def test_killed_batch_resumes_without_redoing_finished_inputs(logs, tmp_path):
    src = tmp_path / "logs"
    src.mkdir()
    for i in range(8):  # more inputs than finish before the kill
        shutil.copy(logs / f"unit{i % N_GOOD}.parquet", src / f"log{i}.parquet")
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "gyrocomp", "-q", "batch", "allan", str(src / "*.parquet"), "--out", str(out), "--workers", "1"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    while not list(out.glob(f"*/{MANIFEST}")) and proc.poll() is None:  # no wall-clock bound: a loaded CPU only slows it
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    # pathlib's "*" matches dot names too: a kill between writing an output's manifest in its temporary folder
    # and renaming the folder leaves ".NAME.tmp-*/MANIFEST", which is not finished (the resume removes it, below).
    finished = {p.parent.name: p.stat().st_mtime_ns for p in out.glob(f"*/{MANIFEST}") if not p.parent.name.startswith(".")}
    if not finished or len(finished) == 8:
        pytest.skip(f"the kill came {'before the first' if not finished else 'after the last'} input finished")
    result = run_batch("allan", [str(src / "*.parquet")], out, workers=2)
    status = {row["output"]: row["status"] for row in result.rows}
    assert {name for name, s in status.items() if s == "skipped"} == set(finished)
    assert {name for name, s in status.items() if s == "ok"} == set(status) - set(finished)
    assert {name: (out / name / MANIFEST).stat().st_mtime_ns for name in finished} == finished
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.is_dir()]


def test_a_temporary_folder_left_by_a_kill_after_its_manifest_is_redone_not_skipped(logs, tmp_path):
    """The race the kill test can hit: the manifest written in the hidden temporary folder, the rename not yet done."""
    pattern = [str(logs / "unit[01].parquet")]
    run_batch("allan", pattern, tmp_path / "done", workers=1)
    out = tmp_path / "out"
    out.mkdir()
    shutil.copytree(tmp_path / "done" / "unit0", out / ".unit0.tmp-killed")
    result = run_batch("allan", pattern, out, workers=1)
    assert {row["output"]: row["status"] for row in result.rows} == {"unit0": "ok", "unit1": "ok"}
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["unit0", "unit1"]


def test_one_and_two_workers_give_identical_bytes(logs, tmp_path):
    # Exact within one machine: the workers run the same build on the same CPU as this process.
    pattern = [str(logs / "unit*.parquet")]
    one = run_batch("allan", pattern, tmp_path / "one", workers=1)
    two = run_batch("allan", pattern, tmp_path / "two", workers=2)
    assert one.rows == two.rows
    assert _tree(tmp_path / "one") == _tree(tmp_path / "two")


def test_dask_cluster_gives_the_local_bytes(logs, tmp_path):
    # Exact within one machine (an in-process cluster); a cluster of other CPUs may differ in the last bits.
    distributed = pytest.importorskip("dask.distributed")
    pattern = [str(logs / "unit[012].parquet")]
    run_batch("allan", pattern, tmp_path / "local", workers=1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        result = run_batch("allan", pattern, tmp_path / "dask", scheduler=cluster.scheduler_address)
    assert result.count("ok") == 3
    assert _tree(tmp_path / "local") == _tree(tmp_path / "dask")


def test_compensate_needs_a_model_and_applies_it(logs, tmp_path):
    assert _invoke("compensate", str(logs / "unit0.parquet"), "--out", str(tmp_path / "x")).exit_code == 2
    sample = Path(__file__).resolve().parents[2] / "sample_data" / "oven_train.parquet"
    model = tmp_path / "model.json"
    trained = CliRunner().invoke(app, ["-q", "train", str(sample), "--config", "polynomial", "--out", str(model)])
    assert trained.exit_code == 0, trained.output
    out = tmp_path / "comp"
    result = _invoke("compensate", str(logs / "unit[01].parquet"), "--model", str(model), "--mode", "causal", "--out", str(out), "--workers", "1")
    assert result.exit_code == 0, result.output
    summary = pd.read_csv(out / "summary.csv")
    assert summary["compensated_drift_std_deg_h"].notna().all()
    assert read_manifest(out / "unit0")["settings"]["options"]["mode"] == "causal"
    assert sorted(p.name for p in (out / "unit0").iterdir()) == ["compensated.meta.json", "compensated.parquet", MANIFEST]


def test_unknown_or_foreign_options_exit_2(logs, tmp_path):
    for extra in (["--no-such"], ["--plot", "x.png"], ["--column"]):
        result = _invoke("allan", str(logs / "unit0.parquet"), "--out", str(tmp_path / "o"), *extra)
        assert result.exit_code == 2, (extra, result.output)
    assert _invoke("nosuch", str(logs / "unit0.parquet"), "--out", str(tmp_path / "o")).exit_code == 2
    assert _invoke("allan", str(tmp_path / "none*.csv"), "--out", str(tmp_path / "o")).exit_code == 2


def test_folder_names_disambiguate_shared_stems_deterministically():
    names = folder_names(["a/x.csv", "b/x.parquet", "c/y.csv"])
    assert names["c/y.csv"] == "y"
    assert names["a/x.csv"] != names["b/x.parquet"]
    assert names["a/x.csv"].startswith("x-") and len(names["a/x.csv"]) == 10
    assert folder_names(["b/x.parquet", "a/x.csv", "d/x.csv"])["a/x.csv"] == names["a/x.csv"]


def test_expand_inputs_and_pairing(tmp_path):
    for name in ("b.csv", "a.csv", "sub/c.csv"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text("time,rate\n")
    found = expand_inputs([str(tmp_path / "**" / "*.csv"), str(tmp_path / "a.csv")])
    assert [Path(p).name for p in found] == ["a.csv", "b.csv", "c.csv"]
    assert paired_path("test/{name}", Path("train/u7.parquet")) == Path("test/u7.parquet")
    assert paired_path("{dir}/{stem}_hold.csv", Path("d/u7.csv")) == Path("d/u7_hold.csv")
    assert paired_path(None, Path("u.csv")) is None


def test_batch_passes_the_commands_options_with_their_defaults():
    """A batch passes options the command has, and the stage's defaults are the command's."""
    import dataclasses
    import importlib

    import typer.main

    from gyrocomp.commands import STAGES, from_params, stage

    for name in STAGES:
        importlib.import_module(f"gyrocomp.cli.{name}")
        command = typer.main.get_command(app).commands[name]
        defaults = {p.name: p.default for p in command.params if p.default is not ...}
        options = stage(name).Options
        assert from_params(options, defaults) == options(), name
        given = {f.name for f in dataclasses.fields(options)} - {"columns"}
        assert given <= set(defaults), (name, given - set(defaults))
    for name, job in JOBS.items():
        command = typer.main.get_command(app).commands[name]
        assert set(job.options) <= {p.name for p in command.params}, name


@pytest.mark.slow
def test_run_batch_pairs_each_unit_with_its_test_run(tmp_path):
    """One calibration per unit: `--test` pairs a training log with its held-out run."""
    sample = Path(__file__).resolve().parents[2] / "sample_data"
    train, test = tmp_path / "train", tmp_path / "test"
    train.mkdir(), test.mkdir()
    shutil.copy(sample / "oven_train.parquet", train / "unit1.parquet")
    shutil.copy(sample / "oven_test.parquet", test / "unit1.parquet")
    out = tmp_path / "out"
    result = _invoke(
        "run", str(train / "*.parquet"), "--config", "compare", "--set", 'run.methods=["polynomial"]',
        "--test", str(test / "{name}"), "--out", str(out), "--workers", "1",
    )
    assert result.exit_code == 0, result.output
    row = pd.read_csv(out / "summary.csv").iloc[0]
    assert bool(row["held_out"]) and row["polynomial_causal_drift_std_deg_h"] < row["raw_drift_std_deg_h"]
    assert (out / "unit1" / "report.json").is_file() and (out / "unit1" / "polynomial" / "model.json").is_file()


@pytest.mark.slow
def test_diagnose_batch_writes_report_and_gap_figures(logs, tmp_path):
    out = tmp_path / "out"
    result = run_batch("diagnose", [str(logs / "unit0.parquet")], out, workers=1, options={"holdout": str(logs / "unit1.parquet")})
    assert result.exit_code == 0, result.rows
    row = result.rows[0]
    assert row["gap_selected_fit"] <= row["gap_baseline_fit"] + 1e-12
    assert sorted(p.name for p in (out / "unit0").iterdir()) == ["gap.png", MANIFEST, "report.json", "report.md"]


def test_batch_allan_writes_what_the_allan_command_writes(logs, tmp_path):
    """Both call gyrocomp.commands.allan.to_files: same allan.json bytes."""
    single = tmp_path / "single.json"
    assert CliRunner().invoke(app, ["-q", "allan", str(logs / "unit2.parquet"), "--out", str(single)]).exit_code == 0
    run_batch("allan", [str(logs / "unit2.parquet")], tmp_path / "b", workers=1)
    assert (tmp_path / "b" / "unit2" / "allan.json").read_bytes() == single.read_bytes()


def test_scheduler_without_dask_is_a_clear_exit_2(logs, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import fails as if not installed
    result = _invoke("allan", str(logs / "unit0.parquet"), "--out", str(tmp_path / "o"), "--scheduler", "tcp://127.0.0.1:1")
    assert result.exit_code == 2
    assert "pip install 'gyrocomp[dask]'" in result.output


def test_compensate_names_the_drift_figures_in_each_axis_unit(tmp_path):
    # A gyro axis and an accelerometer axis: the rate's residual drift is in deg/h, the
    # acceleration's in its own unit (m/s^2), the figures named after it; no accel figure says deg/h.
    import numpy as np

    t = np.arange(4000.0)
    temperature = 20.0 + 10.0 * np.sin(2 * np.pi * t / 4000.0)
    rng = np.random.default_rng(3)
    frame = pd.DataFrame({"time": t, "gx": 0.01 * (temperature - 25) + rng.normal(0, 1e-3, t.size),
                          "az": 9.81 + 2e-3 * (temperature - 25) + rng.normal(0, 1e-4, t.size), "temperature": temperature})
    logs = tmp_path / "logs"
    logs.mkdir()
    frame.to_csv(logs / "imu.csv", index=False)
    columns = ["--rate-col", "gx,az", "--rate-unit", "deg/s,m/s^2"]
    model = tmp_path / "model.json"
    trained = CliRunner().invoke(app, ["-q", "train", str(logs / "imu.csv"), "--config", "polynomial", "--out", str(model), *columns])
    assert trained.exit_code == 0, trained.output
    out = tmp_path / "comp"
    result = _invoke("compensate", str(logs / "imu.csv"), "--model", str(model), "--out", str(out), "--workers", "1", *columns)
    assert result.exit_code == 0, result.output
    row = pd.read_csv(out / "summary.csv").iloc[0]
    assert not [c for c in row.index if c.startswith("az") and "deg_h" in c]
    raw_az = frame["az"].to_numpy()[:4000].reshape(40, 100).mean(axis=1)
    assert row["az_drift_std_m_s2"] == pytest.approx(np.std(raw_az), rel=1e-9)
    assert row["az_compensated_drift_std_m_s2"] < 0.2 * row["az_drift_std_m_s2"]
    assert row["gx_drift_std_deg_h"] == pytest.approx(np.std(frame["gx"].to_numpy().reshape(40, 100).mean(axis=1)) * 3600, rel=1e-9)
