"""``rbd.study``: every combination of some world settings, run against a reference.

A study is a list of runs, each a task for a worker: a reference run per seed, and a run per
variant and seed. Workers build the scene, run it and send back its samples; this process
measures and records each as it arrives (:mod:`.results`), then writes the table
(:class:`~thesis_rbd.studies.table.StudyTable`) and its page.
"""

from __future__ import annotations

import hashlib
import math
import os
import pickle
import platform
from collections.abc import Callable, Mapping

from thesis_rbd._cores import usable_cores
from thesis_rbd._validate import as_positive_scalar
from thesis_rbd.dynamics.contact_settings import ContactSettings
from thesis_rbd.scene import Scene, SceneError
from thesis_rbd.studies.executor import cluster_workers, run_tasks
from thesis_rbd.studies.folder import StudyFolder
from thesis_rbd.studies.grid import StudyError, Variant, check_settings, variant_grid
from thesis_rbd.studies.page import study_page
from thesis_rbd.studies.results import StudyResults
from thesis_rbd.studies.sampling import conserves_momentum, sampled_run
from thesis_rbd.studies.table import StudyTable, checked_thresholds
from thesis_rbd.world.world import DEFAULT_DT

__all__ = ["DEFAULT_PERTURBATION", "reference_settings", "run_task", "study"]

DEFAULT_PERTURBATION = 1e-6
"""Seeds other than 0 move each body by this fraction of its size and turn it by this many
radians."""
# The default reference: a quarter of the finest step, and contacts solved 100 times tighter
# (with ten times the sweeps to get there).
REFERENCE_STEP_DIVISOR = 4
REFERENCE_TOLERANCE_DIVISOR = 100
REFERENCE_ITERATION_FACTOR = 10


def reference_settings(scene: Scene, grid: list[dict], named: Mapping | None) -> dict:
    """The settings of the reference run: the scene's own, with a quarter of the finest
    step in the grid (or the scene's), the contact tolerance tightened 100 times and ten
    times the PGS sweeps; then whatever ``named`` sets."""
    world = scene.world
    finest = min(settings.get("dt", world.get("dt", DEFAULT_DT)) for settings in grid)
    settings = {
        "dt": finest / REFERENCE_STEP_DIVISOR,
        "contact_tolerance": world.get("contact_tolerance", ContactSettings.tolerance)
        / REFERENCE_TOLERANCE_DIVISOR,
        "contact_iterations": world.get("contact_iterations", ContactSettings.iterations)
        * REFERENCE_ITERATION_FACTOR,
    }
    settings.update(named or {})
    return settings


_COMPILED_AHEAD: set[str] = set()


def _compile_ahead(scene: Scene) -> None:
    """In a worker's first run of a built-in scene on a cold cache, compile the scene's
    planned kernels, taking turns with the other workers
    (:func:`thesis_rbd._numba.compile_helpers.compile_ahead`): they share the compiling
    instead of waiting for one another."""
    from thesis_rbd import scenes
    from thesis_rbd._numba.compile_helpers import compile_ahead

    if scene.name not in _COMPILED_AHEAD and scenes.is_builtin(scene):
        compile_ahead([scene.name])
        _COMPILED_AHEAD.add(scene.name)


def run_task(scene: Scene, settings: dict, seconds: float, seed: int, amount: float) -> dict:
    """One run of a study, on a worker: the scene with ``settings``, perturbed for ``seed``.

    Returns
    -------
    dict
        ``samples``, ``wall``, ``failure`` (see :func:`.sampling.sampled_run`) and ``host``.
    """
    _compile_ahead(scene)
    result = sampled_run(scene.with_world(**settings), seconds, seed, amount)
    result["host"] = platform.node()
    return result


def _scene_key(scene: Scene) -> str:
    """A hash of everything the scene is (its bodies, meshes, joints and settings)."""
    return hashlib.sha1(pickle.dumps(scene, protocol=5)).hexdigest()[:16]


def _as_scene(scene) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)):
        from thesis_rbd import scenes

        try:
            return scenes.resolve(str(scene))
        except SceneError as exc:
            raise StudyError(str(exc)) from None
    raise StudyError(f"scene must be a Scene, a scene file or a built-in name, got {scene!r}")


def _cluster_workers(scheduler: str) -> int:
    try:
        return cluster_workers(scheduler)
    except (OSError, TimeoutError) as exc:
        raise StudyError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None


