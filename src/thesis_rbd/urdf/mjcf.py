"""``load_mjcf``: a MuJoCo MJCF model's bodies and joints built into a ``World``.

The file is compiled by the ``mujoco`` package (an optional dependency: MJCF's defaults,
classes, includes and ``fromto`` geometry are its compiler's to resolve), and the compiled
model is read in its reference configuration (``qpos0``, world poses from
``mj_kinematics``): each body's mass, centre of mass and inertia, its geoms as collision
shapes, its joints as world joints. As in ``load_urdf``, the model becomes a plan that is
checked whole before anything is added.

How MJCF maps onto the world's bodies and joints:

* a body without joints is welded to its parent (one body with it; to the world: static);
  a free joint leaves its body free;
* one hinge, slide or ball joint is a "revolute", "prismatic" or "spherical" joint at its
  anchor; several hinges and slides on one body, the hinges at one point and every axis
  square to or along the others, are one "generic" joint whose frame holds the axes (its
  x the first joint's, its turns Cardan angles in the file's order, as MuJoCo composes
  them); hinges about several points of one body (the humanoid's ankles) are joined through
  a light body between each point and the next, 1 % of the body's mass and inertia each,
  taken from it (pybullet's MJCF import adds such links too); axes slanted to each other
  about one point are refused;
* joint damping and friction loss are the joints' ``damping`` and ``friction``, a hinge's or
  slide's stiffness an uncapped position motor towards its spring reference;
* geoms: spheres, capsules, cylinders, boxes, ellipsoids and meshes (a moving body's as
  their convex hull); a plane, in the world only, a static box under it; geoms with
  ``contype`` and ``conaffinity`` both 0 do not collide, and are drawn (``add_body``'s
  ``visual``) with the others;
* bodies collide with each other as MuJoCo's do (``self_collision``): all pairs but a parent
  and its child, the ``<contact><exclude>`` pairs and those whose geoms' ``contype`` and
  ``conaffinity`` never meet.

Not modelled, and named in a warning: armature, joint damping and stiffness on a joint made
generic, and actuators (apply torques through the ``Robot``); the light bodies are named
there too. Refused: equality
constraints, tendons, height fields and the geoms MuJoCo cannot collide (``mjGEOM_SDF``).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from thesis_rbd.geometry import TriangleMesh, shapes
from thesis_rbd.spatial.transform import transform_from_pose
from thesis_rbd.urdf.collision_shapes import (
    CAPSULE_SECTIONS,
    CYLINDER_SECTIONS,
    SPHERE_SUBDIVISIONS,
    floor_box,
)
from thesis_rbd.urdf.link_mass import LinkMass, combine
from thesis_rbd.urdf.plan import (
    ModelPlan,
    PlannedJoint,
    body_arguments,
    build,
    check_joint_reach,
    hinge_limits,
    model_source,
)
from thesis_rbd.urdf.robot import Robot

__all__ = ["load_mjcf"]

# Anchors closer than this fraction of the body's size are one point; axes whose cosine is
# within this of 0 or 1 are square or along each other
_SAME_POINT = 1e-9
_SQUARE = 1e-9
# The share of a body's mass and inertia each light body between its joints' points takes
_LIGHT_FRACTION = 0.01


@dataclass
class _Group:
    """One world body: MJCF bodies welded together, in its root body's frame."""

    root: int
    pose: np.ndarray  # (4, 4) root body frame -> world
    members: list[int] = field(default_factory=list)
    static: bool = False


