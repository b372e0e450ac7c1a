"""``load_urdf``: a URDF file's links and joints built into a ``World``.

The file is read whole and turned into a plan (one body per group of welded links, one
world joint per movable or kept fixed joint), every part of the plan is checked, and only
then is anything added to the world: a bad file leaves the world as it was.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path

import numpy as np

from thesis_rbd._validate import as_finite_array, as_unit_quaternion
from thesis_rbd.dynamics.body_builder import body_fields, body_shape
from thesis_rbd.dynamics.joint_set import check_reach
from thesis_rbd.geometry import shapes
from thesis_rbd.spatial.quaternion import quat_from_matrix
from thesis_rbd.spatial.transform import transform_from_pose
from thesis_rbd.urdf.collision_shapes import collision_meshes
from thesis_rbd.urdf.link_mass import combine, link_mass
from thesis_rbd.urdf.robot import Robot, limit_or_inf

__all__ = ["load_urdf"]

_MOVABLE = ("revolute", "continuous", "prismatic", "planar")
# URDF's planar joint: free travel along the frame's x and y and turn about z (its axis)
_PLANAR_AXES = ("free", "free", "locked", "locked", "locked", "free")
# density of the marker cube that stands for a link without collision geometry
_MARKER_DENSITY = 1000.0


# How far beyond +-pi a hinge limit may be written and still mean +-pi (rad)
_PI_ROUNDING = 1e-3


@dataclass
class _Body:
    """One body to add: a group of links welded together, in its root link's frame."""

    root: str
    pose: np.ndarray  # (4, 4) root link frame -> world
    links: list[str] = field(default_factory=list)
    parts: list = field(default_factory=list)  # (mass, (4, 4) link -> root frame) per link
    shapes: list = field(default_factory=list)  # (TriangleMesh, (4, 4) pose in the root frame)
    static: bool = False


@dataclass
class _Joint:
    """One world joint to add, its geometry in world coordinates now."""

    name: str
    kind: str
    child: int
    parent: int | None
    anchor: np.ndarray
    options: dict


def load_urdf(
    world,
    path,
    *,
    base_position=(0.0, 0.0, 0.0),
    base_orientation=(0.0, 0.0, 0.0, 1.0),
    fixed_base: bool = False,
    merge_fixed_links: bool = True,
    self_collision: bool = False,
    inertia: str = "file",
) -> Robot:
    """Add a URDF model's links and joints to a world, in its zero configuration.

    Parameters
    ----------
    world : World
    path : str or Path
        The URDF file; mesh file names in it are relative to its folder (``package://``
        addresses are looked for in that folder and its ancestors).
    base_position : (3,) array_like
        World position of the root link's frame (m).
    base_orientation : (4,) array_like
        (x, y, z, w) rotation of the root link's frame into the world.
    fixed_base : bool
        Weld the root link to the world (a "fixed" joint to None; a root link of zero mass,
        which cannot move, becomes a static body instead).
    merge_fixed_links : bool
        Make links joined by a fixed joint one body (shapes together, mass properties summed)
        instead of two bodies and a "fixed" joint. A link without mass on a fixed joint is
        merged either way.
    self_collision : bool
        Let the model's links collide with each other, except a parent and its child;
        by default none of them do.
    inertia : {"file", "shapes"}
        Where each moving body's centre of mass and inertia come from: the links'
        ``<inertial>`` (the default; pybullet's ``URDF_USE_INERTIA_FROM_FILE``), or its
        collision shapes taken as solid at the links' summed mass (as pybullet's default
        computes them from the shapes; files whose inertia tensors are placeholders, such
        as pybullet_data's ``random_urdfs`` with ``izz = 0``, load this way).

    Returns
    -------
    Robot
        The bodies by link name and the movable joints, in URDF order.

    Raises
    ------
    ImportError
        Where yourdfpy, the URDF parser, is not installed.
    ValueError
        Naming the file and the link or joint, for a file that does not parse, a missing
        mesh file, a moving link without positive mass or with an inertia that is not
        positive definite, a joint axis of zero length, limits a joint cannot take, a mimic
        joint whose leader is not a movable joint, or links that do not form one tree.
        Nothing is added to the world then.

    Notes
    -----
    Each body's frame is its root link's frame (``world.transform`` maps it to the world),
    its centre of mass and inertia the URDF ``<inertial>`` rotated into that frame; a
    moving link's mesh collides as its convex hull, as pybullet's does. A joint's child
    link is its body_a and its parent body_b, so its position is the URDF joint position.
    A mimic joint is a movable joint of its own, as pybullet loads it; the ``Robot`` sets
    its position and target from its leader's (multiplier x leader + offset).
    """
    try:
        import yourdfpy
    except ImportError as exc:
        raise ImportError(
            "load_urdf reads URDF files through yourdfpy, which is not installed: "
            "pip install thesis_rbd[urdf]"
        ) from exc
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no URDF file at {path}")
    base = transform_from_pose(
        as_finite_array(base_position, "base_position", shape=(3,)),
        as_unit_quaternion(base_orientation, "base_orientation"),
    )
    if inertia not in ("file", "shapes"):
        raise ValueError(f"inertia must be 'file' or 'shapes', got {inertia!r}")
    try:
        model = yourdfpy.URDF.load(
            str(path), build_scene_graph=False, load_meshes=False,
            build_collision_scene_graph=False, load_collision_meshes=False,
        )  # fmt: skip
    except Exception as exc:  # yourdfpy and lxml raise many kinds for a malformed file
        raise ValueError(f"{path}: not a URDF file yourdfpy can read: {exc}") from exc
    try:
        plan = _plan(model.robot, path.parent, base, fixed_base, merge_fixed_links, inertia)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
    return _build(world, plan, self_collision, model.robot.name)


