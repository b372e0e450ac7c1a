"""Distance along approach paths: thesis_rbd against python-fcl, pose by pose.

Three pairs a distance query meets in practice, each along a path of 40 poses: torus-capsule,
torus-torus and hull-torus. Body A stays at the identity; body B starts one bounding-box
diagonal (of the larger body) beyond touching along a fixed seeded direction and comes in,
its separation shrinking linearly to touching, while it turns by a fixed seeded rotation
(slerped over the path). "Touching" at each pose is found by bisection on our own ``collide``
along the approach direction, so the last pose is within 1e-9 of the size of contact.

Each pose is timed by alternating our ``rbd.distance`` and python-fcl's ``distance`` (its
default OBBRSS model, ``enable_nearest_points=True``) in one process; each time is the median
over the repeats, Python wrappers included on both sides.

Run as a script (``python -m validation.distance_paths``) it prints the per-pose table.
"""

from __future__ import annotations

import time

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation, Slerp

import thesis_rbd as rbd

__all__ = ["PAIRS", "approach_poses", "pair_meshes", "time_path"]

PAIRS = ("torus-capsule", "torus-torus", "hull-torus")
POSES = 40


def _torus() -> rbd.TriangleMesh:
    """A 2304-triangle torus (R = 1, r = 0.3)."""
    return rbd.shapes.torus(1.0, 0.3, 48, 24)


def _capsule() -> rbd.TriangleMesh:
    """A 1152-triangle capsule (radius 0.3, cylinder height 1)."""
    m = trimesh.creation.capsule(height=1.0, radius=0.3, count=[32, 18])
    return rbd.TriangleMesh(m.vertices, m.faces)


