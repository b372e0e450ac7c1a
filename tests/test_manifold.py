"""The contacts dynamics acts on (``collision/mesh/manifold.py``, read from a detection-only World)
against an exact oracle for convex pairs (``tests/reference_manifold.py``) and python-fcl.

Two convex bodies are placed with a corner of B pushed into A along a random direction (or
with nearly parallel faces, as in a stack), then one step of a World without contact
response reports the narrow phase's contacts unchanged. The oracle's depth is exact (the
least overlap over every face normal and edge-pair axis), so the contacts must satisfy:

* every normal is a least-penetration axis: the bodies' overlap along it equals the exact
  depth (this holds whichever axis wins a tie);
* every depth equals the exact depth;
* every point lies in both bodies, at most the depth outside either.
"""

import numpy as np
import pytest
import trimesh
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from tests.reference import examples
from tests.reference_manifold import (
    convex_penetration,
    overlap_along,
    penetration_axes,
    signed_distance_to_convex,
)

EXACT = 1e-9  # of the smaller body's size: round-off, not approximation


def convex_mesh(kind, rng):
    if kind == "box":
        return rbd.shapes.box(rng.uniform(0.2, 2.0, 3))
    if kind == "icosphere":
        return rbd.shapes.icosphere(rng.uniform(0.2, 1.0), 1)
    points = rng.normal(size=(int(rng.integers(8, 30)), 3)) * rng.uniform(0.3, 1.0, 3)
    hull = trimesh.convex.convex_hull(points)
    return rbd.TriangleMesh(hull.vertices, hull.faces)


def placed_pair(seed, kind_a, kind_b, depth_fraction):
    """Meshes, poses (centre of mass, quaternion) and world vertices of two touching bodies.

    A's centre of mass is at the origin; B's corner farthest along a random direction n is
    put ``depth_fraction`` of the smaller size into A, past A's corner farthest along -n;
    half the time B also slides sideways. In 40 % of the cases B is turned as A, up to 1e-3
    rad, so that faces are (nearly) parallel, as in a stack.
    """
    rng = np.random.default_rng(seed)
    meshes = convex_mesh(kind_a, rng), convex_mesh(kind_b, rng)
    qa = Rotation.random(random_state=rng)
    qb = Rotation.random(random_state=rng)
    if rng.random() < 0.4:
        qb = qa * Rotation.from_rotvec(rng.normal(size=3) * rng.choice([0.0, 1e-6, 1e-3]))
    local = [m.vertices - rbd.mass_properties(m).center_of_mass for m in meshes]
    VA, VB = qa.apply(local[0]), qb.apply(local[1])
    size = min(np.ptp(VA, axis=0).min(), np.ptp(VB, axis=0).min())
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    slide = rng.uniform(-0.3, 0.3, 3) * size * (rng.random() < 0.5)
    xb = VA[np.argmin(VA @ n)] - VB[np.argmax(VB @ n)] + depth_fraction * size * n + slide
    return {
        "meshes": meshes,
        "orientations": (qa.as_quat(), qb.as_quat()),
        "positions": (np.zeros(3), xb),
        "vertices": (VA, VB + xb),
        "size": size,
    }


def manifold(pair):
    """The mesh path's contacts of the pair (manifold.py; the convex path has its own oracle
    tests in test_convex_contacts.py), normals from B towards A."""
    world = rbd.World(contact_response=False, narrow_phase="mesh")
    for mesh, position, orientation in zip(
        pair["meshes"], pair["positions"], pair["orientations"], strict=True
    ):
        world.add_body(mesh, mass=1.0, position=position, orientation=orientation)
    world.step()
    contacts = world.contacts
    towards_a = np.where(contacts["body_a"] == 0, 1.0, -1.0)[:, None]
    return contacts["points"], contacts["normals"] * towards_a, contacts["depths"]


def errors(pair):
    """Oracle depth, and the contacts' worst errors as fractions of the size: normal (overlap
    along it beyond the exact depth), depth, and points outside either body beyond it."""
    (A, B), (VA, VB), size = pair["meshes"], pair["vertices"], pair["size"]
    _, depth = convex_penetration(VA, A.faces, VB, B.faces)
    points, normals, depths = manifold(pair)
    if len(depths) == 0:
        return depth, np.inf, np.inf, np.inf
    outside = max(
        signed_distance_to_convex(points, VA, A.faces).max(),
        signed_distance_to_convex(points, VB, B.faces).max(),
    )
    return (
        depth,
        np.abs(overlap_along(normals, VA, VB) - depth).max() / size,
        np.abs(depths - depth).max() / size,
        (outside - depth) / size,
    )


