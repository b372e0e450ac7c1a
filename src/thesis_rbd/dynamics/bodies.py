"""Rigid bodies stored as arrays (structure of arrays), the state of thesis 3.2.

Each body i has the state (x_i, q_i, P_i, L_i): world position of its centre of mass, (x, y, z,
w) orientation of its body frame, linear momentum and angular momentum (world frame). Constant
per body: the inverse mass and the inverse inertia tensor in the body frame, both zero for a
static body (thesis 6.1.1), so every formula treats static bodies as infinitely heavy without a
branch. A kinematic body is a static body that moves: immovable by contacts and joints, it
carries the velocity and angular velocity its user set (``kinematic_velocity``,
``kinematic_angular_velocity``, zero for every other body), which its own stage moves it by
and which contacts and joints see as its velocity. Derived quantities follow the thesis:

    v = P / M,    I^-1 = R I_body^-1 R^T,    w = I^-1 L.

The body frame is the mesh frame translated to the centre of mass: a mesh vertex p maps to
world as R (p - c) + x, where c is the mesh-frame centre of mass.

Arrays grow by doubling so adding n bodies one by one costs O(n) copies in total; the public
views (``positions`` etc.) cover the first ``count`` rows and are replaced when capacity grows.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["BodyArrays", "copy_state"]

# The fields that make up the state (x, q, P, L): what a step changes.
STATE_FIELDS = ("position", "orientation", "linear_momentum", "angular_momentum")


@njit(allocates=False)
def copy_state(count, x, q, P, L, x_to, q_to, P_to, L_to):
    """Copy the first ``count`` rows of the state arrays into the ``*_to`` arrays."""
    for i in range(count):
        for a in range(3):
            x_to[i, a] = x[i, a]
            P_to[i, a] = P[i, a]
            L_to[i, a] = L[i, a]
        for a in range(4):
            q_to[i, a] = q[i, a]


_INITIAL_CAPACITY = 8


class BodyArrays:
    """Growable arrays of per-body constants and state.

    Attributes (first ``count`` rows are live)
    ------------------------------------------
    position : (n, 3) float64
        World position of the centre of mass x.
    orientation : (n, 4) float64
        Unit quaternion q, (x, y, z, w), body frame to world.
    linear_momentum : (n, 3) float64
        P, world frame.
    angular_momentum : (n, 3) float64
        L about the centre of mass, world frame.
    inverse_mass : (n,) float64
        1 / M; 0 for static bodies.
    inverse_inertia_body : (n, 3, 3) float64
        I_body^-1 in the body frame; 0 for static bodies.
    mass : (n,) float64
        M (inf for static bodies).
    inertia_body : (n, 3, 3) float64
        I_body about the centre of mass in the body frame (zero for static bodies).
    center_of_mass_local : (n, 3) float64
        c, the centre of mass in the mesh frame.
    size : (n,) float64
        Bounding-sphere radius of the mesh about its centre of mass.
    thickness : (n,) float64
        Smallest width of the mesh's convex hull over its face normals: a body that moves
        further than this in one step may have passed through something (a 1 cm plate's
        bounding radius is 0.42 m, its thickness 0.01 m).
    restitution, friction : (n,) float64
        Material coefficients, combined per contact by the rules of docs/design.md.
    static : (n,) bool
        True for immovable bodies: static and kinematic ones.
    kinematic : (n,) bool
        True for the immovable bodies the user moves.
    kinematic_velocity, kinematic_angular_velocity : (n, 3) float64
        v and w (world frame, w about the centre of mass) of a kinematic body; zero for every
        other body, so a kernel reads an immovable body's velocity from them without a branch.
    collidable : (n,) bool
        False for bodies that take part in no collision (free flight only).
    collision_group, collision_mask : (n,) int64
        Bit fields: two bodies collide only if each one's group meets the other's mask
        (Bullet's rule).
    """

    _FIELDS: ClassVar[dict[str, tuple[tuple[int, ...], type]]] = {
        "position": ((3,), np.float64),
        "orientation": ((4,), np.float64),
        "linear_momentum": ((3,), np.float64),
        "angular_momentum": ((3,), np.float64),
        "inverse_mass": ((), np.float64),
        "inverse_inertia_body": ((3, 3), np.float64),
        "mass": ((), np.float64),
        "inertia_body": ((3, 3), np.float64),
        "center_of_mass_local": ((3,), np.float64),
        "size": ((), np.float64),
        "thickness": ((), np.float64),
        "restitution": ((), np.float64),
        "friction": ((), np.float64),
        "static": ((), np.bool_),
        "kinematic": ((), np.bool_),
        "kinematic_velocity": ((3,), np.float64),
        "kinematic_angular_velocity": ((3,), np.float64),
        "collidable": ((), np.bool_),
        "collision_group": ((), np.int64),
        "collision_mask": ((), np.int64),
    }

    def __init__(self):
        self.count = 0
        self.capacity = _INITIAL_CAPACITY
        self._storage = {
            name: np.zeros((self.capacity, *shape), dtype=dtype)
            for name, (shape, dtype) in self._FIELDS.items()
        }
        self.meshes: list = []
        # the mesh each body is drawn with (its collision mesh unless it was given a visual)
        self.drawn: list = []
        self.names: list[str] = []
        self._saved = (np.empty((0, 3)),)

    def __getattr__(self, name: str) -> np.ndarray:
        storage = self.__dict__.get("_storage")
        if storage is not None and name in storage:
            return storage[name][: self.count]
        raise AttributeError(name)

    def save_state(self) -> None:
        """Keep a copy of the state (x, q, P, L) that ``restore_state`` puts back."""
        self._allocate_saved()
        copy_state(self.count, *self._save_arguments)

    def saved_state(self) -> tuple[np.ndarray, ...]:
        """The arrays ``save_state`` copies the state into and ``restore_state`` copies it
        back from: position, orientation, linear and angular momentum (capacity rows), for a
        kernel that saves the state itself."""
        self._allocate_saved()
        return self._saved

    def restore_state(self) -> None:
        """Put back the state of the last ``save_state``."""
        copy_state(self.count, *self._restore_arguments)

    def _allocate_saved(self) -> None:
        if self._saved[0].shape[0] != self.capacity:
            state = tuple(self._storage[f] for f in STATE_FIELDS)
            self._saved = tuple(np.empty_like(a) for a in state)
            self._save_arguments = state + self._saved
            self._restore_arguments = self._saved + state

    def full(self, name: str) -> np.ndarray:
        """The whole capacity-sized array of a field (kernels index only the live rows)."""
        return self._storage[name]

    def _grow(self) -> None:
        self.capacity *= 2
        for name, old in self._storage.items():
            new = np.zeros((self.capacity, *old.shape[1:]), dtype=old.dtype)
            new[: self.count] = old[: self.count]
            self._storage[name] = new

    def append(self, mesh, name: str, drawn=None, **values) -> int:
        """Append one body; ``values`` gives every field of ``_FIELDS``, ``drawn`` the mesh
        it is drawn with (None: ``mesh``). Returns its index."""
        missing = set(self._FIELDS) - set(values)
        if missing:
            raise ValueError(f"missing body fields: {sorted(missing)}")
        if self.count == self.capacity:
            self._grow()
        index = self.count
        for field, value in values.items():
            self._storage[field][index] = value
        self.count += 1
        self.meshes.append(mesh)
        self.drawn.append(mesh if drawn is None else drawn)
        self.names.append(name)
        return index
