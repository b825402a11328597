"""Hostile inputs at the command boundary: a table of cases, each with its exit code and message (issue 21).

Every case runs the real command line in a folder of its own and checks
three things: the exit code, a one-line message on stderr that names the
file (and, where it applies, the field), and that every file that was
there before is unchanged and nothing new was written (no half-written
artefact, no hidden temporary file).

A stage added to :data:`gyrocomp.commands.STAGES` inherits the output-path
guard: :func:`test_every_stage_is_guarded` fails until its ``to_files`` is
wrapped by :func:`gyrocomp.commands.guarded` with every path it writes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp import commands
from gyrocomp.cli import app
from gyrocomp.errors import InputError


def _recording(path: Path, n: int = 600) -> Path:
    rng = np.random.default_rng(0)
    t = np.arange(n, dtype=float)
    frame = pd.DataFrame({"time": t, "rate": 0.01 * rng.standard_normal(n), "temperature": 20.0 + t / 60.0})
    if path.suffix == ".csv":
        frame.to_csv(path, index=False)
    else:
        frame.to_parquet(path)
    return path


def _setup(folder: Path) -> None:
    _recording(folder / "x.parquet")
    _recording(folder / "h.parquet")
    _recording(folder / "real.csv")
    (folder / "model.json").write_text('{"schema": {"name": "gyrocomp.model"}}\n')
    (folder / "model.meta.json").write_text('{"schema": {"name": "gyrocomp.model"}}\n')  # a model named as a sidecar
    (folder / "out").mkdir()
    _recording(folder / "out" / "train.parquet")
    os.symlink("x.parquet", folder / "link.parquet")
    os.link(folder / "x.parquet", folder / "hard.parquet")


# (case id, argv, exit code, regex the one stderr line must match)
CASES = [
    ("allan-onto-input", ["allan", "x.parquet", "--out", "x.parquet"], 2, r"x\.parquet: the output would overwrite the input x\.parquet"),
    ("allan-onto-symlinked-input", ["allan", "link.parquet", "--out", "x.parquet"], 2, r"overwrite the input link\.parquet"),
    ("allan-onto-hard-linked-input", ["allan", "hard.parquet", "--out", "x.parquet"], 2, r"overwrite the input hard\.parquet"),
    ("allan-plot-onto-input", ["allan", "x.parquet", "--out", "a.json", "--plot", "x.parquet"], 2, r"overwrite the input x\.parquet"),
    ("allan-plot-equals-out", ["allan", "x.parquet", "--out", "a.json", "--plot", "a.json"], 2, r"a\.json: named as two outputs"),
    ("compensate-sidecar-onto-model", ["compensate", "x.parquet", "model.meta.json", "--out", "model.parquet"], 2, r"model\.meta\.json: the output would overwrite the input model\.meta\.json"),
    ("compensate-onto-recording", ["compensate", "x.parquet", "model.json", "--out", "x.parquet"], 2, r"overwrite the input x\.parquet"),
    ("decompose-onto-input", ["decompose", "x.parquet", "--out", "x.parquet"], 2, r"overwrite the input x\.parquet"),
    ("classify-onto-input", ["classify", "x.parquet", "--out", "x.parquet"], 2, r"overwrite the input x\.parquet"),
    ("train-onto-input", ["train", "x.parquet", "--config", "polynomial", "--out", "x.parquet"], 2, r"overwrite the input x\.parquet"),
    ("simulate-onto-profile", ["simulate", "--profile", "real.csv", "--out", "real.csv"], 2, r"overwrite the input real\.csv"),
    ("diagnose-onto-holdout", ["diagnose", "x.parquet", "--holdout", "h.parquet", "--out", "h.parquet"], 2, r"overwrite the input h\.parquet"),
    ("export-onto-model", ["export", "model.json", "--format", "json-plain", "--out", "model.json"], 2, r"overwrite the input model\.json"),
    ("run-into-input-folder", ["run", "compare", "out/train.parquet", "--out", "out"], 2, r"out: the output would overwrite the input out/train\.parquet"),
]


def _snapshot(folder: Path) -> dict:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        for p in sorted(folder.rglob("*"))
    }


@pytest.mark.parametrize("argv, code, message", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_hostile_case(tmp_path, monkeypatch, argv, code, message):
    _setup(tmp_path)
    _check_case(tmp_path, monkeypatch, argv, code, message)


def _check_case(folder: Path, monkeypatch, argv, code, message) -> None:
    """Run `argv` in `folder`: exit `code`, one stderr line matching `message`, every file unchanged, none new."""
    monkeypatch.chdir(folder)
    before = _snapshot(folder)
    result = CliRunner().invoke(app, argv)
    assert result.exit_code == code, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gyrocomp: "), lines
    assert re.search(message, lines[0]), lines[0]
    assert _snapshot(folder) == before


def test_every_stage_is_guarded():
    """Each stage declares what it writes, and every output option (plot, markdown) is among it."""
    for name in commands.STAGES:
        module = commands.stage(name)
        written = getattr(module.to_files, "written", None)
        assert written is not None, f"commands.{name}.to_files is not wrapped by commands.guarded"
        outputs = {f.name for f in dataclasses.fields(module.Options) if f.name in ("plot", "markdown")}
        options = module.Options(**{f: f"{f}.out" for f in outputs})
        listed = {os.fspath(p) for p in written("main.out", options) if p is not None}
        assert {f"{f}.out" for f in outputs} <= listed, (name, listed)


def test_debug_keeps_the_exit_code_and_shows_the_traceback(tmp_path):
    """``--debug`` adds the traceback; a bad input still exits 2, not 1."""
    result = CliRunner().invoke(app, ["--debug", "allan", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "a.json")])
    assert result.exit_code == 2
    assert "Traceback" in result.stderr and "gyrocomp: " in result.stderr.strip().splitlines()[-1]


def test_sigterm_during_a_write_leaves_no_temporary_file(tmp_path):
    """SIGTERM arriving inside an atomic write unwinds like Ctrl-C: exit 143, the temporary file removed."""
    import subprocess
    import sys

    rec = _recording(tmp_path / "x.parquet")
    out = tmp_path / "out"
    script = (
        "import os, signal, sys\n"
        "import gyrocomp.cli as cli\n"
        "real_fsync = os.fsync\n"
        "def fsync(fd):\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    real_fsync(fd)\n"
        "os.fsync = fsync\n"
        "sys.argv = ['gyrocomp', 'allan', sys.argv[1], '--out', sys.argv[2]]\n"
        "cli.main()\n"
    )
    proc = subprocess.run([sys.executable, "-c", script, str(rec), str(out / "allan.json")], capture_output=True, text=True)
    assert proc.returncode == 143, proc.stderr
    assert proc.stderr.strip().splitlines() == ["gyrocomp: terminated"]
    assert list(out.iterdir()) == []


CONFIG_CASES = [
    # (case id, argv, the one line must match)
    ("set-typo-in-table", ["train", "x.parquet", "--config", "polynomial", "--set", "modle.drift.degree=1", "--out", "m.json"], r"polynomial: unknown table modle; this config has \[pipeline\]"),
    ("unknown-table-in-file", ["train", "x.parquet", "--config", "bad.toml", "--out", "m.json"], r"bad\.toml: unknown table piepline"),
    ("allan-config-typo", ["allan", "x.parquet", "--config", "bad_allan.toml", "--out", "a.json"], r"bad_allan\.toml: unknown table alan"),
    ("decompose-config-typo", ["decompose", "x.parquet", "--config", "bad.toml", "--out", "c.parquet"], r"bad\.toml: unknown table piepline"),
    ("diagnose-config-typo", ["diagnose", "x.parquet", "--config", "bad_diagnose.toml", "--out", "d.json"], r"bad_diagnose\.toml: unknown table diagnos; this config has \[diagnose\]"),
    ("run-config-typo", ["run", "bad_run.toml", "x.parquet", "--out", "r"], r"bad_run\.toml: unknown table runn; this config has \[run\]"),
]


@pytest.mark.parametrize("argv, message", [c[1:] for c in CONFIG_CASES], ids=[c[0] for c in CONFIG_CASES])
def test_config_typos_are_refused(tmp_path, monkeypatch, argv, message):
    """Unknown top-level tables and ``--set`` keys with a typo in the table name exit 2 naming the key."""
    _setup(tmp_path)
    (tmp_path / "bad.toml").write_text('[piepline]\nkind = "polynomial"\n')
    (tmp_path / "bad_allan.toml").write_text("[alan]\ntaus = \"octave\"\n")
    (tmp_path / "bad_diagnose.toml").write_text("[diagnos]\ntau_grid_points = 8\n")
    (tmp_path / "bad_run.toml").write_text("[runn]\nmethods = [\"polynomial\"]\n")
    monkeypatch.chdir(tmp_path)
    before = _snapshot(tmp_path)
    result = CliRunner().invoke(app, argv)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and re.search(message, lines[0]), lines
    assert _snapshot(tmp_path) == before


def _constant_recording(path: Path, n: int = 600) -> None:
    t = np.arange(n, dtype=float)
    pd.DataFrame({"time": t, "rate": np.full(n, 0.5), "temperature": 20.0 + t / 60.0}).to_csv(path, index=False)


def _huge_rate(path: Path, value: float, n: int = 600) -> None:
    t = np.arange(n, dtype=float)
    rate = np.zeros(n)
    rate[5] = value
    frame = pd.DataFrame({"time": t, "rate": rate, "temperature": 20.0 + t / 60.0})
    frame.to_csv(path, index=False) if path.suffix == ".csv" else frame.to_parquet(path)


def _with_metadata(path: Path, value: bytes, n: int = 600) -> None:
    """A valid recording whose ``gyrocomp`` Parquet metadata is `value`."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(n, dtype=float)
    table = pa.table({"time": t, "rate": 0.01 * np.sin(t), "temperature": 20.0 + t / 60.0})
    pq.write_table(table.replace_schema_metadata({b"gyrocomp": value}), path)


