"""Worker processes that die with their parent: the local pool of ``batch`` and of ``train --workers``.

:func:`run_local` maps one picklable function over plain-dict tasks and
yields ``(task, result)`` pairs as they finish, in any order. A task whose
worker died yields the exception instead of a result. ``workers=1`` runs
in this process (no start-up cost, easiest to debug); more workers use a
:class:`concurrent.futures.ProcessPoolExecutor` whose processes are forked
from a *forkserver* that has already imported gyrocomp, numpy, pandas and
the stage's modules (safe with threads, and cheap per worker). Workers die
with their parent: each watches the parent process (a pidfd on Linux, else
a poll every 0.5 s) and kills itself when it is gone, even by SIGKILL (a
worker's parent is the forkserver, which outlives the caller while any
worker does, so the parent-death signal cannot serve); an exception in the
caller (Ctrl-C, SIGTERM) kills them at once. When a worker dies (out of
memory, killed), the pool is restarted: the tasks that were in flight are
retried one at a time, so only the task that kills a worker on its own fails.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import select
import signal
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from typing import Callable, Iterable, Iterator, Sequence

from gyrocomp.errors import InputError

__all__ = ["default_workers", "run_local"]

_PRELOAD = ["numpy", "pandas", "pyarrow.parquet", "gyrocomp.recordings", "gyrocomp.artefacts", "gyrocomp.batch.jobs"]
"""Modules the forkserver imports once, so each worker starts warm."""


def default_workers() -> int:
    """The number of CPU cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def run_local(
    fn: Callable[[dict], dict], tasks: Iterable[dict], *, workers: int | None = None, preload: Sequence[str] = ()
) -> Iterator[tuple[dict, dict | BaseException]]:
    """Run `fn` over `tasks` here (``workers=1``) or in a pool of worker processes.

    Parameters
    ----------
    fn : callable(dict) -> dict
        A module-level function (it is pickled by reference).
    tasks : iterable of dict
    workers : int or None
        Processes; ``None`` uses every core (:func:`default_workers`).
        Never more than there are tasks.
    preload : sequence of str
        Modules for the forkserver to import besides gyrocomp's core, so
        that no worker pays for them per input. They take effect when this
        process starts its forkserver (its first pool).
    """
    tasks = list(tasks)
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise InputError(f"--workers {workers}: must be at least 1")
    n = min(n, len(tasks))
    if n <= 1:
        for task in tasks:
            yield task, fn(task)
        return
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([*_PRELOAD, *preload])
    queue = list(tasks)
    while queue:
        broken = []
        for task, outcome in _pool_map(fn, queue, n, context):
            if isinstance(outcome, BrokenProcessPool):
                broken.append(task)
            else:
                yield task, outcome
        broken.sort(key=lambda task: tasks.index(task))  # as given, not as the pool broke
        if not broken:
            return
        suspect, queue = broken[0], broken[1:]
        ((_, outcome),) = list(_pool_map(fn, [suspect], 1, context))  # alone: a death now is its own
        yield suspect, outcome


def _pool_map(fn, tasks: list, n: int, context) -> Iterator[tuple[dict, dict | BaseException]]:
    """Run `tasks` in a fresh pool of `n` workers, yielding as they finish.

    An exception in the batch while it runs (Ctrl-C, SIGTERM, or the
    generator closed early) kills the workers before it propagates, so no
    input goes on running, let alone committing, after the batch stopped.
    """
    pool = cf.ProcessPoolExecutor(max_workers=n, mp_context=context, initializer=_die_with_batch, initargs=(os.getpid(),))
    try:
        futures = {pool.submit(fn, task): task for task in tasks}
        for future in cf.as_completed(futures):
            error = future.exception()
            yield futures[future], (future.result() if error is None else error)
    except BaseException:
        _kill_workers(pool)
        raise
    pool.shutdown(wait=True)


def _kill_workers(pool: cf.ProcessPoolExecutor) -> None:
    """Stop a pool now: cancel what has not started and kill the worker processes."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # no public API before Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.kill()


def _die_with_batch(batch_pid: int) -> None:
    """Worker initializer: a daemon thread that SIGKILLs this worker once the batch process has exited."""
    threading.Thread(target=_watch, args=(batch_pid,), daemon=True, name="gyrocomp-batch-watch").start()


def _watch(batch_pid: int) -> None:
    try:
        fd = os.pidfd_open(batch_pid)  # readable once the process has exited
    except (AttributeError, OSError):
        fd = None
    if fd is not None:
        select.select([fd], [], [])
    else:
        while _alive(batch_pid):
            time.sleep(0.5)
    os.kill(os.getpid(), signal.SIGKILL)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
