"""Putting bodies where the user says between steps: a kinematic body's path
(``set_kinematic``) and a dynamic body's state (``set_body_state``), which ``World``
inherits. Each keeps the step's own records of the body (where the step started it, which
boxes to refit, whether the contacts must be found again, who sleeps) in line with it."""

from __future__ import annotations

import dataclasses

import numpy as np

from thesis_rbd._validate import as_finite_array, as_unit_quaternion
from thesis_rbd.spatial.quaternion import quat_to_matrix
from thesis_rbd.world.step_kernel import CONTACTS

__all__ = ["WorldStateSetters"]


def _checked_state(position, orientation, velocity, angular_velocity) -> tuple:
    """The state arguments of the setters, each checked (None stays None): position (3,),
    a normalised orientation (4,), velocity (3,) and angular velocity (3,)."""
    x = None if position is None else as_finite_array(position, "position", shape=(3,))
    q = None if orientation is None else as_unit_quaternion(orientation)
    v = None if velocity is None else as_finite_array(velocity, "velocity", shape=(3,))
    w = (
        None
        if angular_velocity is None
        else as_finite_array(angular_velocity, "angular_velocity", shape=(3,))
    )
    return x, q, v, w


class WorldStateSetters:
    """State setters of ``World``: they change ``self.bodies`` and keep ``self._state``,
    ``self._sleep`` and ``self._contacts_stale`` in line."""

    def set_kinematic(
        self, body: int, position=None, orientation=None, velocity=None, angular_velocity=None
    ) -> None:
        """Move a kinematic body, or change its velocity, between steps.

        Parameters
        ----------
        body : int
            A kinematic body's index.
        position : (3,) array_like, optional
            Its centre of mass's new world position (m).
        orientation : (4,) array_like, optional
            Its new (x, y, z, w) orientation; normalised.
        velocity, angular_velocity : (3,) array_like, optional
            Its new v (m/s) and w (rad/s, about its centre of mass), world frame, which each
            step from now moves it by.

        Any argument left None keeps the body's current value. A new pose puts the body
        there at once (a jump, with no velocity of its own: a body driven along a path moves
        smoothly by its velocity), and the contacts are found again there before the next
        step, as they are when the body starts to move, so that the bodies it touches wake.
        """
        body = self._check_body(body)
        b = self.bodies
        if not b.kinematic[body]:
            raise ValueError(
                f"body {body} ({b.names[body]!r}) is not kinematic: set_kinematic moves the "
                "bodies added with kinematic=True"
            )
        x, q, v, w = _checked_state(position, orientation, velocity, angular_velocity)
        was_moving = bool(self._moving_kinematic()[body])
        if x is not None:
            b.position[body] = x
        if q is not None:
            b.orientation[body] = q
        if v is not None:
            b.kinematic_velocity[body] = v
        if w is not None:
            b.kinematic_angular_velocity[body] = w
        started = not was_moving and bool(self._moving_kinematic()[body])
        self._moved(body, x is not None or q is not None or started)

    def set_body_state(
        self, body: int, position=None, orientation=None, velocity=None, angular_velocity=None
    ) -> None:
        """Put a dynamic body at a new pose, or give it a new velocity, between steps
        (pybullet's resetBasePositionAndOrientation and resetBaseVelocity).

        Parameters
        ----------
        body : int
            A dynamic body's index (``set_kinematic`` moves kinematic bodies).
        position : (3,) array_like, optional
            Its centre of mass's new world position (m).
        orientation : (4,) array_like, optional
            Its new (x, y, z, w) orientation; normalised.
        velocity, angular_velocity : (3,) array_like, optional
            Its new v (m/s) and w (rad/s, about its centre of mass), world frame.

        Any argument left None keeps the body's current value (a new orientation keeps its
        angular velocity, not its angular momentum). The body wakes, and the contacts are
        found again where it now is before the next step. Joints are not consulted: a body
        put where its joints do not hold is pulled back by them over the next steps
        (``Robot.set_joint_positions`` places a whole mechanism consistently).
        """
        body = self._check_body(body)
        b = self.bodies
        if b.static[body]:
            kind = "kinematic" if b.kinematic[body] else "static"
            raise ValueError(
                f"body {body} ({b.names[body]!r}) is {kind}: set_body_state sets the state of "
                "dynamic bodies (set_kinematic moves kinematic ones)"
            )
        x, q, v, w = _checked_state(position, orientation, velocity, angular_velocity)
        if w is None and q is not None:
            w = self.angular_velocity(body)
        if x is not None:
            b.position[body] = x
        if q is not None:
            b.orientation[body] = q
        if v is not None:
            b.linear_momentum[body] = v / b.inverse_mass[body]
        if w is not None:
            R = quat_to_matrix(b.orientation[body])
            b.angular_momentum[body] = R @ b.inertia_body[body] @ R.T @ w
        self._sleep.wake(np.array([body]))
        self._moved(body, x is not None or q is not None)

    def _moved(self, body: int, jumped: bool) -> None:
        """Record that ``body`` was set: where the step starts it; if it ``jumped`` (or a
        kinematic body started to move), every fat box refitted and the contacts found again
        where it is, which wake the islands it touches."""
        b = self.bodies
        s = self._state
        s.start_position[body], s.start_orientation[body] = b.position[body], b.orientation[body]
        if jumped:
            s.refit_all = True
            self._contacts_stale = bool(self._planned[CONTACTS])
        self._state = dataclasses.replace(s, **self._sleep_fields())
