"""Collision detection for a world: the geometry of its bodies and the broad phase's own state.

The detection stages of a step (bounds -> broad phase -> narrow phase -> tunnelling) run in
the world's step kernel (``world/step_kernel.py``) where they are kernels, and here where they
need Python: the sweep-and-prune update, the narrow phase of mesh pairs, the tunnelling sweep.
Each takes the body poses and the step's hand-overs as explicit arrays and returns what it
found; none moves a body. What the pipeline keeps between steps is its own: the trees and
hulls, the fat boxes, the sweep-and-prune pairs and the buffer the candidate pairs are
written to. Fat boxes only add pairs for the tight-box test, so the candidates are those of a
broad phase on tight boxes, while bodies in steady motion need a sweep-and-prune update only
every hundred steps or so (``broad_phase/bounds.py``).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd.collision.broad_phase.bounds import PREDICTION_STEPS, candidate_pairs
from thesis_rbd.collision.broad_phase.sap import SweepAndPrune
from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.convex.contacts import (
    SPECULATIVE_FRACTION,
    convex_contacts,
    query_scratch_for,
)
from thesis_rbd.collision.convex.hull_data import HullSet
from thesis_rbd.collision.mesh.narrow_phase import GeometrySet, contacts_for_pairs
from thesis_rbd.collision.touching import pairs_touch

__all__ = ["NARROW_PHASES", "CollisionPipeline", "some_pair_may_collide"]

# "auto": pairs of convex bodies by convex-polyhedron contact, the others by the OBBTree;
# "mesh": the OBBTree for every pair
NARROW_PHASES = ("auto", "mesh")

# The most samples the tunnelling sweep takes along one body's step: spacings of half its
# thickness up to a travel of 2048 thicknesses, longer spacings beyond (a body moved by a
# huge force must not make the step's work unbounded).
_MOST_SAMPLES = 4096


class CollisionPipeline:
    """Geometry and broad-phase state of a world's bodies.

    Attributes
    ----------
    geometry : GeometrySet
        The distinct meshes' trees.
    geometry_of_body : (n,) int64
        Tree index of each body.
    hulls : HullSet
        The convex hulls of the convex meshes (narrow phase "auto").
    hull_of_body : (n,) int64
        Hull index of each body, -1 for a body that collides as a mesh.
    every_body_convex : bool
        Whether every body collides as a convex hull (the step kernel then runs the narrow
        phase itself).
    box_offset, box_half : (n, 3) float64
        Mesh-frame box of each body: centre offset from the centre of mass, half-extents.
    fat : (2, n, 3) float64
        [lower, upper] fat world boxes, as the broad phase knows them.
    tight : (2, n, 3) float64
        [lower, upper] tight world boxes of the bodies of fat pairs from the last broad phase
        (a fast body's covers its whole step); other rows are stale.
    fat_pairs : (f, 2) int64
        Pairs of overlapping fat boxes that may ever collide (both collidable, not both
        static), from the last sweep-and-prune update.
    pair_members : (m,) int64
        The bodies of ``fat_pairs``.
    stats : dict
        Counters of the last narrow phase run in Python: ``convex_pairs``, and for mesh pairs
        ``bv_tests``, ``tri_box_tests``, ``tri_tests`` (the candidate count is the step
        state's).
    """

    def __init__(self, narrow_phase: str = "auto"):
        if narrow_phase not in NARROW_PHASES:
            raise ValueError(
                f"unknown narrow_phase {narrow_phase!r}; choose one of {list(NARROW_PHASES)}"
            )
        self.narrow_phase_kind = narrow_phase
        self.geometry = GeometrySet()
        self.geometry_of_body = np.zeros(0, np.int64)
        self.hulls = HullSet()
        self.hull_of_body = np.zeros(0, np.int64)
        self._hull_arrays = self.hulls.arrays()
        self._query_scratch = query_scratch_for(self.hulls)
        self.every_body_convex = self._any_body_convex = False
        self.box_offset = np.zeros((0, 3))
        self.box_half = np.zeros((0, 3))
        self.sap = SweepAndPrune()
        self.tight = np.zeros((2, 0, 3))
        self.fat = np.zeros((2, 0, 3))
        self.fat_pairs = np.zeros((0, 2), np.int64)
        self._candidates = np.zeros((0, 2), np.int64)  # rows written by each broad phase
        self.pair_members = np.zeros(0, np.int64)
        self.stats: dict[str, int] = {}
        self._reach = 0.0
        self._may_pair = np.zeros(0, bool)
        self._static = np.zeros(0, bool)
        self._group = np.zeros(0, np.int64)
        self._mask = np.zeros(0, np.int64)
        self._excluded_keys = np.zeros(0, np.int64)

    def add_body(self, mesh, center_of_mass_local, convex: bool = True) -> None:
        """Register the next body's mesh (its tree is shared with bodies of the same mesh).

        ``center_of_mass_local`` (3,) is the body's centre of mass in the mesh frame;
        ``convex`` False keeps the body off the convex path whatever its mesh (a compound's
        merged parts, whose hull would fill the space between them).
        """
        g = self.geometry.geometry_of(mesh)
        self.geometry_of_body = np.append(self.geometry_of_body, g)
        convex = convex and self.narrow_phase_kind == "auto"
        hull = self.hulls.hull_of(mesh) if convex else -1
        self.hull_of_body = np.append(self.hull_of_body, hull)
        self._hull_arrays = self.hulls.arrays()
        self._query_scratch = query_scratch_for(self.hulls)
        self.every_body_convex = bool(np.all(self.hull_of_body >= 0))
        self._any_body_convex = bool(np.any(self.hull_of_body >= 0))
        # per-body copies of the mesh-frame box, so the bounds stage gathers nothing per step
        lower, upper = self.geometry.local_lower[g], self.geometry.local_upper[g]
        self.box_offset = np.vstack([self.box_offset, 0.5 * (lower + upper) - center_of_mass_local])
        self.box_half = np.vstack([self.box_half, 0.5 * (upper - lower)])

    def plan(self, bodies, reach: float = 0.0, excluded=None) -> None:
        """Take the bodies' constants as they are now (the world plans again whenever a body
        is added); the next bounds stage must refit every fat box.

        Parameters
        ----------
        bodies : BodyArrays
            Their static bodies never pair with each other, their bodies that are not
            collidable with nothing, and two bodies pair only where each one's collision
            group meets the other's mask.
        reach : float
            Gap (>= 0) that any convex pair gets speculative contacts across, whatever the
            bodies' sizes (see ``convex.contacts``): the world's fall in one step.
        excluded : (p, 2) int64, optional
            Body pairs that never collide (jointed bodies, ``World.exclude_pair``).
        """
        n = bodies.count
        excluded = np.zeros((0, 2), np.int64) if excluded is None else excluded
        self._excluded_keys = np.unique(
            np.minimum(excluded[:, 0], excluded[:, 1]) * n
            + np.maximum(excluded[:, 0], excluded[:, 1])
        )
        self._reach = float(reach)
        self._static = bodies.static.copy()
        self._may_pair = bodies.collidable.copy()
        self._group = bodies.collision_group.copy()
        self._mask = bodies.collision_mask.copy()
        full = bodies.full
        self._center_of_mass_local = full("center_of_mass_local")
        self._size, self._thickness = full("size"), full("thickness")
        if self.tight.shape[1] != n:
            self.tight, self.fat = np.zeros((2, n, 3)), np.zeros((2, n, 3))

    def detection_arguments(self, dt: float, fast: np.ndarray) -> tuple:
        """What the step kernel's detection stages take (``run_steps``'s ``detection_group``):
        the bounding radii, the fat-box horizon (s), the fat boxes, the fast-body flags
        ``fast`` (>= n,) bool it writes, the fat pairs and their bodies, the mesh-frame boxes,
        the speculative fraction and reach, the tight boxes and the candidate buffer. The fat
        pairs and the buffer change with every sweep-and-prune update: ask again after one."""
        return (
            self._size, PREDICTION_STEPS * dt, self.fat, fast, self.fat_pairs,
            self.pair_members, self.box_offset, self.box_half, SPECULATIVE_FRACTION,
            self._reach, self.tight, self._candidates,
        )  # fmt: skip

    def convex_arguments(self) -> tuple | None:
        """What the step kernel's convex narrow phase takes (``convex_group``): the hull set
        and its query scratch; None unless every body is convex."""
        if not self.every_body_convex:
            return None
        return (
            self.hull_of_body, self._hull_arrays, self.hulls.longest_loop, self._query_scratch,
            self._center_of_mass_local,
        )  # fmt: skip

    def candidates(self, count: int) -> np.ndarray:
        """The ``count`` candidate pairs (p, 2) the last broad phase wrote (a view that the
        next broad phase overwrites)."""
        return self._candidates[:count]

    def broad_phase(
        self, fat_changed, position, orientation, start_position, fast, frozen
    ) -> int:  # fmt: skip
        """Update the pair cache if the fat boxes changed; write the pairs worth testing.

        Parameters
        ----------
        fat_changed : bool
            Whether a bounds stage refitted the fat boxes since the last update.
        position, orientation : (>= n, 3), (>= n, 4) float64
            The body poses now.
        start_position : (>= n, 3) float64
            Where each body began the step (a fast body's box covers its whole step).
        fast : (>= n,) bool
        frozen : (>= n,) bool
            Static or asleep: a pair of two such bodies cannot produce a new contact.

        Returns
        -------
        int
            The number of candidate pairs (``candidates``): fat pairs whose tight boxes
            overlap and that have a moving body.
        """
        if fat_changed:
            lower, upper = self.fat[0], self.fat[1]
            known = len(self.sap)
            if known < len(lower):
                self.sap.add(lower[known:], upper[known:])
            self.sap.update(lower, upper, check=False)  # kernel bounds: finite, lo <= hi
            # writable arrays always, whatever the sweep-and-prune hands over (its pairs are
            # read-only): the step kernel is compiled for one kind of each argument
            pairs = np.zeros((0, 2), np.int64)
            if len(self.sap.pairs):  # (most refits of a sparse scene find none)
                pairs = self.sap.pairs
                i, j = pairs[:, 0], pairs[:, 1]
                may, static = self._may_pair, self._static
                keep = may[i] & may[j] & ~(static[i] & static[j])
                group, mask = self._group, self._mask
                keep &= ((group[i] & mask[j]) != 0) & ((group[j] & mask[i]) != 0)
                if len(self._excluded_keys):
                    keys = np.minimum(i, j) * len(may) + np.maximum(i, j)
                    keep &= ~np.isin(keys, self._excluded_keys)
                pairs = pairs[keep]
            self.fat_pairs = pairs
            self.pair_members = np.unique(pairs) if len(pairs) else np.zeros(0, np.int64)
            self._candidates = np.empty_like(pairs)
        count = 0
        if len(self.fat_pairs):
            count = candidate_pairs(
                self.fat_pairs, self.pair_members, self.box_offset, self.box_half, self._size,
                position, orientation, start_position, fast, self._thickness,
                SPECULATIVE_FRACTION, self._reach, self.tight, frozen, self._candidates,
            )  # fmt: skip
        return count

    def contacts(self, pairs, position, orientation, cache) -> tuple[ContactSet, tuple]:
        """Contacts of the body ``pairs`` (p, 2) at the poses ``position`` (>= n, 3) and
        ``orientation`` (>= n, 4), world frame (see ``ContactSet``; convex pairs a small gap
        apart have speculative contacts, depth < 0), and the convex pairs' coherence cache
        for the next step (``cache`` is the last step's: see ``convex.contacts``)."""
        state = (position, orientation, self._center_of_mass_local)
        if self.every_body_convex:
            self.stats["convex_pairs"] = len(pairs)
            return self._convex_contacts(pairs, state, cache)
        if not self._any_body_convex:
            self.stats["convex_pairs"] = 0
            return self._mesh_contacts(pairs, state), cache
        hull = self.hull_of_body
        convex = (hull[pairs[:, 0]] >= 0) & (hull[pairs[:, 1]] >= 0)
        self.stats["convex_pairs"] = int(convex.sum())
        mesh = self._mesh_contacts(np.ascontiguousarray(pairs[~convex]), state)
        found, cache = self._convex_contacts(np.ascontiguousarray(pairs[convex]), state, cache)
        return ContactSet.concatenate([mesh, found]), cache

    def touch_inputs(self, cache) -> tuple:
        """What ``touching.pairs_touch`` takes after the pairs and the body poses: the hull
        set, the coherence cache ``cache`` and the trees (None while every body is convex: no
        tree is built, and the tree query is not compiled), so that a kernel can ask it in a
        loop."""
        trees = None if self.every_body_convex else self.geometry.arrays()
        return (
            self.hull_of_body, self._hull_arrays, self.hulls.longest_loop, self._query_scratch,
            *cache, self.geometry_of_body, trees,
        )  # fmt: skip

    @property
    def center_of_mass_local(self) -> np.ndarray:
        """(>= n, 3) each body's centre of mass in its mesh frame."""
        return self._center_of_mass_local

    def intersects(self, pairs, position, orientation, cache) -> bool:
        """Whether any of the body ``pairs`` (p, 2) intersects with the bodies at ``position``
        (>= n, 3) and ``orientation`` (>= n, 4) (``touching.pairs_touch``: convex pairs without
        the speculative margin, so that this answer and ``contacts`` agree)."""
        return pairs_touch(
            np.ascontiguousarray(pairs), position, orientation, self._center_of_mass_local,
            *self.touch_inputs(cache),
        )  # fmt: skip

    def sweep(self, pairs, contacts, fast, position, orientation, start_position,
              start_orientation, cache):  # fmt: skip
        """Catch fast bodies that passed through something during the step.

        For each candidate pair with a fast body, the fast body's motion is sampled at
        spacings of at most half its thickness (positions interpolated, orientations
        normalised-lerped); at the first sample where the pair intersects, the body is caught
        there and the pair's contacts found again, for the contact stage to resolve (it then
        steps back to the exact time of impact). Pairs already touching at the end are sampled
        too: a fast body found deep inside has a contact normal that may point out the far
        side. The rest of the step is lost for that body, as in Bullet's motion clamping. The
        samples per body are bounded (``_MOST_SAMPLES``), whatever the distance travelled.

        Parameters
        ----------
        pairs : (p, 2) int64
            This step's candidate pairs.
        contacts : ContactSet
            This step's contacts.
        fast : (>= n,) bool
        position, orientation : (>= n, 3), (>= n, 4) float64
            Where each body ended the step (not modified).
        start_position, start_orientation : (>= n, 3), (>= n, 4) float64
            Where each body started the step.
        cache : tuple
            The convex coherence cache (``convex.contacts``).

        Returns
        -------
        contacts : ContactSet
            ``contacts`` with the caught bodies' contacts found again where they were caught.
        caught : (k,) int64
            The bodies caught.
        fraction : (k,) float64
            The fraction of its motion over the step at which each was caught.
        caught_position, caught_orientation : (k, 3), (k, 4) float64
            Where they were caught: the caller moves them there.
        """
        involved = fast[pairs[:, 0]] | fast[pairs[:, 1]]
        position, orientation = position.copy(), orientation.copy()
        end_position, end_orientation = position.copy(), orientation.copy()
        thickness = self._thickness
        caught_at = {}  # body -> the fraction of the step at which it was caught
        for i, j in pairs[involved]:
            if fast[i] and fast[j]:
                # two fast bodies: sampled one against the other only if one may pass
                # through the other (two touching cubes flying together do not)
                relative = (end_position[i] - start_position[i]) - (
                    end_position[j] - start_position[j]
                )
                if np.linalg.norm(relative) < 0.5 * min(thickness[i], thickness[j]):
                    continue
            mover = i if fast[i] else j
            if mover in caught_at:
                continue
            travel = np.linalg.norm(end_position[mover] - start_position[mover])
            samples = int(min(np.ceil(travel / (0.5 * thickness[mover])), _MOST_SAMPLES))
            for fraction in np.arange(1, samples) / samples:
                _place_between(mover, fraction, start_position, start_orientation,
                               end_position, end_orientation, position, orientation)  # fmt: skip
                if self.intersects(np.array([[i, j]]), position, orientation, cache):
                    caught_at[mover] = fraction
                    break
            else:
                position[mover], orientation[mover] = end_position[mover], end_orientation[mover]
        # a fast body in contact with a caught one moves with it (two touching cubes flying
        # together): it is caught at the same fraction of its own motion
        companions = _bodies_joined(caught_at, contacts, fast)
        for body, fraction in companions.items():
            _place_between(body, fraction, start_position, start_orientation, end_position,
                           end_orientation, position, orientation)  # fmt: skip
        fraction_of = {**caught_at, **companions}
        caught = np.array(sorted(fraction_of), np.int64)
        fraction = np.array([fraction_of[i] for i in caught], float)
        if not len(caught):
            return contacts, caught, fraction, position[caught], orientation[caught]
        moved = np.isin(pairs[:, 0], caught) | np.isin(pairs[:, 1], caught)
        fresh, _ = self.contacts(np.ascontiguousarray(pairs[moved]), position, orientation, cache)
        keep = ~(np.isin(contacts["body_a"], caught) | np.isin(contacts["body_b"], caught))
        contacts = ContactSet.concatenate([contacts.select(keep), fresh])
        return contacts, caught, fraction, position[caught], orientation[caught]

    def _mesh_contacts(self, pairs, state) -> ContactSet:
        """Contacts of mesh pairs by the OBBTree path (no feature ids)."""
        *found, stats = contacts_for_pairs(
            pairs, self.geometry_of_body, self.geometry.arrays(), *state
        )
        self.stats.update(
            bv_tests=int(stats[0]), tri_box_tests=int(stats[1]), tri_tests=int(stats[2])
        )
        body_a, body_b, points, normals, depths, faces = found
        return ContactSet.from_fields(
            dict(
                body_a=body_a, body_b=body_b, points=points, normals=normals, depths=depths,
                faces=faces, features=np.full(len(depths), -1, np.int64),
            )
        )  # fmt: skip

    def _convex_contacts(self, pairs, state, cache) -> tuple[ContactSet, tuple]:
        """Contacts of convex pairs by the convex kernel, with its coherence cache."""
        return convex_contacts(
            pairs, self.hull_of_body, self._hull_arrays, self.hulls.longest_loop,
            self._query_scratch, *state, cache, SPECULATIVE_FRACTION, self._reach,
        )  # fmt: skip


def some_pair_may_collide(bodies, excluded=None) -> bool:
    """Whether any two of ``bodies`` (``BodyArrays``) may ever collide: both collidable, not
    both static, each one's collision group meeting the other's mask, and the pair not among
    ``excluded`` ((p, 2) int64 body pairs; None: none), the rule of
    ``CollisionPipeline.update``. A scene with none runs no collision stage (a chain whose
    links collide with nothing, a robot alone whose links may not touch each other, pays for
    no bounds or broad phase).

    Bodies with the same (group, mask, static) collide alike, so the test runs over those
    kinds, few in any scene, not over the pairs of bodies; the pairs themselves are listed
    only where the exclusions could cover them all, so never more than the exclusions.
    """
    may = bodies.collidable & (bodies.collision_group != 0) & (bodies.collision_mask != 0)
    if np.count_nonzero(may) < 2:
        return False
    kinds, kind_of, counts = np.unique(
        np.stack(
            [bodies.collision_group[may], bodies.collision_mask[may], bodies.static[may]], axis=1
        ),
        axis=0,
        return_inverse=True,
        return_counts=True,
    )
    group, mask, static = kinds[:, 0], kinds[:, 1], kinds[:, 2].astype(bool)
    meets = ((group[:, None] & mask[None, :]) != 0) & ((group[None, :] & mask[:, None]) != 0)
    meets &= ~(static[:, None] & static[None, :])
    # a kind pairs with itself only if it has two bodies
    meets[np.diag_indices(len(kinds))] &= counts >= 2
    if not meets.any() or excluded is None or len(excluded) == 0:
        return bool(meets.any())
    # pairs of kinds meeting, counted: more of them than exclusions leaves one free
    pairs_per_kind = np.outer(counts, counts) - np.diag(counts * (counts + 1) // 2)
    candidates = int(np.triu(np.where(meets, pairs_per_kind, 0)).sum())
    excluded_keys = np.unique(_keys(excluded[:, 0], excluded[:, 1]))
    if candidates > len(excluded_keys):
        return True
    ids = np.flatnonzero(may)
    first, second = np.triu_indices(len(ids), 1)
    meeting = meets[kind_of.ravel()[first], kind_of.ravel()[second]]
    keys = _keys(ids[first[meeting]], ids[second[meeting]])
    return not bool(np.isin(keys, excluded_keys).all())


def _keys(low, high) -> np.ndarray:
    """Keys of the pairs (low[k], high[k]) as ``_pair_keys`` makes them, in NumPy: the
    planner's few pairs need no kernel."""
    return (np.asarray(low, np.int64) << 32) | np.asarray(high, np.int64)


def _place_between(body, fraction, start_position, start_orientation, end_position,
                   end_orientation, position, orientation):  # fmt: skip
    """Put ``body`` at ``fraction`` of its motion over the step: the position interpolated,
    the orientation normalised-lerped from its start (taken on the end's hemisphere)."""
    position[body] = (1 - fraction) * start_position[body] + fraction * end_position[body]
    q0 = start_orientation[body] * np.sign(start_orientation[body] @ end_orientation[body])
    q = (1 - fraction) * q0 + fraction * end_orientation[body]
    orientation[body] = q / np.linalg.norm(q)


def _bodies_joined(caught_at, contacts, fast) -> dict:
    """The fast bodies joined to a caught one through contacts between fast bodies, not
    caught themselves, each with the earliest fraction of a caught body it is joined to."""
    if not caught_at or contacts.count == 0:
        return {}
    a, b = contacts["body_a"], contacts["body_b"]
    both_fast = fast[a] & fast[b]
    neighbours: dict[int, set] = {}
    for i, j in zip(a[both_fast].tolist(), b[both_fast].tolist(), strict=True):
        neighbours.setdefault(i, set()).add(j)
        neighbours.setdefault(j, set()).add(i)
    joined: dict[int, float] = {}
    for body, fraction in sorted(caught_at.items(), key=lambda item: item[1]):
        frontier = [body]
        while frontier:
            for other in neighbours.get(frontier.pop(), ()):
                if other not in caught_at and other not in joined:
                    joined[other] = fraction
                    frontier.append(other)
    return joined
