"""One job per batchable command: what it accepts, what it writes, what it reports.

A batch runs a stage's ``to_files`` (:mod:`gyrocomp.commands`) once per
input, with the stage's ``Options``: the options a batch passes through
and their defaults are the stage's own, never restated here. A
:class:`Job` adds what is particular to a batch:

* :func:`resolve` runs once, in the calling process: it builds the
  options, loads the configs and hashes the files they name, and returns
  the *settings*: a JSON-able dict that fully determines the outputs of
  one input. The settings go into every manifest, so changing any of them
  (or the model file, or a config's contents) redoes the inputs.
* :attr:`Job.execute` runs once per input, in a worker: it calls the
  stage's ``to_files`` into the folder it is given and returns the
  summary's key figures and the CI threshold message (``""`` when no
  bound was crossed).

:func:`process_input` is the worker's whole task: up-to-date check, the
stage into a hidden temporary folder, the manifest last, the rename into
place. It takes and returns plain dicts, so a process pool or a Dask
cluster can ship it.

Files per output folder
-----------------------
``allan``
    ``allan.json``, ``allan.png`` (as ``gyrocomp allan REC --plot``).
``compensate``
    ``compensated.parquet``, ``compensated.meta.json`` (as ``gyrocomp compensate``).
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
import re
from pathlib import Path
from typing import Callable

from gyrocomp.errors import GyrocompError, InputError, ThresholdError

__all__ = ["Job", "JOBS", "get_job", "resolve", "process_input", "paired_path"]


@dataclasses.dataclass(frozen=True)
class Job:
    """A batchable command.

    Attributes
    ----------
    name : str
        The command's name (``gyrocomp <name>``), also its stage in :mod:`gyrocomp.commands`.
    execute : callable(input: Path, folder: Path, options, files: dict) -> (dict, str)
        Run the stage for one input into `folder`; return the key figures
        and the CI threshold message.
    owned : tuple of str
        Options of the stage that the batch sets itself (outputs, workers,
        the files of its own options); the others pass through.
    resolve : callable(options, files: dict) -> dict
        What else determines the outputs: the configs' contents, the
        files' SHA-256.
    file_options : tuple of str
        Options that name a file every input uses; they travel in `files`
        (as absolute paths), and the settings hold their SHA-256.
    preload : tuple of str
        Modules the stage imports; worker processes import them before
        the first input arrives (:func:`gyrocomp.workers.run_local`).
    paired : tuple of (str, str)
        ``(option, flag)`` of the options that name a second recording per
        input (:func:`paired_path`); its content is part of what makes a
        folder up to date.
    """

    name: str
    execute: Callable
    owned: tuple = ()
    resolve: Callable[[object, dict], dict] = lambda options, files: {}
    file_options: tuple = ()
    preload: tuple = ()
    paired: tuple = ()

    @property
    def options_class(self):
        """The stage's ``Options`` dataclass."""
        from gyrocomp.commands import stage

        return stage(self.name).Options

    @property
    def options(self) -> tuple[str, ...]:
        """Command-line parameter names (Python names) a batch passes through to the stage."""
        from gyrocomp.commands import param_names

        return tuple(name for name in param_names(self.options_class) if name not in self.owned)


def get_job(command: str) -> Job:
    """The :class:`Job` of a command name; :class:`InputError` names the choices."""
    try:
        return JOBS[command]
    except KeyError:
        raise InputError(f"batch: unknown command {command!r}; choose one of {', '.join(JOBS)}") from None


def resolve(job: Job, given: dict, files: dict) -> dict:
    """The settings of a batch: the stage's options (`given` over its defaults) and what :attr:`Job.resolve` adds.

    Raises
    ------
    InputError
        An option the batch does not pass through.
    """
    from gyrocomp.commands import from_params, to_settings

    unknown = sorted(set(given) - set(job.options))
    if unknown:
        names = ", ".join("--" + key.replace("_", "-") for key in unknown)
        raise InputError(f"batch {job.name}: {names} not available in a batch; it passes {', '.join('--' + k.replace('_', '-') for k in job.options)}")
    options = from_params(job.options_class, given)
    return {"options": to_settings(options), **job.resolve(options, files)}


