"""Writing a recorded measurement: what the validation recorders store beside their numbers.

Some comparisons cannot be rerun by every campaign (an earlier checkout's package is needed,
see :mod:`validation.formulation_before` and :mod:`validation.checkout_comparison`); they are
recorded once into ``validation/data/`` with the commits measured, the date and the machine,
and the report says so.
"""

from __future__ import annotations

import datetime
import json
import platform
import subprocess
from pathlib import Path

__all__ = ["commit_of", "write_record"]


def commit_of(source: Path) -> str:
    """The commit checked out at ``source`` ("unknown" outside a git checkout)."""
    try:
        return subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"],
            capture_output=True, text=True, check=True,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def write_record(path: Path, fields: dict) -> None:
    """``fields`` with today's date and this machine, as indented JSON at ``path``."""
    record = {
        **fields,
        "date": datetime.date.today().isoformat(),
        "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}, "
        f"Python {platform.python_version()}",
    }
    path.write_text(json.dumps(record, indent=1))
