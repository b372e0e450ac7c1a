"""A URDF link's mass properties in its link frame, and those of links welded together."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thesis_rbd.dynamics.body_builder import explicit_mass_properties

__all__ = ["LinkMass", "combine", "link_mass"]


@dataclass(frozen=True)
class LinkMass:
    """Mass properties in one frame: ``mass`` (kg), ``center_of_mass`` (3,) and ``inertia``
    (3, 3) about the centre of mass, axes parallel to that frame (kg m^2)."""

    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray


NONE = LinkMass(0.0, np.zeros(3), np.zeros((3, 3)))


def link_mass(link, with_inertia: bool = True) -> LinkMass:
    """A yourdfpy link's ``<inertial>`` in its link frame (all zero where it has none);
    without ``with_inertia``, its mass and centre of mass only (the inertia left zero and
    unchecked: the body's shapes will give it).

    URDF gives the inertia in the inertial frame (``<inertial><origin>``, rotated by R from the
    link frame); in the link frame it is R I R^T about the same centre of mass.

    Raises
    ------
    ValueError
        Naming the link, for a negative or non-finite mass, or where the mass is positive,
        an inertia ``add_body`` would refuse (``body_builder.explicit_mass_properties``).
    """
    inertial = link.inertial
    if inertial is None:
        return NONE
    mass = 0.0 if inertial.mass is None else float(inertial.mass)
    if not (np.isfinite(mass) and mass >= 0.0):
        raise ValueError(f"link {link.name!r}: mass must be finite and >= 0, got {mass!r}")
    origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
    tensor = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, float)
    R = origin[:3, :3]
    center, inertia = origin[:3, 3].copy(), R @ tensor @ R.T
    if not with_inertia:
        return LinkMass(mass, center, np.zeros((3, 3)))
    if mass > 0.0:
        # the checks add_body makes, per link: a welded group's sum could hide a bad one
        try:
            mass, center, inertia = explicit_mass_properties(mass, center, inertia)
        except ValueError as exc:
            raise ValueError(f"link {link.name!r}: {exc}") from exc
    return LinkMass(mass, center, inertia)


def combine(parts: list[tuple[LinkMass, np.ndarray]]) -> LinkMass:
    """Mass properties of links welded together, in a common frame.

    Parameters
    ----------
    parts : list of (LinkMass, (4, 4) ndarray)
        Each link's mass properties in its own frame and the transform of that frame into
        the common one.

    Returns
    -------
    LinkMass
        The sum: masses added, centre of mass their weighted mean, inertias rotated into the
        common frame and moved to that centre by the parallel-axis theorem; ``NONE`` where
        no part has mass.
    """
    placed = [
        (p.mass, T[:3, :3] @ p.center_of_mass + T[:3, 3], T[:3, :3] @ p.inertia @ T[:3, :3].T)
        for p, T in parts
        if p.mass > 0.0
    ]
    if not placed:
        return NONE
    mass = sum(m for m, _, _ in placed)
    center = sum(m * c for m, c, _ in placed) / mass
    inertia = np.zeros((3, 3))
    for m, c, tensor in placed:
        d = c - center
        inertia += tensor + m * (d @ d * np.eye(3) - np.outer(d, d))
    return LinkMass(mass, center, inertia)
