"""Benchmarks of the queries beyond overlap (issue 15) against their peers, in the same run.

Scenes (``validation/tori.py``): the tori demo path (two 5000-triangle tori, B moving through
A in 200 poses, about a third of them apart) and a separated variant of it (B lifted by 0.8
along z: the rings pass over each other, most poses apart by up to 0.6). Each benchmark of a
group is one sweep or one batch; the peer of the group carries ``extra_info["peer"]``
(:mod:`validation.benchjson`), and both sides include their Python wrappers (ours: the public
function with its input checks; python-fcl: ``setTransform``, request and result objects and
the query):

* "distance, tori path" and "distance, lifted tori path": :func:`thesis_rbd.distance` per
  pose against ``fcl.distance`` (OBBRSS ``BVHModel``, ``enable_nearest_points``);
* "collide_batch, tori path": one :func:`thesis_rbd.collide_batch` call over the 200 poses
  against a python-fcl loop (``num_max_contacts=1``); and the same over 10000 random poses of
  B (uniform rotations, centres uniform in a cube of half-side 4 m or 10 m around A: 7 % and
  0.4 % of them touching, most missing at the root boxes, as a sampling motion planner's
  queries do), where the per-call cost a batch saves is most of the work; and over the tori
  path ten times finer (2000 poses), where a pose's intersecting pair mostly still
  intersects at the next, as on a planner's finely checked motion. The batch runs on numba's
  threads (all cores by default; the report states how many), python-fcl on one;
* "first, tori path": :func:`thesis_rbd.collide` in "first" mode per pose against the same
  python-fcl loop (the separated poses included);
* "ray_cast, 4000 rays": :func:`thesis_rbd.ray_cast` of 4000 rays at a 2000-triangle torus
  against trimesh's pure-NumPy ``RayMeshIntersector.intersects_location`` (first hits);
* "overhead, first, apart at the root" and "overhead, distance, single triangles": one call
  on two tori 10 apart (one box test) and on two single triangles 10 apart, against the same
  python-fcl call: the per-call cost of the wrappers.

Run with ``pytest validation/bench_queries.py --benchmark-enable``.
"""

from __future__ import annotations

import numpy as np
import pytest

import thesis_rbd as rbd
from validation.fcl_adapter import fcl_model, fcl_object, fcl_transform, require_fcl
from validation.tori import tori_mesh, tori_poses

LIFT = 0.8  # m along z: the separated variant of the tori path
RAY_COUNT = 4000
FINE_POSE_COUNT = 2000  # the tori path ten times finer, as a planner checks one motion


def lifted_tori_poses() -> np.ndarray:
    """The tori path with B lifted by ``LIFT``: the rings pass over each other."""
    poses = tori_poses()
    poses[:, 2, 3] += LIFT
    return poses


class Scene:
    """The tori path for both libraries: our tree and poses, python-fcl's objects."""

    def __init__(self, poses) -> None:
        self.fcl = require_fcl()
        self.mesh = tori_mesh()
        self.tree = rbd.OBBTree(self.mesh)
        self.identity = np.eye(4)
        self.poses = poses
        model = fcl_model(self.mesh)
        self.fcl_a = fcl_object(model)
        self.fcl_b = fcl_object(model)
        self.fcl_poses = [fcl_transform(P) for P in poses]

    def distances(self) -> np.ndarray:
        tree, identity = self.tree, self.identity
        return np.array([rbd.distance(tree, identity, tree, P).distance for P in self.poses])

    def fcl_distances(self) -> np.ndarray:
        fcl = self.fcl
        out = np.empty(len(self.fcl_poses))
        for k, transform in enumerate(self.fcl_poses):
            self.fcl_b.setTransform(transform)
            request = fcl.DistanceRequest(enable_nearest_points=True)
            out[k] = fcl.distance(self.fcl_a, self.fcl_b, request, fcl.DistanceResult())
        return out

    def firsts(self) -> int:
        tree, identity = self.tree, self.identity
        return sum(rbd.collide(tree, identity, tree, P).colliding for P in self.poses)

    def batch(self) -> int:
        return int(rbd.collide_batch(self.tree, self.identity, self.tree, self.poses).sum())

    def fcl_firsts(self) -> int:
        fcl = self.fcl
        hits = 0
        for transform in self.fcl_poses:
            self.fcl_b.setTransform(transform)
            request = fcl.CollisionRequest(num_max_contacts=1)
            hits += fcl.collide(self.fcl_a, self.fcl_b, request, fcl.CollisionResult())
        return hits