@dataclass
class _Plan:
    """Everything ``load_urdf`` adds, checked: bodies (``add_body`` keywords), joints, the
    body of every link, the movable joints (plan index, name, effort and velocity caps, and
    the URDF angle at the world joint's zero) and
    the (child, parent) body pairs of the URDF tree, and each mimic joint's (leader,
    multiplier, offset)."""

    bodies: list[dict]
    joints: list[_Joint]
    link_body: dict[str, int]
    movable: list[tuple[int, str, float, float, float]]
    tree_pairs: list[tuple[int, int]]
    mimics: dict[str, tuple[str, float, float]]


def _tree_order(robot) -> tuple[str, list]:
    """The root link and the joints in an order that reaches each parent before its child.

    Raises ValueError for a joint naming a link that does not exist, a link with two parents
    (a loop), or links that do not hang from one root."""
    links = {link.name for link in robot.links}
    parent_joint = {}
    for joint in robot.joints:
        for end in (joint.parent, joint.child):
            if end not in links:
                raise ValueError(f"joint {joint.name!r}: no link named {end!r}")
        if joint.child in parent_joint:
            raise ValueError(
                f"link {joint.child!r} is the child of joints {parent_joint[joint.child].name!r} "
                f"and {joint.name!r}: URDF links form a tree, without loops"
            )
        parent_joint[joint.child] = joint
    roots = [link.name for link in robot.links if link.name not in parent_joint]
    if not links:
        raise ValueError("the file has no <link> elements")
    if len(roots) != 1:
        raise ValueError(f"the links hang from {len(roots)} roots {roots}, not one")
    children = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint)
    order, frontier = [], [roots[0]]
    while frontier:
        for joint in children.get(frontier.pop(), []):
            order.append(joint)
            frontier.append(joint.child)
    if len(order) != len(robot.joints):
        loose = sorted(links - {roots[0]} - {j.child for j in order})
        raise ValueError(f"links {loose} lie on a loop that does not reach the root")
    return roots[0], order


def _mimics(robot) -> dict[str, tuple[str, float, float]]:
    """Each mimic joint's (leader, multiplier, offset), checked: both joints movable, the
    leader no mimic itself, the numbers finite."""
    kinds = {joint.name: joint.type for joint in robot.joints}
    found = {}
    for joint in robot.joints:
        mimic = joint.mimic
        if mimic is None:
            continue
        where = f"joint {joint.name!r} mimics {mimic.joint!r}"
        if kinds.get(mimic.joint) not in _MOVABLE or joint.type not in _MOVABLE:
            raise ValueError(f"{where}: a mimic joint and its leader are movable joints")
        multiplier = 1.0 if mimic.multiplier is None else float(mimic.multiplier)
        offset = 0.0 if mimic.offset is None else float(mimic.offset)
        if not (math.isfinite(multiplier) and math.isfinite(offset)):
            raise ValueError(f"{where}: multiplier and offset must be finite")
        found[joint.name] = (mimic.joint, multiplier, offset)
    for name, (leader, _, _) in found.items():
        if leader in found:
            raise ValueError(f"joint {name!r} mimics {leader!r}, which mimics another joint")
    return found


