"""A case: one independent unit of campaign work, named by a stable hash of what it computes."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

__all__ = ["Case", "case_id"]


def case_id(study: str, params: dict) -> str:
    """Stable 16-hex-digit id of a case: a hash of its study name and its parameters.

    Parameters
    ----------
    study : str
        Name of the study the case belongs to.
    params : dict
        JSON-able parameters; key order does not matter.

    Returns
    -------
    str
    """
    text = json.dumps({"study": study, "params": params}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha1(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Case:
    """One unit of work of a study.

    Parameters
    ----------
    study : str
        Name of the study whose ``run`` computes it.
    params : dict
        JSON-able parameters passed to the study's ``run``.
    timed : bool
        True when the record holds wall-clock timings: such cases run one at a time, never
        beside another case, because parallel runs on a small machine corrupt each other's
        timings. Accuracy-only cases (False) may run in parallel.
    """

    study: str
    params: dict = field(hash=False)
    timed: bool = False

    @property
    def id(self) -> str:
        """Stable id: the hash of the study and the parameters."""
        return case_id(self.study, self.params)
