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

import datetime
import json
import platform
import subprocess
import sys
from pathlib import Path

import thesis_rbd
from validation.studies import contact_formulations

OUT = Path(__file__).parent / "data" / "contact_formulation_before.json"


def _commit(source: Path) -> str:
    try:
        return subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"],
            capture_output=True, text=True, check=True,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main() -> int:
    source = Path(thesis_rbd.__file__).resolve().parents[2]
    records = {}
    for name, engine in contact_formulations.case_keys():
        records[f"{name}/{engine}"] = contact_formulations.run({"case": name, "engine": engine})
        print(name, engine, records[f"{name}/{engine}"], flush=True)
    OUT.write_text(
        json.dumps(
            {
                "commit": _commit(source),
                "date": datetime.date.today().isoformat(),
                "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}, "
                f"Python {platform.python_version()}",
                "records": records,
            },
            indent=1,
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
