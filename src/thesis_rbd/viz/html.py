"""Playback page: one self-contained, offline HTML file per trajectory.

The page (template ``player.html`` beside this module) draws the bodies on a ``<canvas>`` with
inline JavaScript (flat-shaded triangles, painter's algorithm, orbit camera), with play/pause,
a time slider and a speed choice. The trajectory is embedded in the page as JSON with base64
arrays: no network reference, no server, no WebGL, opens from disk in any browser.

Frames are thinned to at most ``fps`` per simulated second (the last frame always kept), and
poses and vertices are stored as float32, which is far below screen resolution. A trajectory
that recorded its contacts carries the contacts of the frames kept; the page draws them as
dots with a short tick along the normal, over the bodies, with a checkbox to hide them.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from pathlib import Path

import numpy as np

from thesis_rbd._atomic import atomic_path
from thesis_rbd.trajectory import Trajectory

__all__ = ["playback_frames", "render_html", "write_html"]


def playback_frames(times: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the frames to show at ``fps`` frames per simulated second.

    Parameters
    ----------
    times : (T,) float ndarray
        Non-decreasing frame times (s).
    fps : float
        Frames per simulated second, > 0.

    Returns
    -------
    (k,) int64 ndarray
        Increasing indices: for each tick of a 1/fps grid from ``times[0]``, the last frame at
        or before it; the last frame is always included.
    """
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps!r}")
    times = np.asarray(times, dtype=np.float64)
    if len(times) == 0:
        raise ValueError("a trajectory with no frames cannot be played")
    ticks = times[0] + np.arange(int(np.floor((times[-1] - times[0]) * fps + 1e-9)) + 1) / fps
    indices = np.searchsorted(times, ticks + 1e-12, side="right") - 1
    return np.unique(np.append(indices, len(times) - 1)).astype(np.int64)


def _b64(array: np.ndarray, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def _contact_data(trajectory: Trajectory, frames: np.ndarray) -> dict:
    """The recorded contacts of ``frames``, flattened with per-frame offsets, as base64."""
    per_frame = [trajectory.contacts(int(frame)) for frame in frames]
    counts = [len(contacts["points"]) for contacts in per_frame]
    return {
        "points": _b64(np.concatenate([c["points"] for c in per_frame]), "<f4"),
        "normals": _b64(np.concatenate([c["normals"] for c in per_frame]), "<f4"),
        "offsets": _b64(np.concatenate([[0], np.cumsum(counts)]), "<u4"),
    }


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
    """
    if trajectory.body_count == 0:
        raise ValueError("a trajectory with no bodies cannot be played")
    frames = playback_frames(trajectory.times, fps)
    positions = trajectory.positions[frames]
    orientations = trajectory.orientations[frames]
    # vertices relative to each body's centre of mass: world = R v + x
    body_vertices = [
        mesh.vertices - com
        for mesh, com in zip(trajectory.meshes, trajectory.centers_of_mass, strict=True)
    ]
    reach = max(float(np.linalg.norm(v, axis=1).max()) for v in body_vertices)
    bounds = np.concatenate(
        [positions.reshape(-1, 3).min(axis=0) - reach, positions.reshape(-1, 3).max(axis=0) + reach]
    )
    data = {
        "times": _b64(trajectory.times[frames], "<f8"),
        "poses": _b64(np.concatenate([positions, orientations], axis=2), "<f4"),
        "bounds": bounds.tolist(),
        "bodies": [
            {
                "name": name,
                "static": bool(static),
                "vertices": _b64(vertices, "<f4"),
                "faces": _b64(mesh.faces, "<u4"),
            }
            for name, static, vertices, mesh in zip(
                trajectory.names, trajectory.static, body_vertices, trajectory.meshes, strict=True
            )
        ],
    }
    if trajectory.has_contacts:
        data["contacts"] = _contact_data(trajectory, frames)
    metadata = trajectory.metadata
    heading = title or metadata.get("scene") or "thesis_rbd trajectory"
    subtitle = (
        f"{trajectory.body_count} bodies, {trajectory.times[-1] - trajectory.times[0]:.3g} s"
        + (f", {metadata['integrator']} at dt = {metadata['dt']:.4g} s" if "dt" in metadata else "")
        + (f". {metadata['summary']}" if metadata.get("summary") else "")
    )
    template = resources.files("thesis_rbd.viz").joinpath("player.html").read_text("utf-8")
    # "</" inside a <script> would end it early; JSON allows the escaped form
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return (
        template.replace("__TITLE__", html.escape(str(heading)))
        .replace("__SUBTITLE__", html.escape(subtitle))
        .replace("__DATA__", payload)
    )


def write_html(
    trajectory: Trajectory, path: str | Path, title: str | None = None, fps: float = 60.0
) -> Path:
    """Write the playback page of ``trajectory`` to ``path`` atomically; return the path."""
    page = render_html(trajectory, title=title, fps=fps)
    with atomic_path(path) as temporary:
        temporary.write_text(page, encoding="utf-8")
    return Path(path)
