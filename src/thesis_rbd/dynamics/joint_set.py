"""Joints as flat arrays: what ``World.add_joint`` records, and the islands they join.

A joint holds two bodies together at an anchor. Everything the solver needs is stored in the
bodies' own frames at creation, so the joint is zero where it was made:

* the anchor on each body, relative to its centre of mass in its body frame (``arm_a``,
  ``arm_b``; for the world, ``arm_b`` is the world point);
* the joint axis in each body's frame (``axis_a``, ``axis_b``) and two unit vectors
  perpendicular to it in body b's frame (``normal_b``, ``binormal_b``: right-handed with the
  axis, ``normal_b x binormal_b = axis_b``);
* body a's orientation relative to body b's at creation (``relative_orientation``: conj(q_b)
  q_a), the zero of every angle;
* the anchors' distance at creation (a rod's length);
* the joint's length scale, the larger bounding radius of its bodies, which sets the
  tolerance its gap is solved to;
* the limits of a hinge's angle (rad), a slider's travel (m), a distance joint's length
  (m) or a spherical joint's twist (rad), -inf and inf where none, and a spherical joint's
  cone (rad, inf where none);
* a universal or generic joint's six axes (``AXIS_LOWER``, ``AXIS_UPPER``): travel along
  the joint frame's x, y and z, then turns about them, each free (-inf, inf), locked (0, 0)
  or limited (lower < upper). The joint frame is (axis, normal_b, binormal_b) on body b and
  the same frame carried by body a (it coincides with b's at creation). A turn's position
  is its Cardan angle: body a's orientation relative to b is Rx(alpha) Ry(beta) Rz(gamma)
  in the joint frame (Bullet's generic joint's convention), so beta is within [-pi/2, pi/2]
  and alpha and gamma lose their meaning where beta reaches it; a lone turn the other two
  lock is a hinge's angle about its axis, in (-pi, pi];
* its motor (``joint_motors``): none, a velocity target (rad/s or m/s) with the most torque
  or force it may use, a set torque (N m) or force (N), a position target with stiffness
  (N m/rad or N/m) and damping (N m s/rad or N s/m), or a servo (a position target held
  rigidly, with the most torque or force and speed it may use, and the rate the target
  moves at, rad/s or m/s: a target on a trajectory is reached where it will be);
* the forces along its axis row that no one drives (``joint_forces``): a distance joint's
  spring (stiffness N/m towards its rest length, m), a viscous damping (a hinge's N m s/rad,
  a slider's or a spring's N s/m) and a hinge's or slider's Coulomb friction (N m or N),
  zero where none.

Body b is -1 for the world. Kinds and the constraint rows each one holds (``joint_rows``):

===============  =====  ============================================================
kind (code)      rows   held
===============  =====  ============================================================
"spherical"      3      the anchors together
"revolute"       5      the anchors together, the axes of a and b parallel
"fixed"          6      the anchors together, the relative orientation
"prismatic"      5      the anchor of a on b's line through the anchor along the axis,
                        the relative orientation
"distance"       1      the anchors at the rod's length (a rod: no limits, no spring)
``FREE_LENGTH``  0      nothing: a distance joint with limits (a rope) or a spring, its
                        length free within its limits (``World.add_joint`` kind
                        "distance")
"universal"      4      the anchors together, b's x axis square to a's y axis (a
                        generic joint whose travel and z turn are locked)
"generic"        0-6    each locked axis: travel along b's axis, or the turns (all
                        three: the relative orientation; two: the free turn's axes
                        parallel, as a hinge; one: the Cardan pair square, as a
                        universal joint)
===============  =====  ============================================================

A limited joint has one row more, written only where a limit is passed; a generic joint has
one for each limited axis.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from thesis_rbd._validate import as_finite_array
from thesis_rbd.dynamics.joint_tree import elimination_order, fixed_base_trees, later_neighbours
from thesis_rbd.spatial.quaternion import quat_conjugate, quat_multiply, quat_rotate

__all__ = ["FREE_LENGTH", "JOINT_KINDS", "KIND_NAMES", "JointSet", "check_reach"]

# Kind names and their codes in the kernels (``joint_rows``).
JOINT_KINDS = {
    "spherical": 0, "revolute": 1, "fixed": 2, "prismatic": 3, "distance": 4, "universal": 6,
    "generic": 7,
}  # fmt: skip
# The code of a distance joint that holds no rod (a rope, a spring): a kind of its own in the
# kernels, since it has no equality row.
FREE_LENGTH = 5
# The name of each code, as World.joints reports it.
KIND_NAMES = tuple(
    next(name for name, code in JOINT_KINDS.items() if code == c) if c != FREE_LENGTH
    else "distance"
    for c in range(len(JOINT_KINDS) + 1)
)  # fmt: skip

# Columns of ``JointSet.floats``.
ARM_A, ARM_B, AXIS_A, AXIS_B, NORMAL_B, BINORMAL_B = 0, 3, 6, 9, 12, 15
RELATIVE_ORIENTATION = 18
LENGTH = 22
SCALE = 23
LOWER, UPPER = 24, 25
MOTOR, MOTOR_TARGET, MOTOR_MAX, MOTOR_STIFFNESS, MOTOR_DAMPING, MOTOR_SPEED = range(26, 32)
SPRING_STIFFNESS, SPRING_REST, DAMPING, FRICTION = range(32, 36)
CONE = 36
AXIS_LOWER, AXIS_UPPER = 37, 43
SERVO_VELOCITY = 49
JOINT_FLOATS = 50
# Motor codes in the MOTOR column: none, a velocity target with a force cap, a set torque, a
# position target with stiffness and damping, a servo (the position held as a constraint).
NO_MOTOR, VELOCITY_MOTOR, TORQUE_MOTOR, POSITION_MOTOR, SERVO_MOTOR = range(5)
# Kinds with an axis a hinge turns about or a slider moves along: what motors drive and
# friction and damping resist.
_AXIS_KINDS = ("revolute", "prismatic")
# Kinds whose position (a hinge's angle, a slider's travel, a distance joint's length)
# limits bound.
_LIMITED_KINDS = ("revolute", "prismatic", "distance", "spherical")
# Kinds a fixed-base tree stepped in joint coordinates may hold (``articulated``): one
# coordinate each, or none.
_ARTICULATED_CODES = [JOINT_KINDS[k] for k in ("revolute", "prismatic", "fixed")]
# Kinds whose frame is three axes: each of their six motions is free, locked or limited.
_FRAME_KINDS = ("universal", "generic")
# The six axes of a universal or generic joint, as errors name them.
_AXIS_NAMES = ("travel x", "travel y", "travel z", "turn x", "turn y", "turn z")
# Two axes given as square whose cosine exceeds this are refused (1e-6: a typo, not rounding).
_SQUARE = 1e-6
# Columns of ``JointSet.ints``.
KIND, BODY_A, BODY_B = 0, 1, 2
# An anchor may lie at most this many times a body's bounding radius from that body's centre
# (an anchor far from both bodies is a typo in a coordinate, not a design).
_ANCHOR_REACH = 10.0


def _perpendiculars(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (n, m) with (n, m, axis) right-handed and orthonormal."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    normal = np.cross(helper, axis)
    normal /= np.linalg.norm(normal)
    return normal, np.cross(axis, normal)


def _grouped(group, count, items) -> tuple[np.ndarray, np.ndarray]:
    """CSR of ``items`` by ``group`` (values in [0, count))."""
    order = np.argsort(group, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(group, minlength=count))])
    return start.astype(np.int64), items[order].astype(np.int64)


def _ref(kind: str, ref) -> float:
    """A hinge's angle now (``add_joint``'s ``ref``), checked: a finite float, 0 for every
    other kind."""
    try:
        value = float(ref)
    except (TypeError, ValueError):
        value = math.nan
    if not math.isfinite(value):
        raise ValueError(f"ref must be a finite angle (rad), got {ref!r}")
    if value != 0.0 and kind != "revolute":
        raise ValueError(f"ref is a hinge's angle now: revolute joints only, not {kind!r}")
    return value


def _turn(axis, angle: float) -> np.ndarray:
    """(x, y, z, w) turn by ``angle`` about the unit ``axis``."""
    half = 0.5 * angle
    return np.concatenate([math.sin(half) * np.asarray(axis), [math.cos(half)]])


def _limits(kind: str, limits) -> tuple[float, float, float]:
    """(lower, upper, cone) of a joint from ``limits`` (None: unlimited): the bounds of its
    position, and a spherical joint's cone (rad; inf: none)."""
    if limits is None:
        return -np.inf, np.inf, np.inf
    if kind == "spherical":
        return _cone_and_twist(limits)
    if kind in _FRAME_KINDS:
        return -np.inf, np.inf, np.inf  # an axis's own limits (``_axis_limits``)
    if kind not in _LIMITED_KINDS:
        raise ValueError(
            f"a {kind!r} joint has no free motion to limit; limits bound {_LIMITED_KINDS} joints"
        )
    try:
        lower, upper = (float(v) for v in limits)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"limits must be (lower, upper) numbers, got {limits!r}") from exc
    if np.isnan(lower) or np.isnan(upper) or lower == np.inf or upper == -np.inf:
        raise ValueError(f"limits must be numbers, -inf for no lower, inf for no upper: {limits}")
    if lower > upper:
        raise ValueError(f"limits out of order: lower {lower} > upper {upper}")
    if kind == "revolute" and (-np.inf < lower < -np.pi or np.pi < upper < np.inf):
        raise ValueError(
            f"a hinge's limits lie in [-pi, pi] (its angle's range; -inf or inf for none), got "
            f"({lower}, {upper})"
        )
    if kind == "distance" and not (0.0 <= lower and 0.0 < upper):
        raise ValueError(
            f"a distance joint's limits bound its length: 0 <= lower <= upper, upper > 0 (inf "
            f"for none), got ({lower}, {upper})"
        )
    return lower, upper, np.inf