def _hull() -> rbd.TriangleMesh:
    """The convex hull of 200 seeded points in a 1.2 x 0.8 x 0.6 ellipsoid's shell."""
    rng = np.random.default_rng(7)
    points = rng.normal(size=(200, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    points *= (0.6, 0.4, 0.3)
    hull = trimesh.convex.convex_hull(points)
    return rbd.TriangleMesh(hull.vertices, hull.faces)


def pair_meshes(pair: str) -> tuple[rbd.TriangleMesh, rbd.TriangleMesh]:
    """Meshes (A, B) of a named pair."""
    makers = {"torus": _torus, "capsule": _capsule, "hull": _hull}
    a, b = pair.split("-")
    return makers[a](), makers[b]()


def _touching_offset(tree_a, tree_b, R, direction, far):
    """Offset along ``direction`` where B (turned by R) first touches A, by bisection."""
    pose = np.eye(4)
    pose[:3, :3] = R
    near, out = 0.0, far
    for _ in range(200):
        mid = 0.5 * (near + out)
        pose[:3, 3] = mid * direction
        if rbd.collide(tree_a, np.eye(4), tree_b, pose).colliding:
            near = mid
        else:
            out = mid
        if out - near <= 1e-9 * far:
            break
    return out


def approach_poses(mesh_a, mesh_b, seed: int = 0, count: int = POSES) -> np.ndarray:
    """(count, 4, 4) poses of B approaching A from a bounding-box diagonal to touching."""
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    turn = Slerp([0.0, 1.0], Rotation.random(2, random_state=seed))
    diagonal = max(
        np.linalg.norm(np.ptp(mesh_a.vertices, axis=0)),
        np.linalg.norm(np.ptp(mesh_b.vertices, axis=0)),
    )
    tree_a, tree_b = rbd.OBBTree(mesh_a), rbd.OBBTree(mesh_b)
    s = np.linspace(0.0, 1.0, count)
    poses = np.zeros((count, 4, 4))
    for k, (sk, R) in enumerate(zip(s, turn(s).as_matrix(), strict=True)):
        touch = _touching_offset(tree_a, tree_b, R, direction, 4.0 * diagonal)
        poses[k, :3, :3] = R
        poses[k, :3, 3] = (touch + (1.0 - sk) * diagonal) * direction
        poses[k, 3, 3] = 1.0
    return poses


def _median_time(call, repeats):
    times = np.empty(repeats)
    for i in range(repeats):
        start = time.perf_counter()
        call()
        times[i] = time.perf_counter() - start
    return float(np.median(times))


def time_path(pair: str, repeats: int = 30, seed: int = 0) -> dict:
    """Per-pose median seconds and distances of ours and python-fcl's along a pair's path.

    Returns a dict of (POSES,) arrays: ``ours``, ``fcl`` (seconds), ``ours_distance``,
    ``fcl_distance``, ``separation`` (the planned gap beyond touching, in metres) and
    ``by_hulls`` (1 where the convex hulls proved the distance: no box was tested).
    """
    from validation.fcl_adapter import fcl_model, fcl_object, fcl_transform, require_fcl

    fcl = require_fcl()
    mesh_a, mesh_b = pair_meshes(pair)
    poses = approach_poses(mesh_a, mesh_b, seed)
    tree_a, tree_b = rbd.OBBTree(mesh_a), rbd.OBBTree(mesh_b)
    object_a = fcl_object(fcl_model(mesh_a))
    object_b = fcl_object(fcl_model(mesh_b))
    identity = np.eye(4)
    keys = ("ours", "fcl", "ours_distance", "fcl_distance", "by_hulls")
    out = {key: np.empty(len(poses)) for key in keys}
    for k, pose in enumerate(poses):
        object_b.setTransform(fcl_transform(pose))

        def ours(pose=pose):
            return rbd.distance(tree_a, identity, tree_b, pose).distance

        def peer():
            request = fcl.DistanceRequest(enable_nearest_points=True)
            return fcl.distance(object_a, object_b, request, fcl.DistanceResult())

        ours()
        peer()
        ours_times, fcl_times = [], []
        for _ in range(repeats):
            ours_times.append(_median_time(ours, 1))
            fcl_times.append(_median_time(peer, 1))
        out["ours"][k] = np.median(ours_times)
        out["fcl"][k] = np.median(fcl_times)
        result = rbd.distance(tree_a, identity, tree_b, pose)
        out["ours_distance"][k] = result.distance
        out["by_hulls"][k] = result.distance > 0.0 and result.stats["bv_tests"] == 0
        out["fcl_distance"][k] = max(float(peer()), 0.0)
    diagonal = np.linalg.norm(poses[0, :3, 3] - poses[-1, :3, 3])
    out["separation"] = np.linspace(diagonal, 0.0, len(poses))
    return out


def per_call_overhead(repeats: int = 20000) -> float:
    """Median seconds of ``rbd.distance`` between two one-triangle meshes (the wrapper's cost)."""
    triangle = rbd.TriangleMesh([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    tree = rbd.OBBTree(triangle)
    pose = np.eye(4)
    pose[2, 3] = 1.0
    identity = np.eye(4)
    rbd.distance(tree, identity, tree, pose)
    start = time.perf_counter()
    for _ in range(repeats):
        rbd.distance(tree, identity, tree, pose)
    return (time.perf_counter() - start) / repeats


def main():
    for pair in PAIRS:
        r = time_path(pair)
        ratio = r["ours"] / r["fcl"]
        error = np.abs(r["ours_distance"] - r["fcl_distance"]).max()
        print(
            f"{pair}: summed {r['ours'].sum() * 1e3:.2f} ms vs fcl {r['fcl'].sum() * 1e3:.2f} ms "
            f"= {r['ours'].sum() / r['fcl'].sum():.3f}x; worst pose {ratio.max():.2f}x at "
            f"k={ratio.argmax()}; max |d - fcl| {error:.2e}"
        )
        for k in range(0, POSES, 3):
            print(
                f"  k={k:2d} sep {r['separation'][k]:.3f} d {r['ours_distance'][k]:.4f} "
                f"ours {r['ours'][k] * 1e6:7.1f} us  fcl {r['fcl'][k] * 1e6:7.1f} us"
            )
    print(f"per-call overhead {per_call_overhead() * 1e6:.2f} us")


if __name__ == "__main__":
    main()
