"""simulate() records the right frames; Trajectory round-trips through .npz atomically."""

import numpy as np
import pytest

import thesis_rbd as rbd
from thesis_rbd.trajectory import Trajectory


def two_body_world():
    world = rbd.World(dt=0.01, gravity=(0, 0, -9.81))
    offset_box = rbd.TriangleMesh(rbd.shapes.box((1, 2, 3)).vertices + [3.0, 0, 0], [[0, 1, 2]])
    world.add_body(offset_box, static=True, name="ledge", position=(0, 0, -1))
    world.add_body(
        rbd.shapes.box((1.0, 2.0, 3.0)),
        mass=2.0,
        position=(1, 2, 3),
        linear_velocity=(1, 0, 0),
        angular_velocity=(0.3, 1.0, -0.2),
        name="crate",
    )
    return world


def test_frames_every_k_steps_and_always_the_last():
    world = two_body_world()
    stages = world.stages
    calls = []
    trajectory = rbd.simulate(world, 0.1, record_every=3, progress=lambda *a: calls.append(a))
    # 10 steps: frames after 0, 3, 6, 9 and 10 steps
    np.testing.assert_allclose(trajectory.times, [0, 0.03, 0.06, 0.09, 0.10], atol=1e-12)
    assert calls == [(3, 10), (6, 10), (9, 10), (10, 10)]
    assert trajectory.positions.shape == (5, 2, 3)
    assert trajectory.orientations.shape == (5, 2, 4)
    np.testing.assert_array_equal(trajectory.positions[-1], world.positions)
    np.testing.assert_array_equal(trajectory.orientations[-1], world.orientations)
    np.testing.assert_array_equal(trajectory.positions[0, 1], [1, 2, 3])
    assert trajectory.names == ["ledge", "crate"]
    np.testing.assert_array_equal(trajectory.static, [True, False])
    assert trajectory.metadata["steps"] == 10 and trajectory.metadata["dt"] == 0.01
    assert trajectory.metadata["stages"] == stages
    assert stages[:3] == ["forces", "contacts", "integrate"]


def test_profile_counts_only_this_run():
    world = rbd.World(dt=0.01)
    world.add_body(rbd.shapes.box(), linear_velocity=(1, 0, 0))
    rbd.simulate(world, 0.05)
    second = rbd.simulate(world, 0.1)
    assert second.metadata["profile"]["integrate"]["calls"] == 10
    assert second.metadata["profile"]["forces"]["calls"] == 0
    assert second.times[0] == pytest.approx(0.05)  # continues from the world's time
    assert world.profile["integrate"]["calls"] == 15


def test_transforms_place_mesh_vertices_like_the_world():
    world = two_body_world()
    trajectory = rbd.simulate(world, 0.2)
    for body in range(2):
        mesh = world.bodies.meshes[body]
        T = world.transform(body)
        expected = mesh.vertices @ T[:3, :3].T + T[:3, 3]
        np.testing.assert_allclose(trajectory.world_vertices(-1, body), expected, atol=1e-12)
    assert trajectory.frame_at(0.0) == 0
    assert trajectory.frame_at(0.105) == 10
    assert trajectory.frame_at(99.0) == len(trajectory) - 1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"seconds": 0.0}, "seconds must be finite and positive"),
        ({"seconds": float("nan")}, "seconds must be finite and positive"),
        ({"seconds": "long"}, "seconds must be a number"),
        ({"seconds": 1.0, "record_every": 0}, "record_every must be an integer >= 1"),
        ({"seconds": 1.0, "record_every": 1.5}, "record_every must be an integer >= 1"),
    ],
)
def test_bad_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rbd.simulate(two_body_world(), **kwargs)
    with pytest.raises(ValueError, match="world must be a World"):
        rbd.simulate("world", 1.0)


