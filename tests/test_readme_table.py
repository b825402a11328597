"""The README's headline table comes from a `make run` report by benchmarks/readme_table.py (issue 18, fix 3).

The script is loaded from its file (benchmarks/ is not a package). The
checks: each row's formatting rules on a constructed report, the spread
between two reports, and that the README's table is in the script's form
(same header, every method of configs/compare.toml in it), so a hand-edited
table or a renamed column shows up here.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("readme_table", ROOT / "benchmarks" / "readme_table.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _row(method, mode, arw, b, std, p2p, signal=None):
    return {
        "method": method,
        "mode": mode,
        "arw": {"value": arw},
        "bias_instability": {"value": b},
        "residual_drift": {"std_deg_h": std, "p2p_deg_h": p2p},
        "signal": signal,
    }


REPORT = {
    "rows": [
        _row("raw", None, 1.0412, 16.61, 283.4, 1215.2),
        _row("pe-lcd-anfis", "full", 2e-5, 2.971, 45.03, 373.4, {"gain": 0.79, "parts": {"sine_0.05hz": 0.19, "steps": 0.99}}),
        _row("polynomial", "causal", 1.0412, 16.44, 48.51, 419.0, {"gain": 1.0, "parts": {"sine_0.05hz": 1.0}}),
    ]
}


def test_rows_follow_the_readme_rules(script):
    lines = script.table(REPORT).splitlines()
    assert lines[2] == "| raw | – | 1.04 | 16.6 | 283 / 1215 | – |"
    assert lines[3] == "| PE-LCD-ANFIS | full | 0 (white noise removed) | 2.97 | 45.0 / 373 | 79 % (0.05 Hz sine: 19 %) |"
    assert lines[4] == "| cubic polynomial + dT/dt | causal | 1.04 | 16.4 | 48.5 / 419 | 100 % |"


def test_spread_is_the_largest_relative_difference(script):
    other = {"rows": [dict(r, residual_drift={"std_deg_h": r["residual_drift"]["std_deg_h"] * 1.05, "p2p_deg_h": r["residual_drift"]["p2p_deg_h"]}) for r in REPORT["rows"]]}
    spreads = script.spread([REPORT, other, REPORT])
    assert spreads["cubic polynomial + dT/dt (causal)"]["drift std"] == pytest.approx(0.05)
    assert spreads["cubic polynomial + dT/dt (causal)"]["ARW"] == 0.0
    assert "signal kept" not in spreads["raw"]


def test_the_readme_table_is_in_the_scripts_form(script):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    header = script.table({"rows": []}).splitlines()[0]
    assert header in readme
    start = readme.index(header)
    rows = re.findall(r"^\| ([^|]+?) \|", readme[start:].split("\n\n")[0], flags=re.M)[1:]  # after the header
    assert set(rows) >= set(script.NAMES.values())