SETTING_FILES = {
    "bias.toml": "[allan]\nbias_factor = -1\n",
    "arw.toml": "[allan]\narw_tau_s = 0\n",
    "taus.toml": "[allan]\ntaus = [1.0, 10.0]\n",
    "diag.toml": "[diagnose]\ntau_grid_points = 0\n",
}

SETTING_CASES = [
    # (case id, argv, exit code, the one line must match); each names the file or option and the setting
    ("allan-bias-factor-negative", ["allan", "x.parquet", "--config", "bias.toml", "--out", "a.json"], 2, r"bias\.toml \[allan\]: allan bias_factor = -1\.0; must be a finite number > 0"),
    ("allan-arw-tau-zero", ["allan", "x.parquet", "--config", "arw.toml", "--out", "a.json"], 2, r"arw\.toml \[allan\]: allan arw_tau_s = 0\.0"),
    ("allan-max-arw-nan", ["allan", "x.parquet", "--max-arw", "nan", "--out", "a.json"], 2, r"--max-arw nan: must be a finite number >= 0"),
    ("allan-constant-rate", ["allan", "const.csv", "--out", "a.json"], 2, r"const\.csv `rate`: Allan deviation 0 at tau = 1 s: the series does not vary"),
    ("allan-rate-1e300", ["allan", "huge.csv", "--out", "a.json"], 2, r"huge\.csv line 7: `rate` = 1e\+300 deg/s is beyond \+-100000 deg/s"),
    ("allan-rate-minus-1e300-parquet", ["allan", "huge.parquet", "--out", "a.json"], 2, r"huge\.parquet row 6: `rate` = -1e\+300 deg/s is beyond"),
    ("train-rate-1e300", ["train", "huge.csv", "--config", "polynomial", "--out", "m.json"], 2, r"huge\.csv line 7: `rate` = 1e\+300 deg/s"),
    ("diagnose-rate-1e300", ["diagnose", "huge.csv", "--out", "d.json"], 2, r"huge\.csv line 7: `rate` = 1e\+300 deg/s"),
    ("compensate-rate-1e300", ["compensate", "huge.csv", "m.json", "--out", "c.parquet"], 2, r"huge\.csv line 7: `rate` = 1e\+300 deg/s"),
    ("allan-acceleration-beyond-bound", ["allan", "accel.csv", "--rate-unit", "g", "--out", "a.json"], 2, r"accel\.csv line 7: `rate` = 20000 g is beyond \+-10197\.2 g"),
    ("allan-metadata-deeply-nested", ["allan", "deep.parquet", "--out", "a.json"], 2, r"deep\.parquet: gyrocomp metadata: not valid JSON \(nested too deeply\)"),
    ("allan-metadata-not-utf8", ["allan", "latin.parquet", "--out", "a.json"], 2, r"latin\.parquet: gyrocomp metadata: not valid JSON"),
    ("train-metadata-not-an-object", ["train", "list.parquet", "--config", "polynomial", "--out", "m.json"], 2, r"list\.parquet: gyrocomp metadata: expected a JSON object"),
    ("simulate-level-the-reader-refuses", ["simulate", "--profile", "soak-25", "--set", "profile.levels_c=[1000.0]", "--out", "s.parquet"], 2, r"profile\.levels_c = \(1000\.0,\) leaves \[-100, 200\] degC"),
    ("diagnose-tau-grid-zero", ["diagnose", "x.parquet", "--config", "diag.toml", "--out", "d.json"], 2, r"diag\.toml \[diagnose\]: diagnose\.tau_grid_points = 0"),
    ("simulate-seed-negative", ["simulate", "--seed", "-1", "--out", "s.parquet"], 2, r"--seed = -1: a seed must be an integer in 0\.\.4294967295$"),
    ("simulate-config-seed-negative", ["simulate", "--set", "run.seed=-1", "--out", "s.parquet"], 2, r"run\.seed = -1: a seed must be an integer in 0\.\.4294967295$"),
    ("simulate-config-seed-not-an-integer", ["simulate", "--set", "run.seed=1.5", "--out", "s.parquet"], 2, r"\[run\]: `seed` = 1\.5 should be of type int"),
    ("train-seed-negative", ["train", "x.parquet", "--config", "polynomial", "--seed", "-1", "--out", "m.json"], 2, r"--seed = -1: a seed must be"),
    ("train-seed-beyond-32-bits", ["train", "x.parquet", "--config", "bp", "--seed", "4294967296", "--out", "m.json"], 2, r"--seed = 4294967296: a seed must be an integer in 0\.\.4294967295$"),
    ("decompose-seed-negative", ["decompose", "x.parquet", "--seed", "-1", "--out", "c.parquet"], 2, r"--seed = -1: a seed must be"),
    ("compensate-seed-negative", ["compensate", "x.parquet", "model.json", "--mode", "full", "--seed", "-1", "--out", "c.parquet"], 2, r"--seed = -1: a seed must be"),
    ("run-seed-beyond-32-bits", ["run", "compare", "x.parquet", "--seed", "4294967296", "--out", "r"], 2, r"--seed = 4294967296: a seed must be"),
    ("batch-compensate-seed-negative", ["batch", "compensate", "x.parquet", "--model", "model.json", "--seed", "-1", "--out", "b"], 2, r"--seed = -1: a seed must be"),
    ("batch-run-seed-negative", ["batch", "run", "x.parquet", "--config", "compare", "--seed", "-1", "--out", "b"], 2, r"--seed = -1: a seed must be"),
    ("simulate-fs-huge", ["simulate", "--fs", "1e9", "--out", "s.parquet"], 2, r"run\.fs_hz \(--fs\) = 1000000000\.0 must be in \[0\.01, 100000\] Hz"),
    ("train-rate-window-beyond-recording", ["train", "x.parquet", "--config", "polynomial", "--set", "rate.window_s=1e9", "--out", "m.json"], 2, r"x\.parquet: \[rate\] window_s = 1e\+09 s is longer than the recording \(600 s\)"),
    ("decompose-ensemble-huge", ["decompose", "x.parquet", "--config", "iceemdan-se-tfpf-nsga2elm", "--set", "ensemble=1000000000", "--out", "c.parquet"], 2, r"ensemble = 1000000000; must be in 1\.\.10000"),
]