def process_input(task: dict) -> dict:
    """Bring one input's output folder up to date; never raises for a bad input.

    Parameters
    ----------
    task : dict
        ``command``, ``input`` (as listed), ``path`` (to open), ``name`` (folder name under
        ``out_dir``), ``out_dir``, ``settings`` (from :func:`resolve`)
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
    from gyrocomp import artefacts
    from gyrocomp.batch import manifest as mf
    from gyrocomp.commands import from_settings

    job = get_job(task["command"])
    out_dir = Path(task["out_dir"])
    source = Path(task["path"])
    outcome = {"input": task["input"], "output": task["name"], "status": "failed", "error": "", "exit_code": 0, "threshold": "", "sha256": "", "figures": {}}
    tmp = None
    try:
        sha = artefacts.file_sha256(source)
        outcome["sha256"] = sha
        options = from_settings(job.options_class, task["settings"]["options"])
        settings = {**task["settings"], "paired": _paired_records(job, options, source)}
        done = mf.is_up_to_date(out_dir / task["name"], job.name, sha, settings)
        if done is not None:
            outcome.update(status="skipped", figures=done["figures"], threshold=done["threshold"])
            return outcome
        tmp = mf.new_folder(out_dir, task["name"])
        figures, threshold = job.execute(source, tmp, options, task["files"])
        mf.write_manifest(tmp, command=job.name, input_name=source.name, input_sha256=sha, settings=settings, figures=figures, threshold=threshold)
        mf.commit_folder(tmp, out_dir / task["name"], lock=out_dir / mf.LOCK)
        tmp = None
        outcome.update(status="ok", figures=figures, threshold=threshold)
    except Exception as err:  # a failing input is recorded, the batch goes on
        outcome.update(error=_one_line(err).replace(task["path"], task["input"]), exit_code=err.exit_code if isinstance(err, GyrocompError) else 1)
    finally:
        if tmp is not None:
            mf.discard_folder(tmp)
    return outcome


def _paired_records(job: Job, options, source: Path) -> dict:
    """``{flag: {name, sha256}}`` of the second recordings paired with `source`: a changed holdout is a changed input."""
    from gyrocomp.artefacts import file_record

    records = {}
    for option, flag in job.paired:
        path = _paired(getattr(options, option), source, flag)
        if isinstance(path, tuple):
            if path:
                records[flag] = [file_record(p) for p in path]
        elif path is not None:
            records[flag] = file_record(path)
    return records


def _one_line(err: BaseException) -> str:
    message = " ".join(str(err).split()) or type(err).__name__
    return message if isinstance(err, GyrocompError) else f"{type(err).__name__}: {message}"


def _file_identity(path: str | os.PathLike, what: str) -> dict:
    """``{name, sha256}`` of a file a batch depends on (model, config)."""
    from gyrocomp.artefacts import file_record

    try:
        return file_record(path)
    except InputError as err:
        raise InputError(f"{what} {err}") from None


def _threshold(check, *args, **kwargs) -> str:
    try:
        check(*args, **kwargs)
    except ThresholdError as err:
        return _one_line(err)
    return ""


# ---------------------------------------------------------------- allan

def _allan_resolve(options, files: dict) -> dict:
    from gyrocomp import allan as al
    from gyrocomp.config import settings_dict

    return {"allan": settings_dict(al.get_config(files.get("config") or options.config))}


def _allan_execute(source: Path, folder: Path, options, files: dict) -> tuple[dict, str]:
    from gyrocomp.commands import allan as stage

    options = dataclasses.replace(options, config=files.get("config") or options.config, plot=folder / "allan.png")
    series = stage.to_files([source], folder / "allan.json", options)
    figures = {}
    for s in series:
        prefix = "" if len(series) == 1 else f"{s.column}_"
        for key in ("arw", "bias_instability", "rrw"):
            figures[f"{prefix}{key}_fit"] = s.terms[key]["value"]
            figures[f"{prefix}{key}_readoff"] = s.terms[key].get("readoff")
    return figures, _threshold(stage.check, series, options)


# ---------------------------------------------------------------- compensate

def _compensate_resolve(options, files: dict) -> dict:
    from gyrocomp.pipeline.compensate import MODES

    if not files.get("model"):
        raise InputError("batch compensate: needs --model model.json")
    if options.mode not in MODES:
        raise InputError(f"batch compensate: --mode {options.mode!r}; choose one of {', '.join(MODES)}")
    return {"model": _file_identity(files["model"], "--model")}


def _compensate_execute(source: Path, folder: Path, options, files: dict) -> tuple[dict, str]:
    from gyrocomp.commands import compensate as stage

    groups, summaries, caught = stage.to_files([source, files["model"]], folder / "compensated.parquet", options)
    figures, messages = {}, {str(w.message) for w in caught}
    for _, frame, rec in groups:
        for axis in rec.axis_names:
            for column in (stage.output_name(axis, "compensated"), axis):
                figures.update(_drift_figures(column, frame[column].to_numpy(), rec.fs_hz, summaries[axis]["unit"]))
            messages |= set(summaries[axis].get("warnings", []))
    figures["n_warnings"] = len(messages)
    return figures, ""


def _drift_figures(column: str, values, fs_hz: float, unit: str) -> dict:
    """Residual drift (:func:`gyrocomp.pipeline.evaluate.residual_drift`) of one column, named in its axis' unit.

    An angular rate [deg/s] gives ``<column>_drift_std_deg_h`` and
    ``..._p2p_deg_h`` (block means in deg/h); an acceleration gives the
    block means in its own unit, ``<column>_drift_std_m_s2`` and
    ``..._p2p_m_s2``: an accelerometer axis has no deg/h. Shorter than two
    blocks: both ``None``.
    """
    import numpy as np

    from gyrocomp.pipeline import evaluate
    from gyrocomp.pipeline.settings import EvaluateSettings

    suffix = "deg_h" if unit == "deg/s" else unit.replace("/", "_").replace("^", "")
    try:
        if unit == "deg/s":
            drift = evaluate.residual_drift(values, fs_hz)
            std, p2p = drift["std_deg_h"], drift["p2p_deg_h"]
        else:
            means = evaluate.block_means(values, fs_hz, EvaluateSettings().block_s)
            std, p2p = float(np.std(means)), float(np.ptp(means))
    except InputError:  # shorter than two blocks: no residual-drift figure
        std = p2p = None
    return {f"{column}_drift_std_{suffix}": std, f"{column}_drift_p2p_{suffix}": p2p}


# ---------------------------------------------------------------- run

def _run_resolve(options, files: dict) -> dict:
    from gyrocomp.commands.run import load_run_config
    from gyrocomp.config import load_config, settings_dict

    if not files.get("config"):
        raise InputError("batch run: needs --config (a run config such as compare)")
    run_settings, eval_settings, signal_settings, _ = load_run_config(files["config"], options.overrides)
    return {
        "run": settings_dict(run_settings),
        "evaluate": settings_dict(eval_settings),
        "signal": settings_dict(signal_settings),
        "methods": {method: load_config(method) for method in run_settings.methods},
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
    values = {"stem": source.stem, "name": source.name, "dir": os.fspath(source.parent)}

    def fill(match):
        if match.group(1) not in values:
            raise InputError(f"batch: {option} {template!r}: unknown placeholder {match.group(0)}; use {{stem}}, {{name}} or {{dir}}")
        return values[match.group(1)]

    if _stray_brace(str(template)):
        raise InputError(f"batch: {option} {template!r}: a brace that is no placeholder; use {{stem}}, {{name}} or {{dir}}")
    return Path(_PLACEHOLDER.sub(fill, str(template)))  # plain text substitution: no attribute access, no format spec


_PLACEHOLDER = re.compile(r"\{([^{}]*)\}")


def _stray_brace(template: str) -> bool:
    """Whether a template holds a brace outside ``{word}`` placeholders."""
    return "{" in _PLACEHOLDER.sub("", template) or "}" in _PLACEHOLDER.sub("", template)


def _paired(template, source: Path, option: str):
    """The paired recording(s) of `source`: a path, or a tuple of them for a repeatable option (``diagnose --holdout``)."""
    if isinstance(template, (tuple, list)):
        return tuple(_paired(one, source, option) for one in template)
    path = paired_path(template, source, option)
    if path is not None and not path.is_file():
        raise InputError(f"{source}: its {option} recording {path} does not exist")
    return path


def _run_execute(source: Path, folder: Path, options, files: dict) -> tuple[dict, str]:
    from gyrocomp.commands import run as stage

    options = dataclasses.replace(options, test=_paired(options.test, source, "--test"), workers=1)
    report = stage.to_files([files["config"], source], folder, options)
    figures = {"held_out": bool(report["test"]["held_out"])}
    several = len(report["axes"]) > 1
    for row in report["rows"]:
        label = row["method"] if row["mode"] is None else f"{row['method']}_{row['mode']}"
        label = f"{row['axis']}_{label}" if several else label
        figures[f"{label}_arw"] = row["arw"]["value"]
        figures[f"{label}_bias_instability"] = row["bias_instability"]["value"]
        figures[f"{label}_drift_std_deg_h"] = row["residual_drift"]["std_deg_h"]
        figures[f"{label}_drift_p2p_deg_h"] = row["residual_drift"]["p2p_deg_h"]
    return figures, ""


# ---------------------------------------------------------------- diagnose

def _diagnose_resolve(options, files: dict) -> dict:
    from gyrocomp.config import settings_dict
    from gyrocomp.diagnose import get_config

    return {
        "diagnose": settings_dict(get_config(files.get("config") or options.config)),
        "sim": None if files.get("sim") is None else _file_identity(files["sim"], "--sim"),
    }


def _diagnose_execute(source: Path, folder: Path, options, files: dict) -> tuple[dict, str]:
    from gyrocomp.commands import diagnose as stage

    options = dataclasses.replace(
        options,
        holdout=_paired(options.holdout, source, "--holdout"),
        sim=files.get("sim"),
        config=files.get("config") or options.config,
        plot=folder / "gap.png",
        markdown=folder / "report.md",
    )
    report = stage.to_files([source], folder / "report.json", options)
    figures = {}
    for axis, verdict in report.get("axes", {report.get("axis"): report}).items():
        prefix = f"{axis}_" if "axes" in report else ""
        gap = verdict["gap"]
        figures.update({
            f"{prefix}selected_effects": " ".join(verdict["selected_effects"]),
            f"{prefix}gap_baseline_fit": gap["baseline"]["fit"],
            f"{prefix}gap_selected_fit": gap["selected"]["fit"],
            f"{prefix}gap_baseline_holdout": gap["baseline"]["holdout"],
            f"{prefix}gap_selected_holdout": gap["selected"]["holdout"],
        })
    return figures, ""


JOBS: dict[str, Job] = {
    "allan": Job(
        "allan",
        _allan_execute,
        owned=("config", "plot"),
        resolve=_allan_resolve,
        preload=("gyrocomp.allan", "matplotlib.figure", "matplotlib.backends.backend_agg"),
    ),
    "compensate": Job("compensate", _compensate_execute, owned=("workers",), resolve=_compensate_resolve, preload=("gyrocomp.pipeline",)),
    "run": Job(
        "run",
        _run_execute,
        owned=("workers",),
        resolve=_run_resolve,
        preload=("gyrocomp.pipeline", "matplotlib.pyplot"),
        paired=(("test", "--test"),),
    ),
    "diagnose": Job(
        "diagnose",
        _diagnose_execute,
        owned=("config", "plot", "markdown"),
        resolve=_diagnose_resolve,
        file_options=("sim",),
        preload=("gyrocomp.diagnose", "matplotlib.pyplot"),
        paired=(("holdout", "--holdout"),),
    ),
}
"""The batchable commands by name."""
