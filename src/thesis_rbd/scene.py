"""Scene files: a world described in TOML, validated with messages that name the fault.

A scene file has optional top-level keys ``description``, ``seconds`` (the default run
length) and ``record_contacts`` (whether runs record contact points by default), a
``[world]`` table with the arguments of :class:`~thesis_rbd.World`, and one ``[[body]]``
table per body with the arguments of :meth:`~thesis_rbd.World.add_body`, a
``shape`` table, and optional ``[[body.force]]`` tables for :meth:`~thesis_rbd.World.apply_force`,
and one ``[[joint]]`` table per joint with the arguments of
:meth:`~thesis_rbd.World.add_joint` (bodies by name; no ``body_b``: the world)::

    description = "A box pushed for one second"
    seconds = 3.0

    [world]
    dt = 0.004166666666666667
    gravity = [0.0, 0.0, 0.0]
    integrator = "rk4"

    [[body]]
    name = "box"
    shape = { type = "box", extents = [1.0, 2.0, 3.0] }
    mass = 1.0
    position = [0.0, 0.0, 0.0]
    angular_velocity = [0.0, 6.283185307179586, 0.0]

    [[body.force]]
    force = [2.0, 0.0, 0.0]
    duration = 1.0

    [[joint]]
    kind = "revolute"
    body_a = "box"
    anchor = [0.0, 0.0, 1.5]
    axis = [0.0, 1.0, 0.0]
    limits = [-1.0, inf]
    motor = { velocity = 1.0, max_force = 20.0 }
    friction = 0.5

A body may give its mass properties explicitly, ``mass``, ``center_of_mass = [x, y, z]`` (in
the mesh frame) and ``inertia = [[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]]`` (about the
centre of mass, mesh axes), its shape then collision geometry only; and instead of ``shape``
it may be a compound of parts, each a shape at a pose (position, orientation) in the body's
mesh frame, as ``shapes = [{ shape = {...}, position = [...], orientation = [...] }, ...]``
(each inline table on one line, as TOML has them) or as ``[[body.shapes]]`` tables::

    [[body.shapes]]
    shape = { type = "box", extents = [0.5, 2.0, 3.0] }
    position = [-0.25, 0.0, 0.0]

    [[body.shapes]]
    shape = { type = "icosphere", radius = 0.5 }
    position = [0.75, 0.0, 0.0]
    orientation = [0.0, 0.0, 0.0, 1.0]

A distance joint takes ``anchor_b``, ``limits = [0.0, 1.2]`` (a rope) and
``spring = { stiffness = 100.0, damping = 2.0, rest_length = 1.0 }``.

A ``[[urdf]]`` table loads a robot or mechanism after the bodies and joints, with the
arguments of :func:`~thesis_rbd.load_urdf` (``path`` relative to the scene file), and
``joint_positions`` and ``joint_targets`` tables of joint names to values (rad or m): the
pose it starts in and the targets its servos hold::

    [[urdf]]
    path = "arm/model.urdf"
    fixed_base = true
    joint_positions = { lbr_iiwa_joint_2 = 0.5 }
    joint_targets = { lbr_iiwa_joint_2 = 0.0, lbr_iiwa_joint_4 = -1.0 }

Shapes: ``box`` (extents), ``icosphere`` (radius, subdivisions), ``cylinder`` (radius, height,
sections), ``torus`` (major_radius, minor_radius, major_sections, minor_sections) with the
defaults of :mod:`thesis_rbd.shapes`, and ``mesh`` (path, relative to the scene file; optional
scale) for any file trimesh reads (OBJ, STL, PLY, glTF, ...).

Everything is checked when the scene is loaded: TOML syntax, unknown keys (with a suggestion),
types, ranges, shape parameters, mesh files. A fault raises :class:`SceneError` whose message
names the file, the table (``[world]``, ``body[2] 'lid'``, ``body[2] 'lid' force[0]``,
``joint[0]``), the
field and the value.
"""

from __future__ import annotations

import copyreg
import difflib
import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import NoReturn

import numpy as np

from thesis_rbd.dynamics.body_builder import body_shape
from thesis_rbd.dynamics.integrators import INTEGRATORS
from thesis_rbd.geometry import shapes
from thesis_rbd.geometry.mesh import TriangleMesh, load_mesh
from thesis_rbd.spatial.transform import transform_from_pose
from thesis_rbd.world import World

__all__ = [
    "WORLD_KEYS",
    "BodySpec",
    "ForceSpec",
    "JointSpec",
    "Scene",
    "SceneError",
    "load_scene",
    "parse_scene",
]

DEFAULT_SECONDS = 5.0


def _read_only(table: dict) -> MappingProxyType:
    return MappingProxyType(table)


def _reduce_mapping_proxy(mapping: MappingProxyType):
    return _read_only, (dict(mapping),)


