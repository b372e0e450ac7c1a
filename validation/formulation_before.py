"""Record how an earlier checkout's contact formulation does on the contact-formulation cases.

The library's contact step changed (issue 12): contact used to be solved after the positions
moved, with absolute tolerances; it is now solved before, with relative ones. The earlier
formulation no longer exists in the package, so the study ``contact_formulations`` compares
against results recorded from the last commit that had it::

    git worktree add /tmp/before 4a4472a
    PYTHONPATH=/tmp/before/src python -m validation.formulation_before

runs every case of :data:`validation.studies.contact_formulations.CASES` with the package it
imports (the earlier one, by PYTHONPATH) and writes
``validation/data/contact_formulation_before.json``, with the commit, date and machine.
"""

from __future__ import annotations

import sys
from pathlib import Path

import thesis_rbd
from validation.recording import commit_of, write_record
from validation.studies import contact_formulations

OUT = Path(__file__).parent / "data" / "contact_formulation_before.json"


def main() -> int:
    source = Path(thesis_rbd.__file__).resolve().parents[2]
    records = {}
    for name, engine in contact_formulations.case_keys():
        records[f"{name}/{engine}"] = contact_formulations.run({"case": name, "engine": engine})
        print(name, engine, records[f"{name}/{engine}"], flush=True)
    write_record(OUT, {"commit": commit_of(source), "records": records})
    return 0


if __name__ == "__main__":
    sys.exit(main())
