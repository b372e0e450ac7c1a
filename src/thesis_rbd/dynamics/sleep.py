"""Sleeping: islands at rest stop being simulated until something touches them.

A dynamic body is *still* while its speed stays below ``linear_tolerance`` bounding radii per
second (a tolerance relative to its size: a 10 um part and a 100 m block sleep alike) and its
angular speed below ``angular_tolerance``; an island (bodies joined by this step's contacts, static
bodies excluded) falls asleep once every body in it has been still for ``time_to_sleep`` and it
is supported: one of its bodies touches a static body, a kinematic body that does not move or a
sleeping island. Still alone is not at rest: a body at the top of its flight, or drifting slowly
in zero gravity, never sleeps, whether the world holds one body or many; nor does one carried by
a moving kinematic body, whatever its speed (a box near the axis of a turntable).
Asleep bodies have zero velocity and are frozen: the integrator, the narrow phase between
two resting bodies and the contact solver all skip them, so a settled scene costs almost
nothing (Box2D's and Bullet's islands sleep the same way).

An island wakes as a whole when an awake body or a moving kinematic body touches one of its
bodies, or when a force is applied to one of them; the island a body slept in is remembered for
that.

While every awake body moves faster than ``linear_tolerance``, none has been still and no
contact changed a velocity, an update would only keep every still-time at zero:
``SleepState.update_due`` says so, and the world then does not run the stage at all (a scene
in steady motion pays nothing for sleeping).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.islands import find_islands
from thesis_rbd.spatial.quaternion import conjugate, rotate

__all__ = ["SleepSettings", "SleepState"]


@dataclass(frozen=True)
class SleepSettings:
    """When bodies fall asleep.

    Attributes
    ----------
    enabled : bool
        False keeps every body awake.
    linear_tolerance : float
        Speed, in the body's bounding radii per second, below which it counts as still.
    angular_tolerance : float
        Angular speed (rad/s) below which a body counts as still.
    time_to_sleep : float
        Seconds an island must stay still before it sleeps.
    """

    enabled: bool = True
    linear_tolerance: float = 0.01
    angular_tolerance: float = 0.035
    time_to_sleep: float = 0.5

    def __post_init__(self):
        for name in ("linear_tolerance", "angular_tolerance", "time_to_sleep"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"sleep {name} must be finite and >= 0, got {value!r}")


@njit
def _still_time(
    count, frozen, static, radius, orientation, linear_momentum, angular_momentum, inverse_mass,
    inverse_inertia_body, still, dt, linear_tolerance, angular_tolerance,
):  # fmt: skip
    """Advance each awake dynamic body's still-time; reset it for a moving body.

    Speeds come straight from the momenta: |v| = |P| / M and |w| = |I_body^-1 R^T L| (a
    rotation keeps lengths), so nothing per body is allocated. Returns the largest
    still-time.
    """
    ang2 = angular_tolerance * angular_tolerance
    longest = 0.0
    for i in range(count):
        if static[i] or frozen[i]:
            continue
        im = inverse_mass[i]
        speed2 = (
            (linear_momentum[i, 0] ** 2 + linear_momentum[i, 1] ** 2 + linear_momentum[i, 2] ** 2)
            * im
            * im
        )
        Lb = rotate(conjugate(orientation[i]), angular_momentum[i])
        Ii = inverse_inertia_body[i]
        spin2 = 0.0
        for a in range(3):
            spin2 += (Ii[a, 0] * Lb[0] + Ii[a, 1] * Lb[1] + Ii[a, 2] * Lb[2]) ** 2
        if speed2 <= (linear_tolerance * radius[i]) ** 2 and spin2 <= ang2:
            still[i] += dt
        else:
            still[i] = 0.0
        longest = max(longest, still[i])
    return longest


class SleepState:
    """Per-body sleep bookkeeping of a world.

    Attributes
    ----------
    asleep : (n,) bool
        Frozen because its island is at rest.
    still : (n,) float64
        Seconds the body has been still.
    island : (n,) int64
        Label of the island the body fell asleep in (-1 while awake).
    """

    def __init__(self, settings: SleepSettings):
        self.settings = settings
        self.asleep = np.zeros(0, bool)
        self.still = np.zeros(0)
        self.island = np.zeros(0, np.int64)
        self._next_label = 0
        # whether an awake body may have a nonzero still-time (False only when none has)
        self._still_any = False

    def resize(self, count: int) -> None:
        """Make room for newly added bodies (they start awake)."""
        grow = count - len(self.asleep)
        if grow > 0:
            self.asleep = np.concatenate([self.asleep, np.zeros(grow, bool)])
            self.still = np.concatenate([self.still, np.zeros(grow)])
            self.island = np.concatenate([self.island, np.full(grow, -1, np.int64)])

    @property
    def any_asleep(self) -> bool:
        return bool(self.asleep.any())

    @property
    def still_any(self) -> bool:
        """Whether an awake body may have a nonzero still-time (False only when none has)."""
        return self._still_any

    def snapshot(self) -> tuple:
        """A copy of the bookkeeping, for ``restore`` to put back."""
        return (self.asleep.copy(), self.still.copy(), self.island.copy(), self._next_label,
                self._still_any)  # fmt: skip

    def restore(self, snapshot: tuple) -> None:
        """Put back the bookkeeping of a ``snapshot``."""
        self.asleep, self.still, self.island, self._next_label, self._still_any = snapshot

    def update_due(self, slowest_speed2: float, touching: bool) -> bool:
        """Whether ``update`` could change anything this step.

        Parameters
        ----------
        slowest_speed2 : float
            Smallest (speed / bounding radius)^2 (1/s^2) of an awake dynamic body, measured
            after the integration.
        touching : bool
            Whether there are contacts this step (the contact response changes velocities
            after they were measured, and contacts join islands).

        Returns
        -------
        bool
            False when every awake body is too fast to be still and none has been: the update
            would keep every still-time at zero and put nobody to sleep.
        """
        tolerance = self.settings.linear_tolerance
        return touching or self._still_any or slowest_speed2 <= tolerance * tolerance

    def wake(self, bodies: np.ndarray) -> None:
        """Wake the islands the given body indices slept in."""
        labels = self.island[bodies]
        labels = labels[labels >= 0]
        if len(labels) == 0:
            return
        waking = np.isin(self.island, labels)
        self.asleep[waking] = False
        self.still[waking] = 0.0
        self.island[waking] = -1

    def wake_touched(self, contacts, moving: np.ndarray) -> bool:
        """Wake sleeping islands touched by a ``moving`` (n,) bool body (an awake dynamic
        body, or a kinematic body with a velocity); True if any woke."""
        a, b = contacts["body_a"], contacts["body_b"]
        hits = np.concatenate([b[moving[a] & self.asleep[b]], a[moving[b] & self.asleep[a]]])
        if len(hits) == 0:
            return False
        self.wake(hits)
        return True

    def update(self, bodies, contacts, dt, links=None, carrying=None) -> np.ndarray:
        """Advance still-times and put still islands to sleep.

        Parameters
        ----------
        bodies : BodyArrays
            After the contact response.
        contacts : ContactSet
            This step's contacts (they define the islands).
        dt : float
        links : (j, 2) int64, optional
            Body pairs joints hold (-1: the world): they join islands as contacts do, and a
            body jointed to the world rests on it.
        carrying : (n,) bool, optional
            The moving kinematic bodies: immovable, yet nothing that sleeps rests on them.

        Returns
        -------
        fell_asleep : (k,) int64
            Bodies put to sleep this step (their momenta are zeroed by the caller).
        """
        s = self.settings
        n = bodies.count
        static = bodies.static
        longest = _still_time(
            n, self.asleep, static, bodies.full("size"), bodies.full("orientation"),
            bodies.full("linear_momentum"),
            bodies.full("angular_momentum"), bodies.full("inverse_mass"),
            bodies.full("inverse_inertia_body"), self.still, dt, s.linear_tolerance,
            s.angular_tolerance,
        )  # fmt: skip
        self._still_any = longest > 0.0
        if longest < s.time_to_sleep:
            return np.zeros(0, np.int64)  # nobody has been still long enough: no island work
        a, b = contacts["body_a"], contacts["body_b"]
        to_world = np.zeros(0, np.int64)
        if links is not None and len(links):
            # a body jointed to the world rests on it (its own pair makes it an island)
            to_world = links[links[:, 1] < 0, 0]
            between = links[links[:, 1] >= 0]
            a = np.concatenate([a, between[:, 0], to_world])
            b = np.concatenate([b, between[:, 1], to_world])
        body_island, _, _ = find_islands(n, a, b, static)
        awake = ~(static | self.asleep)
        # bodies touching nothing are islands of their own
        lonely = awake & (body_island < 0)
        labels = np.where(lonely, -2 - np.arange(n), body_island)
        candidates = awake & (self.still >= s.time_to_sleep)
        if not candidates.any():
            return np.zeros(0, np.int64)
        # an island sleeps only if none of its awake bodies is still moving, and only if it
        # rests on something that does not move: a static body or a sleeping island (a body
        # slow at the top of its flight, or drifting in zero gravity, is still but not at rest;
        # one a moving kinematic body carries must go on being carried)
        moving_labels = np.unique(labels[awake & ~candidates])
        held = static | self.asleep
        if carrying is not None:
            held &= ~carrying
        on_support = np.concatenate([a[held[b] & ~held[a]], b[held[a] & ~held[b]], to_world])
        sleepy = candidates & ~np.isin(labels, moving_labels) & np.isin(labels, labels[on_support])
        fell = np.flatnonzero(sleepy)
        if len(fell) == 0:
            return fell
        _, new_labels = np.unique(labels[fell], return_inverse=True)
        self.asleep[fell] = True
        self.island[fell] = self._next_label + new_labels
        self._next_label += int(new_labels.max()) + 1
        return fell