# Scenes travel to worker processes (a study's runs): their read-only tables pickle as the
# dicts they show, and are read-only again when unpickled.
copyreg.pickle(MappingProxyType, _reduce_mapping_proxy)


class SceneError(ValueError):
    """A scene is invalid; the message names the file, table, field and value at fault."""


# ---------------------------------------------------------------------- the validated scene
@dataclass(frozen=True)
class ForceSpec:
    """A force applied to a body from the start of a run.

    Attributes
    ----------
    force : (3,) float ndarray
        World-frame force (N).
    point : (3,) float ndarray or None
        World point of application at t = 0 (attached to the body); None: the centre of mass.
    duration : float or None
        Seconds the force lasts; None: the whole run.
    """

    force: np.ndarray
    point: np.ndarray | None = None
    duration: float | None = None


@dataclass(frozen=True)
class BodySpec:
    """One ``[[body]]`` table, validated; the arguments of :meth:`World.add_body`.

    Attributes
    ----------
    name : str
        Unique label.
    shape : Mapping
        The shape table as written (type and parameters), for display; a compound's is
        ``{"type": "compound", "parts": k}``.
    mesh : TriangleMesh
        The shape, in its mesh frame (a compound's parts merged).
    mass, density : float or None
        At most one is set; neither means density 1.
    position : (3,) float ndarray
        World centre of mass.
    orientation : (4,) float ndarray
        (x, y, z, w) orientation of the mesh frame.
    linear_velocity, angular_velocity : (3,) float ndarray
        World-frame v and w.
    restitution, friction : float
        Material coefficients.
    static : bool
        Immovable body.
    forces : tuple of ForceSpec
        Forces applied from t = 0.
    collision_group, collision_mask : int
        Bit fields of :meth:`World.add_body`.
    kinematic : bool
        A body moved at its ``linear_velocity`` and ``angular_velocity`` that contacts and
        joints push against (:meth:`World.add_body`).
    shapes : tuple of (TriangleMesh, (4, 4) float ndarray) or None
        A compound's parts, each with its pose in the body's mesh frame; None: one ``mesh``.
    center_of_mass : (3,) float ndarray or None
        Explicit centre of mass in the mesh frame, with ``mass`` and ``inertia``.
    inertia : (3, 3) float ndarray or None
        Explicit inertia tensor about the centre of mass, mesh axes.
    """

    name: str
    shape: MappingProxyType
    mesh: TriangleMesh
    mass: float | None
    density: float | None
    position: np.ndarray
    orientation: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    restitution: float
    friction: float
    static: bool
    forces: tuple[ForceSpec, ...]
    collision_group: int = 1
    collision_mask: int = 0xFFFF
    kinematic: bool = False
    shapes: tuple | None = None
    center_of_mass: np.ndarray | None = None
    inertia: np.ndarray | None = None


@dataclass(frozen=True)
class JointSpec:
    """One ``[[joint]]`` table: the arguments of :meth:`World.add_joint`, bodies by index.

    Attributes
    ----------
    kind : str
    body_a : int
    body_b : int or None
        None: the world.
    anchor : (3,) float ndarray
    axis : (3,) or (2, 3) float ndarray
        One direction, or a universal or generic joint's two square ones.
    anchor_b : (3,) float ndarray or None
    collide : bool
    name : str or None
    limits : tuple or None
        (lower, upper), (cone, twist_lo, twist_hi) or a universal joint's ((lower, upper),
        (lower, upper)) of float, -inf / inf for an open side; None: no limits.
    axes : tuple or None
        A generic joint's six axes, each "free", "locked" or (lower, upper).
    motor : Mapping or None
        The motor table as written (numbers by key); None: no motor.
    spring : Mapping or None
        The spring table as written (numbers by key); None: no spring.
    damping, friction : float
        A hinge's or slider's viscous damping and Coulomb friction (0: none).
    """

    kind: str
    body_a: int
    body_b: int | None
    anchor: np.ndarray
    axis: np.ndarray
    anchor_b: np.ndarray | None
    collide: bool
    name: str | None
    limits: tuple | None = None
    axes: tuple | None = None
    motor: MappingProxyType | None = None
    spring: MappingProxyType | None = None
    damping: float = 0.0
    friction: float = 0.0


@dataclass(frozen=True)
class UrdfSpec:
    """One ``[[urdf]]`` table: the arguments of :func:`~thesis_rbd.load_urdf` (its path
    resolved against the scene file's folder), and joint positions and servo targets by
    joint name, set once the model is loaded."""

    path: str
    base_position: tuple = (0.0, 0.0, 0.0)
    base_orientation: tuple = (0.0, 0.0, 0.0, 1.0)
    fixed_base: bool = False
    merge_fixed_links: bool = True
    self_collision: bool = False
    inertia: str = "file"
    joint_positions: MappingProxyType | None = None
    joint_targets: MappingProxyType | None = None


