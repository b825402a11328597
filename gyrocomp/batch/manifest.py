"""Per-input output folders: the up-to-date check, the manifest, and the swap into place.

Each input of a batch owns one folder ``DIR/<name>/``. The folder is built
as a hidden temporary folder ``DIR/.<name>.tmp-<random>`` (the stage writes
its artefacts there, then :func:`write_manifest` writes ``manifest.json``
LAST), and only then renamed onto ``DIR/<name>`` (:func:`commit_folder`).
So a folder that carries a manifest is complete, and a batch killed at any
instant leaves either the previous folder, the finished new one, or no
folder at all; the hidden leftovers are removed by the next batch
(:func:`remove_leftovers`).

A folder is *up to date* (:func:`is_up_to_date`) when its manifest names
the same command, input SHA-256, settings and gyrocomp version, and every
output it lists still has the recorded SHA-256.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from pathlib import Path

from gyrocomp import __version__, artefacts
from gyrocomp.artefacts import file_sha256
from gyrocomp.errors import GyrocompError

__all__ = [
    "MANIFEST",
    "MANIFEST_SCHEMA",
    "read_manifest",
    "is_up_to_date",
    "write_manifest",
    "new_folder",
    "commit_folder",
    "discard_folder",
    "remove_leftovers",
]

MANIFEST = "manifest.json"
LOCK = ".batch.lock"
"""The file a batch holds an exclusive ``flock`` on while it runs (:func:`gyrocomp.batch.run_batch`)."""
MANIFEST_SCHEMA = "gyrocomp.batch-manifest"

_TMP_TAG = ".tmp-"
_OLD_TAG = ".old-"


def read_manifest(folder: str | os.PathLike) -> dict | None:
    """The manifest of an output folder, or ``None`` when absent or unreadable."""
    path = Path(folder) / MANIFEST
    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    if not isinstance(obj, dict) or obj.get("schema", {}).get("name") != MANIFEST_SCHEMA:
        return None
    return obj


def is_up_to_date(folder: str | os.PathLike, command: str, input_sha256: str, settings: dict) -> dict | None:
    """Return the folder's manifest when its outputs are up to date, else ``None``.

    Up to date means: same command, same input SHA-256, same settings
    (compared as canonical JSON), same gyrocomp version, and every listed
    output present with its recorded SHA-256.
    """
    manifest = read_manifest(folder)
    if manifest is None:
        return None
    same = (
        manifest.get("command") == command
        and manifest.get("input_sha256") == input_sha256
        and manifest.get("gyrocomp_version") == __version__
        and _canonical(manifest.get("settings")) == _canonical(settings)
    )
    if not same:
        return None
    for name, sha in (manifest.get("outputs") or {}).items():
        path = Path(folder) / name
        if not path.is_file() or file_sha256(path) != sha:
            return None
    return manifest


def write_manifest(folder: str | os.PathLike, *, command: str, input_name: str, input_sha256: str, settings: dict, figures: dict, threshold: str) -> dict:
    """Write ``manifest.json`` atomically; call it after every other output of the folder.

    The manifest lists every other file of the folder with its SHA-256,
    the key `figures` of the summary and the CI `threshold` message (empty
    when no bound was crossed), so an up-to-date folder reproduces its
    summary row without rerunning the stage.
    """
    folder = Path(folder)
    outputs = {
        p.name: file_sha256(p)
        for p in sorted(folder.iterdir())
        if p.is_file() and p.name != MANIFEST and not p.name.startswith(".")
    }
    manifest = {
        **artefacts.artefact_header(MANIFEST_SCHEMA, inputs=[{"name": input_name, "sha256": input_sha256}], settings=settings),
        "command": command,
        "input_sha256": input_sha256,
        "outputs": outputs,
        "figures": figures,
        "threshold": threshold,
    }
    artefacts.write_json(folder / MANIFEST, manifest)
    return manifest


def new_folder(out_dir: str | os.PathLike, name: str) -> Path:
    """A fresh hidden temporary folder ``OUT/.<name>.tmp-<random>`` to build an input's outputs in."""
    folder = Path(tempfile.mkdtemp(prefix=f".{name}{_TMP_TAG}", dir=out_dir))
    os.chmod(folder, 0o777 & ~artefacts._umask())  # ordinary permissions, not mkdtemp's 0700
    return folder


def commit_folder(tmp: str | os.PathLike, target: str | os.PathLike, lock: str | os.PathLike | None = None) -> None:
    """Move a finished temporary folder onto `target`, replacing an outdated one.

    The outdated folder is first renamed aside (``.<name>.old-<random>``), the
    new one renamed into place, then the old one deleted: at no instant
    does `target` hold a mix of old and new files.

    With `lock`, commit only while some process (the batch) still holds it:
    a worker that outlived its batch raises instead of writing.
    """
    tmp, target = Path(tmp), Path(target)
    if lock is not None and not lock_is_held(lock):
        raise GyrocompError(f"{target}: the batch that started this input is gone (its lock is free); nothing committed")
    aside = None
    if target.exists():
        aside = Path(tempfile.mkdtemp(prefix=f".{target.name}{_OLD_TAG}", dir=target.parent))
        os.replace(target, aside / target.name)
    os.replace(tmp, target)
    if aside is not None:
        shutil.rmtree(aside, ignore_errors=True)


def lock_is_held(lock: str | os.PathLike) -> bool:
    """Whether another open file (the batch's) holds an exclusive ``flock`` on `lock`; True where flock is missing."""
    try:
        import fcntl
    except ImportError:  # not POSIX
        return True
    try:
        fh = open(lock, "r")
    except FileNotFoundError:
        return False
    with fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(fh, fcntl.LOCK_UN)
        return False


def discard_folder(tmp: str | os.PathLike) -> None:
    """Delete a temporary folder whose stage failed."""
    shutil.rmtree(tmp, ignore_errors=True)


def remove_leftovers(out_dir: str | os.PathLike) -> list[str]:
    """Delete the hidden temporary folders an interrupted batch left in `out_dir`; return their names."""
    removed = []
    with contextlib.suppress(FileNotFoundError):
        for entry in sorted(Path(out_dir).iterdir()):
            if entry.name.startswith(".") and (_TMP_TAG in entry.name or _OLD_TAG in entry.name) and entry.is_dir():
                shutil.rmtree(entry, ignore_errors=True)
                removed.append(entry.name)
    return removed


def _canonical(obj) -> str:
    return json.dumps(artefacts.jsonable(obj), sort_keys=True, allow_nan=False)
