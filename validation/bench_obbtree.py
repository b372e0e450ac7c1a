"""OBBTree narrow-phase benchmarks (issue 3): the thesis demo of 5.4.1 against python-fcl.

Scene (``validation/tori.py``): two tori of 5000 triangles (R = 1, r = 0.3,
50 x 50 sections); A fixed at the identity, B standing in the xz-plane, wobbling while it
slides along x from -3 to +3 through A in 200 poses. One *sweep* is one query per pose.

Run with ``pytest validation/bench_obbtree.py --benchmark-enable``: each benchmark times one
sweep, ours per variant and python-fcl's for the same mode (``BVHModel`` of OBBRSS boxes,
``CollisionRequest`` with ``num_max_contacts`` 1 for "first" and 100000 for "all") as a peer
benchmark of the same group (``extra_info["peer"]``), in the same run, so the validation
campaign reads the ratios from the JSON (``validation/benchjson.py``). Both sides include their
Python wrapper (ours: ``collide`` with input checks; fcl: ``setTransform``, request and result
objects, ``fcl.collide``). The scaling benchmarks sweep every fourth pose with tori of 512 to
about 10k triangles (same radii, so the same poses interlock them), ours (default tree) and
fcl's, in "all" mode.

``python -m validation.bench_obbtree`` prints the summary table (medians over repeated,
interleaved sweeps): build time, bytes per triangle, all-pairs rate, first-contact time and
contacts rate per variant (leaf/leafless x triangle/hull fit x float64/float32), python-fcl
alongside, and each variant's agreement with fcl's pair sets.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import pytest

import thesis_rbd as rbd
from validation.fcl_adapter import fcl_model, fcl_object, fcl_transform, require_fcl
from validation.tori import tori_mesh, tori_poses

VARIANTS = {
    "leafless/triangles/f64": dict(leafless=True, fit="triangles", dtype=np.float64),
    "leaf/triangles/f64": dict(leafless=False, fit="triangles", dtype=np.float64),
    "leafless/hull/f64": dict(leafless=True, fit="hull", dtype=np.float64),
    "leaf/hull/f64": dict(leafless=False, fit="hull", dtype=np.float64),
    "leafless/triangles/f32": dict(leafless=True, fit="triangles", dtype=np.float32),
    "leaf/triangles/f32": dict(leafless=False, fit="triangles", dtype=np.float32),
}
FCL_MAX_CONTACTS = {"first": 1, "all": 100000, "contacts": 100000}


class Demo:
    """The tori scene, its trees (built on demand) and python-fcl's objects."""

    def __init__(self) -> None:
        self.mesh = tori_mesh()
        self.poses = list(tori_poses())
        self.identity = np.eye(4)
        self._trees: dict[str, rbd.OBBTree] = {}
        fcl = require_fcl()
        self.fcl = fcl
        self.fcl_model = fcl_model(self.mesh)
        self.fcl_a = fcl_object(self.fcl_model)
        self.fcl_b = fcl_object(self.fcl_model)
        self.fcl_poses = [fcl_transform(P) for P in self.poses]

    def tree(self, variant: str) -> rbd.OBBTree:
        if variant not in self._trees:
            self._trees[variant] = rbd.OBBTree(self.mesh, **VARIANTS[variant])
        return self._trees[variant]

    def sweep(self, variant: str, mode: str) -> tuple[float, int, np.ndarray]:
        """Our sweep: (seconds, pairs found, per-pose seconds)."""
        tree = self.tree(variant)
        I = self.identity
        per_pose = np.empty(len(self.poses))
        pairs = 0
        clock = time.perf_counter
        for k, P in enumerate(self.poses):
            t0 = clock()
            res = rbd.collide(tree, I, tree, P, mode=mode)
            per_pose[k] = clock() - t0
            pairs += len(res.pairs)
        return float(per_pose.sum()), pairs, per_pose

    def fcl_sweep(self, mode: str) -> tuple[float, int, np.ndarray]:
        """python-fcl's sweep: (seconds, contacts reported, per-pose seconds).

        "contacts" asks fcl for its contact points, normals and depths (``enable_contact``).
        """
        fcl = self.fcl
        n = FCL_MAX_CONTACTS[mode]
        per_pose = np.empty(len(self.poses))
        pairs = 0
        clock = time.perf_counter
        for k, tf in enumerate(self.fcl_poses):
            t0 = clock()
            self.fcl_b.setTransform(tf)
            request = fcl.CollisionRequest(num_max_contacts=n, enable_contact=mode == "contacts")
            result = fcl.CollisionResult()
            fcl.collide(self.fcl_a, self.fcl_b, request, result)
            per_pose[k] = clock() - t0
            pairs += len(result.contacts)
        return float(per_pose.sum()), pairs, per_pose

    def fcl_pairs(self, k: int) -> np.ndarray:
        from validation.fcl_adapter import fcl_collide

        self.fcl_b.setTransform(self.fcl_poses[k])
        _, pairs = fcl_collide(self.fcl_a, self.fcl_b)
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