@dataclass(frozen=True)
class Scene:
    """A validated scene, ready to build worlds from.

    Attributes
    ----------
    name : str
        The scene's name (the file's stem).
    description : str
        One paragraph; its first line is the scene's summary.
    seconds : float
        Default run length (s).
    record_contacts : bool
        Whether runs of this scene record each frame's contacts by default (see
        :func:`~thesis_rbd.simulate`); false unless the file sets it.
    world : Mapping
        Keyword arguments of :class:`World`: dt, gravity, integrator, linear_drag,
        quadratic_drag, angular_drag, and the contact settings contact_response,
        contact_solver, contact_iterations, friction_sides, contact_tolerance, penetration,
        sleeping, narrow_phase, joint_substeps and joint_coordinates.
    bodies : tuple of BodySpec
        In world index order.
    joints : tuple of JointSpec
    urdfs : tuple of UrdfSpec
        Models loaded after the bodies and joints, in order.
    source : str
        Where the scene came from (a path), used in messages.
    """

    name: str
    description: str
    seconds: float
    world: MappingProxyType
    bodies: tuple[BodySpec, ...]
    source: str
    record_contacts: bool = False
    joints: tuple[JointSpec, ...] = ()
    urdfs: tuple[UrdfSpec, ...] = ()

    @property
    def summary(self) -> str:
        """First line of the description."""
        return self.description.strip().splitlines()[0] if self.description.strip() else ""

    def build(self) -> World:
        """Return a new :class:`World` holding this scene's bodies and forces at t = 0."""
        world = World(**self.world)
        for index, body in enumerate(self.bodies):
            where = _body_where(index, body.name)
            try:
                handle = world.add_body(
                    body.mesh if body.shapes is None else None,
                    shapes=body.shapes,
                    center_of_mass=body.center_of_mass,
                    inertia=body.inertia,
                    mass=body.mass,
                    density=body.density,
                    position=body.position,
                    orientation=body.orientation,
                    linear_velocity=body.linear_velocity,
                    angular_velocity=body.angular_velocity,
                    restitution=body.restitution,
                    friction=body.friction,
                    static=body.static,
                    name=body.name,
                    collision_group=body.collision_group,
                    collision_mask=body.collision_mask,
                    kinematic=body.kinematic,
                )
                for force in body.forces:
                    world.apply_force(handle, force.force, force.point, force.duration)
            except ValueError as exc:
                raise SceneError(f"{self.source}: {where}: {exc}") from exc
        for index, joint in enumerate(self.joints):
            try:
                world.add_joint(
                    joint.kind, joint.body_a, joint.body_b, anchor=joint.anchor,
                    axis=joint.axis, anchor_b=joint.anchor_b, collide=joint.collide,
                    name=joint.name, limits=joint.limits, axes=joint.axes,
                    motor=None if joint.motor is None else dict(joint.motor),
                    spring=None if joint.spring is None else dict(joint.spring),
                    damping=joint.damping, friction=joint.friction,
                )  # fmt: skip
            except ValueError as exc:
                raise SceneError(f"{self.source}: joint[{index}]: {exc}") from exc
        for index, model in enumerate(self.urdfs):
            try:
                _load_model(world, model)
            except (ValueError, ImportError) as exc:
                raise SceneError(f"{self.source}: urdf[{index}]: {exc}") from exc
        return world

    def with_world(self, **settings) -> Scene:
        """Return a copy with some ``[world]`` settings replaced (validated like the file).

        Parameters
        ----------
        **settings
            Any ``[world]`` key (see :attr:`world`).
        """
        checked = _parse_world(settings, _Context("overrides"))
        merged = {**self.world, **checked}
        _check_world(merged, _Context("overrides"))
        return replace(self, world=MappingProxyType(merged))


# ---------------------------------------------------------------------- loading
def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        A TOML scene file; mesh paths inside it are relative to its folder.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        If the file is missing or not valid TOML, or any table, field or value is at fault.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"scene file not found: {path}")
    try:
        # utf-8-sig: a byte-order mark, as some Windows editors write, is not TOML text
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"cannot read scene file {path}: {exc}") from exc
    return parse_scene(text, name=path.stem, source=str(path), folder=path.parent)


