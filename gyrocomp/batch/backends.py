"""Where the inputs of a batch run: in this process, a local process pool, or a Dask cluster.

Each backend maps one picklable function over plain-dict tasks and yields
``(task, result)`` pairs as they finish, in any order (the batch sorts the
summary afterwards, so the order never reaches an output). A task whose
worker died yields the exception instead of a result.

* :func:`~gyrocomp.workers.run_local`: this process (``workers=1``) or a
  local pool of worker processes that die with the batch
  (:mod:`gyrocomp.workers`, shared with ``train --workers``).
* :func:`run_dask`: an existing ``dask.distributed`` scheduler (the
  optional ``dask`` extra); every worker must see the inputs and the
  output folder at the same paths (a shared file system).
"""

from __future__ import annotations

from typing import Callable, Iterable, Iterator

from gyrocomp.errors import InputError
from gyrocomp.workers import default_workers, run_local

__all__ = ["default_workers", "run_local", "run_dask"]


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