@pytest.mark.parametrize("argv, code, message", [c[1:] for c in SETTING_CASES], ids=[c[0] for c in SETTING_CASES])
def test_bad_setting_is_refused(tmp_path, monkeypatch, trained_model, argv, code, message):
    """Every setting has a validated type and range; the error names the setting (issue 21 items 8, 9)."""
    _setup(tmp_path)
    (tmp_path / "m.json").write_bytes(trained_model.read_bytes())
    _constant_recording(tmp_path / "const.csv")
    _huge_rate(tmp_path / "huge.csv", 1e300)
    _huge_rate(tmp_path / "huge.parquet", -1e300)
    _huge_rate(tmp_path / "accel.csv", 2e4)
    _with_metadata(tmp_path / "deep.parquet", b"[" * 100_000 + b"]" * 100_000)
    _with_metadata(tmp_path / "latin.parquet", '{"name": "caf\u00e9"}'.encode("latin-1"))
    _with_metadata(tmp_path / "list.parquet", b"[1, 2]")
    for name, text in SETTING_FILES.items():
        (tmp_path / name).write_text(text)
    _check_case(tmp_path, monkeypatch, argv, code, message)


@pytest.mark.parametrize("name", [n for n in commands.STAGES if "seed" in {f.name for f in dataclasses.fields(commands.stage(n).Options)}])
@pytest.mark.parametrize("seed", [-1, 2**32, 1.5, True, "1"])
def test_every_stage_with_a_seed_refuses_a_bad_one(name, seed):
    """A stage that takes a seed (now or added later) checks it when its options are built, naming --seed."""
    with pytest.raises(InputError, match=r"^--seed = .*: a seed must be an integer in 0\.\.4294967295$"):
        commands.stage(name).Options(seed=seed)
    assert commands.stage(name).Options(seed=2**32 - 1).seed == 2**32 - 1


def test_a_seed_given_as_text_is_a_usage_error_naming_the_option(tmp_path):
    """``--seed 1.5`` never reaches the check: the option's integer type refuses it (exit 2, naming --seed)."""
    x = _recording(tmp_path / "x.parquet")
    result = CliRunner().invoke(app, ["train", str(x), "--config", "polynomial", "--seed", "1.5", "--out", str(tmp_path / "m.json")])
    assert result.exit_code == 2 and "'--seed'" in result.stderr and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == [x]


def test_allan_taus_list_form_is_read(tmp_path):
    """The documented list form of ``taus`` gives exactly those taus (in seconds)."""
    from gyrocomp.allan import get_config

    (tmp_path / "taus.toml").write_text(SETTING_FILES["taus.toml"])
    x = _recording(tmp_path / "x.parquet")
    result = CliRunner().invoke(app, ["allan", str(x), "--config", str(tmp_path / "taus.toml"), "--out", str(tmp_path / "a.json")])
    assert result.exit_code == 0, result.output
    import json

    assert json.loads((tmp_path / "a.json").read_text())["series"][0]["tau_s"] == [1.0, 10.0]
    assert get_config(tmp_path / "taus.toml").taus == "1.0,10.0"


def test_an_error_that_names_no_file_is_given_the_inputs(tmp_path):
    """A library error about content (``savgol: 20 samples ...``) leaves a stage naming its input (issue 21 item 15)."""
    from gyrocomp.commands import allan as stage

    def failing(message):
        @commands.guarded(stage.written)
        def to_files(inputs, out, options=stage.Options()):
            raise InputError(message)

        return to_files

    x = _recording(tmp_path / "x.parquet")
    with pytest.raises(InputError, match=r"^.*x\.parquet: savgol: 20 samples are fewer than the window$"):
        failing("savgol: 20 samples are fewer than the window")([x], tmp_path / "a.json")
    with pytest.raises(InputError, match=r"^allan: unknown table$"):  # names the config already
        failing("allan: unknown table")([x], tmp_path / "a.json")
    with pytest.raises(InputError, match=r"^" + re.escape(f"{x} line 3: bad")):
        failing(f"{x} line 3: bad")([x], tmp_path / "a.json")


def _heating_and_cooling(path: Path, n: int = 600) -> list[str]:
    """Write a CSV recording (time, rate, temperature heating and cooling) to `path`; return its lines."""
    t = np.arange(n, dtype=float)
    rate = 0.01 * np.random.default_rng(0).standard_normal(n)
    text = pd.DataFrame({"time": t, "rate": rate, "temperature": 25.0 + 10.0 * np.sin(2 * np.pi * t / n)}).to_csv(index=False)
    path.write_text(text)
    return text.splitlines()


def _extra_field(path: Path, line: int) -> None:
    """That recording, with a fourth field on file line `line`."""
    lines = _heating_and_cooling(path)
    lines[line - 1] += ",7"
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def trained_model(tmp_path_factory) -> Path:
    """A polynomial model.json, trained once on that recording, for the commands that need one."""
    folder = tmp_path_factory.mktemp("model")
    _heating_and_cooling(folder / "clean.csv")
    result = CliRunner().invoke(app, ["train", str(folder / "clean.csv"), "--config", "polynomial", "--out", str(folder / "m.json")])
    assert result.exit_code == 0, result.output
    return folder / "m.json"


FIELD_LINE = r"extra\.csv line 5: 4 fields, the header has 3$"
"""Line 5 of extra.csv has 4 fields: every command names the file, the line and the count, in the same words."""

FIELD_CASES = [
    # (case id, argv); every one reads extra.csv as a recording: exit 2 and FIELD_LINE
    ("allan-streamed", ["allan", "extra.csv", "--out", "a.json"]),
    ("allan-whole-file", ["allan", "extra.csv", "--resample", "--out", "a.json"]),
    ("train", ["train", "extra.csv", "--config", "polynomial", "--out", "m2.json"]),
    ("compensate-causal-streamed", ["compensate", "extra.csv", "m.json", "--out", "c.parquet"]),
    ("compensate-full-whole-file", ["compensate", "extra.csv", "m.json", "--mode", "full", "--out", "c.parquet"]),
    ("decompose", ["decompose", "extra.csv", "--out", "c.parquet"]),
    ("diagnose-fit", ["diagnose", "extra.csv", "--out", "d.json"]),
    ("diagnose-holdout", ["diagnose", "x.parquet", "--holdout", "extra.csv", "--out", "d.json"]),
    ("run-train", ["run", "compare", "extra.csv", "--out", "run"]),
    ("run-test", ["run", "compare", "x.parquet", "--test", "extra.csv", "--out", "run"]),
    ("simulate-profile", ["simulate", "--profile", "extra.csv", "--out", "s.parquet"]),
]


@pytest.mark.parametrize("argv", [c[1] for c in FIELD_CASES], ids=[c[0] for c in FIELD_CASES])
def test_a_row_with_an_extra_field_is_refused_by_every_command(tmp_path, monkeypatch, trained_model, argv):
    """A CSV row with more fields than the header: the same one line from the whole-file and the chunked reader (issue 21 item 12)."""
    _setup(tmp_path)
    _extra_field(tmp_path / "extra.csv", 5)
    (tmp_path / "m.json").write_bytes(trained_model.read_bytes())
    _check_case(tmp_path, monkeypatch, argv, 2, FIELD_LINE)


