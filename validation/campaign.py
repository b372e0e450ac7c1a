"""The campaign: gather the studies' cases, run what is not done yet, summarise, report.

Results are one JSON record per case in ``<out>/data/cases/<study>/<case id>.json``, written
as each case finishes, so an interrupted campaign resumes where it stopped: a case whose
record exists is not run again (``fresh=True`` forgets a study's records first). Each
study's summary, tables, text and records go to ``<out>/data/<study>.json``, its figures to
``<out>/figures/``, and the campaign's own facts (machine, versions, commit, counts, wall
time, load) to ``<out>/data/campaign.json``; then ``report.md`` and ``report.html`` are
rendered from those files alone.
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from validation.environment import describe_environment
from validation.execution import run_cases
from validation.report import render_paragraphs, write_report
from validation.store import ResultStore
from validation.studies import STUDIES, get_study

__all__ = ["SCALES", "CampaignOutcome", "run_campaign"]

SCALES = ("full", "quick", "tiny")


@dataclass
class CampaignOutcome:
    """What a campaign run did.

    Attributes
    ----------
    executed : dict
        Study name -> cases run in this invocation.
    cached : dict
        Study name -> cases whose records were already stored.
    seconds : float
        Wall-clock duration of the whole invocation.
    report : Path
        The markdown report.
    """

    executed: dict = field(default_factory=dict)
    cached: dict = field(default_factory=dict)
    seconds: float = 0.0
    report: Path | None = None


def _load_average():
    try:
        return list(os.getloadavg())
    except OSError:
        return None


def _write_json(path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def run_campaign(
    out="reports",
    scale: str = "full",
    only=None,
    jobs: int = 1,
    scheduler: str | None = None,
    fresh: bool = False,
    note: str | None = None,
    log=print,
) -> CampaignOutcome:
    """Run the campaign and regenerate the report.

    Parameters
    ----------
    out : path-like
        Report folder.
    scale : {"full", "quick", "tiny"}
        Size of every study.
    only : list of str, optional
        Study names to run; all registered studies by default. The report still includes
        earlier data of the others.
    jobs : int
        Local processes for accuracy-only cases; timing cases always run alone.
    scheduler : str, optional
        Dask distributed scheduler address; runs every case on that cluster.
    fresh : bool
        Forget the selected studies' stored records and run every case again.
    note : str, optional
        A sentence about the conditions of the run, printed in the report's header.
    log : callable
        Progress messages.

    Returns
    -------
    CampaignOutcome
    """
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {SCALES}, got {scale!r}")
    started = time.perf_counter()
    started_at = datetime.now(UTC).isoformat(timespec="seconds")
    load_before = _load_average()
    out = Path(out)
    data, figures = out / "data", out / "figures"
    store = ResultStore(data / "cases")
    names = list(only) if only else list(STUDIES)
    studies = [get_study(name) for name in names]
    environment = describe_environment()
    commit = environment["git"]["commit"]

    outcome = CampaignOutcome()
    all_cases, pending = {}, []
    for study in studies:
        if fresh:
            store.clear(study.NAME)
        cases = study.cases(scale)
        all_cases[study.NAME] = cases
        todo = [case for case in cases if not store.has(case)]
        outcome.executed[study.NAME] = 0
        outcome.cached[study.NAME] = len(cases) - len(todo)
        pending += todo
        log(f"{study.NAME}: {len(cases)} cases, {len(todo)} to run")

    def on_record(case, record):
        record["case_id"] = case.id
        record["timed"] = case.timed
        record["commit"] = commit
        store.save(case, record)
        outcome.executed[case.study] += 1
        done = sum(outcome.executed.values())
        log(f"  [{done}/{len(pending)}] {case.study} {case.id} {record['seconds']:.2f} s")

    run_cases(pending, on_record, jobs=jobs, scheduler=scheduler)

    study_seconds = {}
    for study in studies:
        start = time.perf_counter()
        cases = all_cases[study.NAME]
        records = [store.load(case) for case in cases]
        section = study.summarise(records, figures)
        section.paragraphs = render_paragraphs(section)
        payload = section.to_json()
        payload.update(
            scale=scale,
            case_count=len(cases),
            commits=sorted({r.get("commit") or "unknown" for r in records}),
            case_seconds=sum(r["seconds"] for r in records),
            records=records,
        )
        _write_json(data / f"{study.NAME}.json", payload)
        study_seconds[study.NAME] = time.perf_counter() - start
        log(f"{study.NAME}: summarised")

    outcome.seconds = time.perf_counter() - started
    _write_json(
        data / "campaign.json",
        {
            "command": " ".join(["python -m validation", *sys.argv[1:]])
            if Path(sys.argv[0]).parent.name == "validation"
            else None,
            "scale": scale,
            "studies": names,
            "jobs": jobs,
            "scheduler": scheduler,
            "started": started_at,
            "finished": datetime.now(UTC).isoformat(timespec="seconds"),
            "seconds": outcome.seconds,
            "executed": outcome.executed,
            "cached": outcome.cached,
            "load_average_before": load_before,
            "load_average_after": _load_average(),
            "note": note,
            "environment": environment,
        },
    )
    outcome.report, _ = write_report(out, list(STUDIES))
    log(f"report: {outcome.report} ({outcome.seconds:.1f} s)")
    return outcome
