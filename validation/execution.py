"""Running cases: in this process, on local worker processes, or on a Dask distributed cluster.

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

from thesis_rbd.studies.executor import run_tasks
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
        Local worker processes for accuracy-only cases; 1 runs everything in this process.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://HOST:PORT``); when given, every case
        runs on the cluster and ``jobs`` is ignored.

    Notes
    -----
    The workers are those of ``rbd.study`` (:func:`thesis_rbd.studies.executor.run_tasks`):
    one way to run a grid of simulations in this repository.
    """
    parallel = [case for case in cases if not case.timed]
    serial = [case for case in cases if case.timed]
    if not scheduler and jobs <= 1:
        parallel, serial = [], parallel + serial
    run_tasks(
        execute_case,
        [(case.study, case.params) for case in parallel],
        lambda index, record: on_record(parallel[index], record),
        workers=jobs,
        scheduler=scheduler,
    )
    for case in serial:
        # one at a time, on the cluster if there is one, else in this process
        run_tasks(
            execute_case,
            [(case.study, case.params)],
            lambda _index, record, case=case: on_record(case, record),
            scheduler=scheduler,
        )
