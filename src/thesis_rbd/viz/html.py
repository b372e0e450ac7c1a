"""Playback page: one self-contained, offline HTML file per trajectory, drawn by viser.

The page is viser's own web client (three.js, WebGL, a depth buffer) with the run embedded as
a viser scene recording: the bodies' meshes once, then each frame's poses at its simulated
time, and the recorded contacts when the run has them; joints are drawn on their bodies
(``joint_nodes``) and move with them. viser's player gives it a timeline (a slider), play/pause
(also the space bar), a speed choice and an orbit camera, and loops at the end. Everything is
inside the one file: it opens from disk, with no server and no network.

Frames are thinned to at most ``fps`` per simulated second (the last frame always kept); a
kept frame without contacts shows those of the latest frame it stands for that has some. The
recording is written by a viser server that lives only while the page is made; it listens on
an ephemeral port of 127.0.0.1 and nothing connects to it.
"""

from __future__ import annotations

import contextlib
import html
import io
from pathlib import Path

import numpy as np

from thesis_rbd._atomic import atomic_path
from thesis_rbd.trajectory import Trajectory
from thesis_rbd.viz.frames import playback_frames
from thesis_rbd.viz.joint_nodes import JointNodes, world_anchors
from thesis_rbd.viz.viser_scene import (
    BodyNodes,
    add_floor_grid,
    frame_camera,
    require_viser,
    scene_bounds,
)

__all__ = ["playback_frames", "render_html", "write_html"]

_OVERLAY = (
    '<div id="thesis-rbd-title" style="position:fixed;top:0.6em;left:0.8em;z-index:10;'
    "pointer-events:none;font:14px system-ui,sans-serif;color:#333;"
    'text-shadow:0 0 3px #fff"><b>{heading}</b><br>{subtitle}</div>'
)


@contextlib.contextmanager
def recording_server():
    """A viser server for writing a recording: local, on a free port, and silent.

    viser prints its address when it starts and a line when it stops; neither means anything
    to someone writing a file, so both are kept off the terminal.
    """
    viser = require_viser()
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        yield server
    finally:
        with contextlib.redirect_stdout(io.StringIO()):
            server.stop()


def render_html(trajectory: Trajectory, title: str | None = None, fps: float = 60.0) -> str:
    """Return the playback page of ``trajectory`` as a string.

    Parameters
    ----------
    trajectory : Trajectory
        The run to show.
    title : str, optional
        Page heading; the scene name from the metadata by default.
    fps : float
        Most frames per simulated second kept in the page.

    Raises
    ------
    ValueError
        If the trajectory has no bodies or no frames, or viser is not installed.
    """
    if trajectory.body_count == 0:
        raise ValueError("a trajectory with no bodies cannot be played")
    frames = playback_frames(trajectory.times, fps)
    positions = trajectory.positions[frames]
    orientations = trajectory.orientations[frames]
    joints = trajectory.joint_frames
    lower, upper = scene_bounds(
        trajectory.meshes,
        trajectory.centers_of_mass,
        positions,
        orientations,
        points=world_anchors(joints),
    )
    size = float(np.linalg.norm(upper - lower))
    times = trajectory.times[frames]
    with recording_server() as server:
        nodes = BodyNodes(
            server.scene,
            trajectory.names,
            trajectory.meshes,
            trajectory.centers_of_mass,
            trajectory.static,
            size,
        )
        JointNodes(server.scene, [handle.name for handle in nodes.handles], joints, size)
        add_floor_grid(server.scene, lower, upper, size)
        frame_camera(server, lower, upper)
        contact_frames = _contact_frames(trajectory, frames)
        nodes.set_poses(positions[0], orientations[0])
        _show_contacts(nodes, trajectory, contact_frames, 0)
        recording = server.get_scene_serializer()
        for k in range(1, len(frames)):
            recording.insert_sleep(float(times[k] - times[k - 1]))
            nodes.set_poses(positions[k], orientations[k])
            _show_contacts(nodes, trajectory, contact_frames, k)
        page = recording.as_html()
    return _with_heading(page, trajectory, title)


def _contact_frames(trajectory: Trajectory, frames: np.ndarray) -> np.ndarray | None:
    """For each kept frame, the recorded frame whose contacts it shows.

    A kept frame stands for the frames since the previous one kept: it shows its own
    contacts, or if it has none, those of the latest of its frames that has some, so that an
    impact lasting a single step is not thinned away. None when no contacts were recorded.
    """
    if not trajectory.has_contacts:
        return None
    counts = trajectory.contact_counts()
    recorded = np.arange(len(counts))
    latest_with_contacts = np.maximum.accumulate(np.where(counts > 0, recorded, -1))
    previous = np.concatenate([[-1], frames[:-1]])
    chosen = latest_with_contacts[frames]
    return np.where((counts[frames] == 0) & (chosen > previous), chosen, frames)


def _show_contacts(nodes: BodyNodes, trajectory: Trajectory, contact_frames, k: int) -> None:
    if contact_frames is not None:
        contacts = trajectory.contacts(int(contact_frames[k]))
        nodes.set_contacts(contacts["points"], contacts["normals"])


def _with_heading(page: str, trajectory: Trajectory, title: str | None) -> str:
    """The page with the run's title as its <title> and as a caption over the view."""
    metadata = trajectory.metadata
    heading = html.escape(str(title or metadata.get("scene") or "thesis_rbd trajectory"))
    subtitle = (
        f"{trajectory.body_count} bodies, {trajectory.times[-1] - trajectory.times[0]:.3g} s"
        + (f", {metadata['integrator']} at dt = {metadata['dt']:.4g} s" if "dt" in metadata else "")
        + (", contacts in red" if trajectory.has_contacts else "")
    )
    page = page.replace("<title>Viser</title>", f"<title>{heading}</title>", 1)
    overlay = _OVERLAY.format(heading=heading, subtitle=html.escape(subtitle))
    body_start = page.index("<body>") + len("<body>")
    return page[:body_start] + overlay + page[body_start:]


def write_html(
    trajectory: Trajectory, path: str | Path, title: str | None = None, fps: float = 60.0
) -> Path:
    """Write the playback page of ``trajectory`` to ``path`` atomically; return the path."""
    page = render_html(trajectory, title=title, fps=fps)
    with atomic_path(path) as temporary:
        temporary.write_text(page, encoding="utf-8")
    return Path(path)
