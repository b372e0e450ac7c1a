"""Runs and their record: :func:`simulate` steps a world and returns a :class:`Trajectory`.

A trajectory holds the poses of every body at each recorded frame, plus what playback needs to
draw them without the scene: each body's mesh (mesh frame) and the mesh-frame centre of mass
that its recorded position refers to. A mesh vertex p of body i is at

    R(q[t, i]) (p - c[i]) + x[t, i]

in the world at frame t (x: ``positions``, q: ``orientations``, c: ``centers_of_mass``).

A run may also record its contacts (``simulate(..., record_contacts=True)``): every frame's
contact points, normals and body pairs, stored flat with per-frame offsets, so that frame t's
contacts are rows ``contact_offsets[t]:contact_offsets[t + 1]`` of ``contact_points`` (C, 3),
``contact_normals`` (C, 3) and ``contact_bodies`` (C, 2). A trajectory without them has
``contact_offsets`` None.

A run of a world with joints also records where each joint sits on its bodies (constant, in
the bodies' frames: ``World.joint_frames``), so that playback draws the joints: a joint's
anchor on body i is at R(q[t, i]) a + x[t, i] at frame t.

Saved as one ``.npz`` (no pickles), written atomically: complete or not at all. The contact and
joint arrays are saved only when there are some; files without them load as trajectories
without contacts or joints.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from thesis_rbd._atomic import atomic_path
from thesis_rbd.geometry.mesh import TriangleMesh
from thesis_rbd.spatial.quaternion import quat_to_matrix
from thesis_rbd.world import World

__all__ = ["Trajectory", "simulate"]

_FORMAT = "thesis_rbd.trajectory/1"
_ARRAYS = (
    "format",
    "times",
    "positions",
    "orientations",
    "names",
    "centers_of_mass",
    "static",
    "mesh_vertices",
    "mesh_faces",
    "vertex_offsets",
    "face_offsets",
    "metadata",
)
_CONTACT_ARRAYS = ("contact_points", "contact_normals", "contact_bodies", "contact_offsets")
_JOINT_ARRAYS = ("joint_names", "joint_bodies", "joint_anchors", "joint_axes")


class Trajectory:
    """Recorded poses of a run, self-contained for playback.

    Parameters
    ----------
    times : (T,) array_like of float
        Simulation time of each frame (s), non-decreasing.
    positions : (T, n, 3) array_like of float
        World centre of mass of each body at each frame.
    orientations : (T, n, 4) array_like of float
        (x, y, z, w) orientation of each body at each frame.
    names : sequence of str
        n body names.
    meshes : sequence of TriangleMesh
        n meshes, each in its mesh frame: what each body is drawn with (its collision mesh,
        or the visual it was given).
    centers_of_mass : (n, 3) array_like of float
        Mesh-frame point that ``positions`` tracks, per body.
    static : (n,) array_like of bool, optional
        Immovable bodies (drawn in another colour); all False by default.
    metadata : dict, optional
        JSON-serialisable facts about the run (scene, dt, integrator, stages, profile, ...).
    contacts : dict of array_like, optional
        Recorded contacts, all four keys or none: ``points`` and ``normals`` (C, 3) (world
        frame, normals from the second body towards the first), ``bodies`` (C, 2) int body
        indices [a, b], and ``offsets`` (T + 1,) int, non-decreasing from 0 to C: frame t's
        contacts are rows ``offsets[t]:offsets[t + 1]``. None: no contacts were recorded.
    joints : dict of array_like, optional
        Where m joints sit on their bodies, the keys of ``World.joint_frames``: ``names`` (m
        str), ``bodies`` (m, 2) int [body_a, body_b] (-1: the world), ``anchors`` and
        ``axes`` (m, 2, 3) in each body's frame relative to its centre of mass (on the world,
        world frame; axes zero where the kind has none). None: no joints.

    Attributes
    ----------
    contact_points, contact_normals : (C, 3) float ndarray or None
    contact_bodies : (C, 2) int64 ndarray or None
    contact_offsets : (T + 1,) int64 ndarray or None
        The recorded contacts (see ``contacts``); all None when none were recorded.
    joint_names : list of str
    joint_bodies : (m, 2) int64 ndarray
    joint_anchors, joint_axes : (m, 2, 3) float ndarray
        The joints (see ``joints``); m = 0 without joints.

    Raises
    ------
    ValueError
        If the shapes do not agree or a value is not finite.
    """

    def __init__(
        self,
        times,
        positions,
        orientations,
        names,
        meshes,
        centers_of_mass,
        static=None,
        metadata: dict | None = None,
        contacts: dict | None = None,
        joints: dict | None = None,
    ):
        self.times = np.ascontiguousarray(times, dtype=np.float64)
        self.positions = np.ascontiguousarray(positions, dtype=np.float64)
        self.orientations = np.ascontiguousarray(orientations, dtype=np.float64)
        self.names = [str(name) for name in names]
        for name in self.names:
            if "\0" in name:
                # NumPy's fixed-width strings drop trailing NULs: a saved name would change
                raise ValueError(f"trajectory body name {name!r} holds a NUL character")
        self.meshes = list(meshes)
        self.centers_of_mass = np.ascontiguousarray(centers_of_mass, dtype=np.float64)
        n = len(self.names)
        self.static = np.zeros(n, dtype=bool) if static is None else np.asarray(static, dtype=bool)
        self.metadata = dict(metadata or {})
        T = len(self.times)
        expected = {
            "times": (self.times, (T,)),
            "positions": (self.positions, (T, n, 3)),
            "orientations": (self.orientations, (T, n, 4)),
            "centers_of_mass": (self.centers_of_mass, (n, 3)),
            "static": (self.static, (n,)),
        }
        for label, (array, shape) in expected.items():
            if array.shape != shape:
                raise ValueError(
                    f"trajectory {label} must have shape {shape} for {T} frames of {n} bodies, "
                    f"got {array.shape}"
                )
            if array.dtype != bool and not np.all(np.isfinite(array)):
                raise ValueError(f"trajectory {label} holds a non-finite value")
        if len(self.meshes) != n or not all(isinstance(m, TriangleMesh) for m in self.meshes):
            raise ValueError(f"trajectory needs one TriangleMesh per body ({n})")
        if T and np.any(np.diff(self.times) < 0):
            raise ValueError("trajectory times must be non-decreasing")
        self.contact_points = self.contact_normals = None
        self.contact_bodies = self.contact_offsets = None
        if contacts is not None:
            self._set_contacts(contacts)
        self._set_joints(joints)

    def _set_contacts(self, contacts: dict) -> None:
        """Check and store recorded contacts (see the class docstring)."""
        keys = {"points", "normals", "bodies", "offsets"}
        if set(contacts) != keys:
            raise ValueError(
                f"trajectory contacts need the keys {sorted(keys)}, got {sorted(contacts)}"
            )
        points = np.ascontiguousarray(contacts["points"], dtype=np.float64).reshape(-1, 3)
        normals = np.ascontiguousarray(contacts["normals"], dtype=np.float64).reshape(-1, 3)
        bodies = np.ascontiguousarray(contacts["bodies"], dtype=np.int64).reshape(-1, 2)
        offsets = np.ascontiguousarray(contacts["offsets"], dtype=np.int64)
        T, count = len(self.times), len(points)
        if offsets.shape != (T + 1,):
            raise ValueError(
                f"trajectory contact offsets must have shape ({T + 1},) for {T} frames, "
                f"got {offsets.shape}"
            )
        if offsets[0] != 0 or offsets[-1] != count or np.any(np.diff(offsets) < 0):
            raise ValueError(f"trajectory contact offsets must rise from 0 to the {count} contacts")
        if len(normals) != count or len(bodies) != count:
            raise ValueError(
                f"trajectory contacts: {count} points, {len(normals)} normals and "
                f"{len(bodies)} body pairs; they must agree"
            )
        if not (np.all(np.isfinite(points)) and np.all(np.isfinite(normals))):
            raise ValueError("trajectory contacts hold a non-finite value")
        if count and (bodies.min() < 0 or bodies.max() >= self.body_count):
            raise ValueError(f"trajectory contact bodies must be indices below {self.body_count}")
        self.contact_points, self.contact_normals = points, normals
        self.contact_bodies, self.contact_offsets = bodies, offsets

    def _set_joints(self, joints: dict | None) -> None:
        """Check and store the joints (see the class docstring); None: none."""
        keys = {"names", "bodies", "anchors", "axes"}
        if joints is None:
            joints = {"names": [], "bodies": [], "anchors": [], "axes": []}
        if set(joints) != keys:
            raise ValueError(
                f"trajectory joints need the keys {sorted(keys)}, got {sorted(joints)}"
            )
        names = [str(name) for name in joints["names"]]
        bodies = np.ascontiguousarray(joints["bodies"], dtype=np.int64).reshape(-1, 2)
        anchors = np.ascontiguousarray(joints["anchors"], dtype=np.float64).reshape(-1, 2, 3)
        axes = np.ascontiguousarray(joints["axes"], dtype=np.float64).reshape(-1, 2, 3)
        count = len(names)
        if not len(bodies) == len(anchors) == len(axes) == count:
            raise ValueError(
                f"trajectory joints: {count} names, {len(bodies)} body pairs, {len(anchors)} "
                f"anchor pairs and {len(axes)} axis pairs; they must agree"
            )
        if any("\0" in name for name in names):
            raise ValueError("a trajectory joint name holds a NUL character")
        if not (np.all(np.isfinite(anchors)) and np.all(np.isfinite(axes))):
            raise ValueError("trajectory joints hold a non-finite value")
        n = self.body_count
        if count and not (
            np.all((bodies[:, 0] >= 0) & (bodies[:, 0] < n))
            and np.all((bodies[:, 1] >= -1) & (bodies[:, 1] < n))
        ):
            raise ValueError(
                f"trajectory joint bodies must be indices below {n} (body_b -1: the world)"
            )
        self.joint_names, self.joint_bodies = names, bodies
        self.joint_anchors, self.joint_axes = anchors, axes

    # ------------------------------------------------------------------ reading
    def __len__(self) -> int:
        """Number of frames T."""
        return len(self.times)

    @property
    def body_count(self) -> int:
        """Number of bodies n."""
        return len(self.names)

    def frame_at(self, time: float) -> int:
        """Index of the last frame recorded at or before ``time`` (clamped to the run)."""
        return int(np.clip(np.searchsorted(self.times, time, side="right") - 1, 0, len(self) - 1))

    @property
    def has_contacts(self) -> bool:
        """Whether the run recorded its contacts."""
        return self.contact_offsets is not None

    @property
    def joint_frames(self) -> dict:
        """The joints as ``World.joint_frames`` gives them (see ``joints``)."""
        return {
            "names": list(self.joint_names),
            "bodies": self.joint_bodies,
            "anchors": self.joint_anchors,
            "axes": self.joint_axes,
        }

    def contacts(self, frame: int) -> dict[str, np.ndarray]:
        """Contacts recorded at ``frame``: the contacts of the step that ended there.

        Returns
        -------
        dict
            ``points``, ``normals`` (c, 3) and ``bodies`` (c, 2) views of the recorded arrays.

        Raises
        ------
        ValueError
            If the run did not record contacts.
        """
        if not self.has_contacts:
            raise ValueError(
                "this trajectory has no recorded contacts; run simulate(..., record_contacts=True)"
            )
        frame = range(len(self))[frame]  # IndexError for a frame outside the run
        rows = slice(self.contact_offsets[frame], self.contact_offsets[frame + 1])
        return {
            "points": self.contact_points[rows],
            "normals": self.contact_normals[rows],
            "bodies": self.contact_bodies[rows],
        }

    def contact_counts(self) -> np.ndarray:
        """(T,) int64 number of contacts recorded at each frame (needs recorded contacts)."""
        if not self.has_contacts:
            raise ValueError(
                "this trajectory has no recorded contacts; run simulate(..., record_contacts=True)"
            )
        return np.diff(self.contact_offsets)

    def transforms(self, frame: int) -> np.ndarray:
        """(n, 4, 4) rigid transforms from each body's mesh frame to the world at ``frame``."""
        R = quat_to_matrix(self.orientations[frame]).reshape(-1, 3, 3)
        T = np.zeros((self.body_count, 4, 4))
        T[:, :3, :3] = R
        T[:, :3, 3] = self.positions[frame] - np.einsum("nij,nj->ni", R, self.centers_of_mass)
        T[:, 3, 3] = 1.0
        return T

    def world_vertices(self, frame: int, body: int) -> np.ndarray:
        """(v, 3) world positions of ``body``'s mesh vertices at ``frame``."""
        T = self.transforms(frame)[body]
        return self.meshes[body].vertices @ T[:3, :3].T + T[:3, 3]

    def __repr__(self) -> str:
        span = f"{self.times[0]:g}..{self.times[-1]:g} s" if len(self) else "empty"
        contacts = f", contacts={len(self.contact_points)}" if self.has_contacts else ""
        return f"Trajectory(frames={len(self)}, bodies={self.body_count}, {span}{contacts})"

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> None:
        """Write the trajectory to ``path`` as a compressed ``.npz``, atomically.

        The file appears complete or not at all: it is written beside ``path`` under a
        temporary name and renamed over it once on disk.
        """
        vertex_counts = [len(m.vertices) for m in self.meshes]
        face_counts = [len(m.faces) for m in self.meshes]
        arrays = {
            "format": np.array(_FORMAT),
            "times": self.times,
            "positions": self.positions,
            "orientations": self.orientations,
            "names": np.array(self.names, dtype=str),
            "centers_of_mass": self.centers_of_mass,
            "static": self.static,
            "mesh_vertices": np.concatenate([m.vertices for m in self.meshes])
            if self.meshes
            else np.zeros((0, 3)),
            "mesh_faces": np.concatenate([m.faces for m in self.meshes])
            if self.meshes
            else np.zeros((0, 3), dtype=np.int64),
            "vertex_offsets": np.concatenate([[0], np.cumsum(vertex_counts)]).astype(np.int64),
            "face_offsets": np.concatenate([[0], np.cumsum(face_counts)]).astype(np.int64),
            "metadata": np.array(_metadata_json(self.metadata)),
        }
        if self.has_contacts:
            arrays.update(
                contact_points=self.contact_points,
                contact_normals=self.contact_normals,
                contact_bodies=self.contact_bodies,
                contact_offsets=self.contact_offsets,
            )
        if self.joint_names:
            arrays.update(
                joint_names=np.array(self.joint_names, dtype=str),
                joint_bodies=self.joint_bodies,
                joint_anchors=self.joint_anchors,
                joint_axes=self.joint_axes,
            )
        with atomic_path(path) as temporary, open(temporary, "wb") as file:
            np.savez_compressed(file, **arrays)

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """Read a trajectory written by :meth:`save`.

        Raises
        ------
        ValueError
            If the file is missing, unreadable, or not a thesis_rbd trajectory.
        """
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"trajectory file not found: {path}")
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {key: data[key] for key in data.files}
        except Exception as exc:  # zip, npy header and pickle errors all mean "not ours"
            raise ValueError(f"cannot read trajectory {path}: {exc}") from exc
        missing = [key for key in _ARRAYS if key not in arrays]
        if missing or str(arrays["format"]) != _FORMAT:
            raise ValueError(
                f"{path} is not a thesis_rbd trajectory "
                + (f"(missing {', '.join(missing)})" if missing else f"({arrays['format']})")
            )
        try:
            return cls._from_arrays(arrays)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{path}: {exc}") from None

    @classmethod
    def _from_arrays(cls, arrays: dict) -> Trajectory:
        """The trajectory of a file's arrays, each field's type and shape checked first
        (ValueError naming the field)."""
        n = _field(arrays, "names", "U", 1).shape[0]
        vertices = _field(arrays, "mesh_vertices", "f", 2, 3)
        faces = _field(arrays, "mesh_faces", "iu", 2, 3)
        vertex_offsets = _offsets(arrays, "vertex_offsets", n + 1, len(vertices))
        face_offsets = _offsets(arrays, "face_offsets", n + 1, len(faces))
        for key, kinds, dims in (("times", "f", 1), ("positions", "f", 3),
                                 ("orientations", "f", 3), ("centers_of_mass", "f", 2),
                                 ("static", "b", 1)):  # fmt: skip
            _field(arrays, key, kinds, dims)
        contact_fields = (
            ("contact_points", "f", 2),
            ("contact_normals", "f", 2),
            ("contact_bodies", "iu", 2),
            ("contact_offsets", "iu", 1),
        )
        joint_fields = (
            ("joint_names", "U", 1),
            ("joint_bodies", "iu", 2),
            ("joint_anchors", "f", 3),
            ("joint_axes", "f", 3),
        )
        for key, kinds, dims in contact_fields + joint_fields:
            if key in arrays:
                _field(arrays, key, kinds, dims)
        try:
            metadata = json.loads(str(_field(arrays, "metadata", "U", 0)))
        except json.JSONDecodeError as exc:
            raise ValueError(f"metadata is not valid JSON ({exc})") from None
        if not isinstance(metadata, dict):
            raise ValueError(f"metadata must be a JSON object, got {type(metadata).__name__}")
        meshes = [
            TriangleMesh(
                vertices[vertex_offsets[i] : vertex_offsets[i + 1]],
                faces[face_offsets[i] : face_offsets[i + 1]],
            )
            for i in range(n)
        ]
        present = [key for key in _CONTACT_ARRAYS if key in arrays]
        if present and len(present) != len(_CONTACT_ARRAYS):
            missing = sorted(set(_CONTACT_ARRAYS) - set(present))
            raise ValueError(f"partial contact data (missing {', '.join(missing)})")
        contacts = (
            {key.removeprefix("contact_"): arrays[key] for key in _CONTACT_ARRAYS}
            if present
            else None
        )
        return cls(
            arrays["times"],
            arrays["positions"],
            arrays["orientations"],
            arrays["names"].tolist(),
            meshes,
            arrays["centers_of_mass"],
            arrays["static"],
            metadata,
            contacts,
            _joints(arrays),
        )