def load_mjcf(
    world,
    path,
    *,
    base_position=(0.0, 0.0, 0.0),
    base_orientation=(0.0, 0.0, 0.0, 1.0),
    self_collision: bool = True,
    free_roots: bool = False,
) -> Robot:
    """Add an MJCF model's bodies and joints to a world, in its reference configuration.

    Parameters
    ----------
    world : World
    path : str or Path
        The MJCF (``.xml``) file, compiled by the ``mujoco`` package.
    base_position : (3,) array_like
        Where the model's world frame goes in the world (m).
    base_orientation : (4,) array_like
        (x, y, z, w) rotation of the model's world frame into the world.
    self_collision : bool
        Let the model's bodies collide with each other, but a parent and its child and the
        file's excluded pairs (MuJoCo's rule, the default); False: none of them do. The
        file's world geoms (a floor) collide with the model either way.
    free_roots : bool
        Leave free the bodies the file hangs from its world without a joint, as pybullet's
        ``loadMJCF`` does (files written for pybullet, as its humanoid, give their root no
        free joint), instead of welding them to the world, MuJoCo's rule (the default).

    Returns
    -------
    Robot
        The bodies by MJCF body name (the world's geoms as body ``"world"``), and as movable
        joints the hinges and slides that are their body's only joint, in file order, with
        no effort or speed caps. Joints made generic are in ``tree_joints``.

    Raises
    ------
    ImportError
        Where the ``mujoco`` package is not installed.
    ValueError
        Naming the file and the body, joint or geom, for a file MuJoCo's compiler refuses, a
        moving body without mass, joints one world joint cannot hold, or what is not read
        (module docstring). Nothing is added to the world then.

    Warns
    -----
    UserWarning
        Naming what the file has that the world does not model (module docstring).
    """
    try:
        import mujoco
    except ImportError as exc:
        raise ImportError(
            "load_mjcf compiles MJCF files with the mujoco package, which is not installed: "
            "pip install mujoco"
        ) from exc
    path, base = model_source(path, "MJCF", base_position, base_orientation)
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:  # the compiler raises ValueError and its own kinds
        raise ValueError(f"{path}: not an MJCF file MuJoCo's compiler accepts: {exc}") from exc
    try:
        plan, unmodelled = _plan(mujoco, model, base, free_roots)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
    if unmodelled:
        warnings.warn(f"{path}: not modelled: {'; '.join(unmodelled)}", stacklevel=2)
    return build(world, plan, self_collision, path.stem)


def _plan(mujoco, model, base: np.ndarray, free_roots: bool) -> tuple[ModelPlan, list[str]]:
    """The bodies and joints of a compiled model, checked, and what is not modelled."""
    if model.neq:
        raise ValueError(f"{model.neq} equality constraints (<equality>) are not read")
    if model.ntendon:
        raise ValueError(f"{model.ntendon} tendons are not read")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    names = _Names(mujoco, model)

    def pose(position, rotation) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = rotation, position
        return base @ T

    body_pose = [pose(data.xpos[b], data.xmat[b].reshape(3, 3)) for b in range(model.nbody)]
    groups, group_of = _groups(model, body_pose, free_roots)
    bodies, sizes = [], []
    for group in groups:
        placed, drawn = [], []
        for b in group.members:
            colliding, only_drawn = _shapes(mujoco, model, data, b, group, names, pose)
            placed += colliding
            drawn += only_drawn
        inverse = np.linalg.inv(group.pose)
        total = combine([(_body_mass(model, b), inverse @ body_pose[b]) for b in group.members])
        kwargs, size = body_arguments(names.body(group.root), group.pose, placed, total,
                                      group.static, True, group.root == 1)  # fmt: skip
        if drawn:  # drawn as MuJoCo draws it: every geom
            kwargs["visual"] = [*placed, *drawn]
        bodies.append(kwargs)
        sizes.append(size)
    joints, movable, pairs, unmodelled = [], [], [], []
    for g, group in enumerate(groups):
        b = group.root
        parent = model.body_parentid[b]
        if group.static:
            continue
        # a child does not collide with its parent, unless the parent is the world
        parent_group = group_of[parent] if parent > 0 else None
        if parent_group is not None:
            pairs.append((g, parent_group))
        runs = _runs(model, data, b)
        # joints about several points of one body: a light body between each run and the
        # next, as pybullet's MJCF import makes (its mass taken from the body's)
        links = _light_bodies(g, runs, bodies, sizes, names.body(b), unmodelled)
        holders = [parent_group, *links]
        for k, found in enumerate(runs):
            held = links[k] if k < len(links) else g
            label = f"body {names.body(b)!r}"
            planned = _joint(mujoco, model, data, found, label, held, holders[k], base, names,
                             unmodelled)  # fmt: skip
            if planned is None:
                continue
            check_joint_reach(planned, bodies, sizes)
            if planned.kind in ("revolute", "prismatic"):
                address = model.jnt_qposadr[found[0]]
                offset = float(model.qpos0[address]) - planned.options.get("ref", 0.0)
                movable.append((len(joints), planned.name, math.inf, math.inf, offset))
            joints.append(planned)
    pairs += _kept_apart(model, groups)
    for k in range(model.nexclude):
        signature = int(model.exclude_signature[k])
        ends = (group_of.get(signature >> 16), group_of.get(signature & 0xFFFF))
        if None not in ends and ends[0] != ends[1]:
            pairs.append(ends)
    armature = [names.joint(j) for j in range(model.njnt) if _armature(model, j) > 0.0]
    if armature:
        unmodelled.append(f"armature of joints {armature}")
    if model.nu:
        unmodelled.append(f"{model.nu} actuators (give torques through the Robot)")
    link_body = {names.body(b): g for b, g in group_of.items()}
    scenery = [g for g, group in enumerate(groups) if group.root == 0]
    return ModelPlan(bodies, joints, link_body, movable, pairs, {}, scenery), unmodelled


