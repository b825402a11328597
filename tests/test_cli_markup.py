"""Names in the terminal tables are text, never console markup (issue 35, item 5).

``name [gx]`` read as rich markup dropped ``[gx]``: a three-axis run showed
its rows with the same label.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from rich.console import Console
from typer.testing import CliRunner

from gyrocomp.cli import app


def test_allan_table_keeps_every_axis_name(tmp_path):
    rng = np.random.default_rng(0)
    t = np.arange(4000) / 10.0
    pd.DataFrame({"time": t, **{a: 0.01 * rng.normal(size=t.size) for a in ("gx", "gy", "gz")}}).to_csv(tmp_path / "x.csv", index=False)
    result = CliRunner().invoke(app, ["allan", str(tmp_path / "x.csv"), "--rate-col", "gx,gy,gz", "--out", str(tmp_path / "a.json")],
                                env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    for axis in ("gx", "gy", "gz"):
        assert f"x.csv [{axis}]" in result.stdout


def test_run_table_keeps_method_and_axis_names():
    from gyrocomp.cli.run import _print

    row = {"mode": "causal", "arw": {"value": 1.0}, "bias_instability": {"value": 2.0}, "residual_drift": {"std_deg_h": 3.0, "p2p_deg_h": 4.0},
           "signal": None, "train_time_s": 1.0}
    report = {"test": {"name": "t.csv"}, "axes": ["gx", "gy"], "findings": [], "total_time_s": 1.0,
              "rows": [{**row, "method": "polynomial", "axis": "gx"}, {**row, "method": "polynomial", "axis": "gy"}]}
    console = Console(record=True, width=200)
    _print(console, report, "out")
    text = console.export_text()
    assert "polynomial [gx]" in text and "polynomial [gy]" in text


def test_compensating_the_training_run_causally_does_not_warn_about_dtdt(tmp_path):
    """Issue 35, item 8: the causal estimator's own training range, and no dT/dt warning for a model without a dT/dt term."""
    import warnings

    from gyrocomp.config import load_config
    from gyrocomp.pipeline.compensate import ExtrapolationWarning, compensate, load_model
    from gyrocomp.pipeline.train import train_direct
    from gyrocomp.recordings import recording_from_frame

    rng = np.random.default_rng(1)
    t = np.arange(0, 6 * 3600.0)
    T = 20 + 20 * np.sin(2 * np.pi * t / 5400) + rng.normal(0, 0.05, t.size)
    rec = recording_from_frame(pd.DataFrame({"time": t, "rate": 0.01 * rng.normal(size=t.size) + 1e-3 * T, "temperature": T}), name="train.csv")
    for config in ("polynomial", "firmware"):
        model = load_model(train_direct(rec, load_config(config), seed=0))
        with warnings.catch_warnings():
            warnings.simplefilter("error", ExtrapolationWarning)
            _, summary = compensate(rec, model, "causal")
        assert summary["warnings"] == []
    X = model.inputs(T, 1.0, causal=True)
    assert X[:, 1].min() < model.rate_range_c_per_s[0] or X[:, 1].max() > model.rate_range_c_per_s[1]  # the two estimators differ