def test_save_and_load_round_trip(tmp_path):
    trajectory = rbd.simulate(two_body_world(), 0.2, record_every=2)
    trajectory.metadata["scene"] = "two bodies"
    path = tmp_path / "run.npz"
    trajectory.save(path)
    loaded = Trajectory.load(path)
    for field in ("times", "positions", "orientations", "centers_of_mass", "static"):
        np.testing.assert_array_equal(getattr(loaded, field), getattr(trajectory, field))
    assert loaded.names == trajectory.names
    assert loaded.metadata == trajectory.metadata
    for mine, theirs in zip(loaded.meshes, trajectory.meshes, strict=True):
        np.testing.assert_array_equal(mine.vertices, theirs.vertices)
        np.testing.assert_array_equal(mine.faces, theirs.faces)
    # no pickles: plain np.load with allow_pickle=False reads every array
    with np.load(path, allow_pickle=False) as data:
        assert data["positions"].shape == (11, 2, 3)


def test_save_is_atomic(tmp_path, monkeypatch):
    path = tmp_path / "run.npz"
    path.write_bytes(b"previous run")
    trajectory = rbd.simulate(two_body_world(), 0.05)

    def write_half_then_fail(file, **arrays):
        file.write(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", write_half_then_fail)
    with pytest.raises(OSError, match="disk full"):
        trajectory.save(path)
    assert path.read_bytes() == b"previous run"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]  # no temporary left
    monkeypatch.undo()
    trajectory.save(path)
    assert Trajectory.load(path).names == ["ledge", "crate"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]


def test_save_needs_an_existing_folder(tmp_path):
    trajectory = rbd.simulate(two_body_world(), 0.05)
    with pytest.raises(ValueError, match=r"folder .*missing does not exist"):
        trajectory.save(tmp_path / "missing" / "run.npz")