def test_a_row_with_an_extra_field_fails_its_batch_input(tmp_path, monkeypatch):
    """``batch`` records the same line for the input (exit 2, every input bad)."""
    _extra_field(tmp_path / "extra.csv", 5)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["batch", "allan", "extra.csv", "--out", "b", "--workers", "1"])
    assert result.exit_code == 2, result.output
    summary = pd.read_csv(tmp_path / "b" / "summary.csv")
    assert list(summary["status"]) == ["failed"]
    assert re.search(FIELD_LINE, summary["error"][0]), summary["error"][0]


@pytest.mark.parametrize("command", [["allan", "--out", "a.json"], ["train", "--config", "polynomial", "--out", "m.json"]], ids=["allan", "train"])
def test_an_extra_field_in_the_first_data_row_is_refused_not_read_as_an_index(tmp_path, monkeypatch, command):
    """pandas would take the first field of every row for an index and shift the columns; both readers refuse it."""
    _setup(tmp_path)
    _extra_field(tmp_path / "extra.csv", 2)
    _check_case(tmp_path, monkeypatch, [command[0], "extra.csv", *command[1:]], 2, r"extra\.csv: the first data row has more fields than the header \(")


def test_a_trailing_separator_on_every_row_reads_the_columns_in_place(tmp_path):
    """``0,1,20,`` (a logger ending each line with the separator) is read as its header says, by both readers."""
    from gyrocomp import recordings, streaming

    frame = pd.DataFrame({"time": np.arange(50.0), "rate": np.linspace(-1, 1, 50), "temperature": np.linspace(20, 30, 50)})
    lines = frame.to_csv(index=False).splitlines()
    (tmp_path / "t.csv").write_text("\n".join([lines[0]] + [line + "," for line in lines[1:]]) + "\n")
    whole = recordings.read_recording(tmp_path / "t.csv", usecols=[])
    chunked = next(iter(streaming.read_chunks(tmp_path / "t.csv", usecols=[], rows=64)))
    for rec in (whole, chunked):
        np.testing.assert_array_equal(rec.time_s, frame["time"])
        np.testing.assert_array_equal(rec.rate_dps, frame["rate"])


# ---------------------------------------------------------------------------
# Second sweep (issue 39): root causes N1..N33, each case named by what it does.
# Cases that end in an exit code and one line go into SWEEP_CASES (same check as
# CASES above); those whose fault was a silent wrong answer check the answer.
# ---------------------------------------------------------------------------


def test_out_through_a_symlink_writes_its_target_and_keeps_the_link(tmp_path):
    """N1: an output path that is a symbolic link is followed; the link is not replaced by a regular file."""
    x = _recording(tmp_path / "x.parquet")
    (tmp_path / "target.json").write_text("old\n")
    os.symlink("target.json", tmp_path / "link.json")
    result = CliRunner().invoke(app, ["allan", str(x), "--out", str(tmp_path / "link.json")])
    assert result.exit_code == 0, result.output
    assert os.path.islink(tmp_path / "link.json")
    assert '"series"' in (tmp_path / "target.json").read_text()


def test_out_to_a_fifo_writes_into_it(tmp_path):
    """N1: a FIFO (as /dev/stdout or /dev/null, not a regular file) receives the bytes and stays a FIFO."""
    import stat
    import threading

    x = _recording(tmp_path / "x.parquet")
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    received = []
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    done = threading.Event()

    def drain():
        while True:
            try:
                data = os.read(fd, 65536)
            except BlockingIOError:
                data = None
            if data:
                received.append(data)
            elif done.is_set():
                break
            else:
                done.wait(0.01)

    reader = threading.Thread(target=drain)
    reader.start()
    try:
        result = CliRunner().invoke(app, ["allan", str(x), "--out", str(fifo)])
    finally:
        done.set()
        reader.join()
        os.close(fd)
    assert result.exit_code == 0, result.output
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert b'"series"' in b"".join(received)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe.json", "x.parquet"]


def test_out_that_is_a_folder_is_refused(tmp_path):
    """N1: an output path that is a folder exits 2 naming it (was an IsADirectoryError from os.replace)."""
    x = _recording(tmp_path / "x.parquet")
    (tmp_path / "d").mkdir()
    result = CliRunner().invoke(app, ["allan", str(x), "--out", str(tmp_path / "d")])
    assert result.exit_code == 2, result.output
    assert re.search(r"d: is a directory, expected a file to write$", result.stderr.strip())


@pytest.fixture(scope="module")
def sweep_files(tmp_path_factory) -> Path:
    """The larger files of :data:`SWEEP_CASES`, written once and copied into each case's folder."""
    import gzip

    import zstandard

    folder = tmp_path_factory.mktemp("sweep")
    text = _frame(np.arange(20_000.0)).to_csv(index=False).encode()
    whole = zstandard.ZstdCompressor().compress(text)
    (folder / "cut.csv.zst").write_bytes(whole[: int(0.6 * len(whole))])  # a log cut at 60 %
    (folder / "field.csv.gz").write_bytes(gzip.compress(b"time,rate,temperature\n0," + b"1" * (2 << 20) + b",20\n"))
    (folder / "damaged.csv.zip").write_bytes(b"PK\x03\x04" + bytes(range(256)) * 4)
    time = np.r_[0.1 * np.arange(65536), 6553.5 + 0.5 * np.arange(1, 2000)]  # 10 Hz for the first chunk, then 2 Hz
    _frame(time).to_csv(folder / "rate_drop.csv", index=False)
    time = 0.1 * np.arange(65538)
    time[-1] += 5.0  # a gap before the last row: a final chunk of 2 rows
    _frame(time).to_csv(folder / "last_alone.csv", index=False)
    time = np.r_[np.arange(100) * 1e-3, 29 * 86400.0 + np.arange(100) * 1e-3]  # 1 kHz, a 29-day gap
    _frame(time).assign(temperature=25.0).to_csv(folder / "month_gap.csv", index=False)
    import pyarrow as pa
    import pyarrow.parquet as pq

    stamps = 1_700_000_000_000_000 + 10_000 * np.arange(1000, dtype=np.uint64)  # unsigned µs, as PX4 stores them
    stamps[600:] = 5 + 10_000 * np.arange(400, dtype=np.uint64)  # the clock resets below the first stamp
    pq.write_table(pa.table({"timestamp": stamps, "rate": np.sin(np.arange(1000.0)), "temperature": np.full(1000, 25.0)}), folder / "reset_us.parquet")
    time = np.arange(600.0)
    time[-1] += 30.0  # a gap before the last sample: a segment of one sample
    _frame(time).to_csv(folder / "lone.csv", index=False)
    time = 0.1 * np.arange(131072)
    time[65536 + 1 : 131072 : 2] += 0.04  # jitter within the tolerance in the second chunk only
    _frame(time).to_csv(folder / "jitter.csv", index=False)
    return folder