def _joints(arrays: dict) -> dict | None:
    """A file's joints as ``Trajectory``'s ``joints``: None without them, all four or none."""
    present = [key for key in _JOINT_ARRAYS if key in arrays]
    if not present:
        return None
    if len(present) != len(_JOINT_ARRAYS):
        missing = sorted(set(_JOINT_ARRAYS) - set(present))
        raise ValueError(f"partial joint data (missing {', '.join(missing)})")
    joints = {key.removeprefix("joint_"): arrays[key] for key in _JOINT_ARRAYS}
    joints["names"] = joints["names"].tolist()
    return joints


def _field(arrays: dict, key: str, kinds: str, dims: int, columns: int | None = None):
    """``arrays[key]`` after checking its dtype kind (one of ``kinds``: NumPy's kind letters),
    its number of dimensions and, if given, its last dimension."""
    array = arrays[key]
    if array.dtype.kind not in kinds or array.ndim != dims:
        wanted = {"U": "text", "f": "floats", "iu": "integers", "b": "booleans"}[kinds]
        raise ValueError(
            f"field {key!r} must be {dims}-dimensional {wanted}, got a {array.ndim}-dimensional "
            f"{array.dtype} array"
        )
    if columns is not None and array.shape[-1] != columns:
        raise ValueError(f"field {key!r} must have {columns} columns, got shape {array.shape}")
    return array


