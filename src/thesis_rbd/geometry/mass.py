"""Mass properties of closed triangle meshes by the divergence theorem.

The volume integrals of 1, x, y, z, x^2, y^2, z^2, xy, yz, zx over a closed polyhedron become
sums over its triangles (Mirtich 1996, in the compact form of Eberly, "Polyhedral Mass
Properties (Revisited)", 2002). The result is exact for any closed, consistently outward
oriented polyhedron, convex or not, of any genus (thesis 3.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thesis_rbd._validate import as_positive_scalar
from thesis_rbd.geometry.mesh import TriangleMesh

__all__ = ["MassProperties", "mass_properties"]


@dataclass(frozen=True)
class MassProperties:
    """Mass, volume, centre of mass and inertia of a uniform-density solid.

    Attributes
    ----------
    mass : float
        Total mass (kg).
    volume : float
        Enclosed volume (m^3).
    density : float
        mass / volume (kg/m^3).
    center_of_mass : (3,) float
        Centre of mass in the mesh frame.
    inertia : (3, 3) float
        Inertia tensor about the centre of mass, axes parallel to the mesh frame.
    """

    mass: float
    volume: float
    density: float
    center_of_mass: np.ndarray
    inertia: np.ndarray

    def principal_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Principal moments (3,) ascending and axes (3, 3), column k the axis of moment k."""
        moments, axes = np.linalg.eigh(self.inertia)
        return moments, axes


def _subexpressions(w0, w1, w2):
    """Eberly's per-triangle polynomial terms along one coordinate (arrays of shape (m,))."""
    temp0 = w0 + w1
    f1 = temp0 + w2
    temp1 = w0 * w0
    temp2 = temp1 + w1 * temp0
    f2 = temp2 + w2 * f1
    f3 = w0 * temp1 + w1 * temp2 + w2 * f2
    g0 = f2 + w0 * (f1 + w0)
    g1 = f2 + w1 * (f1 + w1)
    g2 = f2 + w2 * (f1 + w2)
    return f1, f2, f3, g0, g1, g2


def _volume_integrals(triangles: np.ndarray) -> np.ndarray:
    """Integrals of (1, x, y, z, x^2, y^2, z^2, xy, yz, zx) over the solid, shape (10,)."""
    p0, p1, p2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    d = np.cross(p1 - p0, p2 - p0)
    f1x, f2x, f3x, g0x, g1x, g2x = _subexpressions(p0[:, 0], p1[:, 0], p2[:, 0])
    _, f2y, f3y, g0y, g1y, g2y = _subexpressions(p0[:, 1], p1[:, 1], p2[:, 1])
    _, f2z, f3z, g0z, g1z, g2z = _subexpressions(p0[:, 2], p1[:, 2], p2[:, 2])
    x0, x1, x2 = p0[:, 0], p1[:, 0], p2[:, 0]
    y0, y1, y2 = p0[:, 1], p1[:, 1], p2[:, 1]
    z0, z1, z2 = p0[:, 2], p1[:, 2], p2[:, 2]
    sums = np.array(
        [
            np.sum(d[:, 0] * f1x),
            np.sum(d[:, 0] * f2x),
            np.sum(d[:, 1] * f2y),
            np.sum(d[:, 2] * f2z),
            np.sum(d[:, 0] * f3x),
            np.sum(d[:, 1] * f3y),
            np.sum(d[:, 2] * f3z),
            np.sum(d[:, 0] * (y0 * g0x + y1 * g1x + y2 * g2x)),
            np.sum(d[:, 1] * (z0 * g0y + z1 * g1y + z2 * g2y)),
            np.sum(d[:, 2] * (x0 * g0z + x1 * g1z + x2 * g2z)),
        ]
    )
    weights = np.array([6, 24, 24, 24, 60, 60, 60, 120, 120, 120], dtype=np.float64)
    return sums / weights


def mass_properties(
    mesh: TriangleMesh, density: float | None = 1.0, mass: float | None = None
) -> MassProperties:
    """Mass, centre of mass and inertia of a closed mesh filled with uniform density.

    Parameters
    ----------
    mesh : TriangleMesh
        Closed, consistently and outward-oriented surface.
    density : float, optional
        Density (kg/m^3), > 0. Ignored when ``mass`` is given.
    mass : float, optional
        Total mass (kg), > 0; the density becomes mass / volume.

    Returns
    -------
    MassProperties
        With ``inertia`` (3, 3) about the centre of mass in the mesh frame.

    Raises
    ------
    ValueError
        If the mesh is open, inconsistently oriented, inward-oriented (negative volume) or
        encloses no volume, or if density or mass is not finite and positive.
    """
    if not isinstance(mesh, TriangleMesh):
        raise ValueError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
    if mass is not None:
        mass = as_positive_scalar(mass, "mass")
    else:
        if density is None:
            raise ValueError("give a density or a mass")
        density = as_positive_scalar(density, "density")
    if not mesh.is_closed:
        raise ValueError("mesh is open (an edge is not shared by exactly two faces): no volume")
    if not mesh.is_consistently_oriented:
        raise ValueError("mesh faces are inconsistently oriented: volume is undefined")

    # Integrate about the vertex centroid: far from the origin the raw monomials would cancel
    # catastrophically in the parallel-axis step.
    origin = mesh.vertices.mean(axis=0)
    integrals = _volume_integrals(mesh.triangles - origin)
    volume = integrals[0]
    if not volume > 1e-12 * mesh.scale**3:
        if volume < 0:
            raise ValueError(f"mesh is oriented inward (signed volume {volume:.6g} < 0)")
        raise ValueError(f"mesh encloses no volume (signed volume {volume:.6g})")
    if mass is not None:
        density = mass / volume
    else:
        mass = density * volume

    c = integrals[1:4] / volume
    xx, yy, zz, xy, yz, zx = integrals[4:10]
    inertia_unit = np.array(
        [
            [
                yy + zz - volume * (c[1] ** 2 + c[2] ** 2),
                -(xy - volume * c[0] * c[1]),
                -(zx - volume * c[2] * c[0]),
            ],
            [
                -(xy - volume * c[0] * c[1]),
                xx + zz - volume * (c[2] ** 2 + c[0] ** 2),
                -(yz - volume * c[1] * c[2]),
            ],
            [
                -(zx - volume * c[2] * c[0]),
                -(yz - volume * c[1] * c[2]),
                xx + yy - volume * (c[0] ** 2 + c[1] ** 2),
            ],
        ]
    )
    return MassProperties(
        mass=float(mass),
        volume=float(volume),
        density=float(density),
        center_of_mass=c + origin,
        inertia=density * inertia_unit,
    )