def _plan(
    robot, urdf_dir: Path, base: np.ndarray, fixed_base: bool, merge: bool, inertia: str
) -> _Plan:
    """The bodies and joints a URDF model becomes, checked (see ``load_urdf``)."""
    for joint in robot.joints:
        if joint.type not in (*_MOVABLE, "fixed", "floating"):
            raise ValueError(f"joint {joint.name!r}: unknown joint type {joint.type!r}")
    mimics = _mimics(robot)
    root, order = _tree_order(robot)
    links = {link.name: link for link in robot.links}
    masses = {name: link_mass(link, inertia == "file") for name, link in links.items()}

    # world pose of every link frame in the zero configuration, and its body
    pose = {root: base}
    groups = [_Body(root, base)]
    group_of = {root: 0}
    for joint in order:
        origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
        pose[joint.child] = pose[joint.parent] @ origin
        # a link without mass cannot be a body of its own: welded to its parent it rides along
        if joint.type == "fixed" and (merge or masses[joint.child].mass == 0.0):
            group_of[joint.child] = group_of[joint.parent]
        else:
            group_of[joint.child] = len(groups)
            groups.append(_Body(joint.child, pose[joint.child]))
    for name, g in group_of.items():
        group = groups[g]
        group.links.append(name)
        group.parts.append((masses[name], np.linalg.inv(group.pose) @ pose[name]))
    groups[0].static = fixed_base and combine(groups[0].parts).mass == 0.0

    bodies, sizes = zip(
        *(
            _body_arguments(group, links, urdf_dir, g == 0, inertia == "file")
            for g, group in enumerate(groups)
        ),
        strict=True,
    )
    joints, movable, pairs = [], [], []
    if fixed_base and not groups[0].static:
        joints.append(_Joint("fixed_base", "fixed", 0, None, base[:3, 3].copy(), {}))
    for joint in robot.joints:  # URDF order, as pybullet numbers them
        child, parent = group_of[joint.child], group_of[joint.parent]
        if child == parent:
            continue
        pairs.append((child, parent))
        if joint.type == "floating":
            continue
        planned = _joint(joint, child, parent, pose[joint.child])
        _check_reach(planned, bodies, sizes)
        if joint.type in _MOVABLE:
            limit = joint.limit
            movable.append((
                len(joints), joint.name,
                limit_or_inf(None if limit is None else limit.effort),
                limit_or_inf(None if limit is None else limit.velocity),
                -planned.options.get("ref", 0.0),
            ))  # fmt: skip
        joints.append(planned)
    return _Plan(list(bodies), joints, {k: group_of[k] for k in links}, movable, pairs, mimics)


def _body_arguments(
    group: _Body, links: dict, urdf_dir: Path, is_root: bool, inertia_from_file: bool
) -> tuple[dict, float]:
    """``add_body`` keywords of one group of welded links, checked by a dry run of the body
    builder (so that ``add_body`` cannot fail half-way through a model), and the body's
    bounding radius about its centre of mass (m). Without ``inertia_from_file`` the body's
    centre of mass and inertia are its shapes' at the links' summed mass."""
    placed = []
    for name, (_, T) in zip(group.links, group.parts, strict=True):
        placed += [
            (mesh, T @ pose)
            for mesh, pose in collision_meshes(links[name], urdf_dir, not group.static)
        ]
    total = combine(group.parts)
    if total.mass == 0.0 and not group.static:
        raise ValueError(
            f"link {group.root!r} moves but has no mass (no <inertial>, or mass 0, on it and "
            "the links welded to it)"
            + (": a root link of zero mass loads with fixed_base=True" if is_root else "")
        )
    kwargs = {"name": group.root, "collidable": bool(placed)}
    if not placed:
        # a link without collision geometry still needs a mesh: a non-colliding cube at its
        # centre of mass, as big as the link's mass in water (1 cm for a massless static one)
        side = (total.mass / _MARKER_DENSITY) ** (1.0 / 3.0) if total.mass > 0.0 else 0.01
        placed = [
            (
                shapes.box((side, side, side)),
                transform_from_pose(total.center_of_mass, (0.0, 0.0, 0.0, 1.0)),
            )
        ]
    kwargs["shapes"] = placed
    if group.static:
        kwargs["static"] = True
    elif inertia_from_file:
        kwargs.update(mass=total.mass, center_of_mass=total.center_of_mass, inertia=total.inertia)
    else:
        kwargs["mass"] = total.mass
    try:
        mesh, parts = body_shape(None, placed)
        fields = body_fields(
            mesh, parts=parts, **{k: v for k, v in kwargs.items() if k not in ("name", "shapes")}
        )
    except ValueError as exc:
        raise ValueError(f"link {group.root!r}: {exc}") from exc
    # add_body places the body's centre of mass (the builder's, for a static body too)
    kwargs["position"] = group.pose[:3, :3] @ fields["center_of_mass_local"] + group.pose[:3, 3]
    kwargs["orientation"] = quat_from_matrix(group.pose[:3, :3])
    return kwargs, fields["size"]


