"""Time steps and queries under an earlier checkout and this one, in one process, alternated.

A change to how a step is orchestrated must not slow it down, and two runs of a benchmark on a
shared machine differ by more than the few per cent at stake. So both packages step the same
scenes in one process (the earlier one imported as ``thesis_rbd_before``, as
:mod:`validation.checkout_comparison` does), each timed run of one followed by one of the
other, alternating which goes first::

    git worktree add /tmp/before <commit>
    python -m validation.step_comparison /tmp/before [--runs 7]

Scenes are the step benchmark's (:mod:`validation.bench_step`): one cube, ten cubes, the
15-row pyramid, the 256-cube pile (three pours: a pile is chaotic) and the 1000-cube grid,
kept awake; plus the one cube stepped one step per call (the per-call overhead of a small
scene). Both worlds settle first (compiling every kernel), then each run times the same
number of steps in each. The queries
are the query benchmark's (:mod:`validation.bench_queries`): ``distance`` along the tori path,
``collide`` in each mode along it, ``collide_batch`` over it and over 10000 random poses, and
4000 rays at a torus. The ratio after / before per run, and its median over the runs, are
printed and written to ``--out`` (JSON) with both commits, the date and the machine.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import thesis_rbd
from validation.bench_step import DT, SCENES
from validation.checkout_comparison import import_renamed
from validation.recording import commit_of, write_record

# (scene, steps per call, calls per timed run)
WORKLOADS = {
    "one_cube": ("one_cube", 20, 200),
    "one_cube_single_steps": ("one_cube", 1, 2000),
    "ten_cubes": ("ten_cubes", 20, 200),
    "pyramid_15": ("pyramid_15", 1, 200),
    "pile_256": ("pile_256", 1, 100),
    "pile_256_seed2": ("pile_256_seed2", 1, 100),
    "pile_256_seed3": ("pile_256_seed3", 1, 100),
    "grid_1000": ("grid_1000", 1, 100),
}


def build(package, spec):
    """The scene ``spec`` (``contact_scenes.SceneSpec``) as a world of ``package``, awake."""
    world = package.World(dt=DT, gravity=(0.0, 0.0, -spec.gravity), sleeping=False)
    for body in spec.bodies:
        if body.shape == "box":
            mesh = package.shapes.box(body.size)
        else:
            mesh = package.shapes.icosphere(body.size[0], 3)
        world.add_body(
            mesh, mass=body.mass, static=body.mass is None, position=body.position,
            orientation=body.orientation, linear_velocity=body.linear_velocity,
            angular_velocity=body.angular_velocity, restitution=body.restitution,
            friction=body.friction,
        )  # fmt: skip
    return world


def query_workloads(package) -> dict:
    """Name -> a function running one sweep of that query with ``package``."""
    from validation.bench_queries import RAY_COUNT, random_poses
    from validation.tori import tori_mesh, tori_poses

    mesh = tori_mesh()
    tree = package.OBBTree(package.TriangleMesh(mesh.vertices, mesh.faces))
    identity, poses, cloud = np.eye(4), tori_poses(), random_poses(10000, 4.0)
    torus = package.OBBTree(package.shapes.torus(1.0, 0.3, 50, 20))
    rng = np.random.default_rng(0)
    origins = rng.normal(size=(RAY_COUNT, 3)) * 3.0
    directions = rng.normal(size=(RAY_COUNT, 3)) * 0.4 - origins

    def sweep(mode):
        return lambda: [package.collide(tree, identity, tree, P, mode=mode) for P in poses]

    return {
        "distance, tori path": lambda: [package.distance(tree, identity, tree, P) for P in poses],
        "collide first, tori path": sweep("first"),
        "collide all, tori path": sweep("all"),
        "collide contacts, tori path": sweep("contacts"),
        "collide_batch, tori path": lambda: package.collide_batch(tree, identity, tree, poses),
        "collide_batch, 10000 poses in 4 m": lambda: package.collide_batch(
            tree, identity, tree, cloud
        ),
        "ray_cast, 4000 rays": lambda: package.ray_cast(torus, identity, origins, directions),
    }


def compare_queries(before_package, runs: int) -> dict:
    results = {}
    workloads = {"before": query_workloads(before_package), "after": query_workloads(thesis_rbd)}
    for name in workloads["after"]:
        for which in ("before", "after"):
            workloads[which][name]()  # compile
        seconds = {"before": [], "after": []}
        for run in range(runs):
            order = ("before", "after") if run % 2 == 0 else ("after", "before")
            for which in order:
                start = time.perf_counter()
                workloads[which][name]()
                seconds[which].append(time.perf_counter() - start)
        results[name] = _summary(name, seconds, 1)
    return results


def _summary(name: str, seconds: dict, steps: int) -> dict:
    ratios = [a / b for a, b in zip(seconds["after"], seconds["before"], strict=True)]
    unit = "us/step" if steps > 1 else "ms"
    scale = 1e6 / steps if steps > 1 else 1e3
    print(
        f"{name}: before {scale * statistics.median(seconds['before']):.2f} {unit}, "
        f"after {scale * statistics.median(seconds['after']):.2f} {unit}, "
        f"median ratio {statistics.median(ratios):.3f}"
    )
    sys.stdout.flush()
    return {
        "steps_per_run": steps,
        "before_seconds": seconds["before"],
        "after_seconds": seconds["after"],
        "ratios": ratios,
        "median_ratio": statistics.median(ratios),
    }


def timed(world, per_call: int, calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        world.step(per_call)
    return time.perf_counter() - start


def compare(before_package, runs: int) -> dict:
    results = {}
    for name, (scene, per_call, calls) in WORKLOADS.items():
        factory, settle = SCENES[scene]
        worlds = {"before": build(before_package, factory()), "after": build(thesis_rbd, factory())}
        for world in worlds.values():
            world.step(settle)
        seconds = {"before": [], "after": []}
        for run in range(runs):
            order = ("before", "after") if run % 2 == 0 else ("after", "before")
            for which in order:
                seconds[which].append(timed(worlds[which], per_call, calls))
        results[name] = _summary(name, seconds, per_call * calls)
    return results


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, help="the earlier checkout (a git worktree)")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--only", choices=("steps", "queries"), help="one kind of workload")
    parser.add_argument("--out", type=Path, help="write the figures here (JSON)")
    options = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        before = import_renamed(options.before.resolve(), Path(folder))
        results = {}
        if options.only != "queries":
            results.update(compare(before, options.runs))
        if options.only != "steps":
            results.update(compare_queries(before, options.runs))
    if options.out:
        record = {
            "before": commit_of(options.before),
            "after": commit_of(Path(__file__).resolve().parent.parent),
            "runs": options.runs,
            "workloads": results,
        }
        write_record(options.out, record)


if __name__ == "__main__":
    main()
