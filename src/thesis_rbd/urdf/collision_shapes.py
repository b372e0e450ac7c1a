"""A URDF link's collision and visual geometry as triangle meshes in the link frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from thesis_rbd.geometry import TriangleMesh, shapes

__all__ = [
    "CYLINDER_SECTIONS",
    "SPHERE_SUBDIVISIONS",
    "collision_meshes",
    "mesh_path",
    "visual_meshes",
]

# Tessellation of URDF's curved primitives: a 320-face icosphere (its volume 2.4 % under the
# sphere's) and a 32-sided cylinder (0.6 % under), both inscribed in the true surface.
SPHERE_SUBDIVISIONS = 2
CYLINDER_SECTIONS = 32


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


def collision_meshes(link, urdf_dir: Path, convex: bool) -> list[tuple[TriangleMesh, np.ndarray]]:
    """Each ``<collision>`` element of a yourdfpy link as (mesh, pose).

    Parameters
    ----------
    link : yourdfpy.Link
    urdf_dir : Path
        The URDF file's folder, which mesh file names are relative to.
    convex : bool
        Take each mesh file's convex hull (a moving link's) instead of the mesh itself.

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
    return [
        (_geometry(element.geometry, urdf_dir, convex, link.name, "collision"), _origin(element))
        for element in link.collisions
    ]


def visual_meshes(link, urdf_dir: Path) -> tuple[list[tuple[TriangleMesh, np.ndarray]], list]:
    """Each ``<visual>`` element of a yourdfpy link as (mesh, pose) in the link frame, as
    ``collision_meshes`` reads them (meshes whole, not their hulls), and the reasons of those
    that could not be read (a missing file, a format trimesh cannot load): a link is still
    drawn, by its collision shape, where its visuals fail, as pybullet draws it."""
    placed, failed = [], []
    for element in link.visuals:
        try:
            mesh = _geometry(element.geometry, urdf_dir, False, link.name, "visual")
        except Exception as exc:  # trimesh raises many kinds for a file it cannot read
            failed.append(str(exc))
            continue
        placed.append((mesh, _origin(element)))
    return placed, failed


def _geometry(g, urdf_dir: Path, convex: bool, link: str, role: str) -> TriangleMesh:
    """One element's geometry as a mesh in its own frame (see ``collision_meshes``)."""
    if g.box is not None:
        return shapes.box(g.box.size)
    if g.sphere is not None:
        return shapes.icosphere(g.sphere.radius, SPHERE_SUBDIVISIONS)
    if g.cylinder is not None:
        return shapes.cylinder(g.cylinder.radius, g.cylinder.length, CYLINDER_SECTIONS)
    if g.mesh is not None:
        return _mesh(g.mesh, urdf_dir, convex, link, role)
    raise ValueError(
        f"link {link!r}: a {role} element without a box, sphere, cylinder or mesh (Bullet's "
        "capsule and plane extensions are not read yet)"
    )
