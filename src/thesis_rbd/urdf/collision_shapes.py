"""A URDF link's collision and visual geometry as triangle meshes in the link frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from thesis_rbd.geometry import TriangleMesh, shapes

__all__ = [
    "CAPSULE_SECTIONS",
    "CYLINDER_SECTIONS",
    "SPHERE_SUBDIVISIONS",
    "bullet_extensions",
    "collision_meshes",
    "floor_box",
    "mesh_path",
    "visual_meshes",
]

# Tessellation of URDF's curved primitives: a 320-face icosphere (its volume 2.4 % under the
# sphere's) and a 32-sided cylinder (0.6 % under), both inscribed in the true surface.
SPHERE_SUBDIVISIONS = 2
CYLINDER_SECTIONS = 32
# A capsule: 16 sections around and along each cap (512 faces, its volume within 3 % under
# the true one, inscribed)
CAPSULE_SECTIONS = 16
# A plane's box: as deep as this fraction of its smaller side, at least _FLOOR_DEPTH (m); an
# infinite plane is _INFINITE_PLANE (m) across
_FLOOR_FRACTION = 0.05
_FLOOR_DEPTH = 0.1
_INFINITE_PLANE = 200.0


def floor_box(across=(0.0, 0.0), normal=(0.0, 0.0, 1.0)) -> tuple[TriangleMesh, np.ndarray]:
    """A plane as a static box and its pose in the plane's frame: its top face on the plane,
    facing ``normal``; ``across`` (2,) its sides (m; 0: an infinite plane, ``_INFINITE_PLANE``
    across)."""
    sides = [s if s > 0.0 else _INFINITE_PLANE for s in across]
    depth = max(_FLOOR_DEPTH, _FLOOR_FRACTION * min(sides))
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    # the rotation taking the box's z to the normal
    R = Rotation.align_vectors([n], [[0.0, 0.0, 1.0]])[0].as_matrix()
    pose = np.eye(4)
    pose[:3, :3] = R
    pose[:3, 3] = -0.5 * depth * n
    return shapes.box((*sides, depth)), pose


def bullet_extensions(root) -> dict:
    """Bullet's geometry extensions in a parsed URDF (an ElementTree root), replaced in place
    by elements yourdfpy reads (a cylinder, a box) and returned by where they were:
    {(link name, "collision" or "visual", index): ("capsule", radius, length) or ("plane",
    normal)}."""
    found = {}
    for link in root.iter("link"):
        for role in ("collision", "visual"):
            for index, element in enumerate(link.findall(role)):
                geometry = element.find("geometry")
                if geometry is None:
                    continue
                for child in list(geometry):
                    key = (link.get("name"), role, index)
                    if child.tag == "capsule":
                        found[key] = ("capsule", float(child.get("radius")),
                                      float(child.get("length")))  # fmt: skip
                        child.tag = "cylinder"
                    elif child.tag == "plane":
                        normal = np.fromstring(child.get("normal", "0 0 1"), sep=" ")
                        found[key] = ("plane", normal)
                        child.tag, child.attrib = "box", {"size": "1 1 1"}
    return found


def _origin(element) -> np.ndarray:
    """An element's ``<origin>`` as a (4, 4) transform; absent means identity."""
    return np.eye(4) if element.origin is None else np.asarray(element.origin, dtype=float)


def mesh_path(filename: str, urdf_dir: Path) -> Path:
    """Where a ``<mesh filename=...>`` is: relative to the URDF file's folder, or a
    ``package://`` or ``file://`` address. A ``package://`` address is looked for as pybullet
    does, its path after ``package://`` (with or without its first part, the package's name)
    under the URDF's folder and its ancestors; the rest as yourdfpy resolves them. Returns
    the path found, or yourdfpy's answer when none exists."""
    from yourdfpy.urdf import filename_handler_magic

    if filename.startswith("package://"):
        rest = Path(filename[len("package://") :])
        tails = [rest] + ([Path(*rest.parts[1:])] if len(rest.parts) > 1 else [])
        for folder in (urdf_dir, *urdf_dir.parents):
            for tail in tails:
                if (folder / tail).is_file():
                    return folder / tail
    return Path(filename_handler_magic(filename, dir=str(urdf_dir)))


