"""What a world's bodies are now: positions, orientations, momenta, velocities, transforms
and energies, read from its body arrays (``World`` inherits these; stepping lives in
``world/world.py``)."""

from __future__ import annotations

import numpy as np

from thesis_rbd.spatial.quaternion import quat_conjugate, quat_rotate, quat_to_matrix

__all__ = ["WorldReadout"]


class WorldReadout:
    """Read-outs of ``self.bodies`` (``BodyArrays``) and ``self.gravity`` (3,): copies or
    read-only views, so that no caller can change a world's state behind its step."""

    def _check_body(self, body) -> int:
        if isinstance(body, bool) or int(body) != body or not 0 <= body < self.bodies.count:
            raise ValueError(f"no body {body!r}: the world has {self.bodies.count} bodies")
        return int(body)

    def __len__(self) -> int:
        return self.bodies.count

    @property
    def positions(self) -> np.ndarray:
        """(n, 3) read-only view of the centres of mass (world)."""
        view = self.bodies.position.view()
        view.flags.writeable = False
        return view

    @property
    def orientations(self) -> np.ndarray:
        """(n, 4) read-only view of the (x, y, z, w) orientations."""
        view = self.bodies.orientation.view()
        view.flags.writeable = False
        return view

    @property
    def names(self) -> list[str]:
        return list(self.bodies.names)

    def position(self, body: int) -> np.ndarray:
        """(3,) world centre of mass of a body."""
        return self.bodies.position[self._check_body(body)].copy()

    def orientation(self, body: int) -> np.ndarray:
        """(4,) (x, y, z, w) orientation of a body."""
        return self.bodies.orientation[self._check_body(body)].copy()

    def linear_momentum(self, body: int) -> np.ndarray:
        """(3,) P = M v (world); zero for a static or kinematic body, which no impulse
        changes."""
        return self.bodies.linear_momentum[self._check_body(body)].copy()

    def angular_momentum(self, body: int) -> np.ndarray:
        """(3,) L about the centre of mass (world); zero for a static or kinematic body."""
        return self.bodies.angular_momentum[self._check_body(body)].copy()

    def linear_velocity(self, body: int) -> np.ndarray:
        """(3,) v = P / M (world); a kinematic body's the one set on it, zero for a static
        body."""
        i = self._check_body(body)
        b = self.bodies
        if b.static[i]:
            return b.kinematic_velocity[i].copy()
        return b.linear_momentum[i] * b.inverse_mass[i]

    def angular_velocity(self, body: int) -> np.ndarray:
        """(3,) w = R I_body^-1 R^T L (world); a kinematic body's the one set on it (about its
        centre of mass), zero for a static body."""
        i = self._check_body(body)
        b = self.bodies
        if b.static[i]:
            return b.kinematic_angular_velocity[i].copy()
        R = quat_to_matrix(b.orientation[i])
        return R @ b.inverse_inertia_body[i] @ R.T @ b.angular_momentum[i]

    def transform(self, body: int) -> np.ndarray:
        """(4, 4) rigid transform from the body's mesh frame to the world."""
        i = self._check_body(body)
        b = self.bodies
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(b.orientation[i])
        T[:3, 3] = b.position[i] - T[:3, :3] @ b.center_of_mass_local[i]
        return T

    def kinetic_energy(self) -> float:
        """Total kinetic energy sum(P^2 / 2M + L.w / 2) of the dynamic bodies (J); static and
        kinematic bodies, infinitely heavy, carry none."""
        b = self.bodies
        linear = 0.5 * np.einsum("ij,ij,i->", b.linear_momentum, b.linear_momentum, b.inverse_mass)
        L_body = quat_rotate(quat_conjugate(b.orientation), b.angular_momentum).reshape(-1, 3)
        angular = 0.5 * np.einsum("ij,ijk,ik->", L_body, b.inverse_inertia_body, L_body)
        return float(linear + angular)

    def potential_energy(self) -> float:
        """Gravitational potential energy -sum(M g . x) of the dynamic bodies (J)."""
        b = self.bodies
        dynamic = ~b.static
        return float(-np.sum(b.mass[dynamic] * (b.position[dynamic] @ self.gravity)))