def _cone_and_twist(limits) -> tuple[float, float, float]:
    """(twist_lo, twist_hi, cone) of a spherical joint's ``limits`` = (cone, twist_lo,
    twist_hi): the largest angle (rad) between the axis fixed in body a and the axis fixed in
    body b (inf: no cone), and the range of a's twist about b's axis (as a hinge's angle)."""
    try:
        cone, lower, upper = (float(v) for v in limits)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"a spherical joint's limits are (cone, twist_lo, twist_hi) numbers, got {limits!r}"
        ) from exc
    if not (0.0 < cone <= np.pi or cone == np.inf):
        raise ValueError(
            f"a spherical joint's cone is an angle in (0, pi] (inf for none), got {cone}"
        )
    if np.isnan(lower) or np.isnan(upper) or lower > upper:
        raise ValueError(f"twist limits out of order or not numbers: ({lower}, {upper})")
    if -np.inf < lower < -np.pi or np.pi < upper < np.inf:
        raise ValueError(
            f"a spherical joint's twist limits lie in [-pi, pi] (-inf or inf for none), got "
            f"({lower}, {upper})"
        )
    return lower, upper, cone


def _joint_frame(kind: str, axis) -> np.ndarray:
    """(3, 3) unit axes (x, y, z) of a joint's frame, as rows, from ``add``'s ``axis``: one
    direction (x; y and z chosen square to it), or for a universal or generic joint two
    square directions (x, y; z = x cross y)."""
    values = np.asarray(axis, dtype=float) if _is_numeric(axis) else None
    if values is not None and values.shape == (2, 3) and kind in _FRAME_KINDS:
        x = as_finite_array(values[0], "axis[0]", shape=(3,))
        y = as_finite_array(values[1], "axis[1]", shape=(3,))
        nx, ny = float(np.linalg.norm(x)), float(np.linalg.norm(y))
        if not (nx > 0.0 and ny > 0.0):
            raise ValueError("axis has a direction of zero length; give two square directions")
        x, y = x / nx, y / ny
        if abs(float(x @ y)) > _SQUARE:
            raise ValueError(
                f"a {kind} joint's two axes must be square to each other (their cosine is "
                f"{float(x @ y):.3g})"
            )
        y = y - (x @ y) * x  # square to round-off
        y /= np.linalg.norm(y)
        return np.stack([x, y, np.cross(x, y)])
    if kind in _FRAME_KINDS and values is not None and values.ndim == 2:
        raise ValueError(f"a {kind} joint's axis is one direction (3,) or two square ones (2, 3)")
    x = as_finite_array(axis, "axis", shape=(3,))
    length = float(np.linalg.norm(x))
    if not length > 0.0:
        raise ValueError("axis has zero length; give a direction such as (0, 0, 1)")
    x = x / length
    return np.stack([x, *_perpendiculars(x)])