def _mesh(geometry, urdf_dir: Path, convex: bool, link: str, role: str = "collision"):
    import trimesh

    path = mesh_path(geometry.filename, urdf_dir)
    if not path.is_file():
        raise ValueError(
            f"link {link!r}: {role} mesh {geometry.filename!r} not found (looked for {path})"
        )
    where = f"link {link!r}: {role} mesh {geometry.filename!r}"
    loaded = trimesh.load(path, force="mesh")
    if len(loaded.vertices) == 0 or not np.all(np.isfinite(loaded.vertices)):
        raise ValueError(f"{where} has no vertices, or vertices that are not finite numbers")
    if geometry.scale is not None:
        scale = np.asarray(geometry.scale, dtype=float).reshape(-1)
        if scale.size not in (1, 3) or not np.all(np.isfinite(scale)):
            raise ValueError(
                f"{where}: scale must be one or three finite numbers, got {scale.tolist()}"
            )
        loaded.apply_scale(np.broadcast_to(scale, (3,)))
    # a moving link collides through its mesh's convex hull, as pybullet's default does: the
    # convex path is faster, and a visual-quality mesh is often open or self-intersecting
    return TriangleMesh.from_trimesh(loaded.convex_hull if convex else loaded)


def collision_meshes(
    link, urdf_dir: Path, convex: bool, extensions=None
) -> list[tuple[TriangleMesh, np.ndarray]]:
    """Each ``<collision>`` element of a yourdfpy link as (mesh, pose).

    Parameters
    ----------
    link : yourdfpy.Link
    urdf_dir : Path
        The URDF file's folder, which mesh file names are relative to.
    convex : bool
        Take each mesh file's convex hull (a moving link's) instead of the mesh itself.
    extensions : dict, optional
        ``bullet_extensions`` of the file: a capsule (along z, ``CAPSULE_SECTIONS``) or a
        plane (a static link's: ``floor_box``) where the file has Bullet's elements.

    Returns
    -------
    list of (TriangleMesh, (4, 4) ndarray)
        Each mesh in its own frame and the ``<origin>`` placing it in the link frame; boxes,
        spheres and cylinders centred on their origin, a cylinder along its z axis (URDF's
        and ``shapes.cylinder``'s convention alike).

    Raises
    ------
    ValueError
        Naming the link, for a missing mesh file or an element without geometry.
    """
    placed = []
    for index, element in enumerate(link.collisions):
        extension = (extensions or {}).get((link.name, "collision", index))
        if extension is not None and extension[0] == "plane":
            if convex:
                raise ValueError(f"link {link.name!r}: a plane belongs to a static link")
            mesh, offset = floor_box(normal=extension[1])
            placed.append((mesh, _origin(element) @ offset))
            continue
        placed.append((
            _geometry(element.geometry, urdf_dir, convex, link.name, "collision", extension),
            _origin(element),
        ))  # fmt: skip
    return placed


def visual_meshes(
    link, urdf_dir: Path, extensions=None
) -> tuple[list[tuple[TriangleMesh, np.ndarray]], list]:
    """Each ``<visual>`` element of a yourdfpy link as (mesh, pose) in the link frame, as
    ``collision_meshes`` reads them (meshes whole, not their hulls), and the reasons of those
    that could not be read (a missing file, a format trimesh cannot load): a link is still
    drawn, by its collision shape, where its visuals fail, as pybullet draws it."""
    placed, failed = [], []
    for index, element in enumerate(link.visuals):
        extension = (extensions or {}).get((link.name, "visual", index))
        if extension is not None and extension[0] == "plane":
            mesh, offset = floor_box(normal=extension[1])
            placed.append((mesh, _origin(element) @ offset))
            continue
        try:
            mesh = _geometry(element.geometry, urdf_dir, False, link.name, "visual", extension)
        except Exception as exc:  # trimesh raises many kinds for a file it cannot read
            failed.append(str(exc))
            continue
        placed.append((mesh, _origin(element)))
    return placed, failed


def _geometry(g, urdf_dir: Path, convex: bool, link: str, role: str, extension=None):
    """One element's geometry as a mesh in its own frame (see ``collision_meshes``)."""
    if extension is not None:  # a capsule, read by yourdfpy as a cylinder
        return shapes.capsule(extension[1], extension[2], CAPSULE_SECTIONS)
    if g.box is not None:
        return shapes.box(g.box.size)
    if g.sphere is not None:
        return shapes.icosphere(g.sphere.radius, SPHERE_SUBDIVISIONS)
    if g.cylinder is not None:
        return shapes.cylinder(g.cylinder.radius, g.cylinder.length, CYLINDER_SECTIONS)
    if g.mesh is not None:
        return _mesh(g.mesh, urdf_dir, convex, link, role)
    raise ValueError(f"link {link!r}: a {role} element without a box, sphere, cylinder or mesh")
