"""Building a body: from a mesh and the user's description to the row the body arrays store.

Validation happens here, once per body, so the stepping code never meets bad input: every
value is checked and named in the error; mass properties come from the mesh (closed meshes
only, for a dynamic body) or are given explicitly (a URDF link's mass, centre of mass and
inertia tensor, its mesh then only collision geometry, open or in pieces); the state
(x, q, P, L) is set from the velocities given.

A compound body is several meshes, each placed in the body's mesh frame by a pose; they are
merged into one mesh (the parts share no vertex, so the merged mesh is closed exactly when
every part is, and its volume integrals are the sums of the parts').
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._validate import (
    as_finite_array,
    as_positive_scalar,
    as_rigid_transform,
    as_unit_quaternion,
)
from thesis_rbd.geometry.mass import mass_properties
from thesis_rbd.geometry.mesh import TriangleMesh
from thesis_rbd.geometry.width import hull_thickness
from thesis_rbd.spatial.quaternion import quat_to_matrix

__all__ = ["body_fields", "body_shape", "explicit_mass_properties"]

# Largest asymmetry |I - I^T| of an inertia tensor, relative to its largest entry, taken as
# round-off (R diag(I) R^T computed in floating point) and symmetrised away.
_SYMMETRY_TOLERANCE = 1e-9
# Largest excess of the greatest principal moment over the sum of the other two, relative to
# it: model files write inertias to about six digits, and a flat plate meets the triangle
# inequality with equality, so a stricter test would refuse plates read from files.
_TRIANGLE_TOLERANCE = 1e-6


def body_shape(mesh, shapes) -> tuple[TriangleMesh, tuple[TriangleMesh, ...]]:
    """A body's mesh and its parts, each in the body's mesh frame.

    Parameters
    ----------
    mesh : TriangleMesh or None
        The body's one mesh; give it or ``shapes``.
    shapes : sequence of (TriangleMesh, (4, 4) array_like) or None
        Parts, each with the rigid transform that places its mesh frame in the body's mesh
        frame (p_body = R p + t).

    Returns
    -------
    mesh : TriangleMesh
        ``mesh`` itself, or the parts merged (vertices placed, faces renumbered).
    parts : tuple of TriangleMesh
        ``(mesh,)``, or each part placed in the body's mesh frame.

    Raises
    ------
    ValueError
        On neither or both of ``mesh`` and ``shapes``, an empty ``shapes``, an entry that
        is not a (mesh, pose) pair, or a pose that is not a rigid transform.
    """
    if (mesh is None) == (shapes is None):
        raise ValueError("give a mesh or shapes=[(mesh, pose), ...], exactly one of them")
    if shapes is None:
        if not isinstance(mesh, TriangleMesh):
            raise ValueError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
        return mesh, (mesh,)
    if isinstance(shapes, TriangleMesh | str) or not hasattr(shapes, "__len__"):
        raise ValueError(f"shapes must be a list of (mesh, pose) pairs, got {shapes!r}")
    if len(shapes) == 0:
        raise ValueError("shapes is empty: a body needs at least one (mesh, pose) pair")
    parts = []
    for k, entry in enumerate(shapes):
        if not (isinstance(entry, tuple | list) and len(entry) == 2):
            raise ValueError(f"shapes[{k}] must be a (mesh, pose) pair, got {entry!r}")
        part, pose = entry
        if not isinstance(part, TriangleMesh):
            raise ValueError(f"shapes[{k}] mesh must be a TriangleMesh, got {type(part).__name__}")
        T = as_rigid_transform(pose, f"shapes[{k}] pose")
        parts.append(TriangleMesh(part.vertices @ T[:3, :3].T + T[:3, 3], part.faces))
    if len(parts) == 1:
        return parts[0], tuple(parts)
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    merged = TriangleMesh(
        np.concatenate([p.vertices for p in parts]),
        np.concatenate([p.faces + offset for p, offset in zip(parts, offsets, strict=True)]),
    )
    return merged, tuple(parts)


def explicit_mass_properties(mass, center_of_mass, inertia) -> tuple:
    """The mass (float), centre of mass (3,) and inertia (3, 3) a user gave, checked: the
    inertia symmetric (to round-off, then made exactly so), positive definite, and its
    principal moments within the triangle inequality, as a rigid body's are."""
    m = as_positive_scalar(mass, "mass")
    center = as_finite_array(center_of_mass, "center_of_mass", shape=(3,))
    tensor = as_finite_array(inertia, "inertia", shape=(3, 3))
    largest = float(np.abs(tensor).max())
    asymmetry = np.abs(tensor - tensor.T)
    if asymmetry.max() > _SYMMETRY_TOLERANCE * largest:
        i, j = (int(k) for k in np.unravel_index(np.argmax(asymmetry), (3, 3)))
        raise ValueError(
            f"inertia is not symmetric: inertia[{i}, {j}] = {float(tensor[i, j])!r} but "
            f"inertia[{j}, {i}] = {float(tensor[j, i])!r}"
        )
    # halves of equal entries add up to the entry exactly: a symmetric input is kept to the bit
    tensor = 0.5 * tensor + 0.5 * tensor.T
    moments = np.linalg.eigvalsh(tensor)
    if not moments[0] > 0.0:
        raise ValueError(
            f"inertia is not positive definite: its principal moments are {moments.tolist()}"
        )
    if moments[2] - (moments[0] + moments[1]) > _TRIANGLE_TOLERANCE * moments[2]:
        raise ValueError(
            f"inertia violates the triangle inequality: its principal moments "
            f"{moments.tolist()} have the largest above the sum of the other two, which no "
            "rigid body has"
        )
    return m, center, tensor


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
    parts=None,
    center_of_mass=None,
    inertia=None,
) -> dict:
    """Every ``BodyArrays`` field of one body, validated (see ``World.add_body``).

    ``mesh`` and ``parts`` are what ``body_shape`` returns (``parts`` None: ``(mesh,)``).

    Raises
    ------
    ValueError
        Naming the argument that is wrong.
    """
    if not isinstance(mesh, TriangleMesh):
        raise ValueError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
    parts = (mesh,) if parts is None else parts
    if mass is not None and density is not None:
        raise ValueError("give mass or density, not both")
    explicit = center_of_mass is not None or inertia is not None
    if explicit and (static or kinematic):
        raise ValueError(
            "a static or kinematic body takes no center_of_mass or inertia: nothing moves it"
        )
    if explicit and (center_of_mass is None or inertia is None or mass is None):
        missing = [
            key
            for key, value in (
                ("mass", mass), ("center_of_mass", center_of_mass), ("inertia", inertia)
            )
            if value is None
        ]  # fmt: skip
        raise ValueError(
            "explicit mass properties take mass, center_of_mass and inertia together; "
            f"missing {', '.join(missing)}" + (" (not density)" if density is not None else "")
        )
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
        if explicit:
            m, center, inertia = explicit_mass_properties(mass, center_of_mass, inertia)
        else:
            props = _mesh_mass_properties(mesh, parts, mass, density)
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
            m, inv_m, inertia, inv_inertia,
            "mass and inertia" if explicit else "mass" if mass else "density", mesh.scale,
        )  # fmt: skip
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
        # a flat mesh has no thickness; a thousandth of its radius keeps sampling finite. A
        # compound is as thin as its thinnest part, which a fast body could pass through
        thickness=max(min(hull_thickness(part.vertices) for part in parts), 1e-3 * radius),
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


def _mesh_mass_properties(mesh, parts, mass, density):
    """Mass properties of the closed mesh, or of the union of the closed parts (their volume
    integrals summed: those of the merged mesh), at ``density`` or scaled to ``mass``."""
    if mass is not None:
        mass = as_positive_scalar(mass, "mass")
    elif density is None:
        density = 1.0
    if len(parts) > 1:
        # each part is checked on its own, so that the message names it and an inward part
        # cannot cancel an outward one in the sum
        for k, part in enumerate(parts):
            try:
                mass_properties(part)
            except ValueError as exc:
                raise ValueError(
                    f"shapes[{k}]: {exc}; a compound body takes its mass properties from "
                    "closed parts, or give mass, center_of_mass and inertia"
                ) from exc
    return mass_properties(mesh, density=density, mass=mass)


def _bits(value, name: str) -> int:
    """A collision group or mask: a non-negative integer that fits in 62 bits."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer bit field, got {value!r}")
    if not 0 <= value < 2**62:
        raise ValueError(f"{name} must lie in [0, 2**62), got {value}")
    return int(value)
