"""A study's output folder, which is also what lets an interrupted study resume.

Layout of ``DIR``:

* ``study.json``: what the study is (its scene, span, perturbation and reference); a later
  study in the same folder must be the same study (its grid may grow);
* ``references/<key>.npz``: each seed's reference run, sampled;
* ``runs/<key>.json``: one record per finished run (variant and seed);
* ``results.csv`` and ``study.html``: the table and the page, written when the study ends.

Every file is written to a temporary name beside it and renamed over its own, so a study
killed at any moment leaves whole files or none: a run is either recorded once or not at all,
and rerunning the same study runs exactly the runs that have no record.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from thesis_rbd._atomic import atomic_path
from thesis_rbd.studies.grid import StudyError
from thesis_rbd.studies.sampling import RunSamples

__all__ = ["StudyFolder", "recorded_runs"]


def recorded_runs(root) -> int:
    """How many runs the study folder ``root`` holds a record of (0 for no folder)."""
    # a record's temporary name starts with a dot (``_atomic``): only whole records count
    return len(list(Path(root).glob("runs/[!.]*.json")))


class StudyFolder:
    """The files of one study under ``root``.

    Parameters
    ----------
    root : path-like
        Created if missing.
    definition : dict
        What the study is (JSON-able); compared with the folder's ``study.json``.
    fresh : bool
        Forget every earlier run and reference in the folder.

    Raises
    ------
    StudyError
        If the folder holds another study (and ``fresh`` is false), or cannot be made.
    """

    def __init__(self, root, definition: dict, fresh: bool = False):
        self.root = Path(root)
        try:
            (self.root / "runs").mkdir(parents=True, exist_ok=True)
            (self.root / "references").mkdir(exist_ok=True)
        except OSError as exc:
            raise StudyError(f"cannot make the study folder {self.root}: {exc}") from None
        stored = self.root / "study.json"
        if fresh:
            for path in [*self.root.glob("runs/*.json"), *self.root.glob("references/*.npz")]:
                path.unlink()
        elif stored.is_file():
            earlier = json.loads(stored.read_text(encoding="utf-8"))
            if earlier.get("key") != definition["key"]:
                raise StudyError(
                    f"{self.root} holds another study ({_differences(earlier, definition)}); "
                    "give another --out folder, or --fresh to replace it"
                )
        self._write_text(stored, json.dumps(definition, indent=1, sort_keys=True) + "\n")

    def _write_text(self, path: Path, text: str) -> None:
        with atomic_path(path) as temporary:
            temporary.write_text(text, encoding="utf-8")

    # ------------------------------------------------------------------ runs
    def has_run(self, key: str) -> bool:
        return (self.root / "runs" / f"{key}.json").is_file()

    def load_run(self, key: str) -> dict:
        return json.loads((self.root / "runs" / f"{key}.json").read_text(encoding="utf-8"))

    def save_run(self, key: str, record: dict) -> None:
        self._write_text(self.root / "runs" / f"{key}.json", json.dumps(record, indent=1) + "\n")

    # ------------------------------------------------------------------ references
    def load_reference(self, key: str) -> RunSamples | None:
        path = self.root / "references" / f"{key}.npz"
        if not path.is_file():
            return None
        with np.load(path) as arrays:
            return RunSamples(**{name: arrays[name] for name in RunSamples.__dataclass_fields__})

    def save_reference(self, key: str, samples: RunSamples) -> None:
        with atomic_path(self.root / "references" / f"{key}.npz") as temporary:
            np.savez(temporary, **{n: getattr(samples, n) for n in RunSamples.__dataclass_fields__})

    # ------------------------------------------------------------------ outputs
    def write(self, name: str, text: str) -> Path:
        """Write ``name`` (``results.csv``, ``study.html``) atomically; return its path."""
        path = self.root / name
        self._write_text(path, text)
        return path


def _differences(earlier: dict, now: dict) -> str:
    changed = [
        name
        for name in sorted(set(earlier) | set(now))
        if name != "key" and earlier.get(name) != now.get(name)
    ]
    return "its " + ", ".join(changed) + " differ" if changed else "another version's study"
