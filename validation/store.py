"""The result store: one JSON record per finished case, so an interrupted campaign resumes."""

from __future__ import annotations

import json
from pathlib import Path

from thesis_rbd._atomic import atomic_path
from validation.cases import Case

__all__ = ["ResultStore"]


class ResultStore:
    """Per-case records under ``root/<study>/<case id>.json``, each written atomically.

    A record is written to a temporary file in the same folder and renamed over the final
    name (``thesis_rbd._atomic``, as a study's records), so a campaign killed mid-write
    leaves either the whole record or none.

    Parameters
    ----------
    root : path-like
        Folder of the store; created on first write.
    """

    def __init__(self, root):
        self.root = Path(root)

    def path(self, case: Case) -> Path:
        """Where the record of ``case`` lives."""
        return self.root / case.study / f"{case.id}.json"

    def has(self, case: Case) -> bool:
        """Whether ``case`` has a finished record."""
        return self.path(case).is_file()

    def load(self, case: Case) -> dict:
        """The record of a finished case."""
        with open(self.path(case), encoding="utf-8") as f:
            return json.load(f)

    def save(self, case: Case, record: dict) -> Path:
        """Write the record of ``case`` atomically and return its path."""
        path = self.path(case)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as temporary:
            temporary.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n", "utf-8")
        return path

    def clear(self, study: str) -> int:
        """Delete every record of ``study``; return how many were removed."""
        folder = self.root / study
        removed = 0
        if folder.is_dir():
            for path in folder.glob("*.json"):
                path.unlink()
                removed += 1
        return removed