def urdf_scene(path: str | Path) -> Scene:
    """A scene of one URDF model alone, its base held where it stands and its joints free
    under gravity (what ``thesis-rbd run robot.urdf`` and ``view`` show).

    Raises
    ------
    SceneError
        If the file is missing.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"URDF file not found: {path}")
    return Scene(
        name=path.stem,
        description=f"{path.name}: its base held, its joints falling under gravity",
        seconds=DEFAULT_SECONDS,
        world=MappingProxyType({"dt": 1.0 / 240.0, "gravity": (0.0, 0.0, -9.81)}),
        bodies=(),
        source=str(path),
        urdfs=(UrdfSpec(path=str(path), fixed_base=True),),
    )


def parse_scene(text: str, name: str, source: str, folder: Path) -> Scene:
    """Validate the TOML text of a scene.

    Parameters
    ----------
    text : str
        The scene file's content.
    name : str
        The scene's name.
    source : str
        Where the text came from, used in messages.
    folder : Path
        Folder that relative mesh paths are resolved against.
    """
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: not valid TOML: {exc}") from exc
    top = _Context(source, "top level")
    _check_keys(
        document,
        ("description", "seconds", "record_contacts", "world", "body", "joint", "urdf"),
        top,
    )
    description = _optional(document, "description", "", _as_string, top)
    seconds = _optional(document, "seconds", DEFAULT_SECONDS, _positive_number, top)
    record_contacts = _optional(document, "record_contacts", False, _as_bool, top)
    world = _parse_world(
        _as_table(document.get("world", {}), _Context(source, "top level"), "world"),
        _Context(source, "[world]"),
    )
    body_tables = document.get("body", [])
    if not isinstance(body_tables, list):
        raise SceneError(
            f"{source}: top level: 'body' must be [[body]] tables, got {body_tables!r}"
        )
    bodies = []
    for index, table in enumerate(body_tables):
        bodies.append(_parse_body(table, index, source, folder))
    seen: dict[str, int] = {}
    for index, body in enumerate(bodies):
        if body.name in seen:
            raise SceneError(
                f"{source}: {_body_where(index, body.name)}: name {body.name!r} is already used "
                f"by body[{seen[body.name]}]; body names must be unique"
            )
        seen[body.name] = index
    joints = tuple(
        _parse_joint(table, where, seen) for table, where in _tables(document, "joint", source)
    )
    urdfs = tuple(
        _parse_urdf(table, where, folder) for table, where in _tables(document, "urdf", source)
    )
    return Scene(
        name=name,
        description=description,
        seconds=seconds,
        world=MappingProxyType(world),
        bodies=tuple(bodies),
        source=source,
        record_contacts=record_contacts,
        joints=joints,
        urdfs=urdfs,
    )


# ---------------------------------------------------------------------- tables
# the keys of a [world] table: World's keyword arguments
WORLD_KEYS = (
    "dt",
    "gravity",
    "integrator",
    "linear_drag",
    "quadratic_drag",
    "angular_drag",
    "contact_response",
    "contact_solver",
    "contact_iterations",
    "friction_sides",
    "contact_tolerance",
    "penetration",
    "sleeping",
    "narrow_phase",
    "joint_substeps",
    "joint_coordinates",
)
# keys of earlier versions, refused with the reason
_REMOVED_WORLD_KEYS = {
    key: f"{key} is no longer a setting: contact tolerances are relative to the bodies' sizes "
    "and to the step (see the guide's contact section)"
    for key in ("slop", "bounce_threshold")
}
# type checks of the contact settings; World checks their values (see _check_world)
_CONTACT_CHECKS = {
    "contact_response": lambda v, w: _as_bool(v, w),
    "contact_solver": lambda v, w: _as_string(v, w),
    "contact_iterations": lambda v, w: _integer(v, w),
    "friction_sides": lambda v, w: _integer(v, w),
    "contact_tolerance": lambda v, w: _positive_number(v, w),
    "penetration": lambda v, w: _as_string(v, w),
    "sleeping": lambda v, w: _as_bool(v, w),
    "narrow_phase": lambda v, w: _as_string(v, w),
    "joint_substeps": lambda v, w: v if v == "auto" else _integer(v, w),
    "joint_coordinates": lambda v, w: _as_string(v, w),
}


def _parse_world(table: dict, where: _Context) -> dict:
    for key in _REMOVED_WORLD_KEYS:
        if key in table:
            where.field(key).fail(_REMOVED_WORLD_KEYS[key])
    _check_keys(table, WORLD_KEYS, where)
    world = {}
    if "dt" in table:
        world["dt"] = _positive_number(table["dt"], where.field("dt"))
    if "gravity" in table:
        world["gravity"] = tuple(_vector(table["gravity"], 3, where.field("gravity")))
    if "integrator" in table:
        integrator = _as_string(table["integrator"], where.field("integrator"))
        if integrator not in INTEGRATORS:
            where.field("integrator").fail(
                f"unknown integrator {integrator!r}; choose one of {', '.join(sorted(INTEGRATORS))}"
            )
        world["integrator"] = integrator
    for key in ("linear_drag", "quadratic_drag", "angular_drag"):
        if key in table:
            world[key] = _non_negative_number(table[key], where.field(key))
    for key, check in _CONTACT_CHECKS.items():
        if key in table:
            world[key] = check(table[key], where.field(key))
    _check_world(world, where)
    return world


def _check_world(world: dict, where: _Context) -> None:
    """Let World judge the values it alone knows (solver names, iteration counts, ...)."""
    try:
        World(**world)
    except ValueError as exc:
        where.fail(str(exc))


_BODY_KEYS = (
    "name",
    "shape",
    "mass",
    "density",
    "position",
    "orientation",
    "linear_velocity",
    "angular_velocity",
    "restitution",
    "friction",
    "static",
    "kinematic",
    "collision_group",
    "collision_mask",
    "force",
    "center_of_mass",
    "inertia",
    "shapes",
)


def _body_where(index: int, name: str | None) -> str:
    return f"body[{index}]" + (f" {name!r}" if name is not None else "")


def _parse_body(table, index: int, source: str, folder: Path) -> BodySpec:
    where = _Context(source, _body_where(index, None))
    table = _as_table(table, where, None)
    name = _optional(table, "name", f"body{index}", _as_string, where)
    where = _Context(source, _body_where(index, name))
    _check_keys(table, _BODY_KEYS, where)
    if "shape" not in table and "shapes" not in table:
        where.fail(
            "missing the 'shape' table, e.g. shape = { type = \"box\", extents = [1, 1, 1] } "
            "(or 'shapes', a compound's parts at their poses)"
        )
    if "shape" in table and "shapes" in table:
        where.fail("give a 'shape' table or a compound's 'shapes', not both")
    static = _optional(table, "static", False, _as_bool, where)
    kinematic = _optional(table, "kinematic", False, _as_bool, where)
    mass = _optional(table, "mass", None, _positive_number, where)
    density = _optional(table, "density", None, _positive_number, where)
    if mass is not None and density is not None:
        where.fail("give 'mass' or 'density', not both")
    center_of_mass = _optional(table, "center_of_mass", None, _vector3, where)
    inertia = _optional(table, "inertia", None, _matrix3, where)
    explicit = center_of_mass is not None or inertia is not None
    parts = None
    if "shapes" in table:
        parts = _parse_parts(table["shapes"], where.field("shapes"), folder)
        shape_table = {"type": "compound", "parts": len(parts)}
        try:
            mesh, _ = body_shape(None, parts)
        except ValueError as exc:
            where.field("shapes").fail(str(exc))
    else:
        shape_table = _as_table(table["shape"], where, "shape")
        mesh = _parse_shape(shape_table, where.field("shape"), folder)
    if not (parts is not None or static or kinematic or explicit) and not (
        mesh.is_closed and mesh.is_consistently_oriented
    ):
        where.field("shape").fail(
            "the mesh is not a closed, consistently oriented surface, so it has no volume "
            "and cannot be a dynamic body; set static = true, give mass, center_of_mass and "
            "inertia, or repair the mesh"
        )
    orientation = np.asarray(_optional(table, "orientation", (0, 0, 0, 1), _quaternion, where))
    restitution = _optional(table, "restitution", 0.0, _number, where)
    if not 0.0 <= restitution <= 1.0:
        where.field("restitution").fail(f"must lie in [0, 1], got {restitution!r}")
    forces_tables = table.get("force", [])
    if not isinstance(forces_tables, list):
        where.field("force").fail(f"must be [[body.force]] tables, got {forces_tables!r}")
    forces = tuple(
        _parse_force(force_table, _Context(source, f"{where.table} force[{i}]"))
        for i, force_table in enumerate(forces_tables)
    )
    return BodySpec(
        name=name,
        shape=MappingProxyType(dict(shape_table)),
        mesh=mesh,
        mass=mass,
        density=density,
        position=np.asarray(_optional(table, "position", (0, 0, 0), _vector3, where)),
        orientation=orientation,
        linear_velocity=np.asarray(_optional(table, "linear_velocity", (0, 0, 0), _vector3, where)),
        angular_velocity=np.asarray(
            _optional(table, "angular_velocity", (0, 0, 0), _vector3, where)
        ),
        restitution=restitution,
        friction=_optional(table, "friction", 0.0, _non_negative_number, where),
        static=static,
        forces=forces,
        collision_group=_optional(table, "collision_group", 1, _integer, where),
        collision_mask=_optional(table, "collision_mask", 0xFFFF, _integer, where),
        kinematic=kinematic,
        shapes=parts,
        center_of_mass=None if center_of_mass is None else np.asarray(center_of_mass),
        inertia=None if inertia is None else np.asarray(inertia),
    )


_PART_KEYS = ("shape", "position", "orientation")


def _parse_parts(value, where: _Context, folder: Path) -> tuple:
    """A compound's ``shapes`` array: each part's mesh and its (4, 4) pose."""
    if not isinstance(value, list) or not value:
        where.fail(f"must be a non-empty array of part tables, got {_describe(value)}")
    parts = []
    for k, part in enumerate(value):
        here = where.field(str(k))
        part = _as_table(part, here, None)
        _check_keys(part, _PART_KEYS, here)
        if "shape" not in part:
            here.fail("missing the 'shape' table of this part")
        mesh = _parse_shape(_as_table(part["shape"], here, "shape"), here.field("shape"), folder)
        pose = transform_from_pose(
            _optional(part, "position", (0, 0, 0), _vector3, here),
            _optional(part, "orientation", (0, 0, 0, 1), _quaternion, here),
        )
        parts.append((mesh, pose))
    return tuple(parts)


_JOINT_KEYS = (
    "kind", "body_a", "body_b", "anchor", "axis", "anchor_b", "collide", "name", "limits", "axes",
    "motor", "spring", "damping", "friction",
)  # fmt: skip
# Every key some motor takes; World.add_joint judges which go together.
_MOTOR_KEYS = (
    "velocity", "max_force", "torque", "position", "stiffness", "damping", "servo", "max_velocity",
)  # fmt: skip
_SPRING_KEYS = ("stiffness", "damping", "rest_length")


def _parse_joint(table, where: _Context, body_index: dict) -> JointSpec:
    """A ``[[joint]]`` table; ``body_index`` maps body names to indices."""
    table = _as_table(table, where, None)
    _check_keys(table, _JOINT_KEYS, where)
    for key, example in (("kind", 'kind = "revolute"'), ("body_a", 'body_a = "door"'),
                         ("anchor", "anchor = [0.0, 0.0, 1.0]")):  # fmt: skip
        if key not in table:
            where.fail(f"missing {key!r}, e.g. {example}")

    def body(key):
        name = _as_string(table[key], where.field(key))
        if name not in body_index:
            where.field(key).fail(f"no body named {name!r}{_suggestion(name, body_index)}")
        return body_index[name]

    anchor_b = _optional(table, "anchor_b", None, _vector3, where)
    motor = _optional(table, "motor", None, _numbers_table(_MOTOR_KEYS, "motor key"), where)
    spring = _optional(table, "spring", None, _numbers_table(_SPRING_KEYS, "spring key"), where)
    return JointSpec(
        kind=_as_string(table["kind"], where.field("kind")),
        body_a=body("body_a"),
        body_b=body("body_b") if "body_b" in table else None,
        anchor=np.asarray(_vector3(table["anchor"], where.field("anchor"))),
        axis=np.asarray(_optional(table, "axis", (0, 0, 1), _joint_axis, where)),
        anchor_b=None if anchor_b is None else np.asarray(anchor_b),
        collide=_optional(table, "collide", False, _as_bool, where),
        name=_optional(table, "name", None, _as_string, where),
        limits=_optional(table, "limits", None, _limits, where),
        axes=_optional(table, "axes", None, _axes, where),
        motor=None if motor is None else MappingProxyType(motor),
        spring=None if spring is None else MappingProxyType(spring),
        damping=_optional(table, "damping", 0.0, _non_negative_number, where),
        friction=_optional(table, "friction", 0.0, _non_negative_number, where),
    )


def _joint_axis(value, where: _Context):
    """A joint's axis: [x, y, z], or a universal or generic joint's two square directions
    [[x, y, z], [x, y, z]] (World.add_joint judges which kind takes which)."""
    if isinstance(value, list) and value and all(isinstance(v, list) for v in value):
        if len(value) != 2:
            where.fail(f"must be [x, y, z] or two directions [[x, y, z], [x, y, z]], got {value!r}")
        return [_vector3(v, where) for v in value]
    return _vector3(value, where)


def _axes(value, where: _Context) -> tuple:
    """A generic joint's six axes: each "free", "locked" or [lower, upper]."""
    if not isinstance(value, list) or len(value) != 6:
        where.fail(
            f'must be six entries, each "free", "locked" or [lower, upper], got {_describe(value)}'
        )
    axes = []
    for index, item in enumerate(value):
        if item in ("free", "locked"):
            axes.append(item)
        elif isinstance(item, list):
            axes.append(_limits(item, where.field(str(index))))
        else:
            where.field(str(index)).fail(
                f'must be "free", "locked" or [lower, upper], got {item!r}'
            )
    return tuple(axes)


