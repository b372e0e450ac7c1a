"""The grid of a study: which world settings vary, over which values, and the runs it makes.

A study varies the settings of a scene's ``[world]`` table (the keyword arguments of
:class:`~thesis_rbd.World`): ``dt``, ``integrator``, ``contact_solver``, ``narrow_phase``,
``joint_substeps`` and the rest. Every value is checked by the scene itself
(:meth:`~thesis_rbd.Scene.with_world`, the same check a scene file gets) before anything runs.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from thesis_rbd.scene import WORLD_KEYS, Scene, SceneError

__all__ = [
    "VARIABLE_SETTINGS",
    "StudyError",
    "Variant",
    "check_settings",
    "parse_assignments",
    "parse_value",
    "parse_vary",
    "variant_grid",
]

# Every [world] key but gravity, a vector that is a property of the scene, not of its solver.
VARIABLE_SETTINGS = tuple(key for key in WORLD_KEYS if key != "gravity")


class StudyError(ValueError):
    """A study that cannot run as asked: raised before anything runs, naming the fault."""


def parse_value(text: str) -> bool | int | float | str:
    """A setting's value written on a command line: ``true``/``false``, an integer, a
    number or a fraction (``1/240``), else the text itself (a name such as ``rk4``)."""
    text = text.strip()
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        if "/" in text:
            return float(Fraction(text))
        value = float(text)
    except (ValueError, ZeroDivisionError):
        return text
    return value


def parse_vary(spec: str) -> tuple[str, list]:
    """``NAME=V1,V2,...`` (one ``--vary``) as the name and its values.

    Raises
    ------
    StudyError
        If the text has no ``=``, names no setting or lists no value.
    """
    name, sep, values = spec.partition("=")
    name = name.strip()
    if not sep or not name:
        raise StudyError(f"--vary takes NAME=V1,V2,..., got {spec!r}")
    parsed = [parse_value(value) for value in values.split(",") if value.strip()]
    if not parsed:
        raise StudyError(f"--vary {name} lists no value")
    return name, parsed


def parse_assignments(spec: str, what: str) -> dict:
    """``NAME=V,NAME=V`` (``--within``, ``--reference``) as a dict of parsed values."""
    result = {}
    for item in spec.split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise StudyError(f"{what} takes NAME=VALUE,..., got {spec!r}")
        result[name.strip()] = parse_value(value)
    return result


def check_settings(scene: Scene, settings: Mapping, what: str) -> Scene:
    """The scene with ``settings`` applied, after checking each name and value.

    Raises
    ------
    StudyError
        Naming ``what`` (the variant or the reference) and the fault.
    """
    for name in settings:
        if name not in VARIABLE_SETTINGS:
            raise StudyError(
                f"{what}: unknown setting {name!r}; a study varies {', '.join(VARIABLE_SETTINGS)}"
            )
    try:
        return scene.with_world(**settings)
    except SceneError as exc:
        message = str(exc).removeprefix("overrides: ")
        raise StudyError(f"{what}: {message}") from None


def variant_grid(scene: Scene, vary: Mapping[str, list]) -> list[dict]:
    """Every combination of the values in ``vary``, in the order given (the last setting
    varies fastest), each checked against the scene.

    Raises
    ------
    StudyError
        If the grid is empty, a name is unknown or repeated, or a value is refused.
    """
    if not vary:
        raise StudyError("the study varies nothing: give at least one setting and its values")
    for name, values in vary.items():
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            raise StudyError(f"the values of {name!r} must be a list, got {values!r}")
        values = list(values)
        if not values:
            raise StudyError(f"{name!r} lists no value: the grid is empty")
        if len({json.dumps(_plain(v)) for v in values}) != len(values):
            raise StudyError(f"{name!r} lists a value twice: {values!r}")
        for value in values:
            check_settings(scene, {name: value}, f"{name}={value!r}")
    names = list(vary)
    grid = [
        dict(zip(names, combination, strict=True))
        for combination in itertools.product(*(vary[name] for name in names))
    ]
    for settings in grid:
        check_settings(scene, settings, _describe(settings))
    return grid


def _plain(value):
    """A setting's value as JSON writes it (numpy numbers as Python ones)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    return value


def _describe(settings: Mapping) -> str:
    return ", ".join(f"{name}={value!r}" for name, value in settings.items())


@dataclass(frozen=True)
class Variant:
    """One run of a study: settings of the world and a seed.

    Attributes
    ----------
    settings : tuple of (str, value)
        The varied settings, in the grid's order.
    seed : int
        0 runs the scene as written; seed k > 0 perturbs its initial poses
        (:func:`thesis_rbd.studies.sampling.perturb`).
    """

    settings: tuple
    seed: int

    @classmethod
    def of(cls, settings: Mapping, seed: int) -> Variant:
        return cls(tuple((name, _plain(value)) for name, value in settings.items()), int(seed))

    def key(self, study_key: str) -> str:
        """Stable id of this run within the study whose definition hashes to ``study_key``:
        the name of its record, so a resumed study finds what it already ran."""
        text = json.dumps([study_key, self.settings, self.seed], separators=(",", ":"))
        return hashlib.sha1(text.encode()).hexdigest()[:16]