class _Names:
    """MJCF names of bodies, joints and geoms (``#index`` where a file gives none)."""

    def __init__(self, mujoco, model):
        self._mujoco, self._model = mujoco, model

    def _name(self, kind, index: int) -> str:
        name = self._mujoco.mj_id2name(self._model, kind, index)
        return name if name else f"#{index}"

    def body(self, b: int) -> str:
        return "world" if b == 0 else self._name(self._mujoco.mjtObj.mjOBJ_BODY, b)

    def joint(self, j: int) -> str:
        return self._name(self._mujoco.mjtObj.mjOBJ_JOINT, j)

    def geom(self, g: int) -> str:
        return self._name(self._mujoco.mjtObj.mjOBJ_GEOM, g)


def _groups(model, body_pose, free_roots: bool) -> tuple[list[_Group], dict[int, int]]:
    """The world bodies: the world's geoms (a static one, where it has any), and each MJCF
    body with joints or hanging from the world roots one (without joints: static, or free
    with ``free_roots``); a body without joints below another joins its parent's. A body
    welded to the world is not the world's body: its children do not collide with it, but
    with the world's floor they do."""
    groups, group_of = [], {}
    if np.any(model.geom_bodyid == 0):
        groups.append(_Group(0, body_pose[0], static=True))
        group_of[0] = 0
    for b in range(1, model.nbody):
        parent = int(model.body_parentid[b])
        if model.body_jntnum[b] == 0 and parent != 0:
            g = group_of[parent]
        else:
            g = len(groups)
            welded = model.body_jntnum[b] == 0 and not free_roots
            groups.append(_Group(b, body_pose[b], static=welded))
        group_of[b] = g
    for b, g in group_of.items():
        groups[g].members.append(b)
    return groups, group_of


def _kept_apart(model, groups: list[_Group]) -> list[tuple[int, int]]:
    """The pairs of world bodies none of whose geoms MuJoCo lets collide: geoms collide
    where one's ``contype`` meets the other's ``conaffinity`` (an "or" of two bit tests,
    which a body's collision group and mask, an "and", cannot say; each body's bits are
    those of its geoms together)."""
    kinds = np.zeros((len(groups), 2), np.int64)
    for g, group in enumerate(groups):
        for b in group.members:
            geoms = model.geom_bodyid == b
            for column, bits in enumerate((model.geom_contype, model.geom_conaffinity)):
                kinds[g, column] |= np.bitwise_or.reduce(bits[geoms], initial=0)
    apart = []
    for a in range(len(groups)):
        for b in range(a + 1, len(groups)):
            if not (kinds[a, 0] & kinds[b, 1] or kinds[b, 0] & kinds[a, 1]):
                apart.append((a, b))
    return apart


def _body_mass(model, b: int) -> LinkMass:
    """A body's mass, centre of mass and inertia in its own frame (MuJoCo keeps the inertia
    diagonal in the frame ``body_iquat`` turns to)."""
    w, x, y, z = model.body_iquat[b]
    R = transform_from_pose(np.zeros(3), (x, y, z, w))[:3, :3]
    inertia = R @ np.diag(model.body_inertia[b]) @ R.T
    return LinkMass(float(model.body_mass[b]), model.body_ipos[b].copy(), inertia)


def _shapes(mujoco, model, data, b: int, group: _Group, names, pose) -> tuple[list, list]:
    """Body b's geoms as (mesh, pose in the group's frame): those that collide, and those
    only drawn (``contype`` and ``conaffinity`` both 0; one of a kind the world cannot
    draw is left out)."""
    inverse = np.linalg.inv(group.pose)
    placed, drawn = [], []
    for g in np.flatnonzero(model.geom_bodyid == b):
        at = inverse @ pose(data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3))
        where = f"geom {names.geom(g)!r} of body {names.body(b)!r}"
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0:
            try:
                mesh, offset = _geom_mesh(mujoco, model, g, group.static, False, where)
            except ValueError:
                continue
            drawn.append((mesh, at @ offset))
            continue
        mesh, offset = _geom_mesh(mujoco, model, g, group.static, not group.static, where)
        placed.append((mesh, at @ offset))
    return placed, drawn


