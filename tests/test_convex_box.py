"""The closed-form box-box separating-axis test against the general one it stands in for."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from tests.reference_convex import least_penetration
from tests.test_convex_contacts import Pair, face_pairs, pairs
from thesis_rbd.collision.convex.box import box_box_query
from thesis_rbd.collision.convex.contacts import SPECULATIVE_FRACTION
from thesis_rbd.collision.convex.hull_data import HullSet
from thesis_rbd.collision.convex.sat import (
    EDGES,
    FACE_A,
    edge_pair_separation,
    face_separation,
    place_hull,
    sat_query,
)


def general_query(hulls: HullSet, R, t, tie):
    """``sat_query`` of hull 0 against hull 1 placed by (R, t), with no margin to stop at,
    and B's placed vertices and planes."""
    H = hulls
    va, vb = H.vertices[:8], H.vertices[8:16]
    pa, pb = H.planes[:6], H.planes[6:12]
    ea, eb = H.edges[:12], H.edges[12:24]
    fa, fb = H.edge_faces[:12], H.edge_faces[12:24]
    arcs_a, arcs_b = H.edge_arcs[:12], H.edge_arcs[12:24]
    placed_v, placed_p, placed_a = np.empty((8, 3)), np.empty((6, 4)), np.empty((12, 3))
    place_hull(vb, pb, arcs_b, R, t, placed_v, placed_p, placed_a)
    answer = sat_query(
        va, pa, ea, fa, arcs_a, H.centroids[0], placed_v, placed_p, eb, fb, placed_a,
        0, 0, 0, tie, np.inf, np.empty((6, 12)), np.empty((12, 6)),
    )  # fmt: skip
    return answer, placed_v, placed_p


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pairs(kinds=st.just("box")))
def test_box_query_equals_the_general_separating_axis_test(pair):
    hulls = HullSet()
    for mesh in pair.meshes:
        assert hulls.hull_of(mesh) >= 0
    # distinct hulls, so that the general test's slices below are A's and B's
    assert len(hulls.hulls) == 2 and (hulls.box_features >= 0).all()
    Ra = Rotation.from_quat(pair.orientation[0]).as_matrix()
    Rb = Rotation.from_quat(pair.orientation[1]).as_matrix()
    R = Ra.T @ Rb
    t = Ra.T @ (pair.position[1] - pair.position[0])
    size = pair.size
    tie = 1e-10 * (hulls.sizes[0] + hulls.sizes[1])
    (g_kind, _, _, g_sep, *_), placed_v, placed_p = general_query(hulls, R, t, tie)
    kind, i, j, sep, *axis = box_box_query(hulls.box_frames, hulls.box_features, 0, 1, R, t, tie)
    assert abs(sep - g_sep) <= 1e-9 * size
    # the features it names give its separation and axis under the general test's own
    # formulas: a face of A or B, or an edge pair meeting along the axis
    va = hulls.vertices[:8]
    if kind == FACE_A:
        own = face_separation(hulls.planes[:6], i, placed_v, 8)
        normal = hulls.planes[i, :3]
    elif kind == EDGES:
        own, *normal = edge_pair_separation(
            va, hulls.edges[:12], i, hulls.centroids[0], placed_v, hulls.edges[12:24], j, -np.inf
        )
    else:
        own = face_separation(placed_p, i, va, 8)
        normal = -placed_p[i, :3]
    assert abs(own - sep) <= 1e-9 * size
    np.testing.assert_allclose(axis, normal, atol=1e-9)
    # the same kind of axis, but for ties between a face and an edge pair
    assert kind == g_kind or abs(sep - g_sep) <= 2 * tie


def test_boxes_are_found_and_other_hulls_are_not():
    hulls = HullSet()
    turned = Rotation.from_rotvec([0.3, -1.1, 0.7])
    box = rbd.shapes.box((1.0, 2.0, 3.0))
    moved = rbd.TriangleMesh(box.vertices @ turned.as_matrix().T + [5.0, -2.0, 1.0], box.faces)
    shear = np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    sheared = rbd.TriangleMesh(box.vertices @ shear, box.faces)
    for mesh in (moved, sheared, rbd.shapes.cylinder(0.5, 1.0, 4), rbd.shapes.icosphere(1.0, 1)):
        hulls.hull_of(mesh)
    assert (hulls.box_features[0] >= 0).all()
    frame = hulls.box_frames[0]
    # each axis is one of the turned box's axes, either way round, with its half extent
    cosines = np.abs(frame[:3] @ turned.as_matrix())
    along = cosines.argmax(axis=1)
    np.testing.assert_allclose(cosines, np.eye(3)[along], atol=1e-12)
    np.testing.assert_allclose(frame[4], np.array([0.5, 1.0, 1.5])[along], atol=1e-12)
    np.testing.assert_allclose(frame[3], [5.0, -2.0, 1.0], atol=1e-12)
    assert np.linalg.det(frame[:3]) > 0
    # a sheared box has antiparallel faces that are not perpendicular; a square prism from
    # the cylinder is a box; the sphere is not
    assert (hulls.box_features[1] == -1).all()
    assert (hulls.box_features[2] >= 0).all()
    assert (hulls.box_features[3] == -1).all()


def _contacts_of(pair, find_boxes):
    """The pair's contacts with boxes in closed form, or every hull on the general path."""
    general = Pair(*pair.meshes, *zip(pair.position, pair.orientation, strict=True))
    general.hulls = HullSet(find_boxes=find_boxes)
    general.hull_of_body = np.array([general.hulls.hull_of(m) for m in pair.meshes])
    return general.contacts()[0]


def _thicknesses(pair):
    hulls = HullSet()
    index = [hulls.hull_of(mesh) for mesh in pair.meshes]
    return hulls.thicknesses[index]


def _levelled(depths, level, rounding):
    """Sorted depths, those that lie ``level`` below the deepest to ``rounding`` raised to it."""
    deepest = depths.max()
    above = deepest - depths
    return np.sort(np.where(np.abs(above - level) <= rounding, deepest, depths))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(face_pairs(), pairs(kinds=st.just("box"))))
def test_box_contacts_equal_the_general_path(pair):
    """Two boxes' contacts, closed form and face shortcut, against the general separating-axis
    test and clip: the same depths and normals and the same points (in another order)."""
    boxes = [m for m in pair.meshes if len(m.vertices) == 8]
    if len(boxes) < 2:
        return
    fast, general = _contacts_of(pair, True), _contacts_of(pair, False)
    assert len(fast["depths"]) == len(general["depths"])
    if not len(fast["depths"]):
        return
    size = pair.size
    # A corner within a thousandth of the thinner body of the deepest carries the pair's
    # depth; one that lies that far above it to round-off may go either way on either path
    level = SPECULATIVE_FRACTION * min(_thicknesses(pair))
    np.testing.assert_allclose(
        _levelled(fast["depths"], level, 1e-9 * size),
        _levelled(general["depths"], level, 1e-9 * size),
        atol=1e-9 * size,
    )
    # where the least-penetration axis is tied (a box centred on the other along it: either
    # face is as deep), the two paths may take either; elsewhere the same axis and corners
    depth, _, runner_up = least_penetration(pair.points_a, pair.points_b)[:3]
    if runner_up <= depth + 1e-8 * size:
        return
    np.testing.assert_allclose(fast["normals"], general["normals"], atol=1e-9)
    # the same corner set: every point of one has a partner in the other
    gaps = np.linalg.norm(fast["points"][:, None] - general["points"][None], axis=2)
    assert gaps.min(axis=1).max() <= 1e-9 * size
    assert gaps.min(axis=0).max() <= 1e-9 * size
