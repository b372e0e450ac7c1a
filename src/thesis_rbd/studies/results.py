"""A study's results as they arrive: references and run records, measured and recorded.

Results come back from the workers in whatever order they finish. A run is measured against
its seed's reference (:func:`.measures.run_errors`), held back until that reference has
arrived, and recorded in the study's folder the moment it is measured, so an interrupted
study loses nothing it had finished (:mod:`.folder`).
"""

from __future__ import annotations

import math

from thesis_rbd._cores import usable_cores
from thesis_rbd.studies.grid import StudyError, Variant
from thesis_rbd.studies.measures import MEASURES, run_errors, seed_spread
from thesis_rbd.studies.table import StudyTable
from thesis_rbd.world.world import DEFAULT_DT

__all__ = ["StudyResults"]


class StudyResults:
    """A study's references and run records, those stored by an earlier study in its folder
    and those that arrive; each arriving run is measured against its seed's reference (held
    back until that reference has arrived) and recorded at once.

    Attributes
    ----------
    workers : int
        Runs at once beside each (the table's ``workers`` column).
    progress : callable(done, total) or None
    """

    def __init__(self, runs, seeds, base, study_key, conserving, folder):
        self.runs, self.seeds, self.base, self.study_key = runs, seeds, base, study_key
        self.conserving, self.folder = conserving, folder
        self.reference_keys = {seed: Variant.of(base, seed).key(study_key) for seed in range(seeds)}
        self.references: dict[int, object] = {}
        self.records: dict[str, dict] = {}
        self.waiting: dict[int, list] = {}
        self.workers, self.progress, self.cores = 1, None, usable_cores()
        if folder is not None:
            for seed, key in self.reference_keys.items():
                stored = folder.load_reference(key)
                if stored is not None:
                    self.references[seed] = stored
            for run in runs:
                key = run.key(study_key)
                if folder.has_run(key):
                    self.records[key] = folder.load_run(key)
        self.done = len(self.records) + len(self.references)

    def tasks(self, scene, seconds, span, amount) -> tuple[list, list]:
        """The runs still to do, as the workers' arguments and what each is: the references
        first, then the runs with the most steps (so that two workers do not end with one
        long run left to one of them)."""
        tasks, kinds = [], []
        for seed in range(self.seeds):
            if seed not in self.references:
                tasks.append((scene, self.base, span, seed, amount))
                kinds.append(("reference", seed))
        scene_dt = scene.world.get("dt", DEFAULT_DT)
        for run in sorted(self.runs, key=lambda r: dict(r.settings).get("dt", scene_dt)):
            if run.key(self.study_key) not in self.records:
                tasks.append((scene, dict(run.settings), seconds, run.seed, amount))
                kinds.append(("run", run))
        return tasks, kinds

    def take(self, kind: tuple, result: dict) -> None:
        """One finished task's result (``run_task``'s dict)."""
        what, item = kind
        if what == "reference":
            if result["failure"]:
                raise StudyError(f"the reference run of seed {item} failed: {result['failure']}")
            self.references[item] = result["samples"]
            if self.folder is not None:
                self.folder.save_reference(self.reference_keys[item], result["samples"])
            for run, pending in self.waiting.pop(item, []):
                self._record(run, pending)
        elif item.seed in self.references:
            self._record(item, result)
        else:
            self.waiting.setdefault(item.seed, []).append((item, result))
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, len(self.runs) + self.seeds)

    def _record(self, run: Variant, result: dict) -> None:
        samples = result["samples"]
        simulated = samples.times[-1] - samples.times[0]
        record = {
            **dict(run.settings),
            "seed": run.seed,
            "status": "failed" if result["failure"] else "ok",
            "failure": result["failure"] or "",
            "steps": len(samples) - 1,
            "wall_seconds": result["wall"],
            "wall_per_second": float(result["wall"] / simulated) if simulated > 0 else math.nan,
            "workers": self.workers,
            "workers_per_core": self.workers / self.cores,
            "host": result["host"],
            **run_errors(samples, self.references[run.seed], self.conserving),
        }
        key = run.key(self.study_key)
        self.records[key] = record
        if self.folder is not None:
            self.folder.save_run(key, record)

    def table(self, varied: list[str]) -> StudyTable:
        """The table, in the grid's order, each row with the measures' seed floors."""
        references = [self.references[seed] for seed in range(self.seeds)]
        floors = seed_spread(references, self.conserving)
        rows = [
            {**self.records[run.key(self.study_key)], **{f"{m}_floor": floors[m] for m in MEASURES}}
            for run in self.runs
        ]
        return StudyTable(rows, varied, floors)