def _setup_sweep(folder: Path, files: Path, model: Path) -> None:
    """The files of :data:`SWEEP_CASES`: those of :func:`_setup` (where h.parquet is a byte-identical copy of x.parquet), `files`,
    and `model` (a gyro model, deg/s) as m.json, as an accelerometer's (acc.json) and in furlong/fortnight."""
    import json
    import shutil

    _setup(folder)
    for path in files.iterdir():
        shutil.copy(path, folder / path.name)
    (folder / "m.json").write_bytes(model.read_bytes())
    (folder / "utf16.toml").write_bytes('[pipeline]\nkind = "polynomial"\n'.encode("utf-16"))
    for name, unit in (("acc.json", "m/s^2"), ("furlong.json", "furlong/fortnight")):
        obj = json.loads(model.read_text())
        obj["axes"]["rate"]["unit"] = unit
        (folder / name).write_text(json.dumps(obj))
    def cubic_only() -> dict:  # the model without its dT/dt term, which the firmwares cannot hold
        obj = json.loads(model.read_text())
        fitted = next(iter(obj["axes"]["rate"]["segments"].values()))["learner"]
        fitted["params"]["rate_term"], fitted["fitted"]["rate_coef_"] = False, 0.0
        return obj

    (folder / "cubic.json").write_text(json.dumps(cubic_only()))
    for name, cubic in (("huge.json", 1e306), ("beyond_float.json", 1e39)):  # finite doubles, the cubic coefficient
        obj = cubic_only()
        next(iter(obj["axes"]["rate"]["segments"].values()))["learner"]["fitted"]["coef_"][3] = cubic
        (folder / name).write_text(json.dumps(obj))
    for name, (low, high) in (("wide.json", (-1e300, 1e300)), ("flat.json", (25.0, 25.0))):
        obj = cubic_only()
        obj["axes"]["rate"]["training"]["temperature_c"] = {"min": low, "max": high}
        (folder / name).write_text(json.dumps(obj))
    obj = cubic_only()
    obj["axes"]["rate"]["training"]["temperature_rate_c_per_s"] = {"min": -1e300, "max": 1e300}
    (folder / "wide_rate.json").write_text(json.dumps(obj))
    obj = json.loads(model.read_text())
    obj["axes"] = {"gx": obj["axes"]["rate"], "gx_compensated": obj["axes"]["rate"]}
    (folder / "gx.json").write_text(json.dumps(obj))
    for name, axes in (("cased.json", ("gx", "GX")), ("hyphen.json", ("gx", "g-y"))):
        obj = json.loads(model.read_text())
        obj["axes"] = {axis: obj["axes"]["rate"] for axis in axes}
        (folder / name).write_text(json.dumps(obj))
    frame = _frame(np.arange(600.0))
    frame.assign(gx=frame["rate"], gx_compensated=-frame["rate"]).drop(columns="rate").to_csv(folder / "gx.csv", index=False)
    frame.assign(gx=frame["rate"], **{"gy/../../X": -frame["rate"]}).drop(columns="rate").to_csv(folder / "escape.csv", index=False)
    frame.assign(gx=frame["rate"], **{"g/y": -frame["rate"]}).drop(columns="rate").to_csv(folder / "slash.csv", index=False)


def _frame(time: np.ndarray) -> pd.DataFrame:
    """A recording on the time stamps `time` [s]."""
    rng = np.random.default_rng(0)
    return pd.DataFrame({"time": time, "rate": 0.01 * rng.standard_normal(time.size), "temperature": 20.0 + time / 6000.0})