def _offsets(arrays: dict, key: str, length: int, end: int):
    """An offsets field: ``length`` integers rising from 0 to ``end``."""
    offsets = _field(arrays, key, "iu", 1)
    if (
        len(offsets) != length
        or offsets[0] != 0
        or offsets[-1] != end
        or np.any(np.diff(offsets) < 0)
    ):
        raise ValueError(f"field {key!r} must be {length} integers rising from 0 to {end}")
    return offsets


def _metadata_json(metadata: dict) -> str:
    """``metadata`` as JSON; NumPy scalars and arrays become numbers and lists."""

    def plain(value):
        if isinstance(value, np.generic):
            return value.item()
        if isinstance(value, np.ndarray):
            return value.tolist()
        raise TypeError(f"{type(value).__name__} is not JSON-serialisable")

    try:
        return json.dumps(metadata, default=plain)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"trajectory metadata cannot be saved as JSON: {exc}") from None


# The most steps one run may take, and the default limit on the memory its recorded frames
# may take (each frame holds 7 float64 per body; contacts come on top).
MAX_STEPS = 10**10
MEMORY_LIMIT = 2**32


def planned_steps(
    seconds: float, dt: float, record_every: int, bodies: int, memory_limit: float = MEMORY_LIMIT
) -> int:
    """The steps a run of ``seconds`` takes at ``dt``, after checking that it is a number of
    steps a run can take and that its recorded frames fit in ``memory_limit`` bytes.

    Raises
    ------
    ValueError
        Naming seconds and dt, or the frames' size with the hint of ``record_every``.
    """
    ratio = seconds / dt
    if not ratio < MAX_STEPS:
        raise ValueError(
            f"seconds = {seconds:g} at dt = {dt:g} is {ratio:.3g} steps; a run takes at most "
            f"{MAX_STEPS:.0e}"
        )
    steps = max(1, math.ceil(ratio - 1e-9))
    frames = steps // record_every + 2
    size = frames * bodies * 7 * 8
    if size > memory_limit:
        raise ValueError(
            f"recording {frames} frames of {bodies} bodies takes {size / 2**30:.3g} GiB, over "
            f"the {memory_limit / 2**30:.3g} GiB limit: record fewer frames (record_every, "
            "--record-every) or raise the limit (memory_limit, --memory-limit)"
        )
    return steps


