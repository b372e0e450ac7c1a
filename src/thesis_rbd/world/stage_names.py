"""The names of the stages a world step can run, in pipeline order (see ``world/world.py``)."""

from __future__ import annotations

__all__ = ["STAGE_NAMES"]

# ``World.profile`` has an entry for each, so that a skipped stage shows zero calls.
STAGE_NAMES = (
    "forces",
    "contacts",
    "integrate",
    "kinematic",
    "joints",
    "bounds",
    "broad_phase",
    "narrow_phase",
    "tunnelling",
    "time_of_impact",
    "impacts",
    "sleep",
)