SWEEP_CASES = [
    # (case id, root cause, argv, exit code, regex the one stderr line must match)
    ("diagnose-holdout-is-the-fit-run", "N2", ["diagnose", "x.parquet", "--holdout", "x.parquet", "--out", "d.json"], 2, r"x\.parquet: the same bytes as x\.parquet \(SHA-256 [0-9a-f]{12}\.\.\.\); a held-out run must be another recording"),
    ("diagnose-holdout-a-copy-of-the-fit-run", "N2", ["diagnose", "x.parquet", "--holdout", "h.parquet", "--out", "d.json"], 2, r"h\.parquet: the same bytes as x\.parquet"),
    ("diagnose-same-holdout-twice", "N2", ["diagnose", "real.csv", "--holdout", "x.parquet", "--holdout", "x.parquet", "--out", "d.json"], 2, r"x\.parquet: the same bytes as x\.parquet"),
    ("allan-truncated-zst-streamed", "N3", ["allan", "cut.csv.zst", "--out", "a.json"], 2, r"cut\.csv\.zst: truncated: the compressed stream ends after \d+ decompressed bytes, before its end marker"),
    ("train-truncated-zst-whole-file", "N3", ["train", "cut.csv.zst", "--config", "polynomial", "--out", "m.json"], 2, r"cut\.csv\.zst: truncated"),
    ("allan-gz-with-a-huge-field", "N17", ["allan", "field.csv.gz", "--out", "a.json"], 2, r"field\.csv\.gz: a line longer than max_line_bytes = 1048576 bytes.*configs/recordings\.toml \[files\]"),
    ("train-gz-with-a-huge-field", "N17", ["train", "field.csv.gz", "--config", "polynomial", "--out", "m.json"], 2, r"field\.csv\.gz: a line longer than max_line_bytes"),
    ("allan-damaged-zip", "N20", ["allan", "damaged.csv.zip", "--out", "a.json"], 2, r"damaged\.csv\.zip: damaged zip archive"),
    ("train-damaged-zip", "N20", ["train", "damaged.csv.zip", "--config", "polynomial", "--out", "m.json"], 2, r"damaged\.csv\.zip: damaged zip archive"),
    ("allan-rate-drops-after-the-first-chunk-streamed", "N4", ["allan", "rate_drop.csv", "--max-arw", "1.5", "--out", "a.json"], 2, r"rate_drop\.csv line 65538: segment 2 is one sample"),
    ("diagnose-rate-drops-whole-file", "N4", ["diagnose", "rate_drop.csv", "--out", "d.json"], 2, r"rate_drop\.csv line 65538: segment 2 is one sample \(`time` = 6554\.0, 0\.5 s after the previous sample, 0\.5 s before the next; the interval is 0\.1 s\); the sample rate changes here"),
    ("allan-gap-before-a-final-chunk-of-two-rows", "N4", ["allan", "last_alone.csv", "--out", "a.json"], 2, r"last_alone\.csv line 65539: segment 2 is one sample"),
    ("compensate-accelerometer-model-on-a-gyro", "N5", ["compensate", "x.parquet", "acc.json", "--out", "c.parquet"], 2, r"acc\.json axis rate: a model in m/s\^2 \(acceleration \(accelerometer\)\) cannot compensate axis rate of x\.parquet, in deg/s"),
    ("compensate-gyro-model-on-an-accelerometer", "N5", ["compensate", "x.parquet", "m.json", "--rate-unit", "g", "--out", "c.parquet"], 2, r"m\.json axis rate: a model in deg/s \(angular rate \(gyro\)\) cannot compensate axis rate of x\.parquet, in m/s\^2"),
    ("compensate-full-accelerometer-model-on-a-gyro", "N5", ["compensate", "x.parquet", "acc.json", "--mode", "full", "--out", "c.parquet"], 2, r"acc\.json axis rate: a model in m/s\^2"),
    ("compensate-model-in-furlongs-per-fortnight", "N5", ["compensate", "x.parquet", "furlong.json", "--out", "c.parquet"], 2, r"furlong\.json axis rate: unit 'furlong/fortnight' is not a sensor unit; a model is in deg/s or m/s\^2"),
    ("export-model-in-furlongs-as-px4", "N5", ["export", "furlong.json", "--format", "px4", "--device-id", "1", "--out", "a.params"], 2, r"furlong\.json axis rate: unit 'furlong/fortnight' is not a sensor unit"),
    ("export-model-in-furlongs-as-ardupilot", "N5", ["export", "furlong.json", "--format", "ardupilot", "--out", "a.parm"], 2, r"furlong\.json axis rate: unit 'furlong/fortnight' is not a sensor unit"),
    ("export-model-in-furlongs-as-json", "N5", ["export", "furlong.json", "--format", "json-plain", "--out", "p.json"], 2, r"furlong\.json axis rate: unit 'furlong/fortnight' is not a sensor unit"),
    ("export-c-vectors-from-an-accelerometer", "N5", ["export", "m.json", "--format", "c", "--vectors", "x.parquet", "--rate-unit", "g", "--out", "m.h"], 2, r"m\.json axis rate: a model in deg/s \(angular rate \(gyro\)\) cannot compensate axis rate of x\.parquet, in m/s\^2"),
    ("export-px4-offset-beyond-any-gyro", "N6", ["export", "beyond_float.json", "--format", "px4", "--device-id", "1", "--out", "a.params"], 2, r"beyond_float\.json: export: axis x: the offset reaches -9\.96816e\+39 deg/s at 15 degC, beyond \+-100000 deg/s"),
    ("export-ardupilot-offset-beyond-any-gyro", "N6", ["export", "beyond_float.json", "--format", "ardupilot", "--out", "a.parm"], 2, r"beyond_float\.json: export: axis x: the offset reaches"),
    ("export-c-coefficient-beyond-float32", "N6", ["export", "beyond_float.json", "--format", "c", "--out", "m.h"], 2, r"beyond_float\.json axis rate: segment drift gives a drift of [-0-9.e+]+ deg/s at sample 0 \(T = 15 degC, dT/dt = 0 degC/s\), beyond \+-100000 deg/s"),
    ("export-px4-range-1e300", "N6", ["export", "wide.json", "--format", "px4", "--device-id", "1", "--out", "a.params"], 2, r"wide\.json axis rate: training temperature_c = \[-1e\+300, 1e\+300\] leaves \[-100, 200\]"),
    ("export-px4-tmin-equals-tmax", "N6", ["export", "flat.json", "--format", "px4", "--device-id", "1", "--out", "a.params"], 2, r"flat\.json: export: TMIN = TMAX = 25\.0 degC"),
    ("compensate-temperature-range-1e300", "N6", ["compensate", "x.parquet", "wide.json", "--out", "c.parquet"], 2, r"wide\.json axis rate: training temperature_c = \[-1e\+300, 1e\+300\] leaves \[-100, 200\], a recording's plausible temperatures"),
    ("compensate-rate-range-1e300", "N6", ["compensate", "x.parquet", "wide_rate.json", "--out", "c.parquet"], 2, r"wide_rate\.json axis rate: training temperature_rate_c_per_s = \[-1e\+300, 1e\+300\] leaves \[-100, 100\], max_abs_rate_c_per_s \(configs/recordings\.toml \[temperature\]\)"),
    ("export-px4-device-id-beyond-int32", "N7", ["export", "cubic.json", "--format", "px4", "--device-id", "4294967296", "--out", "a.params"], 2, r"export: TC_G0_ID = 4294967296 is beyond INT32 \(-2147483648\.\.2147483647\)"),
    ("compensate-huge-coefficient-overflows", "N9", ["compensate", "x.parquet", "huge.json", "--out", "c.parquet"], 2, r"huge\.json axis rate: segment drift gives a drift of -1\.24\d+e\+306 deg/s at sample 0 \(T = 20 degC, dT/dt = 0 degC/s\), beyond \+-100000 deg/s \(configs/recordings\.toml \[axes\]\); a corrupted model"),
    ("compensate-full-huge-coefficient-overflows", "N9", ["compensate", "x.parquet", "huge.json", "--mode", "full", "--out", "c.parquet"], 2, r"huge\.json axis rate: segment [^ ]+ gives a drift of"),
    ("allan-one-sample-segment-after-a-gap", "N29", ["allan", "lone.csv", "--out", "a.json"], 2, r"lone\.csv line 601: segment 2 is one sample \(alone after a gap in `time`; the interval is 1 s\)"),
    ("diagnose-one-sample-segment-after-a-gap", "N29", ["diagnose", "lone.csv", "--out", "d.json"], 2, r"lone\.csv line 601: segment 2 is one sample \(`time` = 629\.0, 31 s after the previous sample, the last sample; the interval is 1 s\)"),
    ("simulate-lag-tau-nan", "N8", ["simulate", "--set", "gyro.thermal_lag.tau_s=nan", "--out", "s.parquet"], 2, r"gyro\.thermal_lag\.tau_s = nan: must be a finite number \[s\]$"),
    ("simulate-period-zero", "N8", ["simulate", "--set", "gyro.periodic.period_s=0", "--out", "s.parquet"], 2, r"gyro\.periodic\.period_s = 0\.0: a time constant or period must be > 0 s$"),
    ("simulate-offset-infinite", "N8", ["simulate", "--set", "gyro.offset_dps=inf", "--out", "s.parquet"], 2, r"gyro\.offset_dps = inf: must be a finite number \[deg/s\]$"),
    ("simulate-chamber-tau-nan", "N8", ["simulate", "--set", "profile.chamber_tau_s=nan", "--out", "s.parquet"], 2, r"profile\.chamber_tau_s = nan: must be a finite number"),
    ("allan-resample-a-29-day-gap-at-1-khz", "N18", ["allan", "month_gap.csv", "--resample", "--out", "a.json"], 2, r"month_gap\.csv: --resample onto a 0\.001 s grid over 2\.5056e\+06 s of `time` needs 2\.506e\+09 samples, more than resample_max_samples = 1000000000 \(configs/recordings\.toml \[lengths\]\)"),
    ("compensate-resample-a-29-day-gap-at-1-khz", "N18", ["compensate", "month_gap.csv", "m.json", "--resample", "--out", "c.parquet"], 2, r"month_gap\.csv: --resample onto a 0\.001 s grid .* more than resample_max_samples = 1000000000"),
    ("simulate-duration-1e10-s", "N25", ["simulate", "--set", "run.duration_s=1e10", "--out", "s.parquet"], 2, r"simulate: 1e\+10 s at 1 Hz needs 1e\+10 samples, more than simulate_max_samples = 1000000000 \(configs/recordings\.toml \[lengths\]\)"),
    ("simulate-hold-1e10-s", "N25", ["simulate", "--set", "profile.hold_s=[1e10]", "--out", "s.parquet"], 2, r"more than simulate_max_samples = 1000000000"),
    ("export-c-two-billion-vectors", "N26", ["export", "m.json", "--format", "c", "--n-vectors", "2000000000", "--out", "m.h"], 2, r"m\.json: export --n-vectors 2000000000 needs 2e\+09 samples, more than export_max_vectors = 1000000000 \(configs/recordings\.toml \[lengths\]\)"),
    ("export-c-zero-vectors", "N26", ["export", "m.json", "--format", "c", "--n-vectors", "0", "--out", "m.h"], 2, r"export --n-vectors 0: must be >= 1"),
    ("compensate-axis-named-like-another-axis-output", "N10", ["compensate", "gx.csv", "gx.json", "--rate-col", "gx*", "--out", "c.parquet"], 2, r"gx\.csv: the compensated column of axis gx would be `gx_compensated`, which is axis gx_compensated; rename the column or leave it out of --rate-col"),
    ("compensate-streamed-axis-named-like-another-axis-output", "N10", ["compensate", "gx.csv", "gx.json", "--rate-col", "gx*", "--out", "-"], 2, r"gx\.csv: the compensated column of axis gx would be `gx_compensated`"),
    ("allan-unsigned-us-stamps-reset-below-the-first", "N11", ["allan", "reset_us.parquet", "--time-col", "timestamp", "--time-unit", "us", "--out", "a.json"], 2, r"reset_us\.parquet row 601: `timestamp` = -1699999999\.99999\d* goes back from the previous time 5\.98999\d*; time must be strictly increasing"),
    ("train-unsigned-us-stamps-reset-below-the-first", "N11", ["train", "reset_us.parquet", "--time-col", "timestamp", "--time-unit", "us", "--config", "polynomial", "--out", "m2.json"], 2, r"reset_us\.parquet row 601: `timestamp` = -1699999999\.99999\d* goes back"),
    ("run-axis-named-to-escape-the-output-folder", "N12", ["run", "compare", "escape.csv", "--rate-col", "g*", "--out", "r"], 2, r"escape\.csv: axis 'gy/\.\./\.\./X' cannot name a file or folder \(a path separator, or \. or \.\.\); rename the column"),
    ("diagnose-axis-with-a-slash-and-a-plot", "N21", ["diagnose", "slash.csv", "--rate-col", "gx,g/y", "--plot", "gap.png", "--markdown", "d.md", "--out", "d.json"], 2, r"slash\.csv: axis 'g/y' cannot name a file or folder"),
    ("train-config-is-dev-zero", "N19", ["train", "x.parquet", "--config", "/dev/zero", "--out", "m2.json"], 2, r"/dev/zero: is a device, not a file \(give - to read standard input\)$"),
    ("train-config-in-utf16", "N19", ["train", "x.parquet", "--config", "utf16.toml", "--out", "m2.json"], 2, r"utf16\.toml: not a UTF-8 text file \(TOML is UTF-8\)$"),
    ("train-config-is-a-folder", "N19", ["train", "x.parquet", "--config", "out/", "--out", "m2.json"], 2, r"out/: no such config file$"),
    ("compensate-model-is-dev-zero", "N24", ["compensate", "x.parquet", "/dev/zero", "--out", "c.parquet"], 2, r"/dev/zero: is a device, not a file"),
    ("train-set-a-table-to-a-number", "N22", ["train", "x.parquet", "--config", "polynomial", "--set", "model=5", "--out", "m2.json"], 2, r"--set 'model=5': model is a table; set one of its keys \(model\.<key>=value\)$"),
    ("train-reference-temperature-1e300", "N23", ["train", "x.parquet", "--config", "polynomial", "--set", "model.drift.reference_temperature=1e300", "--out", "m2.json"], 2, r"x\.parquet: PolynomialDrift: `reference_temperature` must be in \[-100\.0, 200\.0\], got 1e\+300$"),
    ("export-c-axes-differing-only-in-case", "N31", ["export", "cased.json", "--format", "c", "--out", "m.h"], 2, r"cased\.json: export c: axes 'gx' and 'GX' differ only in case; their blocks would share the include guard GYROCOMP_GX_H$"),
    ("export-c-axis-no-c-name", "N31", ["export", "hyphen.json", "--format", "c", "--out", "m.h"], 2, r"hyphen\.json: export c: axis 'g-y' cannot be part of a C name \(gyrocomp_g-y\); rename the axis$"),
    ("run-test-is-the-training-run", "N2", ["run", "compare", "x.parquet", "--test", "h.parquet", "--out", "r"], 2, r"h\.parquet: the same bytes as x\.parquet"),
]