def _limits(value, where: _Context) -> tuple:
    """A joint's limits: [lower, upper], a spherical joint's [cone, twist_lo, twist_hi] or a
    universal joint's [[lower, upper], [lower, upper]]; numbers, inf / -inf for an open side
    (TOML's inf). World.add_joint judges which kind takes which."""
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, list) for v in value):
        return tuple(_limits(v, where) for v in value)
    if not isinstance(value, list) or len(value) not in (2, 3):
        where.fail(f"must be [lower, upper] or [cone, twist_lo, twist_hi], got {_describe(value)}")
    bounds = []
    for item in value:
        if isinstance(item, bool) or not isinstance(item, int | float) or math.isnan(item):
            where.fail(f"must be numbers (inf or -inf for an open side), got {value!r}")
        bounds.append(float(item))
    return tuple(bounds)


def _numbers_table(keys, what: str) -> Callable[[object, _Context], dict]:
    """The check of a joint's motor or spring table: numbers by key, e.g.
    { velocity = 1.0, max_force = 2.0 } (World.add_joint judges which go together)."""

    def check(value, where: _Context) -> dict:
        table = _as_table(value, where, None)
        _check_keys(table, keys, where, what=what)
        return {key: _number(item, where.field(key)) for key, item in table.items()}

    return check


