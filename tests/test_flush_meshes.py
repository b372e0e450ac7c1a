"""CAD-like parts against copies of themselves: flush, overlapping by 1e-12, apart by a hair.

Real scenes put parts face to face: stacked, packed, side by side. Each part here (flat faces:
a box, a thin plate, an L-bracket, a hexagonal prism, a cylinder, a plate with a sliver
triangle, a box carrying zero-area faces) meets a copy of itself
placed flush against one of its faces (shifted sideways so the faces overlap in part), pushed
1e-12 of its size into it, or pulled 1e-12 to 1e-3 of its size away; the pair is left as
placed, or turned as a whole by a random rotation (so that B's corners in A's frame carry
rounding), or B is turned about the contact normal. ``collide``'s yes/no and "all" pair set
must equal the exact oracle's on the coordinates the kernel decides on, for both tree
variants, and a separated copy must never collide.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference_exact import exact_pairs, kernel_frame_corners, tri_tri_exact
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.mesh.packed import corner_moved, layout
from thesis_rbd.collision.queries.collide import _relative_pose
from validation.cad_parts import PARTS, placement

# Parts that certainly meet their copy when pushed in: planar faces at every extreme, still
# overlapping when the copy is shifted sideways or turned about the face's centre (the prism
# and the cylinder meet their copies edge to edge, the L-bracket's face is off-centre).
FACE_TO_FACE = ("box", "plate")
GAPS = (0.0, -1e-12, 1e-12, 1e-9, 1e-6, 1e-3)  # of the part's size; < 0 overlaps
TURNS = [("none", 0), ("whole", 7), ("whole", 8), ("whole", 9), ("about_normal", 0)]

TREES = {
    name: (rbd.OBBTree(mesh), rbd.OBBTree(mesh, leafless=False)) for name, mesh in PARTS.items()
}


@pytest.mark.parametrize(("turn", "seed"), TURNS)
@pytest.mark.parametrize("name", sorted(PARTS))
def test_copies_flush_overlapping_and_apart_equal_the_exact_oracle(name, turn, seed):
    mesh = PARTS[name]
    checked = 0
    colliding = 0
    for axis in range(3):
        for gap in GAPS:
            T_a, T_b = placement(mesh, axis, gap, turn, seed)
            want = exact_pairs(mesh, T_a, mesh, T_b)
            if gap < 0 and name in FACE_TO_FACE:
                assert len(want) > 0, "overlapping by 1e-12 of the size is a collision"
            if gap > 0:
                assert len(want) == 0, "1e-12 of the size is far above rounding"
            for tree in TREES[name]:
                got = rbd.collide(tree, T_a, tree, T_b, mode="all").pairs
                np.testing.assert_array_equal(got, want, err_msg=f"{axis=} {gap=}")
                first = rbd.collide(tree, T_a, tree, T_b, mode="first")
                assert first.colliding == (len(want) > 0), f"{axis=} {gap=}"
                if first.colliding:
                    fa, fb = first.pairs[0]
                    assert (fa, fb) in set(map(tuple, want))
                checked += 1
            colliding += len(want) > 0
    assert checked == 2 * 3 * len(GAPS)
    assert colliding > 0  # the flush and pushed-in placements do meet somewhere


@pytest.mark.parametrize("name", ["box", "L_bracket"])
def test_coincident_copies_touch_everywhere_as_the_oracle_says(name):
    mesh = PARTS[name]
    turned = np.eye(4)
    turned[:3, :3] = Rotation.random(random_state=np.random.default_rng(3)).as_matrix()
    for T in (np.eye(4), turned):
        want = exact_pairs(mesh, T, mesh, T)
        if T is not turned:
            assert len(want) >= len(mesh.faces)  # at least every face with itself
        for tree in TREES[name]:
            np.testing.assert_array_equal(rbd.collide(tree, T, tree, T, mode="all").pairs, want)


def test_oracle_sees_the_kernels_coordinates_bitwise():
    """The oracle's float transform is the kernel's, operation for operation."""
    mesh = PARTS["hex_prism"]
    T_a, T_b = placement(mesh, 2, 0.0, "whole", 7)
    Rab, tab = _relative_pose(T_a, T_b)
    M = tuple(float(x) for x in Rab.ravel())
    t = (float(tab[0]), float(tab[1]), float(tab[2]))
    P = rbd.OBBTree(mesh)._packed
    L = layout(P)
    ours = np.array(
        [[corner_moved(P, L, f, k, M, t) for k in range(3)] for f in range(len(mesh.faces))]
    )
    assert np.array_equal(ours, kernel_frame_corners(mesh, T_a, T_b))


def test_flush_faces_touch_under_exact_placement():
    """Sanity of the oracle on its own: a box face on a box face touches, 1 ulp apart not."""
    P = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    Q = np.array([[0.25, 0.25, 0], [2, 0.25, 0], [0.25, 2, 0]])
    assert tri_tri_exact(P, Q)
    Q[:, 2] = np.nextafter(0.0, 1.0)
    assert not tri_tri_exact(P, Q)


def _overlap_corners(a, b):
    """Corners of the overlap of two convex polygons a, b (k, 2) (counter-clockwise): corners
    of each inside the other, and crossings of their edges (plain NumPy, by enumeration)."""

    def inside(x, poly):
        edges = np.roll(poly, -1, axis=0) - poly
        to_x = x - poly
        return np.all(edges[:, 0] * to_x[:, 1] - edges[:, 1] * to_x[:, 0] >= -1e-12)

    points = [x for x in a if inside(x, b)] + [x for x in b if inside(x, a)]
    for p, p2 in zip(a, np.roll(a, -1, axis=0), strict=True):
        for q, q2 in zip(b, np.roll(b, -1, axis=0), strict=True):
            M = np.column_stack([p2 - p, q - q2])
            if abs(np.linalg.det(M)) > 1e-12:
                s, t = np.linalg.solve(M, q - p)
                if 0 <= s <= 1 and 0 <= t <= 1:
                    points.append(p + s * (p2 - p))
    return np.array(points)


@pytest.mark.parametrize("angle", [0.0, 0.4, 1.1])
def test_flush_faces_report_every_corner_of_their_overlap(angle):
    """A box resting exactly flush on a box (turned about the common normal, shifted): the
    corners of the overlap of the two faces are all among the contact points."""
    T_b = np.eye(4)
    T_b[:3, :3] = Rotation.from_rotvec([0.0, 0.0, angle]).as_matrix()
    T_b[:3, 3] = (0.3, 0.1, 0.25)  # B's bottom face on A's top face, z = 0.125 exactly
    tree = TREES["box"][0]
    contacts = rbd.collide(tree, np.eye(4), tree, T_b, mode="contacts").contacts
    face = np.array([[-0.5, -0.25], [0.5, -0.25], [0.5, 0.25], [-0.5, 0.25]])
    turned = face @ T_b[:2, :2].T + T_b[:2, 3]
    corners = _overlap_corners(face, turned)
    assert len(corners) >= 4
    on_face = contacts.points[np.abs(contacts.points[:, 2] - 0.125) <= 1e-12]
    for corner in corners:
        assert np.linalg.norm(on_face[:, :2] - corner, axis=1).min() <= 1e-9


@pytest.mark.parametrize("seed", range(6))
def test_flush_copy_stored_far_from_its_mesh_origin(seed):
    """B's vertices stored 1e3..1e6 away from its mesh origin, its pose bringing them back
    flush against A (stored near its origin, so A's boxes are tight): B's corners carried into
    A's box frames carry rounding of that size, far above the boxes' padding, which the
    triangle-box test must absorb (no touching pair culled)."""
    rng = np.random.default_rng(seed)
    part = PARTS[("hex_prism", "box", "L_bracket")[seed % 3]]
    far = rng.normal(size=3) * 10.0 ** rng.uniform(3, 6)
    stored_far = rbd.TriangleMesh(part.vertices + far, part.faces)
    leafless = bool(seed % 2)
    tree_a = rbd.OBBTree(part, leafless=leafless)
    tree_b = rbd.OBBTree(stored_far, leafless=leafless)
    back = np.eye(4)
    back[:3, 3] = -far
    for axis in range(3):
        for turn in ("none", "whole"):
            T_a, T_b = placement(part, axis, 0.0, turn, seed)
            T_b = T_b @ back
            want = exact_pairs(part, T_a, stored_far, T_b)
            got = rbd.collide(tree_a, T_a, tree_b, T_b, mode="all").pairs
            np.testing.assert_array_equal(got, want)