@pytest.mark.parametrize("argv, code, message", [c[2:] for c in SWEEP_CASES], ids=[f"{c[1]}-{c[0]}" for c in SWEEP_CASES])
def test_sweep_case(tmp_path, monkeypatch, sweep_files, trained_model, argv, code, message):
    """Issue 39: each case exits `code` with one line naming the file and the value, and writes nothing."""
    _setup_sweep(tmp_path, sweep_files, trained_model)
    _check_case(tmp_path, monkeypatch, argv, code, message)


def test_jitter_in_one_chunk_is_judged_against_the_stream_interval(sweep_files):
    """N4: intervals of 0.1 and 0.14 s in the second chunk only: no gaps (the chunk's own median made 32 767 of them), same as the whole file."""
    from gyrocomp import recordings, streaming

    whole = recordings.read_recording(sweep_files / "jitter.csv", allow_gaps=True)
    reader = streaming.read_chunks(sweep_files / "jitter.csv", gaps=True)
    n = sum(chunk.n_samples for chunk in reader)
    assert (n, len(reader.breaks), len(whole.segments)) == (131072, 0, 1)
    assert reader.fs_hz == pytest.approx(whole.fs_hz, rel=1e-9)


def test_an_accelerometer_model_exports_as_plain_json_in_its_unit(tmp_path, sweep_files, trained_model):
    """N5: json-plain keeps the model's unit (it wrote deg/s for every model)."""
    import json

    _setup_sweep(tmp_path, sweep_files, trained_model)
    for model, unit in (("acc.json", "m/s^2"), ("m.json", "deg/s")):
        result = CliRunner().invoke(app, ["export", str(tmp_path / model), "--format", "json-plain", "--out", str(tmp_path / f"plain_{unit[0]}.json")])
        assert result.exit_code == 0, result.output
        assert json.loads((tmp_path / f"plain_{unit[0]}.json").read_text())["units"]["rate"] == unit


def test_firmware_parameters_beyond_single_precision_are_refused():
    """N6: a parameter a float cannot hold is refused, naming it (was written, and loaded as inf)."""
    from gyrocomp.export.cubic import Cubic
    from gyrocomp.export.firmware import Block, ardupilot_params, px4_params

    narrow = Cubic(35.0, (0.0, 0.0, 0.0, 3e40), (35.0 - 1e-12, 35.0 + 1e-12))  # offsets of 3e4 deg/s at most over its range
    with pytest.raises(InputError, match=r"^export: TC_G0_X3_0 = 5\.23\d*e\+38 is beyond single precision \(\+-3\.402823e\+38\), which the firmware stores$"):
        px4_params([Block("gyro", 0, {"x": narrow}, 1)])
    with pytest.raises(InputError, match=r"^export: INS_TCAL1_GYR3_X = 5\.23\d*e\+44 is beyond single precision"):
        ardupilot_params([Block("gyro", 0, {"x": narrow})])


@pytest.mark.slow
def test_a_vector_sweep_longer_than_30_days_is_no_implausible_time_base(trained_model):
    """N26: 2.6e6 vectors of a 1 Hz model span 30 days; the synthetic sweep's time is seconds by declaration (it tripped the reader's check)."""
    from gyrocomp.export import reference_vectors
    from gyrocomp.pipeline.compensate import load_models

    import json

    (model,) = load_models(json.loads(trained_model.read_text())).values()
    vectors = reference_vectors(model, n=2_600_000)
    assert vectors["temperature_c"].size == 2_600_000
    np.testing.assert_allclose(vectors["rate_dps"] - vectors["drift_dps"], vectors["compensated_dps"], rtol=0, atol=1e-12)


def test_batch_folder_names_never_collide():
    """N15: an input named like another's hashed folder (``x-5c400309.csv`` beside ``a/x.csv``, ``b/x.csv``) gets a folder of its own."""
    import hashlib

    from gyrocomp.batch import folder_names

    hashed = "x-" + hashlib.sha256(b"a/x.csv").hexdigest()[:8]
    paths = ["a/x.csv", "b/x.csv", f"{hashed}.csv", "c/X.csv"]
    names = folder_names(paths)
    assert len({n.casefold() for n in names.values()}) == len(paths), names
    assert folder_names(["a/x.csv", "b/y.csv"]) == {"a/x.csv": "x", "b/y.csv": "y"}


def test_batch_repeatable_holdout_template_is_paired_per_input(tmp_path):
    """N16: ``batch diagnose --holdout 'hold/{name}'`` (a repeatable option: a tuple) pairs each input with its holdout."""
    from gyrocomp.batch import jobs

    (tmp_path / "hold").mkdir()
    (tmp_path / "hold" / "u1.csv").write_text("time,rate\n")
    source = tmp_path / "fit" / "u1.csv"
    paired = jobs._paired((str(tmp_path / "hold" / "{name}"),), source, "--holdout")
    assert paired == (tmp_path / "hold" / "u1.csv",)
    records = jobs._paired_records(jobs.get_job("diagnose"), jobs.get_job("diagnose").options_class(holdout=(str(tmp_path / "hold" / "{name}"),)), source)
    assert [r["name"] for r in records["--holdout"]] == ["u1.csv"]


@pytest.mark.parametrize("template", ["hold/{dir.__class__}", "hold/{name!r}", "hold/{stem:>40}", "hold/{0}", "hold/{name"])
def test_batch_template_allows_only_its_placeholders(template):
    """N27: a template is text with {stem}, {name}, {dir}; attribute access, conversions and format specs are refused."""
    from gyrocomp.batch.jobs import paired_path

    with pytest.raises(InputError, match=r"^batch: --test 'hold/\{.*: (unknown placeholder|a brace that is no placeholder)"):
        paired_path(template, Path("fit/u1.csv"))
    assert paired_path("hold/{dir}/{stem}.parquet", Path("fit/u1.csv")) == Path("hold/fit/u1.parquet")


