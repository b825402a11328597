"""``gyrocomp batch``: one stage over many recordings, incrementally, locally or on a Dask cluster.

:func:`run_batch` gives every input its own folder ``DIR/<stem>/``, runs
the command's :class:`~gyrocomp.batch.jobs.Job` on the inputs whose folder
is not up to date (same input SHA-256, settings and gyrocomp version:
:mod:`gyrocomp.batch.manifest`), records a failing input without stopping
the others, and writes ``DIR/summary.csv`` and ``DIR/summary.parquet``.

Exit code of a batch (:attr:`BatchResult.exit_code`)
----------------------------------------------------
* 2 when inputs failed and every failure was a bad input (unreadable,
  truncated or invalid recording: :class:`~gyrocomp.errors.InputError`);
* 1 when any failure was something else;
* 3 when nothing failed but an input crossed a CI threshold (``--max-*``);
* 0 otherwise (``ok`` and ``skipped`` rows only).

Determinism
-----------
The summary is sorted by input path and holds no times, and each folder
is written by the same stage code from the same settings, so the number of
workers and the backend change no byte of the outputs (except the stage
times inside a ``run`` report). The summary's ``status`` says whether the
folder was made now (``ok``) or found up to date (``skipped``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import glob
import hashlib
import os
from pathlib import Path
from typing import Callable, Iterator, Sequence

from gyrocomp.batch.jobs import JOBS, get_job, process_input, resolve
from gyrocomp.errors import InputError

__all__ = ["BatchResult", "run_batch", "expand_inputs", "folder_names", "SUMMARY_SCHEMA", "JOBS"]

SUMMARY_SCHEMA = "gyrocomp.batch"
RESERVED = ("summary.csv", "summary.parquet", ".batch.lock")
"""Files of the batch itself in its folder; no input's folder may take these names."""
BASE_COLUMNS = ("input", "output", "status", "error", "threshold", "sha256")
"""Leading columns of the summary; the command's key figures follow."""


@dataclasses.dataclass
class BatchResult:
    """What a batch did.

    Attributes
    ----------
    command : str
    rows : list of dict
        One per input, sorted by input path: the :data:`BASE_COLUMNS` and
        the command's key figures.
    columns : list of str
        Column order of the summary.
    exit_code : int
        See the module docstring.
    """

    command: str
    rows: list
    columns: list
    exit_code: int

    def count(self, status: str) -> int:
        """Number of rows of a status (``ok``, ``skipped``, ``failed``)."""
        return sum(row["status"] == status for row in self.rows)

    @property
    def thresholds(self) -> int:
        """Number of inputs that crossed a CI threshold."""
        return sum(bool(row["threshold"]) for row in self.rows)

    def frame(self):
        """The summary as a pandas DataFrame."""
        import pandas as pd

        return pd.DataFrame(self.rows, columns=self.columns)


def run_batch(
    command: str,
    inputs: Sequence[str | os.PathLike],
    out_dir: str | os.PathLike,
    *,
    options: dict | None = None,
    files: dict | None = None,
    workers: int | None = None,
    scheduler=None,
    progress: Callable[[int, int], None] | None = None,
) -> BatchResult:
    """Run a command over many recordings, one output folder each.

    Parameters
    ----------
    command : {"allan", "compensate", "run", "diagnose"}
        The stage (:data:`gyrocomp.batch.jobs.JOBS`).
    inputs : sequence of path-like or glob patterns
        Recordings; patterns are expanded (``**`` recurses).
    out_dir : path-like
        Folder of the per-input folders and the summary; created.
    options : dict
        The command's options by Python name (e.g. ``{"max_arw": 1.0}``);
        omitted ones take the command's defaults.
    files : dict
        Files the command needs: ``model`` (compensate), ``config`` (run:
        the run config; allan, diagnose: the TOML of their table).
    workers : int or None
        Local worker processes (``None``: every core; 1 runs in this process).
    scheduler : str or dask.distributed.Client or None
        Run on this Dask cluster instead of locally.
    progress : callable(done, total) or None

    Returns
    -------
    BatchResult
        Also written as ``summary.csv`` and ``summary.parquet`` in `out_dir`.
    """
    from gyrocomp.batch import backends
    from gyrocomp.batch import manifest as mf

    job = get_job(command)
    out = Path(out_dir)
    paths = [p for p in expand_inputs(inputs) if not _inside(p, out)]
    if not paths:
        raise InputError(f"batch: no recording matches {', '.join(map(str, inputs)) or '(nothing given)'}")
    given = dict(options or {})
    files = {**(files or {}), **{key: given.pop(key) for key in job.file_options if key in given}}
    files = {key: _absolute(value) for key, value in files.items() if value is not None}
    settings = resolve(job, given, files)
    out.mkdir(parents=True, exist_ok=True)
    names = folder_names(paths)
    tasks = [
        {"command": command, "input": p, "path": os.path.abspath(p), "name": names[p], "out_dir": os.path.abspath(out), "settings": settings, "files": files}
        for p in paths
    ]
    report = progress or (lambda done, total: None)
    outcomes = []
    with _lock(out):
        mf.remove_leftovers(out)
        report(0, len(tasks))
        if scheduler is not None:
            results = backends.run_dask(process_input, tasks, scheduler=scheduler)
        else:
            results = backends.run_local(process_input, tasks, workers=workers, preload=job.preload)
        for task, result in results:
            if isinstance(result, BaseException):
                result = _worker_died(task, result)
            outcomes.append(result)
            report(len(outcomes), len(tasks))
    result = _summarise(command, outcomes)
    _write_summary(out, result, settings)
    return result