@settings(max_examples=examples(40))
@given(seed=st.integers(0, 2**32 - 1), depth_fraction=st.floats(1e-3, 0.02))
def test_shallow_box_contacts_lie_on_the_exact_least_penetration_axis(seed, depth_fraction):
    pair = placed_pair(seed, "box", "box", depth_fraction)
    depth, normal_error, depth_error, outside = errors(pair)
    # shallow, as in a stack: a sideways slide can push a corner a fifth of the size in,
    # where the region's axis is a known miss (test_known_misses_of_the_region_axis)
    assume(1e-6 * pair["size"] < depth <= 0.05 * pair["size"])
    assert normal_error <= EXACT
    assert depth_error <= EXACT
    assert outside <= EXACT


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_deep_box_contacts_are_exact_too(seed):
    """Boxes a fifth of their size into each other: still the exact axis and depth."""
    pair = placed_pair(seed, "box", "box", 0.2)
    depth, normal_error, depth_error, outside = errors(pair)
    assert depth > 1e-3 * pair["size"]
    assert max(normal_error, depth_error, outside) <= EXACT


# Cases the oracle found where the manifold's axis is not a least-penetration axis of the
# bodies; the comment gives the measured normal and depth errors (fractions of the size).
MANIFOLD_MISSES = pytest.mark.xfail(
    strict=True,
    reason="manifold.py takes a region's axis from the overlap of the region's own faces only: "
    "where a corner of a random hull or an icosphere meets another corner, and where "
    "icospheres or boxes are pushed deep, that is not the bodies' least-penetration axis (issue 11 "
    "gives convex pairs an exact separating-axis test)",
)


@MANIFOLD_MISSES
@pytest.mark.parametrize(
    "seed, kinds, depth_fraction",
    [
        (20, ("hull", "hull"), 0.01),  # normal 0.13, depth 1e-4
        (23, ("hull", "icosphere"), 0.005),  # normal 0.077, depth 6e-4
        (33, ("box", "hull"), 0.01),  # normal 0.002
        (72313494, ("box", "icosphere"), 0.015625),  # normal 0.0065
        (5408, ("box", "box"), 0.015625),  # slid 21 % deep: normal and depth 0.0078
        (8, ("icosphere", "icosphere"), 0.001),  # normal and depth 1e-4 (depth 1e-3)
        (16, ("icosphere", "icosphere"), 0.02),  # normal and depth 0.03
        (0, ("icosphere", "icosphere"), 0.3),  # normal 0.028, depth 0.012
    ],
)
def test_known_misses_of_the_region_axis(seed, kinds, depth_fraction):
    pair = placed_pair(seed, *kinds, depth_fraction)
    depth, normal_error, depth_error, outside = errors(pair)
    assert depth > 1e-6 * pair["size"]
    assert max(normal_error, depth_error, outside) <= EXACT


@settings(max_examples=examples(30))
@given(seed=st.integers(0, 2**32 - 1), depth_fraction=st.floats(1e-3, 0.1))
@example(seed=2706962, depth_fraction=0.0625)  # nearly parallel faces: fcl takes the other
def test_box_face_contacts_agree_with_fcl_boxes(seed, depth_fraction):
    """python-fcl's box-box contact (ODE's dBoxBox) is exact where the least-penetration axis
    is a face normal (it approximates edge-edge contacts), so only those cases are compared:
    fcl's deepest point has our depth, and its normal (from A towards B) reversed is a
    least-penetration axis as ours is. Where faces of both boxes are nearly parallel, their
    normals nearly tie and fcl may pick either: its normal is then held to the overlap of
    the worse of the tied face axes."""
    from validation.fcl_adapter import quat_xyzw_to_wxyz, require_fcl

    fcl = require_fcl()
    pair = placed_pair(seed, "box", "box", depth_fraction)
    (A, B), (VA, VB), size = pair["meshes"], pair["vertices"], pair["size"]
    axes, overlaps = penetration_axes(VA, A.faces, VB, B.faces)
    axis, depth = axes[np.argmin(overlaps)], overlaps.min()
    assume(depth > 1e-6 * size)
    face_normals = np.concatenate(
        [Rotation.from_quat(q).apply(np.eye(3)) for q in pair["orientations"]]
    )
    assume(np.abs(face_normals @ axis).max() > 1 - 1e-12)
    # face axes within 0.01 rad of the best one tie with it (nearly parallel faces)
    on_faces = np.abs(axes @ face_normals.T).max(axis=1) > 1 - 1e-12
    tied = on_faces & (axes @ axis > np.cos(1e-2))
    objects = [
        fcl.CollisionObject(
            fcl.Box(*np.ptp(mesh.vertices, axis=0)),
            fcl.Transform(quat_xyzw_to_wxyz(q), V.mean(axis=0)),
        )
        for mesh, q, V in zip(pair["meshes"], pair["orientations"], pair["vertices"], strict=True)
    ]
    result = fcl.CollisionResult()
    fcl.collide(*objects, fcl.CollisionRequest(enable_contact=True, num_max_contacts=8), result)
    assert result.contacts
    fcl_depth = max(c.penetration_depth for c in result.contacts)
    fcl_normal = -np.asarray(result.contacts[0].normal)
    _, normals, depths = manifold(pair)
    assert depths.max() == pytest.approx(fcl_depth, abs=EXACT * size)
    assert np.abs(overlap_along(normals, VA, VB) - depth).max() <= EXACT * size
    assert overlap_along(fcl_normal, VA, VB)[0] <= overlaps[tied].max() + EXACT * size
