"""Running cases: in this process, on local joblib workers, or on a Dask distributed cluster.

Timing cases run one after another (never two at once, never beside an accuracy case), on the
same executor as the rest, because parallel runs on a small shared machine corrupt each
other's timings. Accuracy-only cases run ``jobs`` at a time locally, or as many as the
cluster's workers allow. Every record comes back to this process and is handed to
``on_record`` as soon as it is done, so the caller can store it before the next one finishes.

Workers import the studies by name (``validation.studies``), so a Dask worker must run with
this repository importable: start ``dask worker tcp://HOST:PORT`` from the repository root or
with it on ``PYTHONPATH``, with the ``validation`` extra installed. Records travel back to the
driver, which alone writes the result store: workers need no shared file system.
"""

from __future__ import annotations

import platform
import time
from collections.abc import Callable, Sequence
from datetime import UTC, datetime

from validation.cases import Case

__all__ = ["execute_case", "run_cases"]


def execute_case(study: str, params: dict) -> dict:
    """Run one case of ``study`` and wrap its result in a record.

    Parameters
    ----------
    study : str
        Registered study name.
    params : dict
        The case's parameters.

    Returns
    -------
    dict
        ``{"study", "params", "result", "seconds", "host", "finished"}``.
    """
    from validation.studies import get_study

    start = time.perf_counter()
    result = get_study(study).run(params)
    return {
        "study": study,
        "params": params,
        "result": result,
        "seconds": time.perf_counter() - start,
        "host": platform.node(),
        "finished": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def run_cases(
    cases: Sequence[Case],
    on_record: Callable[[Case, dict], None],
    jobs: int = 1,
    scheduler: str | None = None,
) -> None:
    """Run ``cases`` and hand each record to ``on_record(case, record)`` as it finishes.

    Parameters
    ----------
    cases : sequence of Case
    on_record : callable
        Called in this process, once per case.
    jobs : int
        Local worker processes for accuracy-only cases (joblib, loky backend); 1 runs
        everything in this process.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://HOST:PORT``); when given, every case
        runs on the cluster and ``jobs`` is ignored.
    """
    parallel = [case for case in cases if not case.timed]
    serial = [case for case in cases if case.timed]
    if scheduler:
        _run_on_dask(parallel, serial, on_record, scheduler)
    else:
        _run_locally(parallel, serial, on_record, jobs)


def _run_locally(parallel, serial, on_record, jobs):
    if jobs > 1 and len(parallel) > 1:
        from joblib import Parallel, delayed

        def tagged(index, case):
            return index, execute_case(case.study, case.params)

        runner = Parallel(n_jobs=jobs, backend="loky", return_as="generator_unordered")
        for index, record in runner(delayed(tagged)(i, c) for i, c in enumerate(parallel)):
            on_record(parallel[index], record)
    else:
        serial = list(parallel) + list(serial)
    for case in serial:
        on_record(case, execute_case(case.study, case.params))


def _run_on_dask(parallel, serial, on_record, scheduler):
    try:
        from dask.distributed import Client, as_completed
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise RuntimeError(
            "--scheduler needs dask.distributed: pip install 'thesis_rbd[validation]'"
        ) from error
    with Client(scheduler) as client:
        if parallel:
            futures = {
                client.submit(execute_case, case.study, case.params, pure=False): case
                for case in parallel
            }
            for future in as_completed(futures):
                on_record(futures[future], future.result())
        for case in serial:
            future = client.submit(execute_case, case.study, case.params, pure=False)
            on_record(case, future.result())
