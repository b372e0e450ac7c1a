"""Primitive closed meshes, outward-oriented, centred at the origin.

Built by ``trimesh.creation`` (a well-kept implementation) and checked closed and consistently
oriented in the tests; sizes are validated here so a zero or negative radius fails clearly.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._validate import as_finite_array, as_positive_scalar
from thesis_rbd.geometry.mesh import TriangleMesh

__all__ = ["MAX_FACES", "box", "capsule", "cylinder", "icosphere", "torus"]

# The most faces a generated shape may have: a few hundred MB with its tree. Asked for more,
# a shape is refused before anything is allocated (an icosphere of 30 subdivisions would
# have 2.3e19 faces); a finer mesh can still be loaded from a file.
MAX_FACES = 2_000_000


def _at_least(value, name: str, minimum: int) -> int:
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _faces_at_most(faces: int, what: str) -> None:
    if faces > MAX_FACES:
        raise ValueError(
            f"{what} would have {faces:.3g} faces; generated shapes have at most {MAX_FACES:,} "
            "(load a finer mesh from a file)"
        )


def box(extents=(1.0, 1.0, 1.0)) -> TriangleMesh:
    """Axis-aligned box of full side lengths ``extents`` (3,), 8 vertices and 12 faces."""
    import trimesh

    extents = as_finite_array(extents, "extents", shape=(3,))
    if np.any(extents <= 0):
        raise ValueError(f"box extents must be positive, got {extents.tolist()}")
    return TriangleMesh.from_trimesh(trimesh.creation.box(extents=extents))


def icosphere(radius: float = 1.0, subdivisions: int = 2) -> TriangleMesh:
    """Geodesic sphere: an icosahedron subdivided ``subdivisions`` times (20 * 4^s faces)."""
    import trimesh

    radius = as_positive_scalar(radius, "radius")
    subdivisions = _at_least(subdivisions, "subdivisions", 0)
    # (in floating point, and capped: the integer 4 ** 1e10 would itself exhaust memory)
    _faces_at_most(
        20.0 * 4.0 ** min(subdivisions, 500), f"an icosphere of subdivisions = {subdivisions}"
    )
    return TriangleMesh.from_trimesh(
        trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    )


def cylinder(radius: float = 0.5, height: float = 1.0, sections: int = 32) -> TriangleMesh:
    """Cylinder along z, ``sections`` sides, caps at z = +-height/2."""
    import trimesh

    radius = as_positive_scalar(radius, "radius")
    height = as_positive_scalar(height, "height")
    sections = _at_least(sections, "sections", 3)
    _faces_at_most(4 * sections, f"a cylinder of sections = {sections}")
    return TriangleMesh.from_trimesh(
        trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
    )


def capsule(radius: float = 0.5, length: float = 1.0, sections: int = 16) -> TriangleMesh:
    """Capsule along z: a cylinder of ``length`` between hemispheres of ``radius`` (ends at
    z = +-(length/2 + radius)), ``sections`` around and along each cap (2 sections^2
    faces)."""
    import trimesh

    radius = as_positive_scalar(radius, "radius")
    length = as_positive_scalar(length, "length")
    sections = _at_least(sections, "sections", 3)
    _faces_at_most(2 * sections**2, f"a capsule of sections = {sections}")
    return TriangleMesh.from_trimesh(
        trimesh.creation.capsule(height=length, radius=radius, count=[sections, sections])
    )


def torus(
    major_radius: float = 1.0,
    minor_radius: float = 0.3,
    major_sections: int = 50,
    minor_sections: int = 50,
) -> TriangleMesh:
    """Ring torus about z: 2 * major_sections * minor_sections faces.

    The defaults are the thesis demo torus (R = 1, r = 0.3, 50 x 50 sections, 5000 faces).
    """
    import trimesh

    major_radius = as_positive_scalar(major_radius, "major_radius")
    minor_radius = as_positive_scalar(minor_radius, "minor_radius")
    if minor_radius >= major_radius:
        raise ValueError(
            f"torus needs minor_radius < major_radius, got {minor_radius} >= {major_radius}"
        )
    major_sections = _at_least(major_sections, "major_sections", 3)
    minor_sections = _at_least(minor_sections, "minor_sections", 3)
    _faces_at_most(
        2 * major_sections * minor_sections,
        f"a torus of {major_sections} x {minor_sections} sections",
    )
    return TriangleMesh.from_trimesh(
        trimesh.creation.torus(
            major_radius=major_radius,
            minor_radius=minor_radius,
            major_sections=major_sections,
            minor_sections=minor_sections,
        )
    )