@pytest.fixture(scope="module")
def demo():
    d = Demo()
    for variant in VARIANTS:  # compile and build outside the timings
        for mode in ("first", "all", "contacts"):
            rbd.collide(d.tree(variant), d.identity, d.tree(variant), d.poses[100], mode=mode)
    return d


def _sweep(benchmark, demo, variant, mode, rounds=5):
    benchmark.group = f"tori demo, {mode}"
    result = benchmark.pedantic(lambda: demo.sweep(variant, mode), rounds=rounds, iterations=1)
    _, pairs, _ = result
    benchmark.extra_info.update(variant=variant, mode=mode, pairs=pairs, triangles=len(demo.mesh))
    return pairs


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_all_pairs(benchmark, demo, variant):
    pairs = _sweep(benchmark, demo, variant, "all")
    assert pairs > 30000


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_first_contact(benchmark, demo, variant):
    pairs = _sweep(benchmark, demo, variant, "first", rounds=10)
    assert 100 < pairs < 200


@pytest.mark.parametrize("variant", ["leafless/triangles/f64", "leaf/triangles/f64"])
def test_contacts(benchmark, demo, variant):
    _sweep(benchmark, demo, variant, "contacts")


@pytest.mark.parametrize("mode", ["all", "first", "contacts"])
def test_fcl_sweep(benchmark, demo, mode):
    benchmark.group = f"tori demo, {mode}"
    benchmark.extra_info.update(peer="python-fcl", mode=mode, triangles=len(demo.mesh))
    result = benchmark.pedantic(
        lambda: demo.fcl_sweep(mode), rounds=10 if mode == "first" else 5, iterations=1
    )
    benchmark.extra_info["pairs"] = result[1]


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_build(benchmark, demo, variant):
    benchmark.group = "tori demo, build"
    benchmark.extra_info.update(variant=variant, triangles=len(demo.mesh))
    benchmark.pedantic(lambda: rbd.OBBTree(demo.mesh, **VARIANTS[variant]), rounds=5, iterations=1)


def test_fcl_build(benchmark, demo):
    benchmark.group = "tori demo, build"
    benchmark.extra_info.update(peer="python-fcl", triangles=len(demo.mesh))
    benchmark.pedantic(lambda: fcl_model(demo.mesh), rounds=5, iterations=1)


SCALING_SECTIONS = (16, 32, 50, 72)  # 512, 2048, 5000, 10368 triangles


@pytest.mark.parametrize("sections", SCALING_SECTIONS)
@pytest.mark.parametrize("engine", ["ours", "fcl"])
def test_scaling_all_pairs(benchmark, demo, engine, sections):
    """Every fourth pose of the demo in "all" mode with tori of 2 sections^2 triangles."""
    mesh = rbd.shapes.torus(1.0, 0.3, sections, sections)
    poses = demo.poses[::4]
    benchmark.group = f"scaling, {len(mesh)} triangles"
    benchmark.extra_info.update(triangles=len(mesh), mode="all")
    if engine == "fcl":
        benchmark.extra_info["peer"] = "python-fcl"
        fcl = demo.fcl
        a, b = fcl_object(fcl_model(mesh)), fcl_object(fcl_model(mesh))
        transforms = [fcl_transform(P) for P in poses]

        def sweep():
            for tf in transforms:
                b.setTransform(tf)
                result = fcl.CollisionResult()
                fcl.collide(a, b, fcl.CollisionRequest(num_max_contacts=100000), result)

    else:
        tree = rbd.OBBTree(mesh)
        benchmark.extra_info["variant"] = "leafless/triangles/f64"

        def sweep():
            for P in poses:
                rbd.collide(tree, demo.identity, tree, P, mode="all")

        sweep()  # compile outside the timing
    benchmark.pedantic(sweep, rounds=5, iterations=1)


