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
        self.local_lower = np.zeros((0, 3))
        self.local_upper = np.zeros((0, 3))
        self.sap = SweepAndPrune()
        self.lower = np.zeros((0, 3))
        self.upper = np.zeros((0, 3))
        self.candidate_pairs = np.zeros((0, 2), np.int64)
        self.contacts = empty_contacts()
        self.stats: dict[str, int] = {}

    def add_body(self, mesh) -> None:
        """Register the next body's mesh (its tree is shared with bodies of the same mesh)."""
        g = self.geometry.geometry_of(mesh)
        self.geometry_of_body = np.append(self.geometry_of_body, g)
        # per-body copies of the mesh-frame box, so the bounds stage gathers nothing per step
        self.local_lower = np.vstack([self.local_lower, self.geometry.local_lower[g]])
        self.local_upper = np.vstack([self.local_upper, self.geometry.local_upper[g]])

    def bounds(self, bodies, margin: np.ndarray, swept_from=None) -> None:
        """World AABB of every body, grown by ``margin`` (n,).

        ``swept_from`` = (fast (n,) bool, start position (n, 3), start orientation (n, 4)):
        the boxes of fast bodies also cover where they started the step, so the broad phase
        sees what they passed through.
        """
        n = bodies.count
        if self.lower.shape[0] != n:
            self.lower, self.upper = np.empty((n, 3)), np.empty((n, 3))
        local_lower, local_upper = self.local_lower, self.local_upper
        com = bodies.full("center_of_mass_local")
        world_bounds(
            n, local_lower, local_upper, com, bodies.full("position"),
            bodies.full("orientation"), margin, self.lower, self.upper,
        )  # fmt: skip
        if swept_from is not None:
            fast, start_position, start_orientation = swept_from
            lower, upper = np.empty((n, 3)), np.empty((n, 3))
            world_bounds(
                n, local_lower, local_upper, com, start_position, start_orientation, margin,
                lower, upper,
            )  # fmt: skip
            self.lower[fast] = np.minimum(self.lower[fast], lower[fast])
            self.upper[fast] = np.maximum(self.upper[fast], upper[fast])

    def sweep(self, bodies, fast, start_position, start_orientation) -> int:
        """Catch fast bodies that passed through something during the step.

        For each candidate pair with a fast body, the fast body's motion is sampled at
        spacings of at most half its size (positions interpolated, orientations
        normalised-lerped); at the first sample where the pair intersects, the body is put
        back there and the pair's contacts join the contact set, for the contact stage to
        resolve (it then steps back to the exact time of impact). Pairs already touching at
        the end are sampled too: a fast body found deep inside has a contact normal that may
        point out the far side. The rest of the step is lost for that body, as in Bullet's
        motion clamping.

        Returns the number of bodies put back.
        """
        pairs = self.candidate_pairs
        involved = fast[pairs[:, 0]] | fast[pairs[:, 1]]
        if not involved.any():
            return 0
        position, orientation = bodies.full("position"), bodies.full("orientation")
        caught = []
        for i, j in pairs[involved]:
            mover = i if fast[i] else j
            if mover in caught:
                continue
            end_position = position[mover].copy()
            end_orientation = orientation[mover].copy()
            q0 = start_orientation[mover] * np.sign(start_orientation[mover] @ end_orientation)
            travel = np.linalg.norm(end_position - start_position[mover])
            samples = int(np.ceil(travel / (0.5 * bodies.size[mover])))
            for s in np.arange(1, samples) / samples:
                position[mover] = (1 - s) * start_position[mover] + s * end_position
                q = (1 - s) * q0 + s * end_orientation
                orientation[mover] = q / np.linalg.norm(q)
                if self.intersects(bodies, np.array([[i, j]])):
                    caught.append(mover)
                    break
            else:
                position[mover], orientation[mover] = end_position, end_orientation
        if caught:
            moved = np.isin(pairs[:, 0], caught) | np.isin(pairs[:, 1], caught)
            fresh = self.contacts_of(bodies, np.ascontiguousarray(pairs[moved]))
            keep = ~(
                np.isin(self.contacts["body_a"], caught) | np.isin(self.contacts["body_b"], caught)
            )
            self.contacts = {
                key: np.concatenate([self.contacts[key][keep], fresh[key]]) for key in fresh
            }
        return len(caught)

    def broad_phase(self, resting: np.ndarray, ignored: np.ndarray | None = None) -> None:
        """Update the pair cache; keep the pairs with at least one moving dynamic body.

        Parameters
        ----------
        ignored : (n,) bool, optional
            Bodies outside collision detection: no pair of theirs is a candidate.
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
        if ignored is not None:
            keep &= ~(ignored[pairs[:, 0]] | ignored[pairs[:, 1]])
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
