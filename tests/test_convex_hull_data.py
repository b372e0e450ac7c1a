"""Convexity and the packed hull arrays, against SciPy's hull and the meshes' own geometry."""

import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial import ConvexHull as ScipyHull

import thesis_rbd as rbd
from thesis_rbd.collision.convex.hull_data import (
    _FIELDS,
    HullSet,
    convex_hull,
    is_convex,
    unpack_hulls,
)


def random_hull_mesh(seed, count):
    points = np.random.default_rng(seed).normal(size=(count, 3))
    return rbd.TriangleMesh.from_trimesh(trimesh.convex.convex_hull(points))


def check_hull(mesh):
    hull = convex_hull(mesh)
    reference = ScipyHull(mesh.vertices)
    scale = mesh.scale
    # same vertex set as qhull's
    np.testing.assert_allclose(
        np.sort(hull.vertices, axis=0), np.sort(mesh.vertices[reference.vertices], axis=0)
    )
    v, f, e = len(hull.vertices), len(hull.planes), len(hull.edges)
    assert v - e + f == 2  # Euler: a closed convex polyhedron
    # every vertex inside every face plane; each face's own corners on it
    gap = hull.vertices @ hull.planes[:, :3].T - hull.planes[:, 3]
    assert gap.max() <= 1e-12 * scale
    for k in range(f):
        loop = hull.loops[hull.loop_start[k] : hull.loop_start[k + 1]]
        assert len(loop) >= 3
        np.testing.assert_allclose(gap[loop, k], 0.0, atol=1e-12 * scale)
        # counter-clockwise seen from outside: Newell normal along the plane normal
        p = hull.vertices[loop]
        newell = np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)
        assert newell @ hull.planes[k, :3] > 0
    # no two neighbouring faces coplanar (merged), each edge between its two faces
    n = hull.planes[:, :3]
    assert (np.einsum("ij,ij->i", n[hull.edge_faces[:, 0]], n[hull.edge_faces[:, 1]]) < 1).all()
    for k, (tail, head) in enumerate(hull.edges):
        left, right = hull.edge_faces[k]
        loop = list(hull.loops[hull.loop_start[left] : hull.loop_start[left + 1]])
        assert loop[(loop.index(tail) + 1) % len(loop)] == head
        loop = list(hull.loops[hull.loop_start[right] : hull.loop_start[right + 1]])
        assert loop[(loop.index(head) + 1) % len(loop)] == tail
    # adjacency: neighbours are the edge ends; faces around a vertex contain it
    for vertex in range(v):
        nb = hull.neighbors[hull.neighbor_start[vertex] : hull.neighbor_start[vertex + 1]]
        ed = hull.neighbor_edges[hull.neighbor_start[vertex] : hull.neighbor_start[vertex + 1]]
        for other, edge in zip(nb, ed, strict=False):
            assert sorted(hull.edges[edge]) == sorted([vertex, other])
        around = hull.vertex_faces[
            hull.vertex_face_start[vertex] : hull.vertex_face_start[vertex + 1]
        ]
        for face in around:
            assert vertex in hull.loops[hull.loop_start[face] : hull.loop_start[face + 1]]
    # the polygon areas add up to the hull's surface
    area = 0.0
    for k in range(f):
        p = hull.vertices[hull.loops[hull.loop_start[k] : hull.loop_start[k + 1]]]
        area += 0.5 * np.linalg.norm(np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0))
    assert area == pytest.approx(reference.area, rel=1e-9)
    return hull


def test_box_is_six_quads_and_prisms_merge_their_caps():
    hull = check_hull(rbd.shapes.box((1.0, 2.0, 3.0)))
    assert len(hull.planes) == 6 and len(hull.edges) == 12
    assert (np.diff(hull.loop_start) == 4).all()
    hull = check_hull(rbd.shapes.cylinder(0.5, 1.0, 16))
    assert sorted(np.diff(hull.loop_start))[-2:] == [16, 16]
    assert len(hull.planes) == 18