def _check_reach(joint: _Joint, bodies, sizes) -> None:
    """Refuse, before anything is added, a joint whose origin ``add_joint`` would refuse as
    far from both its links (``joint_set.check_reach``)."""
    if joint.parent is None:
        return
    ends = (joint.child, joint.parent)
    try:
        check_reach(joint.anchor, np.array([bodies[k]["position"] for k in ends]),
                    np.array([sizes[k] for k in ends]), "its origin")  # fmt: skip
    except ValueError as exc:
        raise ValueError(f"joint {joint.name!r}: {exc}") from exc


def _joint(joint, child: int, parent: int, frame: np.ndarray) -> _Joint:
    """One URDF joint as a world joint, checked; ``frame`` (4, 4) is its child link's world
    pose now, where URDF places the joint frame."""
    anchor = frame[:3, 3].copy()
    if joint.type == "fixed":
        return _Joint(joint.name, "fixed", child, parent, anchor, {})
    axis = np.asarray((1.0, 0.0, 0.0) if joint.axis is None else joint.axis, dtype=float)
    length = float(np.linalg.norm(axis))
    if not (math.isfinite(length) and length > 0.0):
        raise ValueError(f"joint {joint.name!r}: axis {axis.tolist()} has no direction")
    axis = frame[:3, :3] @ (axis / length)
    dynamics = joint.dynamics
    options = {}
    for key in ("damping", "friction"):
        # yourdfpy keeps these as the file's text
        text = None if dynamics is None else getattr(dynamics, key)
        try:
            value = 0.0 if text is None else float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"joint {joint.name!r}: {key} must be finite and >= 0, got {value}")
        options[key] = float(value)
    if joint.type == "planar":
        # a frame whose z is the URDF axis: x any direction square to it, y = z cross x
        x = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
        x /= np.linalg.norm(x)
        options.update(axis=np.stack([x, np.cross(axis, x)]), axes=_PLANAR_AXES)
        return _Joint(joint.name, "generic", child, parent, anchor, options)
    options["axis"] = axis
    limit = joint.limit
    if joint.type != "continuous" and limit is not None and None not in (limit.lower, limit.upper):
        lower, upper = float(limit.lower), float(limit.upper)
        if not lower <= upper:
            raise ValueError(f"joint {joint.name!r}: lower limit {lower} above upper {upper}")
        if joint.type == "revolute":
            # pi written to a few digits (3.1416) is pi
            lower = max(lower, -math.pi) if lower >= -math.pi - _PI_ROUNDING else lower
            upper = min(upper, math.pi) if upper <= math.pi + _PI_ROUNDING else upper
        if joint.type == "revolute" and not -math.pi <= lower <= upper <= math.pi:
            if not upper - lower < 2.0 * math.pi:
                raise ValueError(
                    f"joint {joint.name!r}: limits ({lower}, {upper}) span a full turn or "
                    "more, which a hinge's angle cannot tell apart"
                )
            # the world joint's zero mid-range (``add_joint``'s ``ref``): its limits then lie
            # within [-pi, pi], and the Robot adds the offset back to what it reads
            offset = 0.5 * (lower + upper)
            options["ref"] = -offset
            lower, upper = lower - offset, upper - offset
        options["limits"] = (lower, upper)
    kind = "prismatic" if joint.type == "prismatic" else "revolute"
    return _Joint(joint.name, kind, child, parent, anchor, options)


def _build(world, plan: _Plan, self_collision: bool, name: str) -> Robot:
    """Add a checked plan to the world and return its Robot."""
    index = [world.add_body(**kwargs) for kwargs in plan.bodies]
    joints = [
        world.add_joint(j.kind, index[j.child], None if j.parent is None else index[j.parent],
                        j.anchor, name=j.name, **j.options)
        for j in plan.joints
    ]  # fmt: skip
    # jointed bodies never collide already; the exclusions also cover floating joints and,
    # without self_collision, links that are not neighbours
    pairs = combinations(range(len(index)), 2) if not self_collision else plan.tree_pairs
    for a, b in pairs:
        world.exclude_pair(index[a], index[b])
    return Robot(
        world, name,
        {link: index[g] for link, g in plan.link_body.items()},
        [joints[k] for k, *_ in plan.movable],
        [n for _, n, *_ in plan.movable],
        [f for _, _, f, _, _ in plan.movable],
        [w for _, _, _, w, _ in plan.movable],
        joints,
        plan.mimics,
        [offset for *_, offset in plan.movable],
    )  # fmt: skip
