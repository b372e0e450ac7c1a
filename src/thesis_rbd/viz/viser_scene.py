"""The bodies of a run as nodes of a viser scene, shared by the live view and the playback page.

viser (three.js in the browser, driven from Python) draws each body's mesh with a depth buffer,
so bodies that interpenetrate at a contact are drawn correctly. A body's mesh is stored once,
relative to its centre of mass, and moved by its pose each frame: a world point is
R(q) (p - c) + x, as in :mod:`thesis_rbd.trajectory`. Contacts are drawn as red points with a
short tick along each normal (from body B towards body A).

viser orders quaternions (w, x, y, z); thesis_rbd orders them (x, y, z, w): the reorder lives
here only (:func:`wxyz_from_xyzw`, :func:`xyzw_from_wxyz`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from thesis_rbd.geometry.mesh import TriangleMesh

__all__ = [
    "VISER_MISSING",
    "BodyNodes",
    "add_floor_grid",
    "body_color",
    "camera_pose",
    "frame_camera",
    "require_viser",
    "scene_bounds",
    "wxyz_from_xyzw",
    "xyzw_from_wxyz",
]

VISER_MISSING = (
    "the live view and the playback page need viser, which is not installed: "
    "pip install viser (or reinstall thesis_rbd: pip install .)"
)

PALETTE = ((214, 96, 61), (61, 126, 214), (92, 170, 90), (224, 170, 48), (150, 98, 196))
STATIC_COLOR = (150, 150, 150)
CONTACT_COLOR = (255, 23, 68)


def require_viser():
    """Import and return ``viser``.

    Raises
    ------
    ValueError
        With the install command (:data:`VISER_MISSING`) when viser is not installed.
    """
    try:
        import viser
    except ImportError as exc:
        raise ValueError(VISER_MISSING) from exc
    return viser


def wxyz_from_xyzw(quaternions: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions reordered from (x, y, z, w) to viser's (w, x, y, z)."""
    quaternions = np.asarray(quaternions, dtype=np.float64)
    return quaternions[..., [3, 0, 1, 2]]


