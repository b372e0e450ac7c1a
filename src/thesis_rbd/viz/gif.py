"""Animated GIF of a trajectory through matplotlib (optional dependency), for READMEs and papers.

Each frame draws every body's triangles as a ``Poly3DCollection`` in a fixed 3D view framing
the whole run; frames are thinned to ``fps`` per simulated second and written by Pillow.
Recorded contacts (``simulate(..., record_contacts=True)``) are drawn as red dots over the
bodies.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from thesis_rbd._atomic import atomic_path
from thesis_rbd.trajectory import Trajectory
from thesis_rbd.viz.frames import playback_frames

__all__ = ["require_matplotlib", "write_gif"]

_CONTACT_COLOR = "#ff1744"
_PALETTE = ("#d6603d", "#3d7ed6", "#5caa5a", "#e0aa30", "#9662c4", "#40b2b2", "#cd5c96")


def require_matplotlib():
    """Import and return ``matplotlib`` set to a file-only backend.

    Raises
    ------
    ValueError
        With the install command when matplotlib is not installed.
    """
    try:
        import matplotlib
    except ImportError as exc:
        raise ValueError(
            "writing a GIF needs matplotlib, which is not installed: "
            "pip install 'thesis_rbd[viz]' (or pip install matplotlib)"
        ) from exc
    matplotlib.use("Agg", force=True)
    return matplotlib


def write_gif(
    trajectory: Trajectory,
    path: str | Path,
    fps: float = 20.0,
    size_pixels: int = 480,
    title: str | None = None,
) -> Path:
    """Write an animated GIF of ``trajectory`` to ``path`` atomically; return the path.

    Parameters
    ----------
    trajectory : Trajectory
        The run to draw.
    path : str or Path
        Destination ``.gif``.
    fps : float
        Frames per simulated second (and played back at the same rate: real time).
    size_pixels : int
        Width and height of the image.
    title : str, optional
        Text above the view; the time is appended to it on each frame.
    """
    require_matplotlib()
    import matplotlib.pyplot as plt
    from matplotlib.animation import PillowWriter
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    if trajectory.body_count == 0:
        raise ValueError("a trajectory with no bodies cannot be drawn")
    frames = playback_frames(trajectory.times, fps)
    corners = np.concatenate(
        [
            trajectory.world_vertices(f, b)
            for f in frames[[0, -1]]
            for b in range(trajectory.body_count)
        ]
    )
    reach = max(
        float(np.linalg.norm(m.vertices - c, axis=1).max())
        for m, c in zip(trajectory.meshes, trajectory.centers_of_mass, strict=True)
    )
    low = np.minimum(corners.min(axis=0), trajectory.positions.reshape(-1, 3).min(axis=0) - reach)
    high = np.maximum(corners.max(axis=0), trajectory.positions.reshape(-1, 3).max(axis=0) + reach)
    middle, half = 0.5 * (low + high), 0.5 * float((high - low).max())

    dpi = 100
    figure = plt.figure(figsize=(size_pixels / dpi, size_pixels / dpi), dpi=dpi)
    axes = figure.add_subplot(projection="3d")
    if trajectory.has_contacts:
        # draw in the order added, so the contacts stay over the bodies (the bodies then
        # overlap one another in body order rather than by depth)
        axes.computed_zorder = False
    colors = [
        "#969696" if static else _PALETTE[i % len(_PALETTE)]
        for i, static in enumerate(trajectory.static)
    ]
    label = title or trajectory.metadata.get("scene", "")
    try:
        with atomic_path(path) as temporary:
            writer = PillowWriter(fps=fps)
            with writer.saving(figure, str(temporary), dpi):
                for frame in frames:
                    axes.cla()
                    for body in range(trajectory.body_count):
                        triangles = trajectory.world_vertices(frame, body)[
                            trajectory.meshes[body].faces
                        ]
                        axes.add_collection3d(
                            Poly3DCollection(
                                triangles,
                                facecolors=colors[body],
                                linewidths=0.0,
                                shade=True,
                                zorder=1,
                            )
                        )
                    if trajectory.has_contacts:
                        points = trajectory.contacts(int(frame))["points"]
                        axes.scatter(
                            points[:, 0],
                            points[:, 1],
                            points[:, 2],
                            color=_CONTACT_COLOR,
                            s=10,
                            depthshade=False,
                            zorder=2,
                        )
                    axes.set_xlim(middle[0] - half, middle[0] + half)
                    axes.set_ylim(middle[1] - half, middle[1] + half)
                    axes.set_zlim(middle[2] - half, middle[2] + half)
                    axes.set_box_aspect((1, 1, 1))
                    axes.set_xlabel("x")
                    axes.set_ylabel("y")
                    axes.set_zlabel("z")
                    axes.set_title(f"{label}  t = {trajectory.times[frame]:.2f} s".strip())
                    writer.grab_frame()
    finally:
        plt.close(figure)
    return Path(path)
