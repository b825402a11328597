"""One job per batchable command: what it accepts, what it writes, what it reports.

A :class:`Job` has two halves:

* :attr:`Job.resolve` runs once, in the calling process: it checks the
  command's options, loads the configs and hashes the files they name,
  and returns the *settings*: a JSON-able dict that fully determines the
  outputs of one input. The settings go into every manifest, so changing
  any of them (or the model file, or a config's contents) redoes the
  inputs.
* :attr:`Job.execute` runs once per input, in a worker: it reads the
  input, calls the stage's library function, writes the artefacts into
  the folder it is given and returns the summary's key figures and the
  CI threshold message (``""`` when no bound was crossed).

:func:`process_input` is the worker's whole task: up-to-date check, the
stage into a hidden temporary folder, the manifest last, the rename into
place. It takes and returns plain dicts, so a process pool or a Dask
cluster can ship it.

Files per output folder
-----------------------
``allan``
    ``allan.json``, ``allan.png`` (as ``gyrocomp allan REC --plot``).
``compensate``
    ``compensated.parquet``, ``compensated.json`` (as ``gyrocomp compensate``).
``run``
    ``report.json``, ``report.md``, ``report.png`` and one folder per
    method (as ``gyrocomp run``). The report records stage times, so its
    bytes differ between runs; its scores do not.
``diagnose``
    ``report.json``, ``report.md``, ``gap.png`` (as ``gyrocomp diagnose
    --markdown --plot``).

Every folder also holds ``manifest.json`` (:mod:`gyrocomp.batch.manifest`).
"""

from __future__ import annotations

import dataclasses
import os
import threading
import warnings
from pathlib import Path
from typing import Callable

from gyrocomp.errors import GyrocompError, InputError, ThresholdError

__all__ = ["Job", "JOBS", "get_job", "process_input", "paired_path"]

_PLOT_LOCK = threading.Lock()
"""Matplotlib is not thread-safe (its mathtext parser is shared): a Dask worker
runs several inputs as threads of one process, so plots are drawn one at a time."""

_COLUMN_OPTIONS = {"time_col": "time", "rate_col": "rate", "temp_col": "temperature", "time_unit": "s", "rate_unit": "deg/s", "temp_unit": "degC"}
"""The column options every recording-reading command shares, with their defaults."""


@dataclasses.dataclass(frozen=True)
class Job:
    """A batchable command.

    Attributes
    ----------
    name : str
        The command's name (``gyrocomp <name>``).
    options : dict
        Options of the command that a batch passes through (Python names,
        as in the command's signature) and their defaults (the command's);
        anything else is refused.
    resolve : callable(options: dict, files: dict) -> dict
        Options (and the batch's files, e.g. ``model``, ``config``) to settings.
    execute : callable(input: Path, folder: Path, settings: dict, files: dict) -> (dict, str)
        Run the stage for one input into `folder`; return the key figures
        and the CI threshold message.
    file_options : tuple of str
        Options that name a file every input uses; they travel in `files`
        (as absolute paths), and the settings hold their SHA-256.
    preload : tuple of str
        Modules the stage imports; worker processes import them before
        the first input arrives (:func:`gyrocomp.batch.backends.run_local`).
    """

    name: str
    options: dict
    resolve: Callable[[dict, dict], dict]
    execute: Callable[[Path, Path, dict, dict], tuple[dict, str]]
    file_options: tuple = ()
    preload: tuple = ()


def get_job(command: str) -> Job:
    """The :class:`Job` of a command name; :class:`InputError` names the choices."""
    try:
        return JOBS[command]
    except KeyError:
        raise InputError(f"batch: unknown command {command!r}; choose one of {', '.join(JOBS)}") from None