def expand_inputs(patterns: Sequence[str | os.PathLike]) -> list[str]:
    """Expand glob patterns (``**`` recurses) into sorted, distinct file paths.

    A pattern without wildcards names a file (which need not exist: it is
    then reported as a failed input). Hidden files are left out.
    """
    found = set()
    for pattern in patterns:
        pattern = os.fspath(pattern)
        if glob.has_magic(pattern):
            found.update(p for p in glob.glob(pattern, recursive=True) if not os.path.isdir(p) and not _through_link(p, pattern))
        else:
            found.add(pattern)
    return sorted(found)


def _through_link(path: str, pattern: str) -> bool:
    """Whether a match of `pattern` lies under a symbolic link to a folder below the pattern's fixed part.

    ``**`` follows such links (a link to ``..`` made one recording 41
    inputs); the fixed part the user typed may hold links.
    """
    parts = Path(pattern).parts
    fixed = next((i for i, part in enumerate(parts) if glob.has_magic(part)), len(parts))
    folder = Path(*Path(path).parts[:fixed]) if fixed else Path(".")
    for part in Path(path).parts[fixed:-1]:
        folder = folder / part
        if folder.is_symlink():
            return True
    return False


def folder_names(paths: Sequence[str]) -> dict[str, str]:
    """Output folder name of each input: its stem; names shared by several inputs get a hash suffix.

    ``a/x.csv`` and ``b/x.csv`` become ``x-<8 hex>`` each, the hex the start
    of the SHA-256 of the path as given, so a name depends on nothing but
    the inputs that share it. A stem that is one of the batch's own files
    (``summary.csv.parquet`` has the stem ``summary.csv``) gets the suffix
    too. Names are compared without case (a case-insensitive file system
    holds one of ``X`` and ``x``); when a suffixed name meets another input's
    name (an input called ``x-5c400309.csv``), every input sharing it takes
    a longer suffix, until all differ.
    """
    names = {p: _safe(Path(p).stem) for p in paths}
    for length in (8, 16, 32, 64):
        shared: dict[str, list] = {}
        for p, name in names.items():
            shared.setdefault(name.casefold(), []).append(p)
        clashes = [p for key, members in shared.items() for p in members if len(members) > 1 or key in RESERVED]
        if not clashes:
            break
        for p in clashes:
            names[p] = _safe(Path(p).stem) + "-" + hashlib.sha256(os.fspath(p).encode()).hexdigest()[:length]
    return names


def _safe(stem: str) -> str:
    name = stem.lstrip(".") or "input"
    return name if name not in (".", "..") else "input"


def _inside(path: str, folder: Path) -> bool:
    try:
        Path(os.path.abspath(path)).relative_to(os.path.abspath(folder))
    except ValueError:
        return False
    return True


def _absolute(value) -> str:
    """An existing file as an absolute path (workers may run elsewhere); a bare config name as is."""
    return os.path.abspath(value) if os.path.exists(value) else os.fspath(value)


def _worker_died(task: dict, err: BaseException) -> dict:
    message = " ".join(str(err).split()) or type(err).__name__
    return {
        "input": task["input"],
        "output": task["name"],
        "status": "failed",
        "error": f"worker died: {type(err).__name__}: {message}",
        "exit_code": 1,
        "threshold": "",
        "sha256": "",
        "figures": {},
    }


def _summarise(command: str, outcomes: list[dict]) -> BatchResult:
    outcomes = sorted(outcomes, key=lambda o: o["input"])
    figure_columns = []
    for outcome in outcomes:
        figure_columns += [key for key in outcome["figures"] if key not in figure_columns]
    rows = []
    for outcome in outcomes:
        row = {key: outcome.get(key, "") for key in BASE_COLUMNS}
        row.update({key: outcome["figures"].get(key) for key in figure_columns})
        rows.append(row)
    failures = [o["exit_code"] for o in outcomes if o["status"] == "failed"]
    if failures:
        code = 2 if all(c == 2 for c in failures) else 1
    elif any(o["threshold"] for o in outcomes):
        code = 3
    else:
        code = 0
    return BatchResult(command=command, rows=rows, columns=[*BASE_COLUMNS, *figure_columns], exit_code=code)


def _write_summary(out: Path, result: BatchResult, settings: dict) -> None:
    from gyrocomp import artefacts

    frame = result.frame()
    header = artefacts.artefact_header(
        SUMMARY_SCHEMA,
        inputs=[{"name": row["input"], "sha256": row["sha256"]} for row in result.rows],
        settings={"command": result.command, **settings},
    )
    artefacts.write_table(out / "summary.parquet", frame, header)
    artefacts.write_table(out / "summary.csv", _no_formulas(frame), header)


FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
"""First characters a spreadsheet reads as a formula in a text cell (OWASP "CSV injection")."""


def _no_formulas(frame):
    """The summary for ``summary.csv``: a text cell starting like a formula gets a leading ``'``, which spreadsheets show as text."""
    frame = frame.copy()
    for column in frame.columns:
        values = list(frame[column])
        if any(isinstance(v, str) and v.startswith(FORMULA_STARTS) for v in values):
            frame[column] = [f"'{v}" if isinstance(v, str) and v.startswith(FORMULA_STARTS) else v for v in values]
    return frame


@contextlib.contextmanager
def _lock(out: Path) -> Iterator[None]:
    """Hold ``OUT/.batch.lock`` so that two batches never write one folder at once.

    Workers commit a folder only while it is held
    (:func:`gyrocomp.batch.manifest.commit_folder`), so a worker that
    outlives a killed batch writes nothing.
    """
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    from gyrocomp.batch.manifest import LOCK

    with open(out / LOCK, "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"{out}: another gyrocomp batch is writing this folder") from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)
