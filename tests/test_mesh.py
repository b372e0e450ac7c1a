"""TriangleMesh validation, topology queries, shapes and mesh I/O."""

import numpy as np
import pytest
import trimesh

import thesis_rbd as rbd

TETRA_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def test_valid_mesh_is_read_only_and_closed():
    mesh = rbd.TriangleMesh(TETRA_V, TETRA_F)
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    assert mesh.is_closed and mesh.is_consistently_oriented
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 5.0
    np.testing.assert_allclose(mesh.face_areas.sum(), 1.5 + np.sqrt(3) / 2)


@pytest.mark.parametrize(
    ("vertices", "faces", "message"),
    [
        (np.zeros((4, 2)), TETRA_F, "vertices must have shape"),
        (TETRA_V, TETRA_F[:, :2], "faces must have shape"),
        (np.where(np.eye(4, 3) > 0, np.nan, TETRA_V), TETRA_F, "non-finite"),
        (np.where(np.eye(4, 3) > 0, np.inf, TETRA_V), TETRA_F, "non-finite"),
        (TETRA_V, TETRA_F + 1, "out of range"),
        (TETRA_V, -TETRA_F - 1, "out of range"),
        (TETRA_V, TETRA_F + 0.5, "integer"),
        (np.zeros((0, 3)), np.zeros((0, 3), int), "empty"),
        (TETRA_V, np.zeros((0, 3), int), "empty"),
        ([["a", "b", "c"]], TETRA_F, "numeric"),
    ],
)
def test_bad_input_names_the_problem(vertices, faces, message):
    with pytest.raises(ValueError, match=message):
        rbd.TriangleMesh(vertices, faces)


def test_open_and_flipped_meshes_are_detected():
    open_mesh = rbd.TriangleMesh(TETRA_V, TETRA_F[:3])
    assert not open_mesh.is_closed
    mixed = TETRA_F.copy()
    mixed[0] = mixed[0, ::-1]
    flipped = rbd.TriangleMesh(TETRA_V, mixed)
    assert flipped.is_closed and not flipped.is_consistently_oriented


def test_degenerate_faces_are_reported_not_rejected():
    faces = np.vstack([TETRA_F, [[0, 0, 1], [0, 1, 1]]])
    vertices = np.vstack([TETRA_V, [[0.5, 0, 0]]])
    faces = np.vstack([faces, [[0, 1, 4]]])  # collinear: zero area
    mesh = rbd.TriangleMesh(vertices, faces)
    assert mesh.degenerate_faces.tolist() == [4, 5, 6]
    assert np.all(mesh.face_normals[4:] == 0)


@pytest.mark.parametrize(
    ("mesh", "faces"),
    [
        (rbd.shapes.box((1, 2, 3)), 12),
        (rbd.shapes.icosphere(0.5, 3), 1280),
        (rbd.shapes.cylinder(0.5, 2.0, 40), 160),
        (rbd.shapes.capsule(0.3, 1.0, 16), 512),
        (rbd.shapes.torus(1.0, 0.3, 50, 50), 5000),
    ],
)
def test_shapes_are_closed_and_outward(mesh, faces):
    assert len(mesh) == faces
    assert mesh.is_closed and mesh.is_consistently_oriented
    assert len(mesh.degenerate_faces) == 0
    assert rbd.mass_properties(mesh).volume > 0
    # centred at the origin
    np.testing.assert_allclose(mesh.bounds.sum(axis=0), 0, atol=1e-12)


def test_thesis_torus_lies_on_the_analytic_surface():
    R, r = 1.0, 0.3
    torus = rbd.shapes.torus(R, r, 50, 50)
    x, y, z = torus.vertices.T
    np.testing.assert_allclose((np.hypot(x, y) - R) ** 2 + z**2, r**2, atol=1e-12)
    assert (len(torus.vertices), len(torus.faces)) == (2500, 5000)
    # closed genus-1 surface: V - E + F = 0
    assert torus.is_closed
    assert len(torus.vertices) - 3 * len(torus.faces) // 2 + len(torus.faces) == 0