def process_input(task: dict) -> dict:
    """Bring one input's output folder up to date; never raises for a bad input.

    Parameters
    ----------
    task : dict
        ``command``, ``input`` (as listed), ``path`` (to open), ``name`` (folder name under
        ``out_dir``), ``out_dir``, ``settings`` (from :attr:`Job.resolve`)
        and ``files`` (absolute paths of the files the settings name).

    Returns
    -------
    dict
        ``input``, ``output``, ``status`` (``ok``, ``skipped`` or
        ``failed``), ``error`` (one line, ``""`` unless failed),
        ``exit_code`` (of the error: 2 bad input, 1 anything else; 0),
        ``threshold`` (the CI message, ``""`` when none), ``sha256`` (of
        the input, ``""`` when unreadable), ``figures``.
    """
    from gyrocomp.batch import manifest as mf

    job = get_job(task["command"])
    out_dir = Path(task["out_dir"])
    source = Path(task["path"])
    outcome = {"input": task["input"], "output": task["name"], "status": "failed", "error": "", "exit_code": 0, "threshold": "", "sha256": "", "figures": {}}
    tmp = None
    try:
        try:
            sha = mf.file_sha256(source)
        except FileNotFoundError:
            raise InputError(f"{source}: no such file") from None
        except IsADirectoryError:
            raise InputError(f"{source}: is a directory, expected a file") from None
        outcome["sha256"] = sha
        done = mf.is_up_to_date(out_dir / task["name"], job.name, sha, task["settings"])
        if done is not None:
            outcome.update(status="skipped", figures=done["figures"], threshold=done["threshold"])
            return outcome
        tmp = mf.new_folder(out_dir, task["name"])
        figures, threshold = job.execute(source, tmp, task["settings"], task["files"])
        mf.write_manifest(tmp, command=job.name, input_name=source.name, input_sha256=sha, settings=task["settings"], figures=figures, threshold=threshold)
        mf.commit_folder(tmp, out_dir / task["name"])
        tmp = None
        outcome.update(status="ok", figures=figures, threshold=threshold)
    except Exception as err:  # a failing input is recorded, the batch goes on
        outcome.update(error=_one_line(err).replace(task["path"], task["input"]), exit_code=err.exit_code if isinstance(err, GyrocompError) else 1)
    finally:
        if tmp is not None:
            mf.discard_folder(tmp)
    return outcome


def _one_line(err: BaseException) -> str:
    message = " ".join(str(err).split()) or type(err).__name__
    return message if isinstance(err, GyrocompError) else f"{type(err).__name__}: {message}"


def _columns(options: dict) -> dict:
    return {key: options[key] for key in _COLUMN_OPTIONS}


def _column_spec(settings: dict):
    from gyrocomp.io import ColumnSpec

    c = settings["columns"]
    return ColumnSpec(
        time=c["time_col"],
        rate=c["rate_col"],
        temperature=c["temp_col"],
        time_unit=c["time_unit"],
        rate_unit=c["rate_unit"],
        temperature_unit=c["temp_unit"],
    )


def _file_identity(path: str | os.PathLike, what: str) -> dict:
    """``{name, sha256}`` of a file a batch depends on (model, config)."""
    from gyrocomp.batch.manifest import file_sha256

    try:
        return {"name": Path(path).name, "sha256": file_sha256(path)}
    except OSError as err:
        raise InputError(f"{what} {path}: {err.strerror or err}") from None


# ---------------------------------------------------------------- allan

def _allan_resolve(options: dict, files: dict) -> dict:
    from gyrocomp import allan as al
    from gyrocomp.config import settings_dict

    config = al.get_config(files.get("config") or "allan")
    return {
        "allan": {**settings_dict(config), "taus": options["taus"] or config.taus, "column": options["column"]},
        "columns": _columns(options),
        "resample": options["resample"],
        "thresholds": {key: options[key] for key in ("max_arw", "max_bias_instability", "max_rrw")},
    }


