"""ray_cast() against trimesh's ray-triangle intersector and pybullet's rayTestBatch."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import MESH_KINDS, examples, point_triangle_distance, random_mesh, random_pose
from reference_queries import segment_distance
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd


def _world_trimesh(mesh, T):
    import trimesh

    T = np.asarray(T)
    return trimesh.Trimesh(mesh.vertices @ T[:3, :3].T + T[:3, 3], mesh.faces, process=False)


def trimesh_first_hits(mesh, T, origins, directions):
    """(distance (r,), face (r,)) of each ray's first hit by trimesh's pure-NumPy intersector."""
    from trimesh.ray.ray_triangle import RayMeshIntersector

    located, rays, faces = RayMeshIntersector(_world_trimesh(mesh, T)).intersects_location(
        origins, directions, multiple_hits=False
    )
    distance = np.full(len(origins), np.inf)
    face = np.full(len(origins), -1)
    distance[rays] = np.linalg.norm(located - origins[rays], axis=1)
    face[rays] = faces
    return distance, face


def _rays_at(mesh, T, seed, count):
    """Rays from around the posed mesh towards random points near it."""
    rng = np.random.default_rng(seed)
    T = np.asarray(T)
    centre = mesh.vertices.mean(axis=0) @ T[:3, :3].T + T[:3, 3]
    size = mesh.scale
    origins = centre + rng.normal(size=(count, 3)) * size
    targets = centre + rng.normal(size=(count, 3)) * 0.4 * size
    return origins, targets - origins


def _check_hits_lie_on_their_faces(hits, mesh, T, tolerance):
    T = np.asarray(T)
    for point, face in zip(hits.points[hits.hit], hits.faces[hits.hit], strict=True):
        triangle = mesh.triangles[face] @ T[:3, :3].T + T[:3, 3]
        assert point_triangle_distance(point, triangle) <= tolerance
    normals = hits.normals[hits.hit]
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    winding = mesh.face_cross[hits.faces[hits.hit]] @ T[:3, :3].T
    assert np.all(np.einsum("ij,ij->i", winding, normals) > 0)


@settings(max_examples=examples(30))
@given(
    kind=st.sampled_from(MESH_KINDS),
    seed=st.integers(0, 2**31),
    leafless=st.booleans(),
    dtype=st.sampled_from([np.float64, np.float32]),
)
def test_rays_match_trimesh(kind, seed, leafless, dtype):
    mesh = random_mesh(kind, seed)
    T = random_pose(seed + 1, 2.0)
    origins, directions = _rays_at(mesh, T, seed + 2, 60)
    hits = rbd.ray_cast(rbd.OBBTree(mesh, leafless=leafless, dtype=dtype), T, origins, directions)
    distance, face = trimesh_first_hits(mesh, T, origins, directions)
    tolerance = 1e-9 * mesh.scale
    np.testing.assert_array_equal(hits.hit, np.isfinite(distance))
    np.testing.assert_allclose(hits.distance[hits.hit], distance[hits.hit], atol=tolerance)
    assert np.all(np.isinf(hits.distance[~hits.hit])) and np.all(hits.faces[~hits.hit] == -1)
    assert np.all(np.isnan(hits.points[~hits.hit]))
    expected_points = origins + hits.distance[:, None] * (
        directions / np.linalg.norm(directions, axis=1, keepdims=True)
    )
    np.testing.assert_allclose(hits.points[hits.hit], expected_points[hits.hit], atol=tolerance)
    # Faces may differ only where a ray meets an edge or corner that faces share: the point
    # then lies on trimesh's face as well as on ours.
    T = np.asarray(T)
    for point, theirs in zip(hits.points[hits.hit], face[hits.hit], strict=True):
        triangle = mesh.triangles[theirs] @ T[:3, :3].T + T[:3, 3]
        assert point_triangle_distance(point, triangle) <= tolerance
    _check_hits_lie_on_their_faces(hits, mesh, T, tolerance)


def test_max_distance_keeps_only_nearer_hits():
    mesh = rbd.shapes.torus(1.0, 0.3, 40, 25)
    tree = rbd.OBBTree(mesh)
    T = random_pose(3, 0.5)
    origins, directions = _rays_at(mesh, T, 4, 300)
    full = rbd.ray_cast(tree, T, origins, directions)
    limit = float(np.median(full.distance[full.hit]))
    near = rbd.ray_cast(tree, T, origins, directions, max_distance=limit)
    np.testing.assert_array_equal(near.hit, full.distance <= limit)
    np.testing.assert_array_equal(near.distance[near.hit], full.distance[near.hit])
    assert not rbd.ray_cast(tree, T, origins, directions, max_distance=0.0).hit.any()


def test_one_origin_for_many_directions():
    tree = rbd.OBBTree(rbd.shapes.icosphere(1.0, 3))
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(50, 3))
    hits = rbd.ray_cast(tree, np.eye(4), [0.0, 0.0, 0.0], directions)
    assert hits.hit.all()
    # From the centre every ray leaves through the inscribed polyhedron, 0.98 to 1 away.
    assert np.all((hits.distance > 0.98) & (hits.distance <= 1.0 + 1e-12))


def _pybullet_hits(geometry, shape_kwargs, T, origins, directions, length):
    """pybullet's first hits of the rays against one static body of ``geometry`` ("box",
    "sphere" or "mesh"): (distance, points, normals)."""
    import pybullet as pb

    shape_type = {"box": pb.GEOM_BOX, "sphere": pb.GEOM_SPHERE, "mesh": pb.GEOM_MESH}[geometry]
    client = pb.connect(pb.DIRECT)
    try:
        shape = pb.createCollisionShape(shape_type, physicsClientId=client, **shape_kwargs)
        quaternion = Rotation.from_matrix(T[:3, :3]).as_quat()  # (x, y, z, w), as pybullet
        body = pb.createMultiBody(
            0, shape, basePosition=T[:3, 3].tolist(), baseOrientation=quaternion.tolist(),
            physicsClientId=client,
        )  # fmt: skip
        unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
        results = pb.rayTestBatch(
            origins.tolist(), (origins + length * unit).tolist(), physicsClientId=client
        )
    finally:
        pb.disconnect(client)
    hit = np.array([r[0] == body for r in results])
    distance = np.where(hit, [r[2] * length for r in results], np.inf)
    return distance, np.array([r[3] for r in results]), np.array([r[4] for r in results])


def test_box_matches_pybullet_box_primitive():
    half = np.array([0.5, 0.3, 0.2])
    T = random_pose(8, 0.5)
    rng = np.random.default_rng(2)
    # Rays from all sides at random points of the faces, and rays that mostly miss.
    local = rng.uniform(-0.8, 0.8, size=(400, 3)) * half
    axis = rng.integers(0, 3, size=400)
    local[np.arange(400), axis] = half[axis] * rng.choice([-1.0, 1.0], size=400)
    targets = local @ T[:3, :3].T + T[:3, 3]
    outside = local[np.arange(400), axis][:, None] * np.eye(3)[axis]
    origins = targets + 3.0 * outside / np.linalg.norm(outside, axis=1, keepdims=True)
    origins += rng.normal(size=(400, 3)) * 0.3
    directions = targets - origins
    missing = rng.normal(size=(100, 3))
    missing /= np.linalg.norm(missing, axis=1, keepdims=True)
    origins = np.vstack([origins, T[:3, 3] + 3.0 * missing])
    directions = np.vstack([directions, missing + rng.normal(size=(100, 3)) * 0.1])
    distance, points, normals = _pybullet_hits(
        "box", dict(halfExtents=half.tolist()), T, origins, directions, 10.0
    )
    hits = rbd.ray_cast(rbd.OBBTree(rbd.shapes.box(2 * half)), T, origins, directions, 10.0)

    # Bullet casts rays against a convex primitive by an iterative convex cast that stops
    # within about 1e-3 (its collision margin's order) of the surface: most hits agree to
    # round-off, a few are up to that much early, and rays passing near an edge can be
    # caught by it. Rays that keep 0.01 from every edge must agree on hitting, to within
    # Bullet's tolerance, and to round-off for nearly all of them.
    box = rbd.shapes.box(2 * half)
    corners = box.vertices @ T[:3, :3].T + T[:3, 3]
    edges = {tuple(sorted((f[i], f[(i + 1) % 3]))) for f in box.faces for i in range(3)}
    edges = [(i, j) for i, j in edges if np.count_nonzero(box.vertices[i] != box.vertices[j]) == 1]
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    clearance = np.array(
        [
            min(segment_distance(o, o + 10.0 * u, corners[i], corners[j]) for i, j in edges)
            for o, u in zip(origins, unit, strict=True)
        ]
    )
    clear = clearance > 0.01
    assert clear.sum() > 400 and hits.hit[clear].sum() > 300
    np.testing.assert_array_equal(hits.hit[clear], np.isfinite(distance[clear]))
    both = clear & hits.hit
    error = np.abs(hits.distance[both] - distance[both])
    assert np.all(error < 1e-3) and np.mean(error < 1e-9) > 0.95
    exact = both.copy()
    exact[both] = error < 1e-9
    np.testing.assert_allclose(hits.points[exact], points[exact], atol=1e-9)
    np.testing.assert_allclose(hits.normals[exact], normals[exact], atol=1e-9)
    assert np.all(clearance[hits.hit != np.isfinite(distance)] < 2e-3)


def test_sphere_matches_pybullet_sphere_and_its_mesh():
    radius = 0.7
    mesh = rbd.shapes.icosphere(radius, 3)
    T = random_pose(12, 0.5)
    rng = np.random.default_rng(5)
    away = rng.normal(size=(300, 3))
    origins = T[:3, 3] + 3.0 * away / np.linalg.norm(away, axis=1, keepdims=True)
    directions = T[:3, 3] + rng.normal(size=(300, 3)) * 0.6 - origins
    hits = rbd.ray_cast(rbd.OBBTree(mesh), T, origins, directions, 10.0)
    # The icosphere is inscribed in the sphere: hits lie at most the sagitta of its largest
    # face behind the sphere's.
    distance, _, normals = _pybullet_hits(
        "sphere", dict(radius=radius), T, origins, directions, 10.0
    )
    edge = np.linalg.norm(mesh.triangles[:, 0] - mesh.triangles[:, 1], axis=1).max()
    sagitta = radius - np.sqrt(radius**2 - edge**2 / 3)
    # Rays that meet the sphere at a steep angle (not grazing it) surely hit the icosphere.
    steep = np.abs(np.einsum("ij,ij->i", normals, directions))
    sure = np.isfinite(distance) & (steep > 0.3 * np.linalg.norm(directions, axis=1))
    assert hits.hit[sure].all()
    gap = hits.distance[sure] - distance[sure]
    assert np.all(gap >= -1e-9) and np.all(gap <= 4 * sagitta)
    # Against the same triangles as a pybullet triangle mesh, the answers agree exactly.
    triangles = dict(vertices=mesh.vertices.tolist(), indices=mesh.faces.ravel().tolist())
    distance, points, normals = _pybullet_hits("mesh", triangles, T, origins, directions, 10.0)
    np.testing.assert_array_equal(hits.hit, np.isfinite(distance))
    np.testing.assert_allclose(hits.distance[hits.hit], distance[hits.hit], atol=1e-9)
    np.testing.assert_allclose(hits.points[hits.hit], points[hits.hit], atol=1e-9)


@pytest.mark.parametrize(
    "origins, directions, max_distance, message",
    [
        ([[0, 0, 2]], [[0, 0, 0]], np.inf, "directions row 0 has zero length"),
        ([[0, 0, 2], [0, 0, np.nan]], [[0, 0, -1]], np.inf, "origins row 1"),
        ([[0, 0, 2]], [[0, 0, -1, 0]], np.inf, "directions must have shape"),
        ([[0, 0, 2]] * 3, [[0, 0, -1]] * 2, np.inf, "same number of rows"),
        ([[0, 0, 2]], [[0, 0, -1]], -1.0, "max_distance"),
        ([[0, 0, 2]], [[0, 0, -1]], np.nan, "max_distance"),
        ("origin", [[0, 0, -1]], np.inf, "origins must be numeric"),
    ],
)
def test_bad_rays_raise_naming_the_argument(origins, directions, max_distance, message):
    tree = rbd.OBBTree(rbd.shapes.box())
    with pytest.raises(ValueError, match=message):
        rbd.ray_cast(tree, np.eye(4), origins, directions, max_distance)


def test_bad_pose_and_tree_raise():
    tree = rbd.OBBTree(rbd.shapes.box())
    with pytest.raises(ValueError, match="T is not a rigid"):
        rbd.ray_cast(tree, np.diag([1.0, 2.0, 1.0, 1.0]), [[0, 0, 2]], [[0, 0, -1]])
    with pytest.raises(ValueError, match="tree"):
        rbd.ray_cast(tree.mesh, np.eye(4), [[0, 0, 2]], [[0, 0, -1]])


@pytest.mark.parametrize("posed", [False, True], ids=["identity", "random_pose"])
@pytest.mark.parametrize(
    "mesh",
    [
        rbd.shapes.box((2.0, 1.0, 0.5)),
        rbd.shapes.icosphere(1.0, 2),
        rbd.shapes.cylinder(0.5, 2.0, 24),
        rbd.shapes.icosphere(1e-3, 1),
    ],
    ids=["box", "icosphere", "cylinder", "small_icosphere"],
)
def test_rays_through_shared_edges_and_corners_never_slip_through(mesh, posed):
    """12 500 rays per case (10^5 in all) aimed through a point of a triangle's edge, a fifth
    of them through a corner, towards the inside of a convex closed mesh: each enters there,
    so its first hit is that point, 6 sizes along the ray (a floating-point barycentric test
    lets rays slip between two triangles that share the edge and report the far side)."""
    rng = np.random.default_rng(7)
    count = 12_500
    T = np.eye(4)
    if posed:
        T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        T[:3, 3] = rng.normal(size=3)
    size = np.ptp(mesh.vertices, axis=0).max()
    corners = mesh.vertices[mesh.faces[rng.integers(0, len(mesh.faces), count)]]
    k = rng.integers(0, 3, count)
    along = np.where(rng.random(count) < 0.2, 0.0, rng.uniform(0.0, 1.0, count))
    rows = np.arange(count)
    start, end = corners[rows, k], corners[rows, (k + 1) % 3]
    target = start + along[:, None] * (end - start)
    thinnest = np.ptp(mesh.vertices, axis=0).min()
    inside = mesh.vertices.mean(axis=0) + 0.05 * thinnest * rng.uniform(-1, 1, (count, 3))
    direction = inside - target
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    origins = target - 6.0 * size * direction
    R, p = T[:3, :3], T[:3, 3]
    hits = rbd.ray_cast(rbd.OBBTree(mesh), T, origins @ R.T + p, direction @ R.T)
    assert hits.hit.all()
    np.testing.assert_allclose(hits.distance, 6.0 * size, rtol=1e-9)


def test_extreme_directions_are_normalised_without_overflow():
    """A direction's length does not matter: 1e160 (whose square overflows) and 1e-200
    (whose square is 0) give the hit of a unit direction."""
    tree = rbd.OBBTree(rbd.shapes.box((2.0, 2.0, 2.0)))
    for scale in (1e160, 1e-200, 1.0):
        hits = rbd.ray_cast(tree, np.eye(4), (0.0, 0.0, -5.0), (0.0, 3e-3 * scale, scale))
        np.testing.assert_allclose(hits.distance, [4.0 * np.sqrt(1 + 9e-6)], rtol=1e-12)
