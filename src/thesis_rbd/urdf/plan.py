"""A model's plan: the bodies and joints a robot file becomes, checked before anything is
added to a world, and then added (``build``). The URDF and MJCF loaders each read their
format into one; what a body, a joint and the Robot need is the same for both."""

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
from thesis_rbd.urdf.link_mass import LinkMass
from thesis_rbd.urdf.robot import Robot

__all__ = [
    "ModelPlan",
    "PlannedJoint",
    "body_arguments",
    "build",
    "check_joint_reach",
    "hinge_limits",
    "model_source",
]  # fmt: skip

# density of the marker cube that stands for a link without collision geometry
_MARKER_DENSITY = 1000.0
# How far beyond +-pi a hinge limit may be written and still mean +-pi (rad)
_PI_ROUNDING = 1e-3


@dataclass
class PlannedJoint:
    """One world joint to add, its geometry in world coordinates now (``add_joint``'s
    arguments: kind, child as body_a, parent as body_b or None for the world, anchor,
    options)."""

    name: str
    kind: str
    child: int
    parent: int | None
    anchor: np.ndarray
    options: dict


@dataclass
class ModelPlan:
    """Everything a loader adds, checked: bodies (``add_body`` keywords), joints, the body
    of every link, the movable joints (plan index, name, effort and velocity caps, and the
    file's position at the world joint's zero), the (child, parent) body pairs of the
    model's tree (and other pairs the file keeps apart), each mimic joint's (leader,
    multiplier, offset), and the bodies that are the file's scenery, not the model's (an
    MJCF world's floor: the model's bodies collide with it whatever ``self_collision``
    says)."""

    bodies: list[dict]
    joints: list[PlannedJoint]
    link_body: dict[str, int]
    movable: list[tuple[int, str, float, float, float]]
    tree_pairs: list[tuple[int, int]]
    mimics: dict[str, tuple[str, float, float]]
    scenery: list[int] = field(default_factory=list)


def model_source(path, kind: str, base_position, base_orientation) -> tuple[Path, np.ndarray]:
    """A model file's path and the (4, 4) pose its frame takes in the world, both checked.

    Raises
    ------
    ValueError
        If there is no file at ``path`` (naming ``kind``, "URDF" or "MJCF"), or the base
        position or orientation is not finite or not a rotation.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no {kind} file at {path}")
    base = transform_from_pose(
        as_finite_array(base_position, "base_position", shape=(3,)),
        as_unit_quaternion(base_orientation, "base_orientation"),
    )
    return path, base


def body_arguments(
    name: str, pose: np.ndarray, placed: list, total: LinkMass, static: bool,
    inertia_from_file: bool, is_root: bool,
) -> tuple[dict, float]:  # fmt: skip
    """``add_body`` keywords of one body, checked by a dry run of the body builder (so that
    ``add_body`` cannot fail half-way through a model), and its bounding radius about its
    centre of mass (m).

    Parameters
    ----------
    name : str
        The body's name (its root link's).
    pose : (4, 4) ndarray
        The body frame's world pose.
    placed : list of (TriangleMesh, (4, 4) ndarray)
        Its collision shapes, each at its pose in the body frame.
    total : LinkMass
        Its mass properties in the body frame.
    static : bool
    inertia_from_file : bool
        Take the centre of mass and inertia from ``total`` (else from the shapes, taken as
        solid at ``total.mass``).
    is_root : bool
        Whether it is the model's root (named in the error for a root without mass).
    """
    if total.mass == 0.0 and not static:
        raise ValueError(
            f"link {name!r} moves but has no mass (no <inertial>, or mass 0, on it and "
            "the links welded to it)"
            + (": a root link of zero mass loads with fixed_base=True" if is_root else "")
        )
    kwargs = {"name": name, "collidable": bool(placed)}
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
    if static:
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
        raise ValueError(f"link {name!r}: {exc}") from exc
    # add_body places the body's centre of mass (the builder's, for a static body too)
    kwargs["position"] = pose[:3, :3] @ fields["center_of_mass_local"] + pose[:3, 3]
    kwargs["orientation"] = quat_from_matrix(pose[:3, :3])
    return kwargs, fields["size"]


def check_joint_reach(joint: PlannedJoint, bodies, sizes) -> None:
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


def hinge_limits(name: str, lower: float, upper: float) -> dict:
    """``add_joint`` options of a hinge limited to [lower, upper] (rad, the file's angle,
    zero where the model is loaded): ``limits``, and ``ref`` where they reach past +-pi.

    pi written to a few digits (3.1416) is pi. Limits past +-pi spanning less than a turn
    put the world joint's zero mid-range (``add_joint``'s ``ref``): its limits then lie
    within [-pi, pi], and the Robot adds the offset back to what it reads.
    """
    if not lower <= upper:
        raise ValueError(f"joint {name!r}: lower limit {lower} above upper {upper}")
    lower = max(lower, -math.pi) if lower >= -math.pi - _PI_ROUNDING else lower
    upper = min(upper, math.pi) if upper <= math.pi + _PI_ROUNDING else upper
    if -math.pi <= lower <= upper <= math.pi:
        return {"limits": (lower, upper)}
    if not upper - lower < 2.0 * math.pi:
        raise ValueError(
            f"joint {name!r}: limits ({lower}, {upper}) span a full turn or more, which a "
            "hinge's angle cannot tell apart"
        )
    offset = 0.5 * (lower + upper)
    return {"limits": (lower - offset, upper - offset), "ref": -offset}


def build(world, plan: ModelPlan, self_collision: bool, name: str) -> Robot:
    """Add a checked plan to the world and return its Robot. The plan's ``tree_pairs``
    never collide; without ``self_collision`` no two of the model's bodies do (its scenery
    aside)."""
    index = [world.add_body(**kwargs) for kwargs in plan.bodies]
    joints = [
        world.add_joint(j.kind, index[j.child], None if j.parent is None else index[j.parent],
                        j.anchor, name=j.name, **j.options)
        for j in plan.joints
    ]  # fmt: skip
    # jointed bodies never collide already; the exclusions also cover floating joints and,
    # without self_collision, links that are not neighbours
    pairs = set(plan.tree_pairs)
    if not self_collision:
        pairs |= set(combinations([k for k in range(len(index)) if k not in plan.scenery], 2))
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
