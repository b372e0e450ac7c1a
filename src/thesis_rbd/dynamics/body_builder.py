"""Building a body: from a mesh and the user's description to the row the body arrays store.

Validation happens here, once per body, so the stepping code never meets bad input: every
value is checked and named in the error; mass properties come from the mesh (closed meshes
only, for a dynamic body); the state (x, q, P, L) is set from the velocities given.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._validate import as_finite_array, as_positive_scalar, as_unit_quaternion
from thesis_rbd.geometry.mass import mass_properties
from thesis_rbd.geometry.mesh import TriangleMesh
from thesis_rbd.geometry.width import hull_thickness
from thesis_rbd.spatial.quaternion import quat_to_matrix

__all__ = ["body_fields"]


def _check_mass_properties(m, inv_m, inertia, inv_inertia, name: str, size: float) -> None:
    """Refuse a body whose mass or inertia, or their inverses, are not finite and positive
    (a mass of 1e-320 has an infinite inverse, a 1e-100 m box an inertia of zero): no step
    could move it. ``size`` is the mesh's, for the message."""
    finite = (
        0.0 < m < math.inf and 0.0 < inv_m < math.inf
        and bool(np.all(np.isfinite(inertia))) and bool(np.all(np.isfinite(inv_inertia)))
    )  # fmt: skip
    if not finite:
        raise ValueError(
            f"{name} gives this body ({size:.3g} m across) mass properties that over- or "
            f"underflow (mass {m!r}, inverse mass {inv_m!r}, inertia diagonal "
            f"{np.diag(inertia).tolist()}): choose a size and {name} that make them finite "
            "and positive"
        )


def body_fields(
    mesh,
    mass=None,
    density=None,
    position=(0.0, 0.0, 0.0),
    orientation=(0.0, 0.0, 0.0, 1.0),
    linear_velocity=(0.0, 0.0, 0.0),
    angular_velocity=(0.0, 0.0, 0.0),
    restitution=0.0,
    friction=0.0,
    static=False,
    collidable=True,
    collision_group=1,
    collision_mask=0xFFFF,
    kinematic=False,
) -> dict:
    """Every ``BodyArrays`` field of one body, validated (see ``World.add_body``).

    Raises
    ------
    ValueError
        Naming the argument that is wrong.
    """
    if not isinstance(mesh, TriangleMesh):
        raise ValueError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
    if mass is not None and density is not None:
        raise ValueError("give mass or density, not both")
    if kinematic and static:
        raise ValueError("a body is static or kinematic, not both: a kinematic body is moved")
    if kinematic and (mass is not None or density is not None):
        raise ValueError(
            "a kinematic body takes no mass or density: contacts and joints cannot move it, "
            "so to them it is infinitely heavy"
        )
    position = as_finite_array(position, "position", shape=(3,))
    q = as_unit_quaternion(orientation)
    v = as_finite_array(linear_velocity, "linear_velocity", shape=(3,))
    w = as_finite_array(angular_velocity, "angular_velocity", shape=(3,))
    restitution = float(restitution)
    if not 0.0 <= restitution <= 1.0:
        raise ValueError(f"restitution must lie in [0, 1], got {restitution!r}")
    friction = float(friction)
    if not (math.isfinite(friction) and friction >= 0.0):
        raise ValueError(f"friction must be finite and >= 0, got {friction!r}")

    if static or kinematic:
        center = (
            mass_properties(mesh).center_of_mass
            if mesh.is_closed and mesh.is_consistently_oriented
            else np.zeros(3)
        )
        m, inv_m = math.inf, 0.0
        inertia, inv_inertia = np.zeros((3, 3)), np.zeros((3, 3))
        P, L = np.zeros(3), np.zeros(3)
        v_kinematic, w_kinematic = (v, w) if kinematic else (np.zeros(3), np.zeros(3))
    else:
        if mass is not None:
            props = mass_properties(mesh, mass=as_positive_scalar(mass, "mass"))
        else:
            props = mass_properties(mesh, density=1.0 if density is None else density)
        center, m, inertia = props.center_of_mass, props.mass, props.inertia
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            inv_m = 1.0 / m
            try:
                inv_inertia = np.linalg.inv(inertia)
            except np.linalg.LinAlgError:  # an inertia that underflowed to zero
                inv_inertia = np.full((3, 3), math.inf)
            R = quat_to_matrix(q)
            P = m * v
            L = R @ inertia @ R.T @ w
        v_kinematic, w_kinematic = np.zeros(3), np.zeros(3)
        _check_mass_properties(
            m, inv_m, inertia, inv_inertia, "mass" if mass else "density", mesh.scale
        )
        for name, value in (("linear_velocity", P), ("angular_velocity", L)):
            if not np.all(np.isfinite(value)):
                raise ValueError(
                    f"{name} gives this body a momentum that overflows ({value.tolist()}): "
                    "choose a smaller one"
                )
    radius = float(np.linalg.norm(mesh.vertices - center, axis=1).max())
    return dict(
        position=position,
        orientation=q,
        linear_momentum=P,
        angular_momentum=L,
        inverse_mass=inv_m,
        inverse_inertia_body=inv_inertia,
        mass=m,
        inertia_body=inertia,
        center_of_mass_local=center,
        size=radius,
        # a flat mesh has no thickness; a thousandth of its radius keeps sampling finite
        thickness=max(hull_thickness(mesh.vertices), 1e-3 * radius),
        restitution=restitution,
        friction=friction,
        static=bool(static or kinematic),
        kinematic=bool(kinematic),
        kinematic_velocity=v_kinematic,
        kinematic_angular_velocity=w_kinematic,
        collidable=bool(collidable),
        collision_group=_bits(collision_group, "collision_group"),
        collision_mask=_bits(collision_mask, "collision_mask"),
    )


def _bits(value, name: str) -> int:
    """A collision group or mask: a non-negative integer that fits in 62 bits."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer bit field, got {value!r}")
    if not 0 <= value < 2**62:
        raise ValueError(f"{name} must lie in [0, 2**62), got {value}")
    return int(value)