def _allan_execute(source: Path, folder: Path, settings: dict, files: dict) -> tuple[dict, str]:
    from gyrocomp import allan as al

    config = al.get_config(files.get("config") or "allan")
    series = al.write_report(
        [source],
        folder / "allan.json",
        column=settings["allan"]["column"],
        taus=settings["allan"]["taus"],
        settings=config,
        columns=_column_spec(settings),
        resample=settings["resample"],
    )
    with _PLOT_LOCK:
        al.plot_allan(series, folder / "allan.png")
    figures = {}
    for key in ("arw", "bias_instability", "rrw"):
        term = series[0].terms[key]
        figures[f"{key}_fit"] = term["value"]
        figures[f"{key}_readoff"] = term.get("readoff")
    return figures, _threshold(al.check_thresholds, series, **settings["thresholds"])


def _threshold(check, *args, **kwargs) -> str:
    try:
        check(*args, **kwargs)
    except ThresholdError as err:
        return _one_line(err)
    return ""


# ---------------------------------------------------------------- compensate

def _compensate_resolve(options: dict, files: dict) -> dict:
    from gyrocomp.pipeline.compensate import MODES

    if not files.get("model"):
        raise InputError("batch compensate: needs --model model.json")
    if options["mode"] not in MODES:
        raise InputError(f"batch compensate: --mode {options['mode']!r}; choose one of {', '.join(MODES)}")
    return {
        "mode": options["mode"],
        "seed": options["seed"],
        "model": _file_identity(files["model"], "--model"),
        "columns": _columns(options),
        "resample": options["resample"],
    }


def _compensate_execute(source: Path, folder: Path, settings: dict, files: dict) -> tuple[dict, str]:
    from gyrocomp.pipeline import evaluate
    from gyrocomp.pipeline.run import compensate_to_files

    frame, summary, rec, caught = compensate_to_files(
        source,
        files["model"],
        folder / "compensated.parquet",
        mode=settings["mode"],
        seed=settings["seed"],
        columns=_column_spec(settings),
        resample=settings["resample"],
    )
    figures = {}
    for column in ("compensated", "rate"):
        try:
            drift_figures = evaluate.residual_drift(frame[column].to_numpy(), rec.fs_hz)
        except InputError:  # shorter than two blocks: no residual-drift figure
            drift_figures = {"std_deg_h": None, "p2p_deg_h": None}
        figures[f"{column}_drift_std_deg_h"] = drift_figures["std_deg_h"]
        figures[f"{column}_drift_p2p_deg_h"] = drift_figures["p2p_deg_h"]
    figures["n_warnings"] = len({str(w.message) for w in caught} | set(summary.get("warnings", [])))
    return figures, ""


# ---------------------------------------------------------------- run

def _run_resolve(options: dict, files: dict) -> dict:
    from gyrocomp.config import load_config, settings_dict
    from gyrocomp.pipeline.run import load_run_config

    if not files.get("config"):
        raise InputError("batch run: needs --config (a run config such as compare)")
    run_settings, eval_settings, signal_settings, _ = load_run_config(files["config"], options["assignments"] or ())
    methods = {method: load_config(method) for method in run_settings.methods}
    return {
        "run": settings_dict(run_settings),
        "evaluate": settings_dict(eval_settings),
        "signal": settings_dict(signal_settings),
        "methods": methods,
        "overrides": list(options["assignments"] or ()),
        "test": options["test"],
        "seed": options["seed"],
        "columns": _columns(options),
    }


def paired_path(template: str | None, source: Path, option: str = "--test") -> Path | None:
    """The second recording paired with an input (``run --test``, ``diagnose --holdout``).

    `template` may hold ``{stem}``, ``{name}`` and ``{dir}`` of the input:
    ``--test 'test/{name}'`` pairs ``train/unit07.parquet`` with
    ``test/unit07.parquet``. Without placeholders every input shares one
    recording; ``None`` pairs nothing.
    """
    if template is None:
        return None
    try:
        return Path(str(template).format(stem=source.stem, name=source.name, dir=source.parent))
    except (KeyError, IndexError, ValueError) as err:
        raise InputError(f"batch: {option} {template!r}: bad placeholder ({err}); use {{stem}}, {{name}} or {{dir}}") from None