def test_load_rejects_what_is_not_a_trajectory(tmp_path):
    with pytest.raises(ValueError, match="trajectory file not found"):
        Trajectory.load(tmp_path / "absent.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="cannot read trajectory"):
        Trajectory.load(tmp_path / "junk.npz")
    np.savez(tmp_path / "other.npz", positions=np.zeros((1, 1, 3)))
    with pytest.raises(ValueError, match=r"not a thesis_rbd trajectory .*missing format, times"):
        Trajectory.load(tmp_path / "other.npz")


def test_constructor_checks_shapes():
    mesh = rbd.shapes.box()
    with pytest.raises(ValueError, match=r"positions must have shape \(2, 1, 3\)"):
        Trajectory([0, 1], np.zeros((2, 2, 3)), np.zeros((2, 1, 4)), ["a"], [mesh], [[0, 0, 0]])
    with pytest.raises(ValueError, match="non-decreasing"):
        Trajectory([1, 0], np.zeros((2, 1, 3)), np.ones((2, 1, 4)), ["a"], [mesh], [[0, 0, 0]])
    with pytest.raises(ValueError, match="one TriangleMesh per body"):
        Trajectory([0], np.zeros((1, 1, 3)), np.ones((1, 1, 4)), ["a"], [], [[0, 0, 0]])


# ---------------------------------------------------------------------- recorded contacts
def falling_ball_world():
    """A ball dropped 0.2 m onto a static floor: contacts from about 0.2 s on."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    world.add_body(rbd.shapes.box((4, 4, 1)), static=True, position=(0, 0, -0.5), name="floor")
    world.add_body(rbd.shapes.icosphere(0.5, 2), mass=1.0, position=(0, 0, 0.7), name="ball")
    return world


def test_recorded_contacts_are_each_frames_world_contacts():
    world = falling_ball_world()
    trajectory = rbd.simulate(falling_ball_world(), 0.5, record_every=2, record_contacts=True)
    assert trajectory.has_contacts
    assert trajectory.contact_offsets.shape == (len(trajectory) + 1,)
    counts = trajectory.contact_counts()
    assert counts[0] == 0 and counts.sum() == len(trajectory.contact_points) > 0
    # frame f holds the contacts of the step that ended at it, as World.contacts gave them
    for frame in range(1, len(trajectory)):
        world.step(round((trajectory.times[frame] - trajectory.times[frame - 1]) / world.dt))
        expected, recorded = world.contacts, trajectory.contacts(frame)
        np.testing.assert_array_equal(recorded["points"], expected["points"])
        np.testing.assert_array_equal(recorded["normals"], expected["normals"])
        np.testing.assert_array_equal(recorded["bodies"][:, 0], expected["body_a"])
        np.testing.assert_array_equal(recorded["bodies"][:, 1], expected["body_b"])
    # the ball rests on the floor's top face; normals point between the floor and the ball
    last = trajectory.contacts(-1)
    assert len(last["points"]) > 0
    np.testing.assert_allclose(last["points"][:, 2], 0.0, atol=0.01)
    np.testing.assert_allclose(np.abs(last["normals"][:, 2]), 1.0, atol=1e-6)


def test_contacts_are_not_recorded_unless_asked():
    trajectory = rbd.simulate(falling_ball_world(), 0.05)
    assert not trajectory.has_contacts and trajectory.contact_points is None
    with pytest.raises(ValueError, match="no recorded contacts; run simulate"):
        trajectory.contacts(0)


def test_contacts_round_trip_through_the_file(tmp_path):
    trajectory = rbd.simulate(falling_ball_world(), 0.4, record_contacts=True)
    path = tmp_path / "run.npz"
    trajectory.save(path)
    loaded = Trajectory.load(path)
    for field in ("contact_points", "contact_normals", "contact_bodies", "contact_offsets"):
        np.testing.assert_array_equal(getattr(loaded, field), getattr(trajectory, field))
    assert "contacts=" in repr(loaded)
    # without contacts the file has no contact arrays and loads without them
    rbd.simulate(falling_ball_world(), 0.05).save(path)
    with np.load(path) as data:
        assert not any(key.startswith("contact_") for key in data.files)
    assert not Trajectory.load(path).has_contacts


def test_partial_contact_data_is_refused(tmp_path):
    trajectory = rbd.simulate(falling_ball_world(), 0.3, record_contacts=True)
    path = tmp_path / "run.npz"
    trajectory.save(path)
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files if key != "contact_normals"}
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match=r"partial contact data .*missing contact_normals"):
        Trajectory.load(path)


def test_constructor_checks_contacts():
    mesh = rbd.shapes.box()
    frames = ([0, 1], np.zeros((2, 1, 3)), np.ones((2, 1, 4)), ["a"], [mesh], [[0, 0, 0]])
    good = {
        "points": np.zeros((2, 3)),
        "normals": np.zeros((2, 3)),
        "bodies": np.zeros((2, 2), dtype=int),
        "offsets": [0, 0, 2],
    }
    assert Trajectory(*frames, contacts=good).contact_counts().tolist() == [0, 2]
    faults = {
        "need the keys": {"points": good["points"]},
        r"offsets must have shape \(3,\)": {**good, "offsets": [0, 2]},
        "must rise from 0 to the 2 contacts": {**good, "offsets": [0, 2, 1]},
        "they must agree": {**good, "normals": np.zeros((1, 3))},
        "indices below 1": {**good, "bodies": [[0, 1], [0, 0]]},
        "non-finite": {**good, "points": [[0, 0, np.nan], [0, 0, 0]]},
    }
    for message, contacts in faults.items():
        with pytest.raises(ValueError, match=message):
            Trajectory(*frames, contacts=contacts)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("metadata", np.array("[1, 2]"), "metadata must be a JSON object, got list"),
        ("metadata", np.array("{not json"), "metadata is not valid JSON"),
        ("metadata", np.zeros(3), "field 'metadata' must be 0-dimensional text"),
        ("names", np.array("ledge"), "field 'names' must be 1-dimensional text"),
        ("names", np.array(["ledge"]), "field 'vertex_offsets' must be 2 integers rising"),
        ("vertex_offsets", np.array([0.0, 8.0, 16.0]), "field 'vertex_offsets' must be 1-dim"),
        ("vertex_offsets", np.array([0, 9, 16]), None),
        ("face_offsets", np.array([0, 12, 99]), "field 'face_offsets' must be 3 integers"),
        ("mesh_faces", np.zeros((24, 3)), "field 'mesh_faces' must be 2-dimensional integers"),
        ("positions", np.zeros((11, 2)), "field 'positions' must be 3-dimensional floats"),
        ("static", np.zeros(2), "field 'static' must be 1-dimensional booleans"),
        ("times", np.array(["a"]), "field 'times' must be 1-dimensional floats"),
    ],
)
def test_a_malformed_file_is_refused_naming_the_file_and_the_field(tmp_path, field, value, message):
    """Files with the right format tag whose fields have the wrong type or shape raise one
    ValueError naming the file and the field (they raised TypeErrors from deep inside)."""
    path = tmp_path / "run.npz"
    rbd.simulate(two_body_world(), 0.2, record_every=2).save(path)
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    arrays[field] = value
    np.savez(path, **arrays)
    with pytest.raises(ValueError) as raised:
        Trajectory.load(path)
    assert str(raised.value).startswith(f"{path}: ")
    if message is not None:
        assert message in str(raised.value)


def test_metadata_with_numpy_numbers_saves_as_plain_json(tmp_path):
    trajectory = rbd.simulate(two_body_world(), 0.05)
    trajectory.metadata.update(seed=np.int64(7), scale=np.float32(0.5), size=np.arange(3))
    trajectory.save(tmp_path / "run.npz")
    loaded = Trajectory.load(tmp_path / "run.npz").metadata
    assert (loaded["seed"], loaded["scale"], loaded["size"]) == (7, 0.5, [0, 1, 2])
    trajectory.metadata["bad"] = object()
    with pytest.raises(ValueError, match="metadata cannot be saved as JSON: object"):
        trajectory.save(tmp_path / "other.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]


def test_a_name_with_a_nul_character_is_refused():
    """NumPy's fixed-width strings drop trailing NULs, so such a name would not survive a
    save and load."""
    trajectory = rbd.simulate(two_body_world(), 0.05)
    with pytest.raises(ValueError, match="holds a NUL character"):
        Trajectory(
            trajectory.times, trajectory.positions, trajectory.orientations,
            ["ledge", "crate\0"], trajectory.meshes, trajectory.centers_of_mass,
        )  # fmt: skip


def test_joints_are_recorded_and_round_trip_through_the_file(tmp_path):
    """A run records where each joint sits on its bodies (World.joint_frames), which the file
    keeps; a run without joints saves no joint arrays and loads with none."""
    world = rbd.scenes.get("pendulum").build()
    trajectory = rbd.simulate(world, 0.05)
    assert trajectory.joint_names == ["joint0"]
    np.testing.assert_array_equal(trajectory.joint_bodies, [[0, -1]])
    np.testing.assert_allclose(trajectory.joint_anchors, [[[-1, 0, 0], [0, 0, 0]]], atol=1e-15)
    np.testing.assert_allclose(trajectory.joint_axes, [[[0, 1, 0], [0, 1, 0]]], atol=1e-15)
    path = tmp_path / "run.npz"
    trajectory.save(path)
    loaded = Trajectory.load(path)
    for key, value in trajectory.joint_frames.items():
        np.testing.assert_array_equal(loaded.joint_frames[key], value)
    rbd.simulate(two_body_world(), 0.05).save(path)
    with np.load(path) as data:
        assert not any(key.startswith("joint_") for key in data.files)
    assert Trajectory.load(path).joint_names == []


def test_constructor_checks_joints():
    frames = ([0, 1], np.zeros((2, 1, 3)), np.ones((2, 1, 4)), ["a"], [rbd.shapes.box()],
              [[0, 0, 0]])  # fmt: skip
    good = {"names": ["j"], "bodies": [[0, -1]], "anchors": np.zeros((1, 2, 3)),
            "axes": np.zeros((1, 2, 3))}  # fmt: skip
    assert Trajectory(*frames, joints=good).joint_names == ["j"]
    faults = {
        "need the keys": {"names": ["j"]},
        "they must agree": {**good, "names": ["j", "k"]},
        "indices below 1": {**good, "bodies": [[-1, 0]]},
        "non-finite": {**good, "axes": np.full((1, 2, 3), np.inf)},
        "NUL": {**good, "names": ["j\0"]},
    }
    for message, joints in faults.items():
        with pytest.raises(ValueError, match=message):
            Trajectory(*frames, joints=joints)
