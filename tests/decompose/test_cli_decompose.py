"""`gyrocomp decompose`: contract columns, header, sidecar, exit codes."""

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gyrocomp.cli import app
from gyrocomp.artefacts import read_json, read_table


@pytest.fixture
def recording(tmp_path):
    t = np.arange(1200) / 100.0
    rate = np.sin(2 * np.pi * 6.25 * t) + np.sin(2 * np.pi * 0.78 * t) + 0.01 * t
    path = tmp_path / "rec.csv"
    pd.DataFrame({"time": t, "rate": rate, "temperature": 20 + t}).to_csv(path, index=False)
    return path


@pytest.mark.parametrize("method", ["lcd", "emd", "iceemdan"])
def test_writes_contract_columns_and_sidecar(tmp_path, recording, method):
    out = tmp_path / "components.parquet"
    result = CliRunner().invoke(
        app, ["decompose", str(recording), "--method", method, "--ensemble", "5", "--seed", "3", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    frame, header = read_table(out, "gyrocomp.components")
    names = header["components"]
    assert list(frame.columns) == ["time", "rate", "temperature", *names]
    assert names[-1] == ("trend" if method == "lcd" else "residue")
    assert header["fs_hz"] == pytest.approx(100.0)
    assert header["seed"] == 3 and header["settings"]["method"] == method
    np.testing.assert_allclose(frame[names].sum(axis=1), frame["rate"], atol=1e-9 * frame["rate"].abs().max())
    sidecar = read_json(tmp_path / "components.meta.json", "gyrocomp.components-summary")
    assert [c["name"] for c in sidecar["components"]] == names
    assert sidecar["reconstruction_error"] < 1e-9
    assert sum(c["energy_share"] for c in sidecar["components"]) == pytest.approx(1.0)
    assert {"mean_frequency_hz", "orthogonality_index"} <= set(sidecar["components"][0])


def test_config_and_set(tmp_path, recording):
    out = tmp_path / "c.parquet"
    result = CliRunner().invoke(
        app, ["decompose", str(recording), "--config", "pe-lcd-anfis", "--set", "max_components=2", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert json.loads(json.dumps(read_table(out, "gyrocomp.components")[1]["components"])) == ["isc1", "isc2", "trend"]


@pytest.mark.parametrize(
    "args",
    [["--method", "vmd"], ["--set", "q=2"], ["--set", "nonsense=1"], ["--ensemble", "0", "--method", "iceemdan"]],
)
def test_bad_options_exit_2(tmp_path, recording, args):
    result = CliRunner().invoke(app, ["decompose", str(recording), *args, "--out", str(tmp_path / "c.parquet")])
    assert result.exit_code == 2
    assert not (tmp_path / "c.parquet").exists()


def test_bad_recording_exit_2(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,rate\n0,1\n1,nan\n2,3\n3,4\n")
    result = CliRunner().invoke(app, ["decompose", str(bad), "--out", str(tmp_path / "c.parquet")])
    assert result.exit_code == 2
    assert "bad.csv" in result.output


def test_help():
    result = CliRunner().invoke(app, ["decompose", "--help"])
    assert result.exit_code == 0 and "--method" in result.output


def test_decompose_parquet_writes_without_pandas(tmp_path):
    """`gyrocomp decompose` on Parquet writes its table without pandas (0.4 s of start-up, issue 38).

    The components equal those of a DataFrame written by the same path
    (:func:`gyrocomp.commands.decompose.table`), column for column.
    """
    import subprocess
    import sys

    from gyrocomp.commands.decompose import table
    from gyrocomp.decompose import DecomposeSettings, decompose
    from gyrocomp.recordings import ColumnSpec, read_recording

    t = np.arange(2000) / 100.0
    rng = np.random.default_rng(4)
    pd.DataFrame({"time": t, "rate": rng.standard_normal(t.size) + 0.1 * t, "temperature": 20 + t}).to_parquet(tmp_path / "rec.parquet")
    out = tmp_path / "components.parquet"
    script = (
        "import runpy, sys\n"
        "sys.argv = ['gyrocomp', '--quiet', 'decompose', sys.argv[1], '--method', 'iceemdan', '--ensemble', '5', '--out', sys.argv[2]]\n"
        "try:\n    runpy.run_module('gyrocomp', run_name='__main__')\n"
        "except SystemExit as exit:\n    assert not exit.code, exit.code\n"
        "print('PANDAS', sorted(m for m in sys.modules if m.split('.')[0] == 'pandas'))\n"
    )
    proc = subprocess.run([sys.executable, "-c", script, str(tmp_path / "rec.parquet"), str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "PANDAS []"
    frame, header = read_table(out, "gyrocomp.components")
    recording = read_recording(tmp_path / "rec.parquet", ColumnSpec(), min_samples=4).axis()
    settings = DecomposeSettings(method="iceemdan", ensemble=5)
    expected, _ = table(recording, decompose(recording.rate_dps, settings, seed=0), settings, 0)
    assert list(frame.columns) == list(expected.columns) == ["time", "rate", "temperature", *header["components"]]
    for column in expected.columns:
        np.testing.assert_array_equal(frame[column].to_numpy(), expected[column].to_numpy())
