"""Runs and their record: :func:`simulate` steps a world and returns a :class:`Trajectory`.

A trajectory holds the poses of every body at each recorded frame, plus what playback needs to
draw them without the scene: each body's mesh (mesh frame) and the mesh-frame centre of mass
that its recorded position refers to. A mesh vertex p of body i is at

    R(q[t, i]) (p - c[i]) + x[t, i]

in the world at frame t (x: ``positions``, q: ``orientations``, c: ``centers_of_mass``).

Saved as one ``.npz`` (no pickles), written atomically: complete or not at all.
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
        n meshes, each in its mesh frame.
    centers_of_mass : (n, 3) array_like of float
        Mesh-frame point that ``positions`` tracks, per body.
    static : (n,) array_like of bool, optional
        Immovable bodies (drawn in another colour); all False by default.
    metadata : dict, optional
        JSON-serialisable facts about the run (scene, dt, integrator, stages, profile, ...).

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
    ):
        self.times = np.ascontiguousarray(times, dtype=np.float64)
        self.positions = np.ascontiguousarray(positions, dtype=np.float64)
        self.orientations = np.ascontiguousarray(orientations, dtype=np.float64)
        self.names = [str(name) for name in names]
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
        return f"Trajectory(frames={len(self)}, bodies={self.body_count}, {span})"

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
            "metadata": np.array(json.dumps(self.metadata)),
        }
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
        vertex_offsets, face_offsets = arrays["vertex_offsets"], arrays["face_offsets"]
        meshes = [
            TriangleMesh(
                arrays["mesh_vertices"][vertex_offsets[i] : vertex_offsets[i + 1]],
                arrays["mesh_faces"][face_offsets[i] : face_offsets[i + 1]],
            )
            for i in range(len(vertex_offsets) - 1)
        ]
        return cls(
            arrays["times"],
            arrays["positions"],
            arrays["orientations"],
            arrays["names"].tolist(),
            meshes,
            arrays["centers_of_mass"],
            arrays["static"],
            json.loads(str(arrays["metadata"])),
        )


def simulate(
    world: World,
    seconds: float,
    record_every: int = 1,
    progress: Callable[[int, int], None] | None = None,
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

    Returns
    -------
    Trajectory
        With metadata ``dt``, ``integrator``, ``steps``, ``stages`` (the stages the world
        planned at the start) and ``profile`` (calls and seconds of each stage during this
        run only).
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

    total_steps = max(1, math.ceil(seconds / world.dt - 1e-9))
    frame_steps = np.arange(0, total_steps + 1, record_every)
    if frame_steps[-1] != total_steps:
        frame_steps = np.append(frame_steps, total_steps)
    frames, n = len(frame_steps), len(world)
    times = np.empty(frames)
    positions = np.empty((frames, n, 3))
    orientations = np.empty((frames, n, 4))
    stages = world.stages
    profile_before = {stage: dict(entry) for stage, entry in world.profile.items()}

    times[0], positions[0], orientations[0] = world.time, world.positions, world.orientations
    for frame in range(1, frames):
        world.step(int(frame_steps[frame] - frame_steps[frame - 1]))
        times[frame] = world.time
        positions[frame] = world.positions
        orientations[frame] = world.orientations
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
        list(bodies.meshes),
        bodies.center_of_mass_local.copy(),
        bodies.static.copy(),
        metadata={
            "dt": world.dt,
            "integrator": world.integrator,
            "steps": total_steps,
            "stages": stages,
            "profile": profile,
        },
    )