def _is_numeric(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _axis_limits(kind: str, axes, limits) -> tuple[np.ndarray, np.ndarray]:
    """(6,) lower and upper bounds of a universal or generic joint's axes (module docstring)
    from ``add``'s ``axes`` (generic) or ``limits`` (universal: its two turns' (lower, upper)
    pairs); -inf and inf for the other kinds."""
    if kind not in _FRAME_KINDS:
        if axes is not None:
            raise ValueError(f"axes are a generic joint's, not a {kind!r} joint's")
        return np.full(6, -np.inf), np.full(6, np.inf)
    if kind == "universal":
        if axes is not None:
            raise ValueError("a universal joint's axes are fixed; its limits bound its two turns")
        turns = ("free", "free") if limits is None else _universal_limits(limits)
        axes = ("locked", "locked", "locked", *turns, "locked")
    elif limits is not None:
        raise ValueError("a generic joint's limits are given in its axes: (lower, upper) entries")
    if axes is None or isinstance(axes, str) or len(axes) != 6:
        raise ValueError(
            "a generic joint needs axes: six entries (travel along x, y, z, then turns about "
            f"them), each 'free', 'locked' or (lower, upper); got {axes!r}"
        )
    lower, upper = np.empty(6), np.empty(6)
    for k, entry in enumerate(axes):
        if isinstance(entry, str) and entry in ("free", "locked"):
            bound = np.inf if entry == "free" else 0.0
            lower[k], upper[k] = -bound, bound
            continue
        try:
            lower[k], upper[k] = (float(v) for v in entry)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"axes[{k}] ({_AXIS_NAMES[k]}) must be 'free', 'locked' or (lower, upper), got "
                f"{entry!r}"
            ) from exc
        if np.isnan(lower[k]) or np.isnan(upper[k]) or not lower[k] < upper[k]:
            raise ValueError(
                f"axes[{k}] ({_AXIS_NAMES[k]}) limits must be numbers with lower < upper "
                f"('locked' holds an axis at zero), got {entry!r}"
            )
    turning = np.flatnonzero(~((lower[3:] == 0.0) & (upper[3:] == 0.0)))
    for k in turning:
        # a lone turn is a hinge's angle; several are Cardan angles, the middle one's within
        # a quarter turn either way
        reach = np.pi / 2 if (k == 1 and len(turning) > 1) else np.pi
        if -np.inf < lower[3 + k] < -reach or reach < upper[3 + k] < np.inf:
            raise ValueError(
                f"axes[{3 + k}] ({_AXIS_NAMES[3 + k]}) limits lie in [{-reach:.6g}, "
                f"{reach:.6g}] rad (-inf or inf for none), got ({lower[3 + k]}, "
                f"{upper[3 + k]})"
            )
    return lower, upper