@pytest.fixture(scope="module")
def path():
    scene = Scene(tori_poses())
    scene.distances()  # compile (or load) outside the timings
    scene.batch()
    scene.firsts()
    return scene


@pytest.fixture(scope="module")
def lifted():
    scene = Scene(lifted_tori_poses())
    scene.distances()
    return scene


def _sweep(benchmark, group, function, rounds, peer=None, **info):
    benchmark.group = group
    benchmark.extra_info.update(info)
    if peer:
        benchmark.extra_info["peer"] = peer
    return benchmark.pedantic(function, rounds=rounds, iterations=1, warmup_rounds=1)


def test_distance_path(benchmark, path):
    found = _sweep(benchmark, "distance, tori path", path.distances, 5, triangles=5000)
    assert np.count_nonzero(found) > 50


def test_fcl_distance_path(benchmark, path):
    found = _sweep(
        benchmark, "distance, tori path", path.fcl_distances, 5, "python-fcl", triangles=5000
    )
    assert np.count_nonzero(found > 0) > 50


def test_distance_lifted_path(benchmark, lifted):
    found = _sweep(benchmark, "distance, lifted tori path", lifted.distances, 5, triangles=5000)
    assert np.count_nonzero(found) > 30


def test_fcl_distance_lifted_path(benchmark, lifted):
    group = "distance, lifted tori path"
    _sweep(benchmark, group, lifted.fcl_distances, 5, "python-fcl", triangles=5000)


def test_collide_batch_path(benchmark, path):
    hits = _sweep(benchmark, "collide_batch, tori path", path.batch, 10, triangles=5000)
    assert 100 < hits < 200


def test_fcl_collide_loop_path(benchmark, path):
    _sweep(benchmark, "collide_batch, tori path", path.fcl_firsts, 10, "python-fcl", triangles=5000)


@pytest.fixture(scope="module")
def fine_path():
    scene = Scene(tori_poses(FINE_POSE_COUNT))
    scene.batch()
    return scene


def test_collide_batch_fine_path(benchmark, fine_path):
    group = f"collide_batch, tori path at {FINE_POSE_COUNT} poses"
    hits = _sweep(benchmark, group, fine_path.batch, 5, triangles=5000)
    assert FINE_POSE_COUNT // 2 < hits < FINE_POSE_COUNT


def test_fcl_collide_loop_fine_path(benchmark, fine_path):
    group = f"collide_batch, tori path at {FINE_POSE_COUNT} poses"
    _sweep(benchmark, group, fine_path.fcl_firsts, 3, "python-fcl", triangles=5000)


def test_first_path(benchmark, path):
    hits = _sweep(benchmark, "first, tori path", path.firsts, 10, triangles=5000)
    assert 100 < hits < 200


def test_fcl_first_path(benchmark, path):
    _sweep(benchmark, "first, tori path", path.fcl_firsts, 10, "python-fcl", triangles=5000)


def random_poses(count: int, spread: float, seed: int = 0) -> np.ndarray:
    """``count`` poses: uniform rotations, centres uniform in [-spread, spread]^3."""
    from scipy.spatial.transform import Rotation

    poses = np.zeros((count, 4, 4))
    poses[:, :3, :3] = Rotation.random(count, random_state=seed).as_matrix()
    poses[:, :3, 3] = np.random.default_rng(seed).uniform(-spread, spread, size=(count, 3))
    poses[:, 3, 3] = 1.0
    return poses


@pytest.fixture(scope="module", params=[4.0, 10.0], ids=["within 4 m", "within 10 m"])
def cloud(request):
    scene = Scene(random_poses(10000, request.param))
    scene.batch()
    return scene


def test_collide_batch_cloud(benchmark, cloud):
    group = f"collide_batch, 10000 poses within {cloud.poses[:, :3, 3].max():.0f} m"
    hits = _sweep(benchmark, group, cloud.batch, 10, triangles=5000)
    assert 0 < hits < 2000


