"""OBB fitting (covariance, Jacobi eigenvectors) and the 15-axis test against LP and eigh."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import boxes_overlap_lp, covariance_axes_reference, examples
from scipy.spatial.transform import Rotation

from thesis_rbd.collision.mesh.obb import obb_disjoint, symmetric_eigenvectors, triangle_moments


def _disjoint(c1, R1, h1, c2, R2, h2):
    """The kernel's calling convention: B relative to A, in A's frame."""
    R = R1.T @ R2
    T = R1.T @ (c2 - c1)
    return obb_disjoint(tuple(R.ravel()), tuple(T), tuple(h1), tuple(h2))


@settings(max_examples=examples(150))
@given(seed=st.integers(0, 2**31), spread=st.floats(0.1, 3.0))
def test_obb_disjoint_matches_lp(seed, spread):
    rng = np.random.default_rng(seed)
    R1, R2 = Rotation.random(2, random_state=rng).as_matrix()
    h1, h2 = rng.uniform(0.01, 1.0, (2, 3))
    c1, c2 = rng.normal(scale=spread, size=(2, 3))
    got = _disjoint(c1, R1, h1, c2, R2, h2)
    if got:
        # A reported separation is always real (the epsilon only ever widens boxes).
        assert not boxes_overlap_lp(c1, R1, h1, c2, R2, h2)
    else:
        # Reported overlap: real, or within the documented ~1e-6 relative slack.
        assert boxes_overlap_lp(c1, R1, h1 * (1 + 1e-5) + 1e-9, c2, R2, h2 * (1 + 1e-5) + 1e-9)


def test_near_parallel_edges_do_not_separate_falsely():
    # B is A rotated by a tiny angle and shifted along an edge direction: the cross products
    # of nearly parallel edges are ~1e-12 and their test is pure rounding noise.
    h = np.array([1.0, 0.5, 0.25])
    for angle in (1e-15, 1e-12, 1e-9, 1e-7):
        R2 = Rotation.from_rotvec([angle, angle, 0]).as_matrix()
        for shift in ([0, 0, 0], [1.99, 0, 0], [0, 0.99, 0.49], [0.5, 0.5, 0.2]):
            c2 = np.array(shift, float)
            assert not _disjoint(np.zeros(3), np.eye(3), h, c2, R2, h)


def test_obb_face_and_edge_separation():
    h = np.ones(3)
    # Face axis: apart along x.
    assert _disjoint(np.zeros(3), np.eye(3), h, np.array([2.1, 0, 0]), np.eye(3), h)
    assert not _disjoint(np.zeros(3), np.eye(3), h, np.array([2.0, 0, 0]), np.eye(3), h)
    # Edge-edge axis: B rotated 45 deg about x and about z, placed off the A-edge direction.
    R2 = Rotation.from_euler("xz", [45, 45], degrees=True).as_matrix()
    c2 = np.array([2.2, 2.2, 0.0])
    assert _disjoint(np.zeros(3), np.eye(3), h, c2, R2, h) == (
        not boxes_overlap_lp(np.zeros(3), np.eye(3), h, c2, R2, h)
    )


@settings(max_examples=examples(100))
@given(seed=st.integers(0, 2**31))
def test_jacobi_eigenvectors_match_eigh(seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3))
    C = A @ A.T
    V = symmetric_eigenvectors(C)
    np.testing.assert_allclose(V.T @ V, np.eye(3), atol=1e-12)
    assert np.linalg.det(V) > 0
    w, U = np.linalg.eigh(C)
    order = np.argsort(-w)
    np.testing.assert_allclose(np.diag(V.T @ C @ V), w[order], rtol=1e-10, atol=1e-12)
    # Columns equal eigh's up to sign where eigenvalues are distinct.
    gaps = np.abs(np.diff(w[order]))
    if gaps.min() > 1e-6 * abs(w).max():
        np.testing.assert_allclose(np.abs(V.T @ U[:, order]), np.eye(3), atol=1e-6)


def test_jacobi_handles_diagonal_and_repeated():
    for C in (np.diag([3.0, 1.0, 2.0]), np.eye(3), np.zeros((3, 3)), np.diag([1.0, 1.0, 0.0])):
        V = symmetric_eigenvectors(C)
        np.testing.assert_allclose(V.T @ V, np.eye(3), atol=1e-12)
        vals = np.diag(V.T @ C @ V)
        assert np.all(np.diff(vals) <= 1e-12)


def test_triangle_moments_give_the_thesis_covariance():
    rng = np.random.default_rng(3)
    tris = rng.normal(size=(40, 3, 3))
    area, wc, wm = triangle_moments(tris)
    total = area.sum()
    cH = wc.sum(0) / total
    C = wm.sum(0) / total - np.outer(cH, cH)
    w_ref, v_ref = covariance_axes_reference(tris)
    V = symmetric_eigenvectors(C)
    np.testing.assert_allclose(np.diag(V.T @ C @ V), w_ref, rtol=1e-9)
    np.testing.assert_allclose(np.abs(V.T @ v_ref), np.eye(3), atol=1e-8)


def test_covariance_of_a_box_surface_has_its_axes():
    # A long box rotated arbitrarily: the first axis must be its long edge.
    import thesis_rbd as rbd

    mesh = rbd.shapes.box((4.0, 1.0, 0.5))
    R = Rotation.from_euler("xyz", [10, 20, 30], degrees=True).as_matrix()
    area, wc, wm = triangle_moments(mesh.triangles @ R.T)
    total = area.sum()
    cH = wc.sum(0) / total
    V = symmetric_eigenvectors(wm.sum(0) / total - np.outer(cH, cH))
    np.testing.assert_allclose(np.abs(V.T @ R), np.eye(3), atol=1e-9)


@settings(max_examples=examples(60))
@given(seed=st.integers(0, 2**31), n=st.integers(4, 200))
def test_hull_matches_qhull(seed, n):
    from scipy.spatial import ConvexHull

    from thesis_rbd.collision.mesh.obb_hull import hull_faces, hull_moments

    rng = np.random.default_rng(seed)
    P = rng.normal(size=(n, 3)) * rng.uniform(0.1, 2.0, 3)
    faces = hull_faces(P)
    ref = ConvexHull(P)
    # Closed, outward: the divergence-theorem volume equals qhull's, and every point is inside
    # every face plane.
    a, b, c = P[faces[:, 0]], P[faces[:, 1]], P[faces[:, 2]]
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
    np.testing.assert_allclose(volume, ref.volume, rtol=1e-9)
    normals = np.cross(b - a, c - a)
    assert np.all(np.einsum("fj,pfj->pf", normals, P[:, None, :] - a[None]) <= 1e-9)
    total, _, _ = hull_moments(P)
    np.testing.assert_allclose(total, ref.area, rtol=1e-9)


def test_hull_of_flat_or_tiny_sets_is_empty():
    from thesis_rbd.collision.mesh.obb_hull import hull_faces

    rng = np.random.default_rng(1)
    flat = np.column_stack([rng.normal(size=(30, 2)), np.zeros(30)])
    assert hull_faces(flat).shape == (0, 3)
    assert hull_faces(np.zeros((10, 3))).shape == (0, 3)
    assert hull_faces(rng.normal(size=(3, 3))).shape == (0, 3)


def test_hull_fit_is_tessellation_independent():
    # Gottschalk's point: a box mesh with one face finely subdivided biases the triangle
    # covariance but not the hull's, whose axes stay the box's.
    import thesis_rbd as rbd
    from thesis_rbd.collision.mesh.obb_hull import hull_moments

    mesh = rbd.shapes.box((3.0, 2.0, 1.0)).to_trimesh()
    mesh = mesh.subdivide(face_index=np.flatnonzero(mesh.face_normals[:, 0] > 0.5))
    mesh = mesh.subdivide(face_index=np.flatnonzero(mesh.face_normals[:, 0] > 0.5))
    total, cs, ms = hull_moments(np.asarray(mesh.vertices))
    C = ms / total - np.outer(cs / total, cs / total)
    np.testing.assert_allclose(np.abs(symmetric_eigenvectors(C)), np.eye(3), atol=1e-9)
