"""``load_urdf``: a URDF file's links and joints built into a ``World``.

The file is read whole and turned into a plan (one body per group of welded links, one
world joint per movable or kept fixed joint), every part of the plan is checked, and only
then is anything added to the world: a bad file leaves the world as it was.
"""

from __future__ import annotations

import io
import math
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from thesis_rbd.urdf.collision_shapes import bullet_extensions, collision_meshes, visual_meshes
from thesis_rbd.urdf.link_mass import combine, link_mass
from thesis_rbd.urdf.plan import (
    ModelPlan,
    PlannedJoint,
    body_arguments,
    build,
    check_joint_reach,
    hinge_limits,
    model_source,
)
from thesis_rbd.urdf.robot import Robot, limit_or_inf

__all__ = ["load_urdf"]

_MOVABLE = ("revolute", "continuous", "prismatic", "planar")
# URDF's planar joint: free travel along the frame's x and y and turn about z (its axis)
_PLANAR_AXES = ("free", "free", "locked", "locked", "locked", "free")


@dataclass
class _Body:
    """One body to add: a group of links welded together, in its root link's frame."""

    root: str
    pose: np.ndarray  # (4, 4) root link frame -> world
    links: list[str] = field(default_factory=list)
    parts: list = field(default_factory=list)  # (mass, (4, 4) link -> root frame) per link
    shapes: list = field(default_factory=list)  # (TriangleMesh, (4, 4) pose in the root frame)
    static: bool = False


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
    path, base = model_source(path, "URDF", base_position, base_orientation)
    if inertia not in ("file", "shapes"):
        raise ValueError(f"inertia must be 'file' or 'shapes', got {inertia!r}")
    try:
        source, extensions = _with_bullet_extensions(path)
        model = yourdfpy.URDF.load(
            source, build_scene_graph=False, load_meshes=False,
            build_collision_scene_graph=False, load_collision_meshes=False,
        )  # fmt: skip
    except Exception as exc:  # yourdfpy and lxml raise many kinds for a malformed file
        raise ValueError(f"{path}: not a URDF file yourdfpy can read: {exc}") from exc
    failed = []
    try:
        plan = _plan(model.robot, path.parent, base, fixed_base, merge_fixed_links, inertia,
                     extensions, failed)  # fmt: skip
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
    if failed:
        warnings.warn(
            f"{path}: {len(failed)} visual elements not read, their links drawn by their "
            f"collision shapes: {'; '.join(failed)}",
            stacklevel=2,
        )
    return build(world, plan, self_collision, model.robot.name)


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


def _with_bullet_extensions(path: Path):
    """What yourdfpy is given to read: the file's path, or where it has Bullet's
    ``<capsule>`` or ``<plane>`` (which yourdfpy refuses), the file with those replaced
    (``collision_shapes.bullet_extensions``); and the extensions found."""
    text = path.read_bytes()
    if b"<capsule" not in text and b"<plane" not in text:
        return str(path), {}
    root = ET.fromstring(text.rstrip(b"\0"))  # (pybullet_data's humanoid ends in a NUL)
    extensions = bullet_extensions(root)
    return io.BytesIO(ET.tostring(root)), extensions


def _plan(
    robot, urdf_dir: Path, base: np.ndarray, fixed_base: bool, merge: bool, inertia: str,
    extensions: dict, failed: list,
) -> ModelPlan:  # fmt: skip
    """The bodies and joints a URDF model becomes, checked (see ``load_urdf``); the visual
    elements that could not be read are added to ``failed``."""
    for joint in robot.joints:
        if joint.type not in (*_MOVABLE, "fixed", "floating", "spherical"):
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
            _body_arguments(group, links, urdf_dir, g == 0, inertia == "file", extensions, failed)
            for g, group in enumerate(groups)
        ),
        strict=True,
    )
    joints, movable, pairs = [], [], []
    if fixed_base and not groups[0].static:
        joints.append(PlannedJoint("fixed_base", "fixed", 0, None, base[:3, 3].copy(), {}))
    for joint in robot.joints:  # URDF order, as pybullet numbers them
        child, parent = group_of[joint.child], group_of[joint.parent]
        if child == parent:
            continue
        pairs.append((child, parent))
        if joint.type == "floating":
            continue
        planned = _joint(joint, child, parent, pose[joint.child])
        check_joint_reach(planned, bodies, sizes)
        if joint.type in _MOVABLE:
            limit = joint.limit
            movable.append((
                len(joints), joint.name,
                limit_or_inf(None if limit is None else limit.effort),
                limit_or_inf(None if limit is None else limit.velocity),
                -planned.options.get("ref", 0.0),
            ))  # fmt: skip
        joints.append(planned)
    return ModelPlan(list(bodies), joints, {k: group_of[k] for k in links}, movable, pairs, mimics)


def _body_arguments(
    group: _Body, links: dict, urdf_dir: Path, is_root: bool, inertia_from_file: bool,
    extensions: dict, failed: list,
) -> tuple[dict, float]:  # fmt: skip
    """``add_body`` keywords of one group of welded links and its bounding radius
    (``plan.body_arguments``); its collision shapes are its links' ``<collision>``
    elements, what it is drawn with their ``<visual>`` ones (where any can be read)."""
    placed, drawn = [], []
    for name, (_, T) in zip(group.links, group.parts, strict=True):
        placed += [
            (mesh, T @ pose)
            for mesh, pose in collision_meshes(links[name], urdf_dir, not group.static, extensions)
        ]
        visuals, unread = visual_meshes(links[name], urdf_dir, extensions)
        drawn += [(mesh, T @ pose) for mesh, pose in visuals]
        failed += unread
    kwargs, size = body_arguments(group.root, group.pose, placed, combine(group.parts),
                                  group.static, inertia_from_file, is_root)  # fmt: skip
    if drawn:
        kwargs["visual"] = drawn
    return kwargs, size


def _joint(joint, child: int, parent: int, frame: np.ndarray) -> PlannedJoint:
    """One URDF joint as a world joint, checked; ``frame`` (4, 4) is its child link's world
    pose now, where URDF places the joint frame."""
    anchor = frame[:3, 3].copy()
    if joint.type in ("fixed", "spherical"):  # Bullet's spherical joint: a ball, no limits
        return PlannedJoint(joint.name, joint.type, child, parent, anchor, {})
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
        return PlannedJoint(joint.name, "generic", child, parent, anchor, options)
    options["axis"] = axis
    limit = joint.limit
    if joint.type != "continuous" and limit is not None and None not in (limit.lower, limit.upper):
        lower, upper = float(limit.lower), float(limit.upper)
        if joint.type == "revolute":
            options.update(hinge_limits(joint.name, lower, upper))
        elif not lower <= upper:
            raise ValueError(f"joint {joint.name!r}: lower limit {lower} above upper {upper}")
        else:
            options["limits"] = (lower, upper)
    kind = "prismatic" if joint.type == "prismatic" else "revolute"
    return PlannedJoint(joint.name, kind, child, parent, anchor, options)
