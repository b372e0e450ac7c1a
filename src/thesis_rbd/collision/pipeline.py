"""The detection stages of a world step: bounds -> broad phase -> narrow phase -> tunnelling.

Rapier-style, the stages talk through explicit arrays that one returns and the next takes:
``bounds`` checks every moving body against the fat box the broad phase keeps for it, refits the
fat boxes when one was left (``broad_phase/bounds.py``) and returns the fast bodies;
``broad_phase`` brings the sweep-and-prune pair cache up to date only when the fat boxes changed
and returns the candidate pairs worth testing (tight boxes overlap, never static-static, never
two resting bodies); ``narrow_phase`` turns candidate pairs into contacts (a ``ContactSet``,
world frame, normals from body_b towards body_a); ``sweep`` puts back fast bodies that passed
through something and returns the contacts with theirs. Fat boxes only add pairs for the
tight-box test, so the candidates are those of a broad phase on tight boxes, while bodies in
steady motion need a sweep-and-prune update only every hundred steps or so. What the pipeline
keeps between steps is its own: the trees, the fat boxes and the sweep-and-prune state.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd.collision.broad_phase.bounds import (
    PREDICTION_STEPS,
    candidate_pairs,
    tight_bounds,
    update_fat_bounds,
)
from thesis_rbd.collision.broad_phase.sap import SweepAndPrune
from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.convex.contacts import (
    SPECULATIVE_FRACTION,
    convex_contacts,
    empty_cache,
    query_scratch_for,
)
from thesis_rbd.collision.convex.hull_data import HullSet
from thesis_rbd.collision.mesh.narrow_phase import GeometrySet, contacts_for_pairs
from thesis_rbd.collision.touching import pairs_touch

__all__ = ["NARROW_PHASES", "CollisionPipeline"]

# "auto": pairs of convex bodies by convex-polyhedron contact, the others by the OBBTree;
# "mesh": the OBBTree for every pair
NARROW_PHASES = ("auto", "mesh")

_NO_BODIES = np.zeros(0, np.int64)
_NO_PAIRS = np.zeros((0, 2), np.int64)
_NO_BODIES.flags.writeable = _NO_PAIRS.flags.writeable = False


class CollisionPipeline:
    """Geometry, broad-phase state and the latest contacts of a world's bodies.

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
    convex_cache : tuple
        Coherence cache of the convex pairs (``convex.contacts.empty_cache``; its arrays by
        ``convex.contacts.cache_views``), from the last ``narrow_phase`` stage.
    box_offset, box_half : (n, 3) float64
        Mesh-frame box of each body: centre offset from the centre of mass, half-extents.
    fat : (2, n, 3) float64
        [lower, upper] fat world boxes, as the broad phase knows them.
    tight : (2, n, 3) float64
        [lower, upper] tight world boxes of the bodies of fat pairs from the last
        ``broad_phase`` stage (a fast body's covers its whole step); other rows are stale.
    fat_pairs : (f, 2) int64
        Pairs of overlapping fat boxes that may ever collide (both collidable, not both
        static), from the last sweep-and-prune update.
    pair_members : (m,) int64
        The bodies of ``fat_pairs``.
    stats : dict
        Counters of the last stage calls (candidate_pairs, bv_tests, tri_tests, contacts).
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
        self.convex_cache = empty_cache()
        self._hull_arrays = self.hulls.arrays()
        self._query_scratch = query_scratch_for(self.hulls)
        self._every_body_convex = self._any_body_convex = False
        self.box_offset = np.zeros((0, 3))
        self.box_half = np.zeros((0, 3))
        self.sap = SweepAndPrune()
        self.tight = np.zeros((2, 0, 3))
        self._reach = 0.0
        self.fat = np.zeros((2, 0, 3))
        self._fast = np.zeros(0, bool)
        self.fat_pairs = np.zeros((0, 2), np.int64)
        self._candidates = np.zeros((0, 2), np.int64)  # rows written by each broad phase
        self.pair_members = np.zeros(0, np.int64)
        self.stats: dict[str, int] = {}
        self._may_pair = np.zeros(0, bool)
        self._static = np.zeros(0, bool)
        self._refit_all = True
        self._fat_changed = False
        self._start_position = np.zeros((0, 3))

    def add_body(self, mesh, center_of_mass_local) -> None:
        """Register the next body's mesh (its tree is shared with bodies of the same mesh).

        ``center_of_mass_local`` (3,) is the body's centre of mass in the mesh frame.
        """
        g = self.geometry.geometry_of(mesh)
        self.geometry_of_body = np.append(self.geometry_of_body, g)
        hull = self.hulls.hull_of(mesh) if self.narrow_phase_kind == "auto" else -1
        self.hull_of_body = np.append(self.hull_of_body, hull)
        self._hull_arrays = self.hulls.arrays()
        self._query_scratch = query_scratch_for(self.hulls)
        self._every_body_convex = bool(np.all(self.hull_of_body >= 0))
        self._any_body_convex = bool(np.any(self.hull_of_body >= 0))
        # per-body copies of the mesh-frame box, so the bounds stage gathers nothing per step
        lower, upper = self.geometry.local_lower[g], self.geometry.local_upper[g]
        self.box_offset = np.vstack([self.box_offset, 0.5 * (lower + upper) - center_of_mass_local])
        self.box_half = np.vstack([self.box_half, 0.5 * (upper - lower)])

    def plan(self, bodies, reach: float = 0.0) -> None:
        """Take the bodies as they are now; the next ``bounds`` fits every box afresh.

        Parameters
        ----------
        bodies : BodyArrays
            Their static bodies never pair with each other, their bodies that are not
            collidable with nothing. The stages read the state from the arrays as they are
            now: the world plans again whenever they are replaced (a body added).
        reach : float
            Gap (>= 0) that any convex pair gets speculative contacts across, whatever the
            bodies' sizes (see ``convex.contacts``): the world's fall in one step.
        """
        static, collidable = bodies.static, bodies.collidable
        n = len(static)
        self._reach = float(reach)
        self._static = static.copy()
        self._may_pair = collidable.copy()
        # the kernels' body arguments, looked up once per plan
        full = bodies.full
        self._position, self._orientation = full("position"), full("orientation")
        self._center_of_mass_local = full("center_of_mass_local")
        self._size, self._thickness = full("size"), full("thickness")
        self._linear_momentum, self._inverse_mass = full("linear_momentum"), full("inverse_mass")
        if self.tight.shape[1] != n:
            self.tight, self.fat = np.zeros((2, n, 3)), np.zeros((2, n, 3))
            self._fast = np.zeros(n, bool)
        self._refit_all = True

    def bounds(self, bodies, frozen, start_position, dt) -> tuple[np.ndarray, int, float]:
        """Find the fast bodies; refit the fat boxes if a moving body left its own.

        Parameters
        ----------
        bodies : BodyArrays
        frozen : (n,) bool
            Bodies that did not move this step (static or asleep).
        start_position : (n, 3) float64
            Centres of mass at the start of the step: a fast body's boxes cover its whole step.
        dt : float
            Step length (s); fat boxes leave room for ``PREDICTION_STEPS`` steps of motion.

        Returns
        -------
        fast : (n,) bool
            Bodies that moved further than their thickness this step (a view the next call
            overwrites).
        fast_count : int
        slowest : float
            Smallest (speed / radius)^2 (1/s^2) of a moving body (inf if none).
        """
        b = bodies
        self._start_position = start_position
        refit, fast_count, slowest = update_fat_bounds(
            b.count, self._refit_all, frozen, self._size, self._thickness, self._position,
            start_position, self._linear_momentum, self._inverse_mass,
            PREDICTION_STEPS * dt, self.fat, self._fast,
        )  # fmt: skip
        if self._refit_all:
            # static and sleeping bodies do not move: their fat boxes are their tight boxes
            self._tight_bounds(np.flatnonzero(frozen[: b.count]), self.fat)
            self._refit_all = False
        self._fat_changed |= refit
        return self._fast, fast_count, slowest

    @property
    def broad_phase_due(self) -> bool:
        """Whether ``broad_phase`` has work: fat boxes changed, or fat pairs to filter."""
        return self._fat_changed or len(self.fat_pairs) > 0

    def sweep(self, bodies, pairs, contacts, fast, start_position, start_orientation):
        """Catch fast bodies that passed through something during the step.

        For each candidate pair with a fast body, the fast body's motion is sampled at
        spacings of at most half its thickness (positions interpolated, orientations
        normalised-lerped); at the first sample where the pair intersects, the body is put
        back there and the pair's contacts join the contact set, for the contact stage to
        resolve (it then steps back to the exact time of impact). Pairs already touching at
        the end are sampled too: a fast body found deep inside has a contact normal that may
        point out the far side. The rest of the step is lost for that body, as in Bullet's
        motion clamping.

        Parameters
        ----------
        bodies : BodyArrays
            Positions and orientations of caught bodies are put back.
        pairs : (p, 2) int64
            This step's candidate pairs.
        contacts : ContactSet
            This step's contacts.
        fast : (n,) bool
        start_position, start_orientation : (n, 3), (n, 4) float64
            Where each body started the step.

        Returns
        -------
        contacts : ContactSet
            ``contacts`` with the caught bodies' contacts found again where they were put.
        caught : int
            Number of bodies put back.
        """
        involved = fast[pairs[:, 0]] | fast[pairs[:, 1]]
        if not involved.any():
            return contacts, 0
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
            samples = int(np.ceil(travel / (0.5 * bodies.thickness[mover])))
            for s in np.arange(1, samples) / samples:
                position[mover] = (1 - s) * start_position[mover] + s * end_position
                q = (1 - s) * q0 + s * end_orientation
                orientation[mover] = q / np.linalg.norm(q)
                if self.intersects(np.array([[i, j]])):
                    caught.append(mover)
                    break
            else:
                position[mover], orientation[mover] = end_position, end_orientation
        if not caught:
            return contacts, 0
        moved = np.isin(pairs[:, 0], caught) | np.isin(pairs[:, 1], caught)
        fresh = self.contacts_of(np.ascontiguousarray(pairs[moved]))
        keep = ~(np.isin(contacts["body_a"], caught) | np.isin(contacts["body_b"], caught))
        return ContactSet.concatenate([contacts.select(keep), fresh]), len(caught)

    def broad_phase(self, resting: np.ndarray) -> np.ndarray:
        """Update the pair cache if the fat boxes changed; return the pairs worth testing.

        Candidates (p, 2) int64 are the fat pairs whose tight boxes overlap and that have a
        body not in ``resting`` (n,) bool (static or asleep: a pair of two of them cannot
        produce a new contact): a view that the next call overwrites.
        """
        if self._fat_changed:
            lower, upper = self.fat[0], self.fat[1]
            known = len(self.sap)
            if known < len(lower):
                self.sap.add(lower[known:], upper[known:])
            self.sap.update(lower, upper, check=False)  # kernel bounds: finite, lo <= hi
            pairs = self.sap.pairs
            if len(pairs):  # (most refits of a sparse scene find none: no array work then)
                i, j = pairs[:, 0], pairs[:, 1]
                may, static = self._may_pair, self._static
                pairs = pairs[may[i] & may[j] & ~(static[i] & static[j])]
            self.fat_pairs = pairs
            self.pair_members = np.unique(pairs) if len(pairs) else _NO_BODIES
            self._candidates = np.empty_like(pairs)
            self._fat_changed = False
        if len(self.fat_pairs):
            count = candidate_pairs(
                self.fat_pairs, self.pair_members, self.box_offset, self.box_half, self._size,
                self._position, self._orientation, self._start_position, self._fast,
                self._thickness, SPECULATIVE_FRACTION, self._reach, self.tight,
                resting, self._candidates,
            )  # fmt: skip
            candidates = self._candidates[:count]
        else:
            candidates = _NO_PAIRS
        self.stats["candidate_pairs"] = len(candidates)
        return candidates

    @property
    def steady_ready(self) -> bool:
        """Whether the next steps' detection can run inside ``run_steady_steps``: every body
        convex and the fat boxes fitted (the first ``bounds`` after a plan fits them)."""
        return self._every_body_convex and not self._refit_all

    def steady_arguments(self, dt: float) -> tuple:
        """What ``run_steady_steps`` takes of the detection stages, from ``size`` to
        ``center_of_mass_local`` (the fat pairs and candidate buffer change when the
        sweep-and-prune pairs do: ask again after every ``broad_phase``)."""
        return (
            self._size, PREDICTION_STEPS * dt, self.fat, self._fast, self.fat_pairs,
            self.pair_members, self.box_offset, self.box_half, SPECULATIVE_FRACTION,
            self._reach, self.tight, self._candidates, self.hull_of_body, self._hull_arrays,
            self.hulls.longest_loop, self._query_scratch, self._center_of_mass_local,
        )  # fmt: skip

    def take_steady(self, refit: bool, candidate_count: int, cache: tuple) -> np.ndarray:
        """Take what ``run_steady_steps`` did to the detection state: whether a body left its
        fat box, the candidates it wrote (their count) and the convex coherence cache.
        Returns the candidate pairs (a view that the next broad phase overwrites)."""
        self._fat_changed |= refit
        self.convex_cache = cache
        self.stats["candidate_pairs"] = self.stats["convex_pairs"] = candidate_count
        return self._candidates[:candidate_count]

    def _tight_bounds(self, members: np.ndarray, out: np.ndarray) -> None:
        """Tight boxes of the bodies ``members`` (m,) into ``out`` (2, n, 3)."""
        tight_bounds(
            members, self.box_offset, self.box_half, self._size, self._position,
            self._orientation, self._start_position, self._fast, self._thickness,
            SPECULATIVE_FRACTION, self._reach, out,
        )  # fmt: skip

    def narrow_phase(self, pairs: np.ndarray) -> ContactSet:
        """Contacts of the candidate ``pairs`` (p, 2), world frame (see ``ContactSet``;
        convex pairs a small gap apart have speculative contacts, depth < 0); the convex
        pairs' coherence cache is kept for the next step."""
        return self._contacts(pairs, keep_cache=True)

    def _convex_pairs(self, pairs: np.ndarray) -> np.ndarray:
        """(p,) bool: the pairs of two convex bodies."""
        hull = self.hull_of_body
        return (hull[pairs[:, 0]] >= 0) & (hull[pairs[:, 1]] >= 0)

    def touch_inputs(self) -> tuple:
        """What ``touching.pairs_touch`` takes after the pairs and the body poses: the hull
        set, the coherence cache and the trees (None while every body is convex: no tree is
        built, and the tree query is not compiled), so that a kernel can ask it in a loop."""
        trees = None if self._every_body_convex else self.geometry.arrays()
        return (
            self.hull_of_body, self._hull_arrays, self.hulls.longest_loop, self._query_scratch,
            *self.convex_cache, self.geometry_of_body, trees,
        )  # fmt: skip

    def intersects(self, pairs: np.ndarray, position=None, orientation=None) -> bool:
        """Whether any of the body ``pairs`` (p, 2) intersects in the current state, or with
        the bodies at ``position`` (n, 3) and ``orientation`` (n, 4) if given
        (``touching.pairs_touch``: convex pairs without the speculative margin, so that
        this answer and ``contacts_of`` agree)."""
        if position is None:
            position, orientation = self._position, self._orientation
        return pairs_touch(
            np.ascontiguousarray(pairs), position, orientation, self._center_of_mass_local,
            *self.touch_inputs(),
        )  # fmt: skip

    def contacts_of(self, pairs: np.ndarray) -> ContactSet:
        """Contacts of the body ``pairs`` (p, 2) in the current state (see ``ContactSet``)."""
        return self._contacts(pairs, keep_cache=False)

    def _contacts(self, pairs: np.ndarray, keep_cache: bool) -> ContactSet:
        """Contacts of ``pairs``: convex pairs by the convex kernel, the others by the
        OBBTree; ``keep_cache`` stores the convex pairs' coherence cache for the next step.
        A scene whose bodies are all convex (or none) makes one kernel call and nothing else."""
        state = (self._position, self._orientation, self._center_of_mass_local)
        if self._every_body_convex:
            self.stats["convex_pairs"] = len(pairs)
            return self._convex_contacts(pairs, state, keep_cache)
        if not self._any_body_convex:
            self.stats["convex_pairs"] = 0
            return self._mesh_contacts(pairs, state)
        convex = self._convex_pairs(pairs)
        self.stats["convex_pairs"] = int(convex.sum())
        parts = [
            self._mesh_contacts(np.ascontiguousarray(pairs[~convex]), state),
            self._convex_contacts(np.ascontiguousarray(pairs[convex]), state, keep_cache),
        ]
        return ContactSet.concatenate(parts)

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

    def _convex_contacts(self, pairs, state, keep_cache: bool) -> ContactSet:
        """Contacts of convex pairs by the convex kernel, with its coherence cache."""
        contacts, cache = convex_contacts(
            pairs, self.hull_of_body, self._hull_arrays, self.hulls.longest_loop,
            self._query_scratch, *state,
            self.convex_cache, SPECULATIVE_FRACTION, self._reach,
        )  # fmt: skip
        if keep_cache:
            self.convex_cache = cache
        return contacts