def simulate(
    world: World,
    seconds: float,
    record_every: int = 1,
    progress: Callable[[int, int], None] | None = None,
    record_contacts: bool = False,
    memory_limit: float = MEMORY_LIMIT,
) -> Trajectory:
    """Step ``world`` for ``seconds`` of simulated time and record its poses.

    Parameters
    ----------
    world : World
        Advanced in place from its current time.
    seconds : float
        Simulated time to run (s), > 0; the run takes ceil(seconds / dt) steps.
    record_every : int
        Record one frame every this many steps. The first frame (the state before the run)
        and the last (after the final step) are always recorded.
    progress : callable(steps_done, steps_total), optional
        Called after each recorded frame.
    record_contacts : bool
        Also record each frame's contacts (:attr:`World.contacts`: points, normals, body
        pairs): those of the step that ended at the frame (with ``record_every`` > 1, the
        contacts of the steps in between are not kept). Frame 0 holds the world's contacts
        before the run (none for a freshly built world).

    memory_limit : float
        Bytes the recorded frames may take (``MEMORY_LIMIT``, 4 GiB, by default): a run
        whose frames would take more is refused before it starts.
    Returns
    -------
    Trajectory
        With metadata ``dt``, ``integrator``, ``steps``, ``stages`` (the stages the world
        planned at the start) and ``profile`` (calls and seconds of each stage during this
        run only), and the world's joints (``World.joint_frames``).
    """
    if not isinstance(world, World):
        raise ValueError(f"world must be a World, got {type(world).__name__}")
    try:
        seconds = float(seconds)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"seconds must be a number, got {seconds!r}") from exc
    if not math.isfinite(seconds) or seconds <= 0:
        raise ValueError(f"seconds must be finite and positive, got {seconds!r}")
    if isinstance(record_every, bool) or int(record_every) != record_every or record_every < 1:
        raise ValueError(f"record_every must be an integer >= 1, got {record_every!r}")
    record_every = int(record_every)
    if not (isinstance(memory_limit, (int, float)) and memory_limit > 0):
        raise ValueError(f"memory_limit must be a positive number of bytes, got {memory_limit!r}")

    total_steps = planned_steps(seconds, world.dt, record_every, len(world), memory_limit)
    frame_steps = np.arange(0, total_steps + 1, record_every)
    if frame_steps[-1] != total_steps:
        frame_steps = np.append(frame_steps, total_steps)
    frames, n = len(frame_steps), len(world)
    times = np.empty(frames)
    positions = np.empty((frames, n, 3))
    orientations = np.empty((frames, n, 4))
    stages = world.stages
    profile_before = {stage: dict(entry) for stage, entry in world.profile.items()}

    contact_frames: list[dict[str, np.ndarray]] = []
    times[0], positions[0], orientations[0] = world.time, world.positions, world.orientations
    if record_contacts:
        contact_frames.append(world.contacts)
    for frame in range(1, frames):
        world.step(int(frame_steps[frame] - frame_steps[frame - 1]))
        times[frame] = world.time
        positions[frame] = world.positions
        orientations[frame] = world.orientations
        if record_contacts:
            contact_frames.append(world.contacts)
        if progress is not None:
            progress(int(frame_steps[frame]), total_steps)

    profile = {
        stage: {
            "calls": entry["calls"] - profile_before[stage]["calls"],
            "seconds": entry["seconds"] - profile_before[stage]["seconds"],
        }
        for stage, entry in world.profile.items()
    }
    bodies = world.bodies
    return Trajectory(
        times,
        positions,
        orientations,
        world.names,
        list(bodies.drawn),
        bodies.center_of_mass_local.copy(),
        bodies.static.copy(),
        metadata={
            "dt": world.dt,
            "integrator": world.integrator,
            "steps": total_steps,
            "stages": stages,
            "profile": profile,
        },
        contacts=_stack_contacts(contact_frames) if record_contacts else None,
        joints=world.joint_frames,
    )


def _stack_contacts(per_frame: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Flatten per-frame ``World.contacts`` dicts into the arrays a Trajectory stores."""
    counts = [len(contacts["points"]) for contacts in per_frame]
    return {
        "points": np.concatenate([c["points"] for c in per_frame]).reshape(-1, 3),
        "normals": np.concatenate([c["normals"] for c in per_frame]).reshape(-1, 3),
        "bodies": np.concatenate(
            [np.stack([c["body_a"], c["body_b"]], axis=1).reshape(-1, 2) for c in per_frame]
        ).astype(np.int64),
        "offsets": np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
    }