def _universal_limits(limits) -> tuple:
    """A universal joint's ``limits``: ((lower, upper) of its turn about b's axis, (lower,
    upper) of its turn about a's)."""
    try:
        first, second = limits
        pairs = tuple(tuple(float(v) for v in pair) for pair in (first, second))
        if any(len(pair) != 2 for pair in pairs):
            raise ValueError
    except (TypeError, ValueError) as exc:
        raise ValueError(
            "a universal joint's limits are ((lower, upper), (lower, upper)) of its two turns, "
            f"got {limits!r}"
        ) from exc
    return pairs


def _motor(kind: str, motor) -> tuple[tuple[float, ...], float]:
    """((code, target, cap, stiffness, damping, speed), servo velocity) of a motor given as
    World.add_joint's ``motor`` (None: none)."""
    if motor is None:
        return (NO_MOTOR, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0
    if not isinstance(motor, dict):
        raise ValueError(f"motor must be a dict such as {{'velocity': 1.0, 'max_force': 2.0}}, "
                         f"got {motor!r}")  # fmt: skip
    if kind not in _AXIS_KINDS:
        raise ValueError(
            f"a motor drives a hinge or a slider along its axis: {_AXIS_KINDS} joints, not {kind!r}"
        )
    keys = set(motor)
    if keys == {"velocity", "max_force"}:
        return (VELOCITY_MOTOR, _finite(motor["velocity"], "motor velocity"),
                _cap(motor, "max_force"), 0.0, 0.0, 0.0), 0.0  # fmt: skip
    if keys == {"torque"}:
        return (TORQUE_MOTOR, _finite(motor["torque"], "motor torque"), 0.0, 0.0, 0.0, 0.0), 0.0
    if {"position", "stiffness", "damping"} <= keys <= {"position", "stiffness", "damping",
                                                        "max_force"}:  # fmt: skip
        return (POSITION_MOTOR, _target(kind, motor["position"], "position"),
                _cap(motor, "max_force"), _cap(motor, "stiffness"), _cap(motor, "damping"),
                0.0), 0.0  # fmt: skip
    if {"servo"} <= keys <= {"servo", "velocity", "max_force", "max_velocity"}:
        return (
            (SERVO_MOTOR, _target(kind, motor["servo"], "servo"), _cap(motor, "max_force"),
             0.0, 0.0, _cap(motor, "max_velocity")),
            _finite(motor.get("velocity", 0.0), "servo velocity"),
        )  # fmt: skip
    raise ValueError(
        f"motor {motor!r}: give {{'velocity': v, 'max_force': f}}, {{'torque': t}}, "
        "{'position': q, 'stiffness': k, 'damping': c[, 'max_force': f]} or "
        "{'servo': q[, 'velocity': v, 'max_force': f, 'max_velocity': w]}"
    )


def _forces(kind: str, options: dict, length: float) -> tuple[float, float, float, float]:
    """(spring stiffness, rest length, damping, friction) of World.add_joint's ``spring``,
    ``damping`` and ``friction``, checked against the joint's kind; ``length`` is the anchors'
    distance now (the rest length where none is given)."""
    spring = options.get("spring")
    damping = _non_negative(options.get("damping", 0.0), "damping")
    friction = _non_negative(options.get("friction", 0.0), "friction")
    if (damping > 0.0 or friction > 0.0) and kind not in _AXIS_KINDS:
        field = "damping" if damping > 0.0 else "friction"
        hint = (
            "; a distance joint's damping is its spring's: spring={'stiffness': k, 'damping': c}"
            if kind == "distance" and field == "damping"
            else ""
        )
        raise ValueError(
            f"{field} resists a hinge's turning or a slider's travel: {_AXIS_KINDS} joints, not "
            f"{kind!r}{hint}"
        )
    if spring is None:
        return 0.0, 0.0, damping, friction
    if kind != "distance":
        raise ValueError(
            f"spring is for distance joints (a force along the anchors' line), not {kind!r}"
        )
    if not isinstance(spring, dict) or not {"stiffness"} <= set(spring) <= {
        "stiffness", "damping", "rest_length"
    }:  # fmt: skip
        raise ValueError(
            "spring must be a dict {'stiffness': k[, 'damping': c, 'rest_length': L]}, got "
            f"{spring!r}"
        )
    stiffness = _non_negative(spring["stiffness"], "spring stiffness")
    rest = _non_negative(spring.get("rest_length", length), "spring rest_length")
    return stiffness, rest, _non_negative(spring.get("damping", 0.0), "spring damping"), 0.0


def _non_negative(value, name: str) -> float:
    number = _finite(value, name)
    if number < 0.0:
        raise ValueError(f"{name} must be >= 0, got {number}")
    return number


def _cap(motor: dict, key: str) -> float:
    """A motor's non-negative gain or cap; inf where a cap is not given."""
    value = _finite(motor[key], f"motor {key}", allow_inf=True) if key in motor else np.inf
    if value < 0.0:
        raise ValueError(f"motor {key} must be >= 0, got {value}")
    return value


def _target(kind: str, value, key: str) -> float:
    target = _finite(value, f"motor {key}")
    if kind == "revolute" and not -np.pi <= target <= np.pi:
        raise ValueError(f"a hinge's motor {key} lies in [-pi, pi] (its angle), got {target}")
    return target


def _finite(value, name: str, allow_inf: bool = False) -> float:
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if np.isnan(number) or (np.isinf(number) and not (allow_inf and number > 0)):
        raise ValueError(f"{name} must be finite, got {number}")
    return number


def check_reach(point, centres, radii, field: str) -> None:
    """Refuse a joint's point further than ``_ANCHOR_REACH`` bounding radii from both of its
    bodies' centres, (2, 3) m and (2,) m: a typo in a coordinate, not a mechanism."""
    gaps = np.linalg.norm(np.asarray(point) - centres, axis=1)
    if np.all(gaps > _ANCHOR_REACH * radii):
        raise ValueError(
            f"{field} is far from both bodies: {gaps[0]:.6g} m from body_a's centre and "
            f"{gaps[1]:.6g} m from body_b's, more than {_ANCHOR_REACH:g} times their "
            f"bounding radii ({radii[0]:.6g} m, {radii[1]:.6g} m)"
        )


class JointSet:
    """Growable arrays of joints.

    Attributes
    ----------
    ints : (m, 3) int64
        kind code, body a, body b (-1: the world).
    floats : (m, JOINT_FLOATS) float64
        The frames of the module docstring.
    collide : (m,) bool
        Whether the joint's two bodies still collide with each other.
    names : list of str
    """

    def __init__(self):
        self.ints = np.zeros((0, 3), np.int64)
        self.floats = np.zeros((0, JOINT_FLOATS))
        self.collide = np.zeros(0, bool)
        self.names: list[str] = []

    def __len__(self) -> int:
        return len(self.ints)

    def add(self, kind, body_a, body_b, anchor, axis, anchor_b, collide, name, bodies, options):
        """Validate a joint against ``bodies`` (``BodyArrays``) and append it; return its index.

        See ``World.add_joint`` for the arguments; ``options`` holds ``limits``, ``axes``,
        ``motor``, ``spring``, ``damping`` and ``friction`` (each left out: none).
        """
        if not isinstance(kind, str) or kind not in JOINT_KINDS:
            raise ValueError(f"unknown joint kind {kind!r}; choose one of {list(JOINT_KINDS)}")
        a = self._body(body_a, "body_a", bodies, allow_world=False)
        b = self._body(body_b, "body_b", bodies, allow_world=True)
        if a == b:
            raise ValueError(f"body_a and body_b are the same body ({a}): a body jointed to itself")
        if bodies.static[a] and (b < 0 or bodies.static[b]):
            raise ValueError(
                f"body_a ({a}) is static and so is body_b: a joint between immovable bodies "
                "holds nothing"
            )
        anchor = as_finite_array(anchor, "anchor", shape=(3,))
        anchor_b = anchor if anchor_b is None else as_finite_array(anchor_b, "anchor_b", (3,))
        if kind != "distance" and anchor_b is not anchor and not np.array_equal(anchor, anchor_b):
            raise ValueError(f"anchor_b is for distance joints only, not {kind!r} joints")
        frame = _joint_frame(kind, axis)
        axis, normal, binormal = frame
        axis_lower, axis_upper = _axis_limits(kind, options.get("axes"), options.get("limits"))
        if b >= 0:
            check_reach(anchor, bodies.position[[a, b]], bodies.size[[a, b]], "anchor")
            if kind == "distance":
                check_reach(anchor_b, bodies.position[[a, b]], bodies.size[[a, b]], "anchor_b")
        length = float(np.linalg.norm(anchor - anchor_b))
        # a distance joint with limits or a spring lets its length go: no rod
        code = JOINT_KINDS[kind]
        if kind == "distance" and (
            options.get("limits") is not None or options.get("spring") is not None
        ):
            code = FREE_LENGTH
        if code == JOINT_KINDS["distance"] and not length > 0.0:
            raise ValueError(
                "a distance joint needs anchor_b apart from anchor (its length is their distance)"
            )

        q_a = bodies.orientation[a]
        q_b = bodies.orientation[b] if b >= 0 else np.array([0.0, 0.0, 0.0, 1.0])
        x_b = bodies.position[b] if b >= 0 else np.zeros(3)
        to_a, to_b = quat_conjugate(q_a), quat_conjugate(q_b)
        row = np.zeros(JOINT_FLOATS)
        row[ARM_A : ARM_A + 3] = quat_rotate(to_a, anchor - bodies.position[a])
        row[ARM_B : ARM_B + 3] = quat_rotate(to_b, anchor_b - x_b)
        row[AXIS_A : AXIS_A + 3] = quat_rotate(to_a, axis)
        row[AXIS_B : AXIS_B + 3] = quat_rotate(to_b, axis)
        row[NORMAL_B : NORMAL_B + 3] = quat_rotate(to_b, normal)
        row[BINORMAL_B : BINORMAL_B + 3] = quat_rotate(to_b, binormal)
        row[RELATIVE_ORIENTATION : RELATIVE_ORIENTATION + 4] = quat_multiply(
            _turn(row[AXIS_B : AXIS_B + 3], -_ref(kind, options.get("ref", 0.0))),
            quat_multiply(to_b, q_a),
        )
        row[LENGTH] = length
        row[SCALE] = max(bodies.size[a], bodies.size[b] if b >= 0 else 0.0)
        row[LOWER], row[UPPER], row[CONE] = _limits(kind, options.get("limits"))
        row[AXIS_LOWER : AXIS_LOWER + 6] = axis_lower
        row[AXIS_UPPER : AXIS_UPPER + 6] = axis_upper
        row[MOTOR : MOTOR + 6], row[SERVO_VELOCITY] = _motor(kind, options.get("motor"))
        row[SPRING_STIFFNESS : FRICTION + 1] = _forces(kind, options, length)
        if name is not None and (not isinstance(name, str) or not name or "\0" in name):
            raise ValueError(f"joint name must be a non-empty string, got {name!r}")
        # every check is done: nothing half-added is left when one fails
        index = len(self.names)
        self.ints = np.vstack([self.ints, [code, a, b]])
        self.floats = np.vstack([self.floats, row])
        self.collide = np.append(self.collide, bool(collide))
        self.names.append(name if name is not None else f"joint{index}")
        return index

    def set_motor(self, index: int, motor: dict | None) -> None:
        """Replace joint ``index``'s motor (None: switch it off), in place."""
        if isinstance(index, bool) or not isinstance(index, int | np.integer):
            raise ValueError(f"joint must be a joint index, got {index!r}")
        if not 0 <= index < len(self):
            raise ValueError(f"no joint {index}; the world has {len(self)} joints")
        kind = KIND_NAMES[self.ints[index, KIND]]
        self.floats[index, MOTOR : MOTOR + 6], self.floats[index, SERVO_VELOCITY] = _motor(
            kind, motor
        )

    @staticmethod
    def _body(body, field, bodies, allow_world) -> int:
        if body is None and allow_world:
            return -1
        if isinstance(body, bool) or not isinstance(body, int | np.integer):
            raise ValueError(f"{field} must be a body index, got {body!r}")
        if not 0 <= body < bodies.count:
            raise ValueError(f"{field}: no body {body}; the world has {bodies.count} bodies")
        return int(body)

    def jointed(self, count: int) -> np.ndarray:
        """(count,) bool: the bodies some joint holds."""
        mask = np.zeros(count, bool)
        mask[self.ints[:, BODY_A]] = True
        b = self.ints[:, BODY_B]
        mask[b[b >= 0]] = True
        return mask

    def islands(self, static: np.ndarray) -> tuple[np.ndarray, ...]:
        """Joints and moving bodies grouped by the islands the joints make (static bodies and
        the world join none), each island's joints in elimination order (``joint_tree``).

        Returns
        -------
        joint_start, island_joints : (k + 1,), (m,) int64
            Island i holds the joints ``island_joints[joint_start[i]:joint_start[i + 1]]``,
        body_start, island_bodies : (k + 1,), (b,) int64
            and the moving bodies ``island_bodies[body_start[i]:body_start[i + 1]]``.
        tree : (k,) bool
            Whether island i is a tree (solved by ``joint_tree``) or has a closed loop.
        neighbour_start, neighbour : (m + 1,), (p,) int64
            ``joint_tree.later_neighbours`` of each joint slot.
        fixed_base, parents, sides : (k,) bool, (m,), (m,) int64
            The islands ``articulated`` may step in joint coordinates, and each joint's
            parent and child there (``joint_tree.fixed_base_trees``).
        """
        n = len(static)
        a, b = self.ints[:, BODY_A], self.ints[:, BODY_B]
        links = (b >= 0) & ~static[a] & ~static[np.maximum(b, 0)]
        graph = coo_matrix((np.ones(int(links.sum())), (a[links], b[links])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        # a joint is in the island of its moving body
        joint_island = label[np.where(static[a], np.maximum(b, 0), a)]
        islands, joint_island = np.unique(joint_island, return_inverse=True)
        count = len(islands)
        depth, tree = elimination_order(a, b, static, joint_island, count)
        order = np.lexsort((-depth, joint_island))
        joint_start = np.concatenate([[0], np.cumsum(np.bincount(joint_island, minlength=count))])
        moving = np.zeros(n, bool)
        moving[a] = True
        moving[b[b >= 0]] = True
        moving &= ~static
        bodies = np.flatnonzero(moving)
        body_island = np.searchsorted(islands, label[bodies])
        body_start, island_bodies = _grouped(body_island, count, bodies)
        neighbour_start, neighbour = later_neighbours(a, b, static, order, joint_start)
        articulable = np.isin(self.ints[:, KIND], _ARTICULATED_CODES)
        fixed_base, parents, sides = fixed_base_trees(
            a, b, static, order, joint_start, tree, articulable
        )
        return (
            joint_start.astype(np.int64), order.astype(np.int64), body_start, island_bodies,
            tree, neighbour_start, neighbour, fixed_base, parents, sides,
        )  # fmt: skip

    def moving_links(self, moving: np.ndarray) -> np.ndarray:
        """(p, 2) int64 body pairs of the joints between two ``moving`` (n,) bool bodies."""
        a, b = self.ints[:, BODY_A], self.ints[:, BODY_B]
        keep = b >= 0
        keep[keep] = moving[a[keep]] & moving[b[keep]]
        return np.stack([a, b], axis=1)[keep].astype(np.int64).reshape(-1, 2)

    def excluded_pairs(self) -> np.ndarray:
        """(p, 2) int64 body pairs (low, high) that must not collide: jointed, collide=False."""
        a, b = self.ints[:, BODY_A], self.ints[:, BODY_B]
        keep = ~self.collide & (b >= 0)
        pairs = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)[keep]
        return pairs.astype(np.int64).reshape(-1, 2)