def _geom_mesh(mujoco, model, g: int, static: bool, convex: bool, where: str):
    """One geom's mesh and its offset from the geom's frame (a plane's box lies under it)."""
    kinds = mujoco.mjtGeom
    kind, size = model.geom_type[g], model.geom_size[g]
    if kind == kinds.mjGEOM_PLANE:
        if not static:
            raise ValueError(f"{where}: a plane belongs to the world or a static body")
        return floor_box(2.0 * size[:2])
    if kind == kinds.mjGEOM_SPHERE:
        mesh = shapes.icosphere(size[0], SPHERE_SUBDIVISIONS)
    elif kind == kinds.mjGEOM_CAPSULE:
        mesh = shapes.capsule(size[0], 2.0 * size[1], CAPSULE_SECTIONS)
    elif kind == kinds.mjGEOM_CYLINDER:
        mesh = shapes.cylinder(size[0], 2.0 * size[1], CYLINDER_SECTIONS)
    elif kind == kinds.mjGEOM_BOX:
        mesh = shapes.box(2.0 * size)
    elif kind == kinds.mjGEOM_ELLIPSOID:
        sphere = shapes.icosphere(1.0, SPHERE_SUBDIVISIONS)
        mesh = TriangleMesh(sphere.vertices * size, sphere.faces)
    elif kind == kinds.mjGEOM_MESH:
        mesh = _mesh(model, int(model.geom_dataid[g]), convex)
    else:
        raise ValueError(f"{where}: geoms of type {kinds(kind).name} are not read")
    return mesh, np.eye(4)


def _mesh(model, mesh: int, convex: bool) -> TriangleMesh:
    """A mesh asset as MuJoCo compiled it (in the geom's frame), or its convex hull."""
    import trimesh

    first, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    vertices = np.asarray(model.mesh_vert[first : first + count], dtype=float)
    first, count = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
    faces = np.asarray(model.mesh_face[first : first + count], dtype=np.int64)
    loaded = trimesh.Trimesh(vertices, faces, process=False)
    return TriangleMesh.from_trimesh(loaded.convex_hull if convex else loaded)


def _armature(model, j: int) -> float:
    dof, count = model.jnt_dofadr[j], {0: 6, 1: 3}.get(int(model.jnt_type[j]), 1)
    return float(np.max(model.dof_armature[dof : dof + count]))


def _light_bodies(g: int, runs, bodies, sizes, name: str, unmodelled) -> list[int]:
    """One light body for each run of body ``g``'s joints but its last (``_runs``),
    appended to ``bodies`` and ``sizes`` (their indices returned): a copy of the body's mass
    properties at ``_LIGHT_FRACTION`` of them, taken from the body's own, colliding with
    nothing, drawn as nothing."""
    if len(runs) < 2:
        return []
    body = bodies[g]
    share = _LIGHT_FRACTION * body["mass"]
    links = []
    for k in range(len(runs) - 1):
        links.append(len(bodies))
        marker = shapes.box((1e-3, 1e-3, 1e-3))
        bodies.append({
            "name": f"{name}:{k}", "collidable": False, "mass": share,
            "center_of_mass": body["center_of_mass"],
            "inertia": _LIGHT_FRACTION * np.asarray(body["inertia"]),
            "shapes": [(marker, transform_from_pose(body["center_of_mass"], (0, 0, 0, 1)))],
            "position": body["position"], "orientation": body["orientation"],
        })  # fmt: skip
        sizes.append(sizes[g])
    kept = 1.0 - _LIGHT_FRACTION * len(links)
    body["mass"] *= kept
    body["inertia"] = kept * np.asarray(body["inertia"])
    unmodelled.append(
        f"body {name!r}'s joints turn about {len(runs)} points: joined through "
        f"{len(links)} light bodies of {_LIGHT_FRACTION:.0%} of its mass each"
    )
    return links


def _runs(model, data, b: int) -> list[list[int]]:
    """Body b's joints in runs about one point each: a hinge about another point than the
    run's hinges so far starts a new run (MuJoCo composes a body's joints in order)."""
    runs, point = [[]], None
    for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
        if model.jnt_type[j] == 3:  # mjJNT_HINGE
            anchor = data.xanchor[j]
            scale = max(1.0, float(np.max(np.abs(anchor))))
            if point is not None and np.linalg.norm(anchor - point) > _SAME_POINT * scale:
                runs.append([])
            point = anchor.copy()
        runs[-1].append(j)
    return runs