@pytest.mark.parametrize("subdivisions", [0, 1, 2])
def test_icosphere_hull_keeps_every_triangle(subdivisions):
    mesh = rbd.shapes.icosphere(0.5, subdivisions)
    hull = check_hull(mesh)
    assert len(hull.planes) == len(mesh.faces)


@given(st.integers(0, 2**31), st.integers(4, 64))
def test_random_hulls_pack_consistently(seed, count):
    check_hull(random_hull_mesh(seed, count))


def test_convex_meshes_are_told_from_others():
    assert is_convex(rbd.shapes.box((1, 2, 3)))
    assert is_convex(rbd.shapes.icosphere(1.0, 2))
    assert is_convex(rbd.shapes.cylinder(0.5, 1.0, 32))
    assert is_convex(random_hull_mesh(3, 30))
    assert not is_convex(rbd.shapes.torus())
    # an open box (one face missing) is not a convex solid
    box = rbd.shapes.box((1, 1, 1))
    assert not is_convex(rbd.TriangleMesh(box.vertices, box.faces[:-1]))
    # a unit cube whose top face is a fan around a centre vertex: that vertex sunk by less
    # than the tolerance is ignored, by more it is not
    for dent, convex in ((1e-9, True), (1e-4, False)):
        vertices = np.vstack([box.vertices, [0.0, 0.0, 0.5 - dent]])
        top = [i for i in range(8) if vertices[i, 2] > 0]
        ring = sorted(top, key=lambda i: np.arctan2(vertices[i, 1], vertices[i, 0]))
        fan = [[ring[k], ring[(k + 1) % 4], 8] for k in range(4)]
        faces = np.vstack([[f for f in box.faces if not (vertices[f, 2] > 0).all()], fan])
        assert is_convex(rbd.TriangleMesh(vertices, faces)) == convex


def test_surface_folded_inside_its_hull_is_not_convex():
    """A closed, oriented surface whose vertices are all on the hull but whose volume is not
    the hull's: the cube's corners, meshed as the tetrahedron inscribed in the cube."""
    v = rbd.shapes.box((1, 1, 1)).vertices
    corners = [i for i in range(8) if np.prod(np.sign(v[i])) > 0]
    tet = v[corners]
    faces = ScipyHull(tet).simplices.copy()
    centre = tet.mean(axis=0)
    for k, f in enumerate(faces):
        if np.cross(tet[f[1]] - tet[f[0]], tet[f[2]] - tet[f[0]]) @ (tet[f[0]] - centre) < 0:
            faces[k] = f[[0, 2, 1]]
    assert is_convex(rbd.TriangleMesh(tet, faces))
    folded = rbd.TriangleMesh(v, np.array(corners)[faces])
    assert not is_convex(folded)


def test_hull_set_shares_hulls_and_marks_non_convex_meshes():
    hulls = HullSet()
    cube, ball, torus = rbd.shapes.box(), rbd.shapes.icosphere(0.5, 2), rbd.shapes.torus()
    assert hulls.hull_of(cube) == 0
    assert hulls.hull_of(ball) == 1
    assert hulls.hull_of(cube) == 0
    assert hulls.hull_of(torus) == -1
    # the packed arrays unpack to the fields, in the kernels' order
    unpacked = unpack_hulls(hulls.arrays())
    assert len(unpacked) == 20
    for name, value in zip(_FIELDS, unpacked, strict=True):
        np.testing.assert_array_equal(value, getattr(hulls, name))
    # the cube is a box, the ball is not
    assert (hulls.box_features[0] >= 0).all() and (hulls.box_features[1] == -1).all()
    assert hulls.vertex_start.tolist() == [0, 8, 170]
    assert hulls.face_start.tolist() == [0, 6, 326]
    assert hulls.longest_loop == 4
    # the CSR offsets run on across hulls; indices stay local
    assert hulls.neighbor_start[8] == 24
    assert hulls.neighbors[24:].max() < 162
    np.testing.assert_allclose(
        hulls.edge_arcs[:12],
        np.cross(
            hulls.planes[hulls.edge_faces[:12, 1], :3], hulls.planes[hulls.edge_faces[:12, 0], :3]
        ),
    )