@pytest.mark.parametrize(
    ("factory", "kwargs", "message"),
    [
        (rbd.shapes.box, {"extents": (1, -1, 1)}, "positive"),
        (rbd.shapes.icosphere, {"radius": 0.0}, "radius"),
        (rbd.shapes.icosphere, {"subdivisions": 1.5}, "subdivisions"),
        (rbd.shapes.cylinder, {"sections": 2}, "sections"),
        (rbd.shapes.capsule, {"length": 0.0}, "length"),
        (rbd.shapes.torus, {"major_radius": 0.2, "minor_radius": 0.3}, "minor_radius"),
    ],
)
def test_shape_arguments_are_validated(factory, kwargs, message):
    with pytest.raises(ValueError, match=message):
        factory(**kwargs)


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".glb"])
def test_load_mesh_round_trips_through_trimesh(tmp_path, suffix):
    source = rbd.shapes.icosphere(0.7, 1)
    path = tmp_path / f"sphere{suffix}"
    source.to_trimesh().export(path)
    loaded = rbd.load_mesh(path)
    assert loaded.is_closed
    np.testing.assert_allclose(
        rbd.mass_properties(loaded).volume, rbd.mass_properties(source).volume, rtol=1e-6
    )


def _with_seams(mesh, seed):
    """A trimesh copy whose every face has its own corners, with random texture coordinates
    and flat-shading normals: each vertex is split along texture and normal seams."""
    import trimesh

    split = mesh.to_trimesh()
    split.unmerge_vertices()
    uv = np.random.default_rng(seed).uniform(size=(len(split.vertices), 2))
    split.visual = trimesh.visual.TextureVisuals(uv=uv)
    split.vertex_normals = np.repeat(split.face_normals, 3, axis=0)
    return split


@pytest.mark.parametrize("suffix", [".obj", ".glb", ".ply"])
@pytest.mark.parametrize(
    "source", [rbd.shapes.box((1.0, 2.0, 0.5)), rbd.shapes.icosphere(0.7, 2)], ids=["box", "sphere"]
)
def test_textured_models_with_seams_load_closed(tmp_path, suffix, source):
    import trimesh

    path = tmp_path / f"model{suffix}"
    _with_seams(source, 0).export(path)
    # The file really holds the seams: read as stored, the surface is open.
    stored = trimesh.load(path, force="mesh", process=False)
    assert len(stored.vertices) == 3 * len(source.faces)
    loaded = rbd.load_mesh(path)
    assert loaded.is_closed and loaded.is_consistently_oriented
    assert len(loaded.vertices) == len(source.vertices)
    np.testing.assert_allclose(
        rbd.mass_properties(loaded).volume, rbd.mass_properties(source).volume, rtol=1e-6
    )


def test_load_mesh_errors(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        rbd.load_mesh(tmp_path / "missing.obj")
    bad = tmp_path / "bad.stl"
    bad.write_text("this is not a mesh")
    with pytest.raises(ValueError, match=r"bad\.stl"):
        rbd.load_mesh(bad)


def test_from_trimesh_keeps_arrays():
    tm = trimesh.creation.box((1, 1, 1))
    mesh = rbd.TriangleMesh.from_trimesh(tm)
    np.testing.assert_array_equal(mesh.faces, tm.faces)
    np.testing.assert_array_equal(mesh.to_trimesh().vertices, tm.vertices)


@pytest.mark.parametrize("faces", [[["0", "1", "2"]], [[None, 1, 2]], [[0, 1, 2.5]]])
def test_faces_that_are_not_integers_are_refused_by_name(faces):
    """Text and objects raised a TypeError from inside NumPy."""
    with pytest.raises(ValueError, match="faces must hold integer vertex indices"):
        rbd.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces)
