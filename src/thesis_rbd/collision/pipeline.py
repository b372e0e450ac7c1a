"""The detection stages of a world step: bounds -> broad phase -> narrow phase.

Rapier-style, the stages talk through explicit arrays: ``bounds`` writes one world AABB per
body, ``broad_phase`` keeps the sweep-and-prune pair cache current and turns it into the
candidate pairs worth testing (never static-static, never two resting bodies), and
``narrow_phase`` turns candidates into contacts (``contacts`` dict, world frame, normals from
body_b towards body_a).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd.collision.bounds import world_bounds
from thesis_rbd.collision.narrow_phase import GeometrySet, any_intersection, contacts_for_pairs
from thesis_rbd.collision.sap import SweepAndPrune

__all__ = ["CollisionPipeline", "empty_contacts"]


def empty_contacts() -> dict[str, np.ndarray]:
    """A contact set with no rows."""
    return {
        "body_a": np.zeros(0, np.int64),
        "body_b": np.zeros(0, np.int64),
        "points": np.zeros((0, 3)),
        "normals": np.zeros((0, 3)),
        "depths": np.zeros(0),
        "faces": np.zeros((0, 2), np.int64),
    }


class CollisionPipeline:
    """Geometry, broad-phase state and the latest contacts of a world's bodies.

    Attributes
    ----------
    geometry : GeometrySet
        The distinct meshes' trees.
    geometry_of_body : (n,) int64
        Tree index of each body.
    lower, upper : (n, 3) float64
        World AABBs from the last ``bounds`` stage.
    candidate_pairs : (p, 2) int64
        Body pairs for the narrow phase from the last ``broad_phase`` stage.
    contacts : dict of arrays
        From the last ``narrow_phase`` stage (see ``empty_contacts``).
    stats : dict
        Counters of the last stage calls (pairs, bv_tests, tri_tests, contacts).
    """

    def __init__(self):
        self.geometry = GeometrySet()
        self.geometry_of_body = np.zeros(0, np.int64)
        self.sap = SweepAndPrune()
        self.lower = np.zeros((0, 3))
        self.upper = np.zeros((0, 3))
        self.candidate_pairs = np.zeros((0, 2), np.int64)
        self.contacts = empty_contacts()
        self.stats: dict[str, int] = {}

    def add_body(self, mesh) -> None:
        """Register the next body's mesh (its tree is shared with bodies of the same mesh)."""
        self.geometry_of_body = np.append(self.geometry_of_body, self.geometry.geometry_of(mesh))

    def bounds(self, bodies, margin: np.ndarray) -> None:
        """World AABB of every body, grown by ``margin`` (n,)."""
        n = bodies.count
        if self.lower.shape[0] != n:
            self.lower, self.upper = np.empty((n, 3)), np.empty((n, 3))
        g = self.geometry_of_body
        world_bounds(
            n,
            self.geometry.local_lower[g],
            self.geometry.local_upper[g],
            bodies.full("center_of_mass_local"),
            bodies.full("position"),
            bodies.full("orientation"),
            margin,
            self.lower,
            self.upper,
        )

    def broad_phase(self, resting: np.ndarray) -> None:
        """Update the pair cache; keep the pairs with at least one moving dynamic body.

        Parameters
        ----------
        resting : (n,) bool
            Bodies that do not move this step (static or asleep): a pair of two of them
            cannot produce a new contact.
        """
        n = len(self.lower)
        known = len(self.sap)
        if known < n:
            self.sap.add(self.lower[known:], self.upper[known:])
        self.sap.update(self.lower, self.upper, check=False)  # kernel bounds: finite, lo <= hi
        pairs = self.sap.pairs
        keep = ~(resting[pairs[:, 0]] & resting[pairs[:, 1]])
        self.candidate_pairs = np.ascontiguousarray(pairs[keep])
        self.stats["candidate_pairs"] = len(self.candidate_pairs)
        if len(self.candidate_pairs) == 0:
            self.contacts = empty_contacts()  # the narrow phase will not run this step

    def narrow_phase(self, bodies) -> None:
        """Contacts of the candidate pairs, world frame, into ``contacts``."""
        self.contacts = self.contacts_of(bodies, self.candidate_pairs)

    def intersects(self, bodies, pairs: np.ndarray) -> bool:
        """Whether any of the body ``pairs`` (p, 2) intersects in the current state."""
        return bool(
            any_intersection(
                pairs,
                self.geometry_of_body,
                self.geometry.arrays(),
                bodies.full("position"),
                bodies.full("orientation"),
                bodies.full("center_of_mass_local"),
            )
        )

    def contacts_of(self, bodies, pairs: np.ndarray) -> dict[str, np.ndarray]:
        """Contacts of the body ``pairs`` (p, 2) in the current state (see ``empty_contacts``)."""
        body_a, body_b, points, normals, depths, faces, stats = contacts_for_pairs(
            pairs,
            self.geometry_of_body,
            self.geometry.arrays(),
            bodies.full("position"),
            bodies.full("orientation"),
            bodies.full("center_of_mass_local"),
        )
        self.stats.update(
            bv_tests=int(stats[0]), tri_box_tests=int(stats[1]), tri_tests=int(stats[2]),
            contacts=len(depths),
        )  # fmt: skip
        return {
            "body_a": body_a,
            "body_b": body_b,
            "points": points,
            "normals": normals,
            "depths": depths,
            "faces": faces,
        }
