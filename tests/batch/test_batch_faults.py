"""Batch faults (issue 21 items 3, 4, 10, 11): killed batches, dying workers, stale pairs, reserved names.

The pool tests run in a subprocess of their own: worker processes come
from a forkserver that keeps the environment of its first use, and the
tests need one that can import a small job module written here.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp.batch import folder_names
from gyrocomp.batch import manifest as mf
from gyrocomp.batch.jobs import JOBS, _paired_records
from gyrocomp.cli import app
from gyrocomp.commands import stage

JOB_MODULE = '''
import os, signal, time
from pathlib import Path

def work(task):
    folder = Path(task["dir"])
    (folder / f".started-{task['i']}").write_text(str(os.getpid()))
    os.replace(folder / f".started-{task['i']}", folder / f"started-{task['i']}")
    if task["i"] == task.get("killer"):
        os.kill(os.getpid(), signal.SIGKILL)  # as the OOM killer would
    time.sleep(task.get("sleep", 0.0))
    (folder / f"done-{task['i']}").write_text("")
    return {"i": task["i"]}
'''

DRIVER = '''
import json, signal, sys
from gyrocomp.batch import backends
from gyrocomp.cli._app import raise_on_sigterm
import faultjob

signal.signal(signal.SIGTERM, raise_on_sigterm)
spec = json.loads(sys.argv[1])
tasks = [{"i": i, "dir": spec["dir"], "sleep": spec["sleep"], "killer": spec.get("killer")} for i in range(spec["n"])]
for task, outcome in backends.run_local(faultjob.work, tasks, workers=2):
    print(json.dumps({"i": task["i"], "ok": isinstance(outcome, dict), "error": type(outcome).__name__}), flush=True)
'''


def _driver(tmp_path: Path, **spec) -> subprocess.Popen:
    (tmp_path / "faultjob.py").write_text(JOB_MODULE)
    work = tmp_path / "work"
    work.mkdir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen(
        [sys.executable, "-c", DRIVER, json.dumps({"dir": str(work), **spec})],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as fh:  # a zombie is dead
        return fh.read().split(")")[-1].split()[0] != "Z"


def _wait_for(predicate, seconds: float = 60.0) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM])
def test_workers_die_with_a_killed_batch_and_commit_nothing_after(tmp_path, how):
    proc = _driver(tmp_path, n=6, sleep=3.0)
    work = tmp_path / "work"
    assert _wait_for(lambda: len(list(work.glob("started-*"))) >= 2, 300.0), proc.stderr.read() if proc.poll() else "no start"
    pids = [int(p.read_text()) for p in work.glob("started-*")]
    proc.send_signal(how)
    proc.wait(timeout=60)
    assert _wait_for(lambda: not any(_alive(pid) for pid in pids), 30.0), "orphan workers"
    time.sleep(3.5)  # longer than a task: an orphan would have finished it by now
    assert list(work.glob("done-*")) == []


def test_a_dying_worker_fails_only_its_own_input(tmp_path):
    """The pool restarts; inputs in flight with the killer are retried alone, so only the killer fails."""
    proc = _driver(tmp_path, n=8, sleep=0.2, killer=3)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    rows = {row["i"]: row for row in map(json.loads, out.splitlines())}
    assert sorted(rows) == list(range(8))
    assert [i for i, row in rows.items() if not row["ok"]] == [3]
    assert rows[3]["error"] == "BrokenProcessPool"


def test_commit_refuses_once_the_batch_lock_is_free(tmp_path):
    import fcntl

    out = tmp_path / "out"
    out.mkdir()
    lock = out / mf.LOCK
    lock.write_text("")
    tmp = mf.new_folder(out, "unit")
    (tmp / "allan.json").write_text("{}")
    with pytest.raises(Exception, match="the batch that started this input is gone"):
        mf.commit_folder(tmp, out / "unit", lock=lock)
    assert not (out / "unit").exists()
    with open(lock) as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        mf.commit_folder(tmp, out / "unit", lock=lock)
    assert (out / "unit" / "allan.json").is_file()


def test_a_changed_paired_recording_makes_the_folder_stale(tmp_path):
    """The up-to-date check hashes the paired holdout's content, not the --holdout template."""
    (tmp_path / "hold").mkdir()
    source = tmp_path / "unit1.csv"
    source.write_text("time,rate,temperature\n")
    paired = tmp_path / "hold" / "unit1.csv"
    paired.write_text("a")
    job = JOBS["diagnose"]
    options = stage("diagnose").Options(holdout=str(tmp_path / "hold" / "{name}"))
    before = _paired_records(job, options, source)
    paired.write_text("b")
    after = _paired_records(job, options, source)
    assert before["--holdout"]["sha256"] != after["--holdout"]["sha256"]
    assert _paired_records(JOBS["allan"], stage("allan").Options(), source) == {}


def test_an_input_named_like_the_summary_gets_its_own_folder(tmp_path):
    names = folder_names(["a/summary.csv.parquet", "b/summary.parquet.csv", "c/unit.csv"])
    assert names["c/unit.csv"] == "unit"
    assert names["a/summary.csv.parquet"].startswith("summary.csv-") and names["b/summary.parquet.csv"].startswith("summary.parquet-")
    rng = np.random.default_rng(0)
    frame = pd.DataFrame({"time": np.arange(2000.0), "rate": rng.standard_normal(2000), "temperature": 25.0})
    frame.to_parquet(tmp_path / "summary.csv.parquet")
    out = tmp_path / "out"
    for _ in range(2):  # and again: it used to break every later batch of the folder
        result = CliRunner().invoke(app, ["-q", "batch", "allan", str(tmp_path / "*.parquet"), "--out", str(out), "--workers", "1"])
        assert result.exit_code == 0, result.output
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary["status"]) == ["skipped"] and summary["output"][0].startswith("summary.csv-")