def _joint(mujoco, model, data, found, label, child, parent, base, names, unmodelled):
    """The world joint of MJCF joints ``found`` (about one point) holding group ``child``
    to ``parent`` (None: the world), or None for a free body."""
    kinds = mujoco.mjtJoint
    count = len(found)
    if count == 0:
        return None  # a free root
    types = [int(model.jnt_type[j]) for j in found]
    if kinds.mjJNT_FREE in types:
        if count > 1:
            raise ValueError(f"{label}: a free joint with other joints")
        return None
    anchor = [base[:3, :3] @ data.xanchor[j] + base[:3, 3] for j in found]
    axis = [base[:3, :3] @ data.xaxis[j] for j in found]
    if count == 1:
        j, kind = found[0], types[0]
        name = names.joint(j)
        if kind == kinds.mjJNT_BALL:
            if model.jnt_limited[j]:
                raise ValueError(f"joint {name!r}: a ball joint's limits are not read")
            return PlannedJoint(name, "spherical", child, parent, anchor[0], {})
        options = {"axis": axis[0], **_axis_forces(model, j)}
        rest = float(model.qpos0[model.jnt_qposadr[j]])
        if model.jnt_limited[j]:
            lower, upper = (float(v) - rest for v in model.jnt_range[j])
            if kind == kinds.mjJNT_HINGE:
                options.update(hinge_limits(name, lower, upper))
            else:
                options["limits"] = (lower, upper)
        kind = "revolute" if kind == kinds.mjJNT_HINGE else "prismatic"
        return PlannedJoint(name, kind, child, parent, anchor[0], options)
    return _generic(model, kinds, found, types, anchor, axis, child, parent, names, label,
                    unmodelled)  # fmt: skip


def _axis_forces(model, j: int) -> dict:
    """A hinge's or slide's damping, friction loss and stiffness (a position motor towards
    its spring reference, in the world joint's terms: zero at qpos0)."""
    dof = model.jnt_dofadr[j]
    options = {
        "damping": float(model.dof_damping[dof]),
        "friction": float(model.dof_frictionloss[dof]),
    }
    stiffness = float(model.jnt_stiffness[j])
    if stiffness > 0.0:
        address = model.jnt_qposadr[j]
        target = float(model.qpos_spring[address] - model.qpos0[address])
        options["motor"] = {"position": target, "stiffness": stiffness, "damping": 0.0}
    return options


def _generic(model, kinds, found, types, anchor, axis, child, parent, names, label, unmodelled):
    """Several hinges and slides of one body as one generic joint (module docstring)."""
    joint_names = [names.joint(j) for j in found]
    if any(kind not in (kinds.mjJNT_HINGE, kinds.mjJNT_SLIDE) for kind in types):
        raise ValueError(f"{label}: joints {joint_names}: a ball joint with other joints")
    hinges = [k for k, kind in enumerate(types) if kind == kinds.mjJNT_HINGE]
    directions = [a / np.linalg.norm(a) for a in axis]
    order = hinges + [k for k in range(len(found)) if k not in hinges]
    frame = [directions[order[0]]]
    for k in order[1:]:
        cosine = abs(float(directions[k] @ frame[0]))
        if cosine < _SQUARE and len(frame) == 1:
            frame.append(directions[k])
    if len(frame) == 1:
        helper = np.eye(3)[int(np.argmin(np.abs(frame[0])))]
        second = np.cross(frame[0], helper)
        frame.append(second / np.linalg.norm(second))
    frame.append(np.cross(frame[0], frame[1]))
    entries = ["locked"] * 6
    for k, j in enumerate(found):
        cosines = np.array([float(directions[k] @ f) for f in frame])
        along = int(np.argmax(np.abs(cosines)))
        if abs(abs(cosines[along]) - 1.0) > _SQUARE or np.sum(np.abs(cosines) > _SQUARE) > 1:
            raise ValueError(
                f"{label}: joint {joint_names[k]!r}'s axis is slanted to the body's other "
                f"joints' {joint_names}: one world joint holds axes square to each other"
            )
        slot = along + (3 if types[k] == kinds.mjJNT_HINGE else 0)
        if entries[slot] != "locked":
            raise ValueError(f"{label}: joints {joint_names} move along one axis twice")
        entries[slot] = "free"
        if model.jnt_limited[j]:
            rest = float(model.qpos0[model.jnt_qposadr[j]])
            lower, upper = (float(v) - rest for v in model.jnt_range[j])
            sign = 1.0 if cosines[along] > 0.0 else -1.0
            entries[slot] = tuple(sorted((sign * lower, sign * upper)))
    forces = [joint_names[k] for k, j in enumerate(found) if any(_axis_forces(model, j).values())]
    if forces:
        unmodelled.append(f"damping, friction and stiffness of {forces}, made one generic joint")
    options = {"axis": np.stack(frame[:2]), "axes": tuple(entries)}
    where = anchor[hinges[0]] if hinges else anchor[0]
    return PlannedJoint("+".join(joint_names), "generic", child, parent, where, options)