def _tables(document: dict, key: str, source: str) -> list[tuple[dict, _Context]]:
    """The ``[[key]]`` tables of a scene document, each with its context ``key[i]``."""
    tables = document.get(key, [])
    if not isinstance(tables, list):
        raise SceneError(f"{source}: top level: {key!r} must be [[{key}]] tables, got {tables!r}")
    return [(table, _Context(source, f"{key}[{index}]")) for index, table in enumerate(tables)]


_URDF_KEYS = (
    "path", "base_position", "base_orientation", "fixed_base", "merge_fixed_links",
    "self_collision", "inertia", "joint_positions", "joint_targets",
)  # fmt: skip


def _parse_urdf(table, where: _Context, folder: Path) -> UrdfSpec:
    """A ``[[urdf]]`` table; its path relative to ``folder``, which must hold the file."""
    table = _as_table(table, where, None)
    _check_keys(table, _URDF_KEYS, where)
    if "path" not in table:
        where.fail("needs a 'path' to its URDF file")
    path = folder / _as_string(table["path"], where.field("path"))
    if not path.is_file():
        where.field("path").fail(f"no URDF file at {path}")
    inertia = _optional(table, "inertia", "file", _as_string, where)
    if inertia not in ("file", "shapes"):
        where.field("inertia").fail(f"must be 'file' or 'shapes', got {inertia!r}")

    def by_name(value, here: _Context) -> MappingProxyType:
        value = _as_table(value, here, None)
        return MappingProxyType({str(k): _number(v, here.field(str(k))) for k, v in value.items()})

    return UrdfSpec(
        path=str(path),
        base_position=tuple(_optional(table, "base_position", (0.0, 0.0, 0.0), _vector3, where)),
        base_orientation=tuple(
            _optional(table, "base_orientation", (0.0, 0.0, 0.0, 1.0), _quaternion, where)
        ),
        fixed_base=_optional(table, "fixed_base", False, _as_bool, where),
        merge_fixed_links=_optional(table, "merge_fixed_links", True, _as_bool, where),
        self_collision=_optional(table, "self_collision", False, _as_bool, where),
        inertia=inertia,
        joint_positions=_optional(table, "joint_positions", None, by_name, where),
        joint_targets=_optional(table, "joint_targets", None, by_name, where),
    )