def _paired(template: str | None, source: Path, option: str) -> Path | None:
    path = paired_path(template, source, option)
    if path is not None and not path.is_file():
        raise InputError(f"{source}: its {option} recording {path} does not exist")
    return path


def _run_execute(source: Path, folder: Path, settings: dict, files: dict) -> tuple[dict, str]:
    from gyrocomp.pipeline.run import run

    test = _paired(settings["test"], source, "--test")
    with _PLOT_LOCK:  # the report's plot uses pyplot: a threaded Dask worker runs one unit at a time
        report = run(
            files["config"],
            source,
            folder,
            test_path=test,
            seed=settings["seed"],
            workers=1,
            overrides=settings["overrides"],
            columns=_column_spec(settings),
        )
    figures = {"held_out": bool(report["test"]["held_out"])}
    for row in report["rows"]:
        label = row["method"] if row["mode"] is None else f"{row['method']}_{row['mode']}"
        figures[f"{label}_arw"] = row["arw"]["value"]
        figures[f"{label}_bias_instability"] = row["bias_instability"]["value"]
        figures[f"{label}_drift_std_deg_h"] = row["residual_drift"]["std_deg_h"]
        figures[f"{label}_drift_p2p_deg_h"] = row["residual_drift"]["p2p_deg_h"]
    return figures, ""


# ---------------------------------------------------------------- diagnose

def _diagnose_resolve(options: dict, files: dict) -> dict:
    from gyrocomp.config import settings_dict
    from gyrocomp.diagnose import get_config

    return {
        "diagnose": settings_dict(get_config(files.get("config") or "diagnose")),
        "holdout": options["holdout"],
        "sim": None if files.get("sim") is None else _file_identity(files["sim"], "--sim"),
        "columns": _columns(options),
        "resample": options["resample"],
    }


def _diagnose_execute(source: Path, folder: Path, settings: dict, files: dict) -> tuple[dict, str]:
    from gyrocomp.diagnose import get_config
    from gyrocomp.diagnose.report import plot_gap, write_report

    report = write_report(
        source,
        folder / "report.json",
        holdout=_paired(settings["holdout"], source, "--holdout"),
        settings=get_config(files.get("config") or "diagnose"),
        sim=files.get("sim"),
        columns=_column_spec(settings),
        resample=settings["resample"],
        markdown=folder / "report.md",
    )
    with _PLOT_LOCK:
        plot_gap(report, folder / "gap.png")
    gap = report["gap"]
    figures = {
        "selected_effects": " ".join(report["selected_effects"]),
        "gap_baseline_fit": gap["baseline"]["fit"],
        "gap_selected_fit": gap["selected"]["fit"],
        "gap_baseline_holdout": gap["baseline"]["holdout"],
        "gap_selected_holdout": gap["selected"]["holdout"],
    }
    return figures, ""


JOBS: dict[str, Job] = {
    "allan": Job(
        "allan",
        {"column": "rate", "taus": None, "max_arw": None, "max_bias_instability": None, "max_rrw": None, **_COLUMN_OPTIONS, "resample": False},
        _allan_resolve,
        _allan_execute,
        preload=("gyrocomp.allan", "matplotlib.figure", "matplotlib.backends.backend_agg"),
    ),
    "compensate": Job(
        "compensate",
        {"mode": "causal", "seed": None, **_COLUMN_OPTIONS, "resample": False},
        _compensate_resolve,
        _compensate_execute,
        preload=("gyrocomp.pipeline",),
    ),
    "run": Job(
        "run",
        {"test": None, "seed": 0, "assignments": None, **_COLUMN_OPTIONS},
        _run_resolve,
        _run_execute,
        preload=("gyrocomp.pipeline", "matplotlib.pyplot"),
    ),
    "diagnose": Job(
        "diagnose", {"holdout": None, "sim": None, **_COLUMN_OPTIONS, "resample": False}, _diagnose_resolve, _diagnose_execute, ("sim",), ("gyrocomp.diagnose", "matplotlib.pyplot")
    ),
}
"""The batchable commands by name."""
