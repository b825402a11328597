"""Where the inputs of a batch run: in this process, a local process pool, or a Dask cluster.

Each backend maps one picklable function over plain-dict tasks and yields
``(task, result)`` pairs as they finish, in any order (the batch sorts the
summary afterwards, so the order never reaches an output). A task whose
worker died yields the exception instead of a result.

* :func:`run_local`: ``workers=1`` runs in this process (no start-up
  cost, easiest to debug); more workers use a
  :class:`concurrent.futures.ProcessPoolExecutor` whose processes are
  forked from a *forkserver* that has already imported gyrocomp, numpy,
  pandas and the stage's modules (safe with threads, and cheap per worker).
* :func:`run_dask`: an existing ``dask.distributed`` scheduler (the
  optional ``dask`` extra); every worker must see the inputs and the
  output folder at the same paths (a shared file system).
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
from typing import Callable, Iterable, Iterator, Sequence

from gyrocomp.errors import InputError

__all__ = ["default_workers", "run_local", "run_dask"]

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
    with cf.ProcessPoolExecutor(max_workers=n, mp_context=context) as pool:
        futures = {pool.submit(fn, task): task for task in tasks}
        for future in cf.as_completed(futures):
            error = future.exception()
            yield futures[future], (future.result() if error is None else error)


def run_dask(fn: Callable[[dict], dict], tasks: Iterable[dict], *, scheduler) -> Iterator[tuple[dict, dict | BaseException]]:
    """Run `fn` over `tasks` on a Dask distributed cluster.

    Parameters
    ----------
    scheduler : str or distributed.Client
        The scheduler's address (``tcp://host:8786``), or a connected client.

    Raises
    ------
    InputError
        dask.distributed is not installed, or the scheduler cannot be reached.
    """
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise InputError(
            "--scheduler needs dask.distributed, which is not installed; install the extra: pip install 'gyrocomp[dask]'"
        ) from None
    tasks = list(tasks)
    own = not isinstance(scheduler, Client)
    if own:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as err:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({' '.join(str(err).split())})") from None
    else:
        client = scheduler
    try:
        futures = client.map(fn, tasks, pure=False)
        index = {future.key: task for future, task in zip(futures, tasks)}
        for future in as_completed(futures):
            task = index[future.key]
            if future.status == "finished":
                yield task, future.result()
            else:
                yield task, future.exception()
    finally:
        if own:
            client.close()
