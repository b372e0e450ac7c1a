"""Running independent tasks: in this process, on local worker processes, or on a Dask cluster.

Each result comes back to this process and is handed to the caller as soon as its task is
done, so the caller can store it (atomically) before the next one finishes: what is stored
survives whatever happens to the rest. A local worker that dies (killed, out of memory) takes
no result with it that was stored; the tasks it had not finished are given to a new pool, up
to ``retries`` times each. A Dask cluster reschedules the tasks of a lost worker itself.

Local workers are started by ``spawn`` (a fresh interpreter, not a fork of this one, whose
threads and numba state a fork would copy half-way); they load compiled kernels from numba's
on-disk cache, shared by every process, so a kernel compiles once. A Dask worker must be able
to import the task's function: install this package (and, for the validation campaign, run
the worker from the repository's root) on every node.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

__all__ = ["WorkerLost", "cluster_workers", "run_tasks"]


class WorkerLost(RuntimeError):
    """A task whose worker process died every time it was given one."""


def run_tasks(
    function: Callable,
    tasks: Sequence[tuple],
    on_result: Callable[[int, object], None],
    workers: int = 1,
    scheduler: str | None = None,
    retries: int = 2,
) -> None:
    """Call ``function(*tasks[i])`` for every i and ``on_result(i, result)`` as each ends.

    Parameters
    ----------
    function : callable
        Importable by name (a module's top-level function): workers receive it pickled.
    tasks : sequence of tuple
        The arguments of each call (picklable).
    on_result : callable(index, result)
        Called in this process, once per task, in the order tasks finish.
    workers : int
        Local worker processes; 1 runs every task in this process.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://HOST:PORT``); when given, every
        task runs on that cluster and ``workers`` is ignored.
    retries : int
        How many times the tasks of a local pool whose worker died are given to a new pool
        (a Dask scheduler retries a lost worker's tasks by its own ``allowed-failures``).

    Raises
    ------
    WorkerLost
        If a task's worker died on every try.
    ImportError
        If ``scheduler`` is given and dask.distributed is not installed.
    Exception
        Whatever a task raised (the other tasks' results are handed over first where
        they had finished).
    """
    if scheduler:
        _run_on_dask(function, tasks, on_result, scheduler)
    elif workers > 1 and len(tasks) > 1:
        _run_on_processes(function, tasks, on_result, workers, retries)
    else:
        for index, arguments in enumerate(tasks):
            on_result(index, function(*arguments))


@contextlib.contextmanager
def _main_script_hidden():
    """While worker processes start, hide the path of the script run as ``__main__``.

    A spawned worker runs the parent's main script again (as ``__mp_main__``) before it
    takes a task, so that functions defined there can be unpickled; a script that calls
    ``rbd.study`` outside an ``if __name__ == "__main__":`` guard would then start a study in
    every worker, which multiprocessing refuses. The tasks here are this package's own
    functions, so the workers need nothing from the script: without its path they skip it.
    """
    main = sys.modules["__main__"]
    path = main.__dict__.pop("__file__", None) if getattr(main, "__spec__", None) is None else None
    try:
        yield
    finally:
        if path is not None:
            main.__file__ = path


def _run_on_processes(function, tasks, on_result, workers, retries):
    pending = list(range(len(tasks)))
    deaths = dict.fromkeys(pending, 0)
    context = multiprocessing.get_context("spawn")
    while pending:
        with ProcessPoolExecutor(
            max_workers=min(workers, len(pending)), mp_context=context
        ) as pool:
            with _main_script_hidden():  # the workers start as the tasks are submitted
                futures = {pool.submit(function, *tasks[index]): index for index in pending}
            broken = False
            try:
                while futures and not broken:
                    done, _ = wait(futures, return_when=FIRST_COMPLETED)
                    for future in done:
                        index = futures.pop(future)
                        try:
                            result = future.result()
                        except BrokenProcessPool:
                            broken = True
                            continue
                        pending.remove(index)
                        on_result(index, result)
            except BaseException:
                pool.shutdown(wait=False, cancel_futures=True)
                raise
        if broken:
            # every task still pending lost its worker or its pool: count a try against those
            # that had started (the others had not run and lost nothing)
            for index in pending:
                deaths[index] += 1
                if deaths[index] > retries:
                    raise WorkerLost(
                        f"task {index} lost its worker process {deaths[index]} times "
                        f"({function.__name__}{tasks[index]!r:.200})"
                    )


def _dask():
    try:
        from dask import distributed
    except ImportError as error:
        raise ImportError(
            "running on a Dask cluster needs dask.distributed: pip install 'dask[distributed]'"
        ) from error
    return distributed


def cluster_workers(scheduler: str) -> int:
    """Tasks the Dask cluster at ``scheduler`` runs at once (its workers' threads)."""
    with _dask().Client(scheduler) as client:
        return sum(client.nthreads().values())


def _run_on_dask(function, tasks, on_result, scheduler):
    distributed = _dask()
    with distributed.Client(scheduler) as client:
        futures = {
            client.submit(function, *arguments, pure=False): index
            for index, arguments in enumerate(tasks)
        }
        for future in distributed.as_completed(futures):
            on_result(futures[future], future.result())
