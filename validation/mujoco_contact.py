"""MuJoCo as a peer for contact scenes (optional: the ``mujoco`` package).

MuJoCo runs at its defaults: the scene sets the time step, gravity, each body's shape, mass,
pose and sliding friction (MuJoCo's geom friction, default 1, is a property of the scene like
pybullet's lateral friction) and nothing of the solver. Its contacts are soft: a resting body
sits in a small steady penetration that its solver reference time sets (``solref`` 0.02 s by
default), whatever the body's size. Bodies never sleep unless the model enables it.

MuJoCo quaternions are (w, x, y, z); the scenes here give (x, y, z, w), reordered only in
``_mjcf_quaternion``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["MujocoScene", "require_mujoco"]


def require_mujoco():
    """The ``mujoco`` module, or ImportError saying how to install it."""
    try:
        import mujoco
    except ImportError as error:
        raise ImportError(
            "the MuJoCo peer needs the optional 'mujoco' package: pip install mujoco"
        ) from error
    return mujoco


def _mjcf_quaternion(q) -> str:
    """(x, y, z, w) as MJCF's "w x y z"."""
    x, y, z, w = (float(v) for v in q)
    return f"{w!r} {x!r} {y!r} {z!r}"


def _vector(v) -> str:
    return " ".join(repr(float(x)) for x in v)


class MujocoScene:
    """A MuJoCo model built from boxes and spheres, stepped at a fixed time step.

    Parameters
    ----------
    dt : float
        Time step (s).
    gravity : float
        Magnitude of g along -z.
    bodies : list of (shape, size, mass, position, orientation, friction, linear_velocity,
        angular_velocity)
        ``shape`` "box" (``size`` the (3,) half extents) or "sphere" (``size`` (radius,));
        ``mass`` None for a static body (a geom of the world body); orientation (x, y, z, w);
        the velocities (3,) in the world frame, those of a static body ignored.
    """

    def __init__(self, dt: float, gravity: float, bodies):
        mujoco = require_mujoco()
        self.mujoco = mujoco
        parts = []
        # MuJoCo body id of each given body (0, the world body, for static ones)
        self._body_id = []
        velocities = []
        for shape, size, mass, position, orientation, friction, v, w in bodies:
            if mass is not None:
                velocities.append((orientation, v, w))
            self._body_id.append(0 if mass is None else 1 + sum(i > 0 for i in self._body_id))
            geom = (
                f'<geom type="{shape}" size="{_vector(size)}" friction="{float(friction)!r}"'
                + ("" if mass is None else f' mass="{float(mass)!r}"')
                + "/>"
            )
            pose = f'pos="{_vector(position)}" quat="{_mjcf_quaternion(orientation)}"'
            if mass is None:
                parts.append(geom.replace("<geom ", f"<geom {pose} "))
            else:
                parts.append(f"<body {pose}><freejoint/>{geom}</body>")
        xml = (
            f'<mujoco><option timestep="{float(dt)!r}" gravity="0 0 {-float(gravity)!r}"/>'
            f"<worldbody>{''.join(parts)}</worldbody></mujoco>"
        )
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        # a free joint's velocity: the linear one in the world frame, the angular one in the
        # body's
        for k, (orientation, v, w) in enumerate(velocities):
            turn = Rotation.from_quat(orientation)
            self.data.qvel[6 * k : 6 * k + 6] = [*v, *turn.inv().apply(w)]
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        self.mujoco.mj_step(self.model, self.data, n)

    def position(self, body: int) -> np.ndarray:
        """(3,) world position of the given body's centre."""
        return self.data.xpos[self._body_id[body]].copy()

    def orientation(self, body: int) -> np.ndarray:
        """(4,) (x, y, z, w) orientation of the given body."""
        w, x, y, z = self.data.xquat[self._body_id[body]]
        return np.array([x, y, z, w])

    def velocity(self, body: int) -> np.ndarray:
        """(3,) world linear velocity of the given body's centre of mass."""
        return self._velocity(body)[3:]

    def angular_velocity(self, body: int) -> np.ndarray:
        """(3,) world angular velocity of the given body."""
        return self._velocity(body)[:3]

    def _velocity(self, body: int) -> np.ndarray:
        out = np.zeros(6)
        self.mujoco.mj_objectVelocity(
            self.model, self.data, self.mujoco.mjtObj.mjOBJ_BODY, self._body_id[body], out, 0
        )
        return out

    def max_penetration(self) -> float:
        """Deepest active contact (m), 0 when none penetrates."""
        contacts = self.data.contact[: self.data.ncon]
        return float(max(0.0, -contacts.dist.min())) if self.data.ncon else 0.0

    def close(self) -> None:
        """Nothing to release (kept for symmetry with the pybullet peer)."""
