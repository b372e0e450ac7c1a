"""Time ``collide`` under an earlier checkout and this one, in one process, calls interleaved.

Issue 16 made the triangle tests decide touching and flush faces exactly (filtered orientation
predicates with an exact fallback); its bound is that the common case costs no more than 10 %
over the float tests it replaced. Two runs of a benchmark on a shared machine differ by more
than that (the tori sweep varied by half between runs here), so both packages are timed in
the same process, each query answered by one and then the other, alternating which goes first::

    git worktree add /tmp/before e9ba8aa
    python -m validation.checkout_comparison /tmp/before

copies the earlier checkout's ``src/thesis_rbd`` into a temporary folder as the package
``thesis_rbd_before`` (imports renamed), builds the same trees in both, and times "first",
"all" and "contacts" over three workloads: the tori path (the thesis's demo, 200 poses), and
the CAD-like parts of :mod:`validation.cad_parts` against copies of themselves at random
overlapping poses (the common case) and at flush, pushed-in and pulled-away placements (where
the exact fallback decides). Per pose, the minimum and the median over the repeats; per
workload and mode, their sums. Writes
``validation/data/predicate_cost.json`` with both commits, the date and the machine; the
study ``predicate_cost`` renders it.
"""

from __future__ import annotations

import argparse
import importlib
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import thesis_rbd
from validation.cad_parts import PARTS, placement
from validation.recording import commit_of, write_record
from validation.tori import tori_mesh, tori_poses

OUT = Path(__file__).parent / "data" / "predicate_cost.json"
MODES = ("first", "all", "contacts")
REPEATS = {"first": 25, "all": 7, "contacts": 7}
RANDOM_POSES_PER_PART = 30
FLUSH_GAPS = (0.0, -1e-12, 1e-12, 1e-6)  # of the part's size, as in the flush tests
FLUSH_TURNS = (("none", 0), ("whole", 7), ("about_normal", 0))


def import_renamed(checkout: Path, folder: Path):
    """The package of ``checkout`` imported as ``thesis_rbd_before`` from a copy in ``folder``."""
    target = folder / "thesis_rbd_before"
    shutil.copytree(
        checkout / "src" / "thesis_rbd", target, ignore=shutil.ignore_patterns("__pycache__")
    )
    for path in target.rglob("*.py"):
        path.write_text(re.sub(r"\bthesis_rbd\b", "thesis_rbd_before", path.read_text()))
    sys.path.insert(0, str(folder))
    return importlib.import_module("thesis_rbd_before")


def workloads() -> dict[str, list[tuple[object, np.ndarray, np.ndarray]]]:
    """Per workload, its queries as (mesh, T_a, T_b); both meshes of a query are the same."""
    mesh = tori_mesh()
    tori = [(mesh, np.eye(4), T) for T in tori_poses()]
    rng = np.random.default_rng(1)
    random, flush = [], []
    for part in PARTS.values():
        extent = part.bounds[1] - part.bounds[0]
        for _ in range(RANDOM_POSES_PER_PART):
            T = np.eye(4)
            T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
            T[:3, 3] = rng.uniform(-0.6, 0.6, 3) * extent
            random.append((part, np.eye(4), T))
        for axis in range(3):
            for gap in FLUSH_GAPS:
                for turn, seed in FLUSH_TURNS:
                    flush.append((part, *placement(part, axis, gap, turn, seed)))
    return {
        "tori path": tori,
        "CAD-like parts, random poses": random,
        "CAD-like parts, flush": flush,
    }


def _trees(package, meshes: dict) -> dict:
    """Each mesh's default tree, built by ``package`` from the same vertices and faces."""
    return {
        key: package.OBBTree(package.TriangleMesh(m.vertices, m.faces)) for key, m in meshes.items()
    }


def time_interleaved(engines: dict, queries: list, mode: str, repeats: int) -> dict:
    """Per engine, the sums over queries of the minimum and the median time of ``repeats``
    interleaved calls (ms); each engine is warmed on every query first."""
    names = list(engines)
    samples = {name: np.empty((len(queries), repeats)) for name in names}
    for package, trees in engines.values():
        for mesh, T_a, T_b in queries:
            package.collide(trees[id(mesh)], T_a, trees[id(mesh)], T_b, mode)
    for r in range(repeats):
        for i, (mesh, T_a, T_b) in enumerate(queries):
            order = names if (i + r) % 2 else names[::-1]
            for name in order:
                package, trees = engines[name]
                tree = trees[id(mesh)]
                start = time.perf_counter()
                package.collide(tree, T_a, tree, T_b, mode)
                samples[name][i, r] = time.perf_counter() - start
    return {
        name: {
            "min_ms": 1e3 * float(s.min(axis=1).sum()),
            "median_ms": 1e3 * float(np.median(s, axis=1).sum()),
        }
        for name, s in samples.items()
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("before", type=Path, help="checkout of the earlier commit")
    args = parser.parse_args(argv)
    after_source = Path(thesis_rbd.__file__).resolve().parents[2]
    with tempfile.TemporaryDirectory() as folder:
        before = import_renamed(args.before.resolve(), Path(folder))
        loads = workloads()
        meshes = {id(m): m for queries in loads.values() for (m, _, _) in queries}
        engines = {
            label: (package, _trees(package, meshes))
            for label, package in (("before", before), ("after", thesis_rbd))
        }
        results = {}
        for load, queries in loads.items():
            results[load] = {"queries": len(queries)}
            for mode in MODES:
                timing = time_interleaved(engines, queries, mode, REPEATS[mode])
                results[load][mode] = {**timing, "repeats": REPEATS[mode]}
                print(load, mode, timing, flush=True)
    write_record(
        OUT,
        {
            "before_commit": commit_of(args.before),
            "after_commit": commit_of(after_source),
            "workloads": results,
        },
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