def test_pairs_agree_with_fcl(demo):
    for k in range(0, len(demo.poses), 5):
        expected = demo.fcl_pairs(k)
        for variant in VARIANTS:
            res = rbd.collide(
                demo.tree(variant), demo.identity, demo.tree(variant), demo.poses[k], mode="all"
            )
            np.testing.assert_array_equal(res.pairs, expected)


# ---------------------------------------------------------------------- summary table
def _median_time(fn, repeats: int) -> float:
    return float(np.median([_timed(fn) for _ in range(repeats)]))


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def summary(repeats: int = 5) -> str:
    """Markdown table of the demo benchmark (medians over ``repeats`` interleaved sweeps)."""
    d = Demo()
    rows = []
    for variant in VARIANTS:
        _timed(lambda v=variant: rbd.OBBTree(d.mesh, **VARIANTS[v]))  # compile
        build = _median_time(lambda v=variant: rbd.OBBTree(d.mesh, **VARIANTS[v]), repeats)
        tree = d.tree(variant)
        for mode in ("first", "all", "contacts"):
            rbd.collide(tree, d.identity, tree, d.poses[100], mode=mode)
        stats = {}
        for mode in ("all", "first", "contacts"):
            ours, theirs = [], []
            for _ in range(repeats):
                ours.append(d.sweep(variant, mode))
                theirs.append(d.fcl_sweep(mode))
            stats[mode] = (ours, theirs)
        agree = sum(
            np.array_equal(rbd.collide(tree, d.identity, tree, P, mode="all").pairs, d.fcl_pairs(k))
            for k, P in enumerate(d.poses)
        )
        rows.append((variant, build, tree, stats, agree))

    def rate(sweeps):
        return float(np.median([pairs / (sec * 1e3) for sec, pairs, _ in sweeps]))

    def first_median_us(sweeps):
        return float(np.median([np.median(per) for _, _, per in sweeps])) * 1e6

    def total_ms(sweeps):
        return float(np.median([sec for sec, _, _ in sweeps])) * 1e3

    fcl_build = _median_time(lambda: fcl_model(d.mesh), repeats)
    lines = [
        f"Two tori of {len(d.mesh)} triangles, {len(d.poses)} poses; medians of {repeats} "
        "interleaved sweeps. Rates: intersecting pairs per ms of query time.",
        "",
        "| variant | build ms | bytes/tri | all: pairs/ms (fcl) | first: median us (fcl) "
        "| first: sweep ms (fcl) | contacts: pairs/ms (fcl) | agrees with fcl |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for variant, build, tree, stats, agree in rows:
        all_ours, all_fcl = stats["all"]
        first_ours, first_fcl = stats["first"]
        contacts_ours, contacts_fcl = stats["contacts"]
        lines.append(
            f"| {variant} | {build * 1e3:.1f} | {tree.nbytes / len(d.mesh):.0f} "
            f"| {rate(all_ours):.0f} ({rate(all_fcl):.0f}) "
            f"| {first_median_us(first_ours):.1f} ({first_median_us(first_fcl):.1f}) "
            f"| {total_ms(first_ours):.2f} ({total_ms(first_fcl):.2f}) "
            f"| {rate(contacts_ours):.0f} ({rate(contacts_fcl):.0f}) | {agree}/{len(d.poses)} |"
        )
    lines.append(
        f"| python-fcl (OBBRSS) | {fcl_build * 1e3:.1f} | n/a | see rows | see rows | see rows "
        "| - | - |"
    )
    return "\n".join(lines)


if __name__ == "__main__":
    print(summary(int(sys.argv[1]) if len(sys.argv) > 1 else 5))