def _load_model(world: World, model: UrdfSpec) -> None:
    """Load one ``[[urdf]]`` model into ``world`` and set its joints."""
    from thesis_rbd.urdf import load_urdf

    robot = load_urdf(
        world, model.path, base_position=model.base_position,
        base_orientation=model.base_orientation, fixed_base=model.fixed_base,
        merge_fixed_links=model.merge_fixed_links, self_collision=model.self_collision,
        inertia=model.inertia,
    )  # fmt: skip
    if model.joint_positions:
        robot.set_joint_positions(dict(model.joint_positions))
    if model.joint_targets:
        robot.set_joint_targets(dict(model.joint_targets))


def _parse_force(table, where: _Context) -> ForceSpec:
    table = _as_table(table, where, None)
    _check_keys(table, ("force", "point", "duration"), where)
    if "force" not in table:
        where.fail("missing 'force', e.g. force = [2.0, 0.0, 0.0]")
    point = _optional(table, "point", None, _vector3, where)
    return ForceSpec(
        force=np.asarray(_vector3(table["force"], where.field("force"))),
        point=None if point is None else np.asarray(point),
        duration=_optional(table, "duration", None, _positive_number, where),
    )


# Each shape: its builder and its parameters with the checker of each.
_SHAPES: dict[str, tuple[Callable[..., TriangleMesh] | None, dict[str, Callable]]] = {
    "box": (shapes.box, {"extents": lambda v, w: _vector(v, 3, w)}),
    "icosphere": (
        shapes.icosphere,
        {"radius": lambda v, w: _number(v, w), "subdivisions": lambda v, w: _integer(v, w)},
    ),
    "cylinder": (
        shapes.cylinder,
        {
            "radius": lambda v, w: _number(v, w),
            "height": lambda v, w: _number(v, w),
            "sections": lambda v, w: _integer(v, w),
        },
    ),
    "torus": (
        shapes.torus,
        {
            "major_radius": lambda v, w: _number(v, w),
            "minor_radius": lambda v, w: _number(v, w),
            "major_sections": lambda v, w: _integer(v, w),
            "minor_sections": lambda v, w: _integer(v, w),
        },
    ),
    "mesh": (
        None,
        {"path": lambda v, w: _as_string(v, w), "scale": lambda v, w: _positive_number(v, w)},
    ),
}