def test_fcl_collide_loop_cloud(benchmark, cloud):
    group = f"collide_batch, 10000 poses within {cloud.poses[:, :3, 3].max():.0f} m"
    _sweep(benchmark, group, cloud.fcl_firsts, 3, "python-fcl", triangles=5000)


@pytest.fixture(scope="module")
def rays():
    """4000 rays from above at a 2000-triangle torus (about 40 % hit), our tree, trimesh's
    intersector (its acceleration tree built outside the timings, as ours)."""
    from trimesh.ray.ray_triangle import RayMeshIntersector

    mesh = rbd.shapes.torus(1.0, 0.3, 40, 25)
    rng = np.random.default_rng(0)
    origins = rng.normal(size=(RAY_COUNT, 3)) * 0.5 + (0.0, 0.0, 3.0)
    directions = rng.normal(size=(RAY_COUNT, 3)) * 0.3 + (0.0, 0.0, -1.0)
    tree = rbd.OBBTree(mesh)
    rbd.ray_cast(tree, np.eye(4), origins, directions)
    intersector = RayMeshIntersector(mesh.to_trimesh())
    intersector.intersects_location(origins[:10], directions[:10], multiple_hits=False)
    return tree, intersector, origins, directions


def test_ray_cast(benchmark, rays):
    tree, _, origins, directions = rays

    def cast():
        return rbd.ray_cast(tree, np.eye(4), origins, directions)

    hits = _sweep(benchmark, "ray_cast, 4000 rays", cast, 10, triangles=2000)
    assert 0.2 * RAY_COUNT < hits.hit.sum() < 0.8 * RAY_COUNT


def test_trimesh_rays(benchmark, rays):
    _, intersector, origins, directions = rays

    def cast():
        return intersector.intersects_location(origins, directions, multiple_hits=False)

    _sweep(benchmark, "ray_cast, 4000 rays", cast, 3, "trimesh", triangles=2000)


@pytest.fixture(scope="module")
def apart():
    """Two tori 10 apart (separated at the root boxes) and two single triangles 10 apart, for
    both libraries."""
    fcl = require_fcl()
    torus = rbd.OBBTree(tori_mesh())
    triangle = rbd.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    single = rbd.OBBTree(triangle)
    far = np.eye(4)
    far[0, 3] = 10.0
    identity = np.eye(4)
    fcl_tori = (fcl_object(fcl_model(torus.mesh)), fcl_object(fcl_model(torus.mesh), far))
    fcl_single = (fcl_object(fcl_model(triangle)), fcl_object(fcl_model(triangle), far))
    assert not rbd.collide(torus, identity, torus, far).colliding
    assert rbd.distance(single, identity, single, far).distance == pytest.approx(9.0)
    return fcl, torus, single, identity, far, fcl_tori, fcl_single


def test_overhead_first(benchmark, apart):
    _, torus, _, identity, far, _, _ = apart
    benchmark.group = "overhead, first, apart at the root"
    benchmark.extra_info["triangles"] = 5000
    benchmark(rbd.collide, torus, identity, torus, far)


def test_fcl_overhead_first(benchmark, apart):
    fcl, _, _, _, _, (a, b), _ = apart
    benchmark.group = "overhead, first, apart at the root"
    benchmark.extra_info.update(peer="python-fcl", triangles=5000)

    def query():
        return fcl.collide(a, b, fcl.CollisionRequest(num_max_contacts=1), fcl.CollisionResult())

    benchmark(query)


def test_overhead_distance(benchmark, apart):
    _, _, single, identity, far, _, _ = apart
    benchmark.group = "overhead, distance, single triangles"
    benchmark.extra_info["triangles"] = 1
    benchmark(rbd.distance, single, identity, single, far)


def test_fcl_overhead_distance(benchmark, apart):
    fcl, _, _, _, _, _, (a, b) = apart
    benchmark.group = "overhead, distance, single triangles"
    benchmark.extra_info.update(peer="python-fcl", triangles=1)

    def query():
        request = fcl.DistanceRequest(enable_nearest_points=True)
        return fcl.distance(a, b, request, fcl.DistanceResult())

    benchmark(query)
