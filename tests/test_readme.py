"""The README's recipes run as written (issue 36), and the API page's examples run.

Each ``bash`` block under the README's "Recipes" runs in a fresh folder that
sees the repository's ``sample_data/`` and ``configs/`` where the README's
reader has them (the repository's root), with this interpreter's ``gyrocomp``
first on the PATH; every command must succeed. Then what the recipe says it
makes is checked. The diagnose recipe and the API's diagnosis example take
minutes of CPU and run with the slow tests.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def recipes(text: str) -> dict[str, list[str]]:
    """The ``bash`` blocks of each subsection of the README's "Recipes", by subsection title."""
    start = text.index("\n## Recipes\n")
    section = text[start:text.index("\n## ", start + 1)]
    parts = re.split(r"^### (.*)$", section, flags=re.M)[1:]
    return {title: re.findall(r"```bash\n(.*?)```", body, re.S) for title, body in zip(parts[::2], parts[1::2])}


RECIPES = recipes((ROOT / "README.md").read_text(encoding="utf-8"))


def _marks(script: str):
    if "gyrocomp diagnose" in script:
        return [pytest.mark.slow]
    if "--config firmware" in script and not (ROOT / "configs" / "firmware.toml").exists():
        return [pytest.mark.skip(reason="configs/firmware.toml is not on this branch yet (issue 35)")]
    return []


@pytest.mark.parametrize("title", [pytest.param(t, marks=_marks("".join(b)), id=t.split(":")[0][:30]) for t, b in RECIPES.items()])
def test_readme_recipe_runs_as_written(tmp_path, title):
    for name in ("sample_data", "configs"):
        (tmp_path / name).symlink_to(ROOT / name)
    warmup = _warmup_logs(tmp_path) if "warmup.ulg" in "".join(RECIPES[title]) else None
    for script in RECIPES[title]:
        _bash(script, tmp_path)
    made = set(re.findall(r"--(?:out|plot|markdown) (\S+)", "".join(RECIPES[title])))
    assert made and all((tmp_path / name).stat().st_size > 0 for name in made), made
    if warmup is not None:  # issue 35: every instance of the warm-up logs within 20 deg/h of the truth, one file per autopilot
        px4 = warmup.px4_errors(warmup.parameters(tmp_path / "imu.params"))
        ardupilot = warmup.ardupilot_errors(warmup.parameters(tmp_path / "imu.parm"))
        assert len(px4) == len(ardupilot) == 2 * warmup.N_INSTANCES
        assert warmup.within_tolerance(px4) and warmup.within_tolerance(ardupilot), (px4, ardupilot)


def _warmup_logs(folder: Path):
    """Write the warm-up logs of ``tests/warmup_logs.py`` (pyulog, pymavlink) where the recipe reads them; return that module (its truth)."""
    import importlib.util

    pytest.importorskip("pyulog")
    pytest.importorskip("pymavlink")
    spec = importlib.util.spec_from_file_location("warmup_logs", Path(__file__).resolve().parent / "warmup_logs.py")
    warmup = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(warmup)
    warmup.write_ulog(folder / "warmup.ulg")
    warmup.write_dataflash(folder / "warmup.bin")
    return warmup


def test_the_readme_has_the_three_recipes_of_the_issue():
    """Oven log to autopilot parameters (3 axes, three commands, the firmware config; a PX4 and an ArduPilot warm-up log, every instance); diagnose; Allan in CI."""
    assert len(RECIPES) == 3
    firmware, diagnose, allan = RECIPES.values()
    assert [line.split()[1] for line in firmware[0].strip().splitlines()] == ["train", "compensate", "export"]
    assert "--rate-col gx,gy,gz --config firmware" in firmware[0] and "--format px4" in firmware[0]
    assert "--format ardupilot" in firmware[1]
    assert "warmup.ulg" in firmware[2] and "--format px4" in firmware[2] and "warmup.bin" in firmware[2] and "--format ardupilot" in firmware[2]
    assert "gyrocomp diagnose" in diagnose[0] and "--holdout" in diagnose[0]
    assert "--max-arw" in allan[0]


def _bash(script: str, cwd: Path) -> None:
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}", OPENBLAS_NUM_THREADS="1")
    result = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=cwd, env=env, capture_output=True, text=True)
    assert result.returncode == 0, f"{script}\n{result.stderr}"


API = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(encoding="utf-8"), re.S)


@pytest.mark.parametrize("code", [pytest.param(c, marks=[pytest.mark.slow] if "diagnose(" in c else [], id=f"block{i}") for i, c in enumerate(API)])
def test_api_page_examples_run(code, monkeypatch):
    monkeypatch.chdir(ROOT)
    exec(compile(code, "docs/api.md", "exec"), {"__name__": "api_example"})