def _checked_count(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise StudyError(f"{name} must be an integer >= 1, got {value!r}")
    return value


def _checked_positive(value, name: str) -> float:
    try:
        return as_positive_scalar(value, name)
    except ValueError as exc:
        raise StudyError(str(exc)) from None


def study(
    scene,
    vary: Mapping[str, list],
    seconds: float | None = None,
    reference: Mapping | None = None,
    seeds: int = 1,
    scheduler: str | None = None,
    workers: int | None = None,
    perturbation: float = DEFAULT_PERTURBATION,
    out=None,
    fresh: bool = False,
    within: Mapping[str, float] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> StudyTable:
    """Run every combination of ``vary`` on ``scene`` and measure each against a reference.

    Parameters
    ----------
    scene : Scene, str or path
        A scene, a scene file, a URDF file or a built-in scene's name.
    vary : mapping of str to list
        World settings (``grid.VARIABLE_SETTINGS``: dt, integrator, contact_solver,
        narrow_phase, joint_substeps, ...) and the values each takes; every combination
        runs.
    seconds : float, optional
        Simulated time of every run (s); the scene's own by default.
    reference : mapping, optional
        Settings of the reference run, over the default (:func:`reference_settings`: the
        scene's own with a quarter of the finest step and contacts solved 100 times
        tighter).
    seeds : int
        Runs per variant: seed 0 is the scene as written, seeds 1.. perturb its initial
        poses by ``perturbation``. The references of the perturbed seeds measure how far
        the scene itself amplifies so small a change (the table's ``*_floor`` columns).
    scheduler : str, optional
        A Dask scheduler's address (``tcp://HOST:PORT``): the runs go to that cluster.
    workers : int, optional
        Local worker processes; every core this process may use by default.
    perturbation : float
        Fraction of each body's size it is moved by, and radians it is turned by, in the
        perturbed seeds.
    out : path-like, optional
        Folder for the records, ``results.csv`` and ``study.html``; a study run again with
        the same folder resumes where it stopped.
    fresh : bool
        Forget the runs already recorded in ``out``.
    within : mapping of str to float, optional
        Thresholds per measure (``position``, ``orientation``, ``energy``, ``penetration``,
        ``momentum``, ``angular_momentum``; in the scene's units): the page recommends the
        cheapest variant within them (:meth:`StudyTable.recommend`).
    progress : callable(done, total), optional
        Called as runs finish.

    Returns
    -------
    StudyTable
        One row per variant and seed, in the grid's order.

    Raises
    ------
    StudyError
        Before anything runs, naming the fault: an unknown setting, a value the world
        refuses, an empty grid, a bad count or span, a folder holding another study.
        After the runs, if a reference run failed.
    """
    scene = _as_scene(scene)
    seeds = _checked_count(seeds, "seeds")
    seconds = _checked_positive(scene.seconds if seconds is None else seconds, "seconds")
    perturbation = _checked_positive(perturbation, "perturbation")
    if workers is None:
        workers = usable_cores()
    workers = _checked_count(workers, "workers")
    if reference is not None and not isinstance(reference, Mapping):
        raise StudyError(f"reference must be a mapping of settings, got {reference!r}")
    grid = variant_grid(scene, vary)
    if within is not None:
        try:
            checked_thresholds(within)
        except ValueError as exc:
            raise StudyError(str(exc)) from None
    base = reference_settings(scene, grid, reference)
    check_settings(scene, base, "reference")
    definition = {
        "scene": scene.name,
        "scene_key": _scene_key(scene),
        "seconds": seconds,
        "perturbation": perturbation,
        "reference": base,
    }
    definition["key"] = hashlib.sha1(repr(sorted(definition.items())).encode()).hexdigest()[:16]
    # how many runs share the machine with each (the timing columns' context); asking the
    # cluster first makes a missing dask or an unreachable scheduler an error before any run
    cluster = _cluster_workers(scheduler) if scheduler else None
    folder = None if out is None else StudyFolder(out, definition, fresh)

    runs = [Variant.of(settings, seed) for settings in grid for seed in range(seeds)]
    results = StudyResults(runs, seeds, base, definition["key"], conserves_momentum(scene), folder)
    tasks, kinds = results.tasks(scene, seconds, _span(scene, grid, seconds), perturbation)
    results.workers = cluster if scheduler else max(1, min(workers, len(tasks)))
    results.progress = progress
    run_tasks(
        run_task, tasks, lambda i, r: results.take(kinds[i], r), workers=workers,
        scheduler=scheduler,
    )  # fmt: skip

    table = results.table(list(vary))
    if folder is not None:
        folder.write("results.csv", table.to_csv())
        recommendation = None if not within else table.recommend(within)
        description = _description(len(grid), seeds, seconds, base, perturbation)
        folder.write("study.html", study_page(table, scene.name, description, recommendation))
    return table


def _span(scene: Scene, grid: list[dict], seconds: float) -> float:
    """How long the reference runs: as long as the longest variant, ceil(seconds / dt) of
    its steps."""
    scene_dt = scene.world.get("dt", DEFAULT_DT)
    return max(
        math.ceil(seconds / s.get("dt", scene_dt) - 1e-9) * s.get("dt", scene_dt) for s in grid
    )


def _description(variants: int, seeds: int, seconds: float, base: dict, amount: float) -> str:
    """What was run, in a sentence for the page."""
    reference = ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in base.items()
    )
    perturbed = (
        f"; seeds 1.. perturbed by {amount:g} of each body's size and in radians"
        if seeds > 1
        else ""
    )
    runs = f"{variants} variants x {seeds} seed(s), {seconds:g} s each"
    return f"{runs}; reference: {reference}{perturbed}"
