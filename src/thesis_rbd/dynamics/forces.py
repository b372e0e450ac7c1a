"""Forces and torques on free bodies: gravity, drag and applied forces (thesis 2.2, 1.3).

The force model splits in two:

* a state-independent part gathered once per step by the ``forces`` stage: M g plus every
  applied force active this step (``external_force``, (n, 3)), and the applied forces that act
  at a point, whose torque arm turns with the body (``PointForces``);
* a state-dependent part evaluated by the integrator at every sub-stage, so that RK4 stays
  fourth order with drag: linear drag -k1 v, quadratic drag -k2 |v| v, angular drag -ka w, and
  the point forces' torques (R r) x F.

An applied force with a ``duration`` delivers exactly ``force * duration`` of impulse: in the
step where it runs out it is scaled by the fraction of the step it still covers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from thesis_rbd.spatial.quaternion import quat_rotate

__all__ = ["AppliedForces", "DragCoefficients", "PointForces", "world_arm_to_body"]


@dataclass(frozen=True)
class DragCoefficients:
    """Air resistance shared by every dynamic body.

    Attributes
    ----------
    linear : float
        k1 in F = -k1 v (N s/m).
    quadratic : float
        k2 in F = -k2 |v| v (N s^2/m^2).
    angular : float
        ka in tau = -ka w (N m s).
    """

    linear: float = 0.0
    quadratic: float = 0.0
    angular: float = 0.0

    def __post_init__(self):
        for name in ("linear", "quadratic", "angular"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name} drag must be finite and >= 0, got {value!r}")

    @property
    def any(self) -> bool:
        return self.linear > 0 or self.quadratic > 0 or self.angular > 0


@dataclass
class PointForces:
    """Forces acting this step at body-fixed points, grouped by body (CSR layout).

    Attributes
    ----------
    start : (n + 1,) int64
        Forces of body i are rows start[i]:start[i+1].
    arm : (k, 3) float64
        Point of application minus centre of mass, in the body frame.
    force : (k, 3) float64
        World-frame force, already scaled by the share of the step it is active.
    """

    start: np.ndarray
    arm: np.ndarray
    force: np.ndarray

    @classmethod
    def empty(cls, body_count: int) -> PointForces:
        return cls(np.zeros(body_count + 1, np.int64), np.zeros((0, 3)), np.zeros((0, 3)))


@dataclass
class AppliedForces:
    """Forces applied by the user, each to one body, for a duration or until removed.

    Attributes
    ----------
    body : (k,) int64
        Body index of each force.
    force : (k, 3) float64
        World-frame force (N).
    arm : (k, 3) float64
        Point of application relative to the centre of mass in the body frame (zero: through
        the centre of mass, no torque).
    remaining : (k,) float64
        Seconds left; inf for a force that lasts until the end of the run.
    """

    body: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    force: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    arm: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    remaining: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.body)

    def add(self, body: int, force: np.ndarray, arm: np.ndarray, duration: float) -> None:
        """Append one force (arrays already validated by the caller)."""
        self.body = np.append(self.body, np.int64(body))
        self.force = np.vstack([self.force, force])
        self.arm = np.vstack([self.arm, arm])
        self.remaining = np.append(self.remaining, duration)

    def gather(self, dt: float, base_force: np.ndarray, static) -> tuple[np.ndarray, PointForces]:
        """Forces of the coming step, then advance every duration by ``dt``.

        Parameters
        ----------
        dt : float
            Step length (s).
        base_force : (n, 3) float64
            The constant part, M g per dynamic body (world frame); not modified.
        static : (n,) bool
            Static bodies get no force.

        Returns
        -------
        external_force : (n, 3) float64
            ``base_force`` plus the sum of the active applied forces of each body.
        point_forces : PointForces
            The active applied forces with a non-zero arm, for the torque.
        """
        body_count = len(base_force)
        external_force = base_force.copy()
        share = np.clip(self.remaining, 0.0, dt) / dt
        active = (share > 0) & ~static[self.body]
        scaled = self.force * share[:, None]
        np.add.at(external_force, self.body[active], scaled[active])

        with_torque = active & np.any(self.arm != 0.0, axis=1)
        order = np.argsort(self.body[with_torque], kind="stable")
        bodies = self.body[with_torque][order]
        start = np.searchsorted(bodies, np.arange(body_count + 1)).astype(np.int64)
        points = PointForces(
            start=start,
            arm=np.ascontiguousarray(self.arm[with_torque][order]),
            force=np.ascontiguousarray(scaled[with_torque][order]),
        )

        self.remaining = self.remaining - dt
        keep = self.remaining > 0
        if not keep.all():
            self.body, self.force = self.body[keep], self.force[keep]
            self.arm, self.remaining = self.arm[keep], self.remaining[keep]
        return external_force, points


def world_arm_to_body(point, position, orientation) -> np.ndarray:
    """Body-frame arm (3,) of a world point (3,) on a body at (position, orientation)."""
    conj = np.array([-orientation[0], -orientation[1], -orientation[2], orientation[3]])
    return quat_rotate(conj, np.asarray(point, dtype=np.float64) - position)