def test_batch_glob_does_not_follow_folder_links(tmp_path, monkeypatch):
    """N32: ``logs/**/*.csv`` with a link from inside ``logs`` back to it lists each recording once."""
    from gyrocomp.batch import expand_inputs

    (tmp_path / "logs" / "sub").mkdir(parents=True)
    (tmp_path / "logs" / "a.csv").write_text("x\n")
    (tmp_path / "logs" / "sub" / "b.csv").write_text("x\n")
    os.symlink("..", tmp_path / "logs" / "sub" / "up")
    os.symlink(tmp_path / "logs", tmp_path / "via")
    monkeypatch.chdir(tmp_path)
    assert expand_inputs(["logs/**/*.csv"]) == ["logs/a.csv", "logs/sub/b.csv"]
    assert expand_inputs(["via/**/*.csv"]) == ["via/a.csv", "via/sub/b.csv"]  # a link the user typed is followed


def test_batch_summary_csv_defuses_formulas(tmp_path):
    """N33: a text cell starting with =, +, -, @ is written to summary.csv with a leading ' (spreadsheets show it as text)."""
    from gyrocomp.batch import BatchResult, _write_summary

    rows = [{"input": "=HYPERLINK(\"http://x\")", "output": "@x", "status": "ok", "error": "", "threshold": "", "sha256": "ab", "figure": -1.5}]
    result = BatchResult(command="allan", rows=rows, columns=[*rows[0]], exit_code=0)
    _write_summary(tmp_path, result, {})
    frame = pd.read_csv(tmp_path / "summary.csv")
    assert frame["input"][0] == "'=HYPERLINK(\"http://x\")" and frame["output"][0] == "'@x" and frame["figure"][0] == -1.5
    assert pd.read_parquet(tmp_path / "summary.parquet")["input"][0] == "=HYPERLINK(\"http://x\")"


def test_compensate_stream_outputs_never_overwrite_the_model(tmp_path, monkeypatch, trained_model):
    """N13: with several streams of a flight log, ``<out>_<stream>.meta.json`` is checked like every output: it may not be the model."""
    from gyrocomp import recordings
    from gyrocomp.commands import compensate as stage

    frame = _frame(np.arange(600.0))
    streams = [recordings.recording_from_frame(frame, name="two.ulg", metadata={"stream": key}) for key in ("s0", "s1")]
    monkeypatch.setattr(recordings, "read_recordings", lambda *args, **kwargs: streams)
    model = tmp_path / "c_s1.meta.json"
    model.write_bytes(trained_model.read_bytes())
    (tmp_path / "two.ulg").write_bytes(b"")
    before = _snapshot(tmp_path)
    with pytest.raises(InputError, match=r"c_s1\.meta\.json: the output would overwrite the input .*c_s1\.meta\.json"):
        stage.to_files([tmp_path / "two.ulg", model], tmp_path / "c.parquet")
    assert _snapshot(tmp_path) == before
    with pytest.raises(InputError, match=r"stream 'a/b' cannot name a file or folder"):
        stage.stream_path(tmp_path / "c.parquet", "a/b")


def test_a_folder_named_like_a_shipped_config_does_not_shadow_it(tmp_path, monkeypatch):
    """N19: ``./polynomial/`` (as ``run --out .`` makes) beside ``--config polynomial``: the shipped config is read."""
    x = _recording(tmp_path / "x.parquet")
    (tmp_path / "polynomial").mkdir()
    (tmp_path / "default").mkdir()
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["train", "x.parquet", "--config", "polynomial", "--out", "m.json"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(app, ["simulate", "--set", "run.duration_s=60", "--set", "run.gyro=default", "--out", "s.parquet"])
    assert result.exit_code == 0, result.output


def test_sighup_during_a_write_leaves_no_temporary_file(tmp_path):
    """N28: an ssh hang-up (SIGHUP) inside an atomic write unwinds like SIGTERM: exit 129, one line, the temporary file removed."""
    import subprocess
    import sys

    rec = _recording(tmp_path / "x.parquet")
    out = tmp_path / "out"
    script = (
        "import os, signal, sys\n"
        "import gyrocomp.cli as cli\n"
        "real_fsync = os.fsync\n"
        "def fsync(fd):\n"
        "    os.kill(os.getpid(), signal.SIGHUP)\n"
        "    real_fsync(fd)\n"
        "os.fsync = fsync\n"
        "sys.argv = ['gyrocomp', 'compensate', sys.argv[1], sys.argv[2], '--out', sys.argv[3]]\n"
        "cli.main()\n"
    )
    model = tmp_path / "m.json"
    result = CliRunner().invoke(app, ["train", str(rec), "--config", "polynomial", "--out", str(model)])
    assert result.exit_code == 0, result.output
    proc = subprocess.run([sys.executable, "-c", script, str(rec), str(model), str(out / "c.parquet")], capture_output=True, text=True)
    assert proc.returncode == 129, proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == "gyrocomp: hung up"
    assert list(out.iterdir()) == []


def test_a_library_warning_is_one_line_without_a_source_path(tmp_path):
    """N30: ``allan --taus 1,1e6``: the tau left out is one ``gyrocomp: warning:`` line, not Python's ``path:line: UserWarning`` and code."""
    x = _recording(tmp_path / "x.parquet")
    result = CliRunner().invoke(app, ["allan", str(x), "--taus", "1,1e6", "--out", str(tmp_path / "a.json")])
    assert result.exit_code == 0, result.output
    lines = result.stderr.strip().splitlines()
    assert lines == ["gyrocomp: warning: taus 1e+06 s left out: a record of 600 samples reaches tau = 299 s"], lines


PX4_SAMPLE = Path("/work/shared/real-data/px4-ulog-sample/sample_log_small.ulg")


@pytest.mark.skipif(not PX4_SAMPLE.exists(), reason="shared real data absent")
def test_what_a_log_library_prints_stays_out_of_stdout(tmp_path, monkeypatch):
    """N14: pyulog prints its warnings on stdout; with ``--out -`` they would corrupt the JSON. They become one note on stderr."""
    import json

    import pyulog

    real = pyulog.ULog

    def noisy(*args, **kwargs):
        for k in range(3):
            print(f"Warning: unknown message type {k}")
        return real(*args, **kwargs)

    monkeypatch.setattr(pyulog, "ULog", noisy)
    result = CliRunner().invoke(app, ["allan", str(PX4_SAMPLE), "--out", "-"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["series"]
    notes = [line for line in result.stderr.splitlines() if "pyulog printed" in line]
    assert notes == [f"gyrocomp: note: {PX4_SAMPLE}: pyulog printed 3 lines while reading it, the first: Warning: unknown message type 0"], result.stderr


def test_decompressed_size_is_bounded_by_its_setting(tmp_path):
    """N17: past ``max_decompressed_gib`` the stream is refused, naming the setting (a small bound stands in for 256 GiB)."""
    import gzip

    from gyrocomp import compressed

    text = _frame(np.arange(20_000.0)).to_csv(index=False).encode()
    (tmp_path / "x.csv.gz").write_bytes(gzip.compress(text))
    with compressed.open_csv(str(tmp_path / "x.csv.gz"), compressed.FileLimits(max_decompressed_gib=len(text) / 2**30)) as stream:
        assert stream.read() == text  # exactly at the bound
    with pytest.raises(InputError, match=r"x\.csv\.gz: decompresses to more than max_decompressed_gib = [0-9.e-]+ GiB \(configs/recordings\.toml \[files\]\)$"):
        with compressed.open_csv(str(tmp_path / "x.csv.gz"), compressed.FileLimits(max_decompressed_gib=1e-4)) as stream:
            stream.read()