def _parse_shape(table: dict, where: _Context, folder: Path) -> TriangleMesh:
    if "type" not in table:
        where.fail(f"missing 'type'; choose one of {', '.join(sorted(_SHAPES))}")
    kind = _as_string(table["type"], where.field("type"))
    if kind not in _SHAPES:
        where.field("type").fail(
            f"unknown shape {kind!r}{_suggestion(kind, _SHAPES)}; "
            f"choose one of {', '.join(sorted(_SHAPES))}"
        )
    builder, parameters = _SHAPES[kind]
    _check_keys(table, ("type", *parameters), where, what=f"{kind} parameter")
    arguments = {
        key: parameters[key](value, where.field(key))
        for key, value in table.items()
        if key != "type"
    }
    if kind == "mesh":
        return _load_mesh_shape(arguments, where, folder)
    try:
        return builder(**arguments)
    except ValueError as exc:
        where.fail(f"{kind}: {exc}")


def _load_mesh_shape(arguments: dict, where: _Context, folder: Path) -> TriangleMesh:
    if "path" not in arguments:
        where.fail("missing 'path' (a mesh file relative to the scene file)")
    relative = arguments["path"]
    path = (folder / relative).resolve()
    if not path.is_file():
        where.field("path").fail(f"mesh file not found: {path} (from path = {relative!r})")
    try:
        mesh = load_mesh(path)
    except ValueError as exc:
        where.field("path").fail(str(exc))
    scale = arguments.get("scale")
    if scale is not None:
        mesh = TriangleMesh(mesh.vertices * scale, mesh.faces)
    return mesh


# ---------------------------------------------------------------------- field checks
class _Context:
    """Where in a scene a check runs: source, table and (optionally) field, for messages."""

    def __init__(self, source: str, table: str = "", field_name: str | None = None):
        self.source, self.table, self.field_name = source, table, field_name

    def field(self, name: str) -> _Context:
        prefix = f"{self.field_name}." if self.field_name else ""
        return _Context(self.source, self.table, prefix + name)

    def fail(self, problem: str) -> NoReturn:
        location = ": ".join(part for part in (self.source, self.table) if part)
        if self.field_name:
            location += f": field '{self.field_name}'"
        raise SceneError(f"{location}: {problem}")


def _describe(value) -> str:
    kinds = {
        bool: "boolean",
        int: "integer",
        float: "number",
        str: "string",
        list: "array",
        dict: "table",
    }
    return f"{value!r} ({kinds.get(type(value), type(value).__name__)})"


def _suggestion(key: str, allowed) -> str:
    close = difflib.get_close_matches(key, list(allowed), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_keys(table: dict, allowed, where: _Context, what: str = "key") -> None:
    for key in table:
        if key not in allowed:
            where.fail(
                f"unknown {what} {key!r}{_suggestion(key, allowed)}; allowed: {', '.join(allowed)}"
            )


def _optional(table: dict, key: str, default, check: Callable, where: _Context):
    return check(table[key], where.field(key)) if key in table else default


def _as_table(value, where: _Context, key: str | None) -> dict:
    if not isinstance(value, dict):
        (where.field(key) if key else where).fail(f"must be a table, got {_describe(value)}")
    return value


def _as_string(value, where: _Context) -> str:
    if not isinstance(value, str):
        where.fail(f"must be a string, got {_describe(value)}")
    return value


def _as_bool(value, where: _Context) -> bool:
    if not isinstance(value, bool):
        where.fail(f"must be true or false, got {_describe(value)}")
    return value


def _number(value, where: _Context) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        where.fail(f"must be a number, got {_describe(value)}")
    if not math.isfinite(value):
        where.fail(f"must be finite, got {value!r}")
    return float(value)


def _positive_number(value, where: _Context) -> float:
    number = _number(value, where)
    if number <= 0.0:
        where.fail(f"must be > 0, got {value!r}")
    return number


def _non_negative_number(value, where: _Context) -> float:
    number = _number(value, where)
    if number < 0.0:
        where.fail(f"must be >= 0, got {value!r}")
    return number


def _integer(value, where: _Context) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        where.fail(f"must be an integer, got {_describe(value)}")
    return value


def _vector(value, length: int, where: _Context) -> list[float]:
    if not isinstance(value, list) or len(value) != length:
        where.fail(f"must be an array of {length} numbers, got {_describe(value)}")
    return [_number(item, where) for item in value]


def _vector3(value, where: _Context) -> list[float]:
    return _vector(value, 3, where)


def _matrix3(value, where: _Context) -> list[list[float]]:
    if not isinstance(value, list) or len(value) != 3:
        where.fail(f"must be an array of 3 rows of 3 numbers, got {_describe(value)}")
    return [_vector3(row, where) for row in value]


def _quaternion(value, where: _Context) -> list[float]:
    q = _vector(value, 4, where)
    if math.hypot(*q) < 1e-12:
        where.fail("quaternion (x, y, z, w) has zero length")
    return q