def xyzw_from_wxyz(quaternions: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions reordered from viser's (w, x, y, z) to (x, y, z, w)."""
    quaternions = np.asarray(quaternions, dtype=np.float64)
    return quaternions[..., [1, 2, 3, 0]]


def body_color(index: int, static: bool) -> tuple[int, int, int]:
    """RGB colour of body ``index``: grey when static, else the palette in turn."""
    return STATIC_COLOR if static else PALETTE[index % len(PALETTE)]


def scene_bounds(
    meshes,
    centers_of_mass,
    positions: np.ndarray,
    orientations: np.ndarray,
    samples: int = 50,
    points: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper (3,) corners of the box holding every body's mesh over a run, and
    ``points``.

    Parameters
    ----------
    meshes : sequence of TriangleMesh
        n meshes in their mesh frames.
    centers_of_mass : (n, 3) array_like
        Mesh-frame point each body's position refers to.
    positions : (T, n, 3) array_like
        Centres of mass at each frame.
    orientations : (T, n, 4) array_like
        (x, y, z, w) orientations at each frame.
    samples : int
        Frames looked at, evenly spread over the run (the first and last included).
    points : (k, 3) array_like, optional
        Fixed world points the box holds too (the joints' anchors on the world).
    """
    positions = np.asarray(positions, dtype=np.float64)
    orientations = np.asarray(orientations, dtype=np.float64)
    frames = np.unique(np.linspace(0, len(positions) - 1, samples).round().astype(np.int64))
    lower, upper = np.full(3, np.inf), np.full(3, -np.inf)
    for body, (mesh, center) in enumerate(zip(meshes, centers_of_mass, strict=True)):
        local = mesh.vertices - np.asarray(center, dtype=np.float64)
        rotations = Rotation.from_quat(orientations[frames, body]).as_matrix()
        world = np.einsum("fij,vj->fvi", rotations, local) + positions[frames, body][:, None, :]
        lower = np.minimum(lower, world.reshape(-1, 3).min(axis=0))
        upper = np.maximum(upper, world.reshape(-1, 3).max(axis=0))
    if points is not None and len(points):
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        lower, upper = np.minimum(lower, points.min(axis=0)), np.maximum(upper, points.max(axis=0))
    return lower, upper


class BodyNodes:
    """The meshes of the bodies and the contact markers, as nodes of one viser scene.

    Parameters
    ----------
    scene : viser.SceneApi
        ``server.scene`` of a ``viser.ViserServer``.
    names : sequence of str
        n body names (labels of the nodes).
    meshes : sequence of TriangleMesh
        n meshes in their mesh frames.
    centers_of_mass : (n, 3) array_like
        Mesh-frame point each body's position refers to.
    static : (n,) array_like of bool
        Immovable bodies, drawn grey.
    size : float
        A length that spans the scene (m): contact markers and the floor grid scale with it.

    Attributes
    ----------
    handles : list of viser.MeshHandle
        One per body, in body order; ``handle.name`` is the node's name.
    """

    def __init__(self, scene, names, meshes, centers_of_mass, static, size: float):
        if not size > 0:
            raise ValueError(f"size must be positive, got {size!r}")
        centers = np.asarray(centers_of_mass, dtype=np.float64).reshape(-1, 3)
        static = np.asarray(static, dtype=bool)
        self.scene = scene
        self.size = float(size)
        self.handles = []
        for index, (name, mesh, center) in enumerate(zip(names, meshes, centers, strict=True)):
            if not isinstance(mesh, TriangleMesh):
                raise ValueError(f"body {index} needs a TriangleMesh, got {type(mesh).__name__}")
            label = str(name).replace("/", "_") or f"body{index}"
            self.handles.append(
                scene.add_mesh_simple(
                    f"/bodies/{index}_{label}",
                    vertices=mesh.vertices - center,
                    faces=mesh.faces,
                    color=body_color(index, bool(static[index])),
                    flat_shading=True,
                    # open meshes (a floor plane) show from below too
                    side="front" if mesh.is_closed else "double",
                )
            )
        self.contact_points = scene.add_point_cloud(
            "/contacts/points",
            points=np.zeros((1, 3)),
            colors=CONTACT_COLOR,
            point_size=0.012 * self.size,
            point_shape="circle",
            precision="float32",
            visible=False,
        )
        self.contact_normals = scene.add_line_segments(
            "/contacts/normals",
            points=np.zeros((1, 2, 3)),
            colors=CONTACT_COLOR,
            thickness=0.004 * self.size,
            visible=False,
        )

    def set_poses(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        """Move the bodies: (n, 3) centres of mass and (n, 4) (x, y, z, w) orientations."""
        positions = np.asarray(positions, dtype=np.float64)
        wxyz = wxyz_from_xyzw(orientations)
        for handle, position, rotation in zip(self.handles, positions, wxyz, strict=True):
            handle.position = position
            handle.wxyz = rotation

    def set_contacts(self, points: np.ndarray | None, normals: np.ndarray | None) -> None:
        """Show (c, 3) contact points with their (c, 3) unit normals; None or c = 0 hides them."""
        if points is None or len(points) == 0:
            self.contact_points.visible = False
            self.contact_normals.visible = False
            return
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        self.contact_points.points = points.astype(np.float32)
        self.contact_normals.points = np.stack(
            [points, points + 0.04 * self.size * normals], axis=1
        ).astype(np.float32)
        self.contact_points.visible = True
        self.contact_normals.visible = True


def add_floor_grid(scene, lower: np.ndarray, upper: np.ndarray, size: float):
    """A faint grid in the plane z = lower[2], under the scene's box, for depth cues."""
    center = 0.5 * (np.asarray(lower) + np.asarray(upper))
    span = float(max(upper[0] - lower[0], upper[1] - lower[1], size))
    return scene.add_grid(
        "/floor",
        width=2.0 * span,
        height=2.0 * span,
        plane="xy",
        # a hair below the lowest point: no z-fighting with the bottom face of a floor
        position=(center[0], center[1], lower[2] - 2e-3 * size),
        cell_size=_nice_cell(span / 10.0),
        section_size=_nice_cell(span / 2.0),
    )


def _nice_cell(length: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``length``."""
    exponent = np.floor(np.log10(length))
    for step in (5.0, 2.0, 1.0):
        if step * 10.0**exponent <= length:
            return float(step * 10.0**exponent)
    return float(10.0**exponent)


def camera_pose(lower, upper, fov: float) -> tuple[np.ndarray, np.ndarray]:
    """A camera position and the point it looks at, framing the box [lower, upper].

    From the front right and above, far enough that the box's bounding sphere fits in a vertical
    field of view ``fov`` (radians).

    Returns
    -------
    position, look_at : (3,) float ndarray
    """
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    center = 0.5 * (lower + upper)
    radius = max(0.5 * float(np.linalg.norm(upper - lower)), 1e-6)
    direction = np.array([1.0, -1.6, 0.9])
    direction /= np.linalg.norm(direction)
    distance = 1.05 * radius / np.sin(0.5 * fov)
    return center + distance * direction, center


def frame_camera(server, lower, upper) -> float:
    """Point the initial camera of ``server`` at the box [lower, upper] (:func:`camera_pose`);
    return the camera's distance to the box's centre."""
    position, look_at = camera_pose(lower, upper, float(server.initial_camera.fov))
    distance = float(np.linalg.norm(position - look_at))
    server.initial_camera.look_at = look_at
    server.initial_camera.position = position
    server.initial_camera.near = distance * 1e-3
    server.initial_camera.far = distance * 1e2
    return distance
