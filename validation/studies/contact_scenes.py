"""Contact scenes described once as data and built in thesis_rbd or in pybullet.

A :class:`SceneSpec` is a list of :class:`BodySpec` (boxes and spheres, static or dynamic);
:func:`build_world` turns it into a :class:`thesis_rbd.World` and :func:`build_pybullet` into
a :class:`validation.pybullet_contact.PybulletScene`, body i of the spec being body i of
either, so a study reads the same body in both engines. The factories below are the resting
and impact scenes the contact studies share: stacks, pyramids, leaning plates, piles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "BodySpec",
    "SceneSpec",
    "build_mujoco",
    "build_pybullet",
    "build_world",
    "card_house",
    "cube_stack",
    "drifting_pair",
    "dropped_plate",
    "dropped_rod",
    "elastic_pile",
    "floor",
    "heavy_on_light",
    "plate_column",
    "poured_pile",
    "pyramid",
    "resting_grid",
    "resting_row",
    "scale_ball",
    "scale_column",
    "struck_row",
    "thin_plate",
    "touching_pair_strike",
    "wall_slide",
]

G = 9.81


@dataclass(frozen=True)
class BodySpec:
    """One body of a scene.

    Parameters
    ----------
    shape : {"box", "sphere"}
    size : tuple of float
        Box extents (3,), or the sphere's (radius,).
    mass : float or None
        None makes the body static.
    position : (3,) float
        Centre (of mass) in the world.
    orientation : (4,) float
        (x, y, z, w).
    linear_velocity, angular_velocity : (3,) float
    restitution, friction : float
    """

    shape: str
    size: tuple
    mass: float | None
    position: tuple
    orientation: tuple = (0.0, 0.0, 0.0, 1.0)
    linear_velocity: tuple = (0.0, 0.0, 0.0)
    angular_velocity: tuple = (0.0, 0.0, 0.0)
    restitution: float = 0.0
    friction: float = 0.5


@dataclass(frozen=True)
class SceneSpec:
    """A scene: its bodies and the gravity along -z."""

    bodies: list = field(default_factory=list)
    gravity: float = G

    def dynamic(self) -> list[int]:
        """Indices of the dynamic bodies."""
        return [i for i, b in enumerate(self.bodies) if b.mass is not None]


def _mesh(body: BodySpec):
    import thesis_rbd as rbd

    if body.shape == "box":
        return rbd.shapes.box(body.size)
    return rbd.shapes.icosphere(body.size[0], 3)


def build_world(spec: SceneSpec, dt: float, **options):
    """The scene as a :class:`thesis_rbd.World`; ``options`` go to the World."""
    import thesis_rbd as rbd

    world = rbd.World(dt=dt, gravity=(0.0, 0.0, -spec.gravity), **options)
    for body in spec.bodies:
        world.add_body(
            _mesh(body),
            mass=body.mass,
            static=body.mass is None,
            position=body.position,
            orientation=body.orientation,
            linear_velocity=body.linear_velocity,
            angular_velocity=body.angular_velocity,
            restitution=body.restitution,
            friction=body.friction,
        )
    return world


def build_pybullet(spec: SceneSpec, dt: float, configuration: str = "defaults", sleeping=True):
    """The scene in pybullet, in one of the configurations of
    :mod:`validation.pybullet_contact` ("defaults" or "restitution"); ``sleeping=False``
    keeps its bodies awake."""
    from validation.pybullet_contact import PybulletScene

    scene = PybulletScene(
        dt,
        gravity=spec.gravity,
        floor_half_extents=None,
        configuration=configuration,
        sleeping=sleeping,
    )
    for body in spec.bodies:
        mass = 0.0 if body.mass is None else body.mass
        if body.shape == "box":
            scene.add_box(
                0.5 * np.asarray(body.size),
                mass,
                body.position,
                body.restitution,
                body.friction,
                orientation=body.orientation,
                linear_velocity=body.linear_velocity,
                angular_velocity=body.angular_velocity,
            )
        else:
            sphere = scene.add_sphere(
                body.size[0], mass, body.position, body.restitution, body.friction
            )
            scene.p.resetBaseVelocity(
                sphere,
                list(body.linear_velocity),
                list(body.angular_velocity),
                physicsClientId=scene.client,
            )
    return scene


def build_mujoco(spec: SceneSpec, dt: float):
    """The scene in MuJoCo at its defaults (:mod:`validation.mujoco_contact`); restitution
    is not carried over (MuJoCo's contacts are soft), so use it for resting scenes."""
    from validation.mujoco_contact import MujocoScene

    shapes = []
    for body in spec.bodies:
        size = 0.5 * np.asarray(body.size) if body.shape == "box" else np.asarray(body.size)
        shapes.append(
            (
                body.shape,
                size,
                body.mass,
                body.position,
                body.orientation,
                body.friction,
                body.linear_velocity,
                body.angular_velocity,
            )
        )
    return MujocoScene(dt, spec.gravity, shapes)


def floor(size: float = 4.0, centre=(0.0, 0.0), restitution=0.0, friction=0.5) -> BodySpec:
    """A static floor box, ``size`` wide and a tenth as thick, its top face at z = 0."""
    thickness = max(size / 10.0, 1e-3)
    return BodySpec(
        "box",
        (size, size, thickness),
        None,
        (centre[0], centre[1], -thickness / 2),
        restitution=restitution,
        friction=friction,
    )


def cube_stack(
    count=10, mass_ratio=1.0, offset=0.0, edge=1.0, origin=(0.0, 0.0), seed=0
) -> SceneSpec:
    """``count`` cubes touching in a column on a floor; masses grow geometrically from 1 kg
    at the bottom to ``mass_ratio`` kg at the top; each cube is shifted sideways by up to
    ``offset`` (uniform, seeded) so the column is not perfectly aligned."""
    shifts = np.random.default_rng(seed).uniform(-offset, offset, (count, 2))
    bodies = [floor(max(4.0 * edge, 4.0), origin)]
    for i in range(count):
        mass = mass_ratio ** (i / (count - 1)) if count > 1 else 1.0
        position = (origin[0] + shifts[i, 0], origin[1] + shifts[i, 1], edge * (0.5 + i))
        bodies.append(BodySpec("box", (edge, edge, edge), mass, position))
    return SceneSpec(bodies)


def pyramid(rows=4, gap=0.1) -> SceneSpec:
    """A 2D pyramid of unit cubes: ``rows`` at the bottom, each row above centred on the
    gaps of the one below, every cube resting on two."""
    bodies = [floor(2.0 * rows + 4.0)]
    pitch = 1.0 + gap
    for r in range(rows):
        for i in range(rows - r):
            x = (i - (rows - r - 1) / 2) * pitch
            bodies.append(BodySpec("box", (1.0, 1.0, 1.0), 1.0, (x, 0.0, 0.5 + r)))
    return SceneSpec(bodies)


def card_house(angle_degrees=20.0, height=1.0, thickness=0.02, friction=0.6) -> SceneSpec:
    """Two plates (``thickness`` x 1 x ``height`` m, 0.5 kg) leaning against each other like
    a house of cards, each tilted by ``angle_degrees`` from the vertical, their top edges
    touching at x = 0 and their bottom edges on the floor."""
    bodies = [floor(4.0, friction=friction)]
    half = 0.5 * np.array([thickness, 1.0, height])
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for side in (-1.0, 1.0):
        rotation = Rotation.from_euler("y", -side * math.radians(angle_degrees))
        world_corners = rotation.apply(corners * half)
        # lowest corner on the floor; the innermost corner at x = 0
        inner = world_corners[:, 0].max() if side < 0 else world_corners[:, 0].min()
        centre = (-inner, 0.0, -world_corners[:, 2].min())
        bodies.append(
            BodySpec(
                "box",
                (thickness, 1.0, height),
                0.5,
                centre,
                orientation=tuple(rotation.as_quat()),
                friction=friction,
            )
        )
    return SceneSpec(bodies)


def thin_plate(speed=30.0, thickness=0.01, height=1.0) -> SceneSpec:
    """A 0.6 x 0.6 m plate ``thickness`` thick falling flat at ``speed`` m/s onto a floor."""
    return SceneSpec(
        [
            floor(4.0),
            BodySpec(
                "box",
                (0.6, 0.6, thickness),
                1.0,
                (0.0, 0.0, height),
                linear_velocity=(0.0, 0.0, -speed),
            ),
        ]
    )


def elastic_pile(radius=0.25, layers=2) -> SceneSpec:
    """Frictionless balls of restitution 1 in square layers (3 x 3, 2 x 2, ...) nested into
    each other's gaps, dropped from 0.5 m onto a floor of restitution 1."""
    bodies = [floor(4.0, restitution=1.0, friction=0.0)]
    pitch = 2.0 * radius * 1.02
    for layer in range(layers):
        side = 3 - layer
        z = 0.5 + radius + layer * pitch * math.sqrt(0.5)
        for i in range(side):
            for j in range(side):
                x, y = (i - (side - 1) / 2) * pitch, (j - (side - 1) / 2) * pitch
                bodies.append(
                    BodySpec("sphere", (radius,), 1.0, (x, y, z), restitution=1.0, friction=0.0)
                )
    return SceneSpec(bodies)


DENSITY = 2000.0  # kg/m^3, the scale cases' material


def _scale_floor(width: float) -> BodySpec:
    """A static floor ``width`` wide and a tenth as thick, its top face at z = 0."""
    return BodySpec("box", (width, width, width / 10.0), None, (0.0, 0.0, -width / 20.0))


def scale_column(edge: float, count: int = 1) -> SceneSpec:
    """``count`` cubes of edge ``edge`` and density 2000 exactly touching in a column on a
    floor 40 edges wide: the same scene at every scale."""
    mass = DENSITY * edge**3
    bodies = [_scale_floor(40.0 * edge)]
    for i in range(count):
        bodies.append(BodySpec("box", (edge, edge, edge), mass, (0.0, 0.0, edge * (0.5 + i))))
    return SceneSpec(bodies)


def scale_ball(diameter: float) -> SceneSpec:
    """A ball (icosphere) of density 2000 resting on a face on a floor 40 diameters wide.

    A polyhedral ball's rest is on a face: balanced on a vertex, it tips onto one (its centre
    moves by a few percent of its diameter), which is the geometry of the mesh, not drift.
    """
    import thesis_rbd as rbd

    radius = 0.5 * diameter
    mesh = rbd.shapes.icosphere(radius, 3)
    mass = rbd.mass_properties(mesh, density=DENSITY).mass
    corners = mesh.vertices[mesh.faces[0]]
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    if normal @ corners.mean(axis=0) < 0.0:
        normal = -normal
    turn, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [normal])
    # the turned icosphere's lowest face touches the floor
    lowest = -(mesh.vertices @ turn.as_matrix().T)[:, 2].min()
    return SceneSpec(
        [
            _scale_floor(40.0 * diameter),
            BodySpec("sphere", (radius,), mass, (0.0, 0.0, lowest), tuple(turn.as_quat())),
        ]
    )


def dropped_plate(thickness: float, tilt_degrees: float = 0.0) -> SceneSpec:
    """A square plate 50 thicknesses wide and ``thickness`` thick (density 2000), its centre
    dropped from 25 thicknesses above the floor, tilted by ``tilt_degrees`` about x."""
    width = 50.0 * thickness
    rotation = Rotation.from_euler("x", tilt_degrees, degrees=True)
    return SceneSpec(
        [
            _scale_floor(40.0 * width),
            BodySpec(
                "box",
                (width, width, thickness),
                DENSITY * width * width * thickness,
                (0.0, 0.0, 25.0 * thickness),
                orientation=tuple(rotation.as_quat()),
            ),
        ]
    )


def heavy_on_light(heavy: float = 100.0, light: float = 1.0) -> SceneSpec:
    """A unit cube of ``heavy`` kg resting on one of ``light`` kg on a floor."""
    return SceneSpec(
        [
            _scale_floor(40.0),
            BodySpec("box", (1.0, 1.0, 1.0), light, (0.0, 0.0, 0.5)),
            BodySpec("box", (1.0, 1.0, 1.0), heavy, (0.0, 0.0, 1.5)),
        ]
    )


def resting_row(count: int, spacing: float = 1.5) -> SceneSpec:
    """``count`` unit cubes (1 kg, friction 0.5) resting on a floor in a row ``spacing``
    apart, each touching the floor exactly."""
    bodies = [floor(spacing * count + 4.0)]
    for i in range(count):
        x = (i - (count - 1) / 2) * spacing
        bodies.append(BodySpec("box", (1.0, 1.0, 1.0), 1.0, (x, 0.0, 0.5)))
    return SceneSpec(bodies)


def resting_grid(count: int, spacing: float = 1.5) -> SceneSpec:
    """``count`` unit cubes resting on a floor in a square grid ``spacing`` apart."""
    side = int(np.ceil(np.sqrt(count)))
    bodies = [floor(spacing * side + 4.0)]
    for k in range(count):
        i, j = divmod(k, side)
        x, y = (i - (side - 1) / 2) * spacing, (j - (side - 1) / 2) * spacing
        bodies.append(BodySpec("box", (1.0, 1.0, 1.0), 1.0, (x, y, 0.5)))
    return SceneSpec(bodies)


def poured_pile(
    count: int = 256, columns: int = 4, spacing: float = 1.8, seed: int = 1
) -> SceneSpec:
    """``count`` unit cubes in random orientations, in a lattice of ``columns`` x ``columns``
    stacks ``spacing`` apart, released above a floor: they collapse into a tumbled pile,
    at rest after about 9 s."""
    rng = np.random.default_rng(seed)
    bodies = [floor(columns * spacing * 4.0)]
    for k in range(count):
        layer, cell = divmod(k, columns * columns)
        i, j = divmod(cell, columns)
        x, y = (i - (columns - 1) / 2) * spacing, (j - (columns - 1) / 2) * spacing
        orientation = tuple(Rotation.random(random_state=rng).as_quat())
        bodies.append(
            BodySpec("box", (1.0, 1.0, 1.0), 1.0, (x, y, 1.0 + spacing * layer), orientation)
        )
    return SceneSpec(bodies)


# The hard cases of issue 33: scenes a new user builds in the first hour, each with an answer
# from physics or geometry (see the stability suite).


def struck_row(count: int = 5, speed: float = 2.0, restitution: float = 0.5) -> SceneSpec:
    """Zero gravity: a 0.1 m box of 0.2 kg at ``speed`` m/s along +x into a row of ``count``
    such boxes at rest touching face to face (frictionless, ``restitution`` everywhere). The
    striker is body 1 of the spec's dynamic bodies, the row's far end the last."""
    edge, mass = 0.1, 0.2
    striker = BodySpec(
        "box",
        (edge, edge, edge),
        mass,
        (-1.5 * edge, 0.0, 0.0),
        linear_velocity=(speed, 0.0, 0.0),
        restitution=restitution,
        friction=0.0,
    )
    row = [
        BodySpec(
            "box",
            (edge, edge, edge),
            mass,
            (edge * i, 0.0, 0.0),
            restitution=restitution,
            friction=0.0,
        )
        for i in range(count)
    ]
    return SceneSpec([striker, *row], gravity=0.0)


def wall_slide(speed: float = 20.0, wall: float = 0.01) -> SceneSpec:
    """A 0.1 m box of 1 kg sliding at ``speed`` m/s on a frictionless floor (so that it
    touches the floor all along) into a static wall ``wall`` thick whose near face is at
    x = 1 - wall / 2 (e = 0)."""
    return SceneSpec(
        [
            BodySpec("box", (50.0, 2.0, 0.2), None, (0.0, 0.0, -0.1), friction=0.0),
            BodySpec("box", (wall, 2.0, 1.0), None, (1.0, 0.0, 0.5), friction=0.0),
            BodySpec(
                "box",
                (0.1, 0.1, 0.1),
                1.0,
                (0.0, 0.0, 0.05),
                linear_velocity=(speed, 0.0, 0.0),
                friction=0.0,
            ),
        ]
    )


def touching_pair_strike(speed: float = 300.0) -> SceneSpec:
    """Zero gravity: two touching unit cubes of 1 kg at ``speed`` m/s along +x into a third
    at rest 3 m ahead (at 300 m/s each moves 1.25 cubes a step at 240 Hz)."""
    moving = dict(linear_velocity=(speed, 0.0, 0.0), friction=0.0)
    return SceneSpec(
        [
            BodySpec("box", (1.0, 1.0, 1.0), 1.0, (-3.0, 0.0, 0.0), **moving),
            BodySpec("box", (1.0, 1.0, 1.0), 1.0, (-2.0, 0.0, 0.0), **moving),
            BodySpec("box", (1.0, 1.0, 1.0), 1.0, (2.0, 0.0, 0.0), friction=0.0),
        ],
        gravity=0.0,
    )


def plate_column(count: int = 10, thickness: float = 1e-3, gap: float = 1e-3) -> SceneSpec:
    """``count`` 1 m x 1 m plates ``thickness`` thick (1 kg) one above another ``gap``
    apart, the lowest touching the floor, released: each lands on the one below."""
    bodies = [floor(4.0)]
    for k in range(count):
        z = thickness / 2 + k * (thickness + gap)
        bodies.append(BodySpec("box", (1.0, 1.0, thickness), 1.0, (0.0, 0.0, z)))
    return SceneSpec(bodies)


def dropped_rod(seed: int = 0) -> SceneSpec:
    """A 1 x 1 x 20 cm rod of 0.1 kg dropped from 1 m in a random orientation (seeded) onto
    a floor, e = 0 and no friction: nothing in the scene can add energy."""
    orientation = tuple(Rotation.random(random_state=seed).as_quat())
    return SceneSpec(
        [
            floor(4.0, friction=0.0),
            BodySpec("box", (0.01, 0.01, 0.2), 0.1, (0.0, 0.0, 1.0), orientation, friction=0.0),
        ]
    )


def drifting_pair(speed: float = 1e-3) -> SceneSpec:
    """Zero gravity: two unit cubes 2 m apart drifting at ``speed`` m/s along +x, touching
    nothing: nothing acts on them, so their momentum must stay."""
    drift = dict(linear_velocity=(speed, 0.0, 0.0))
    return SceneSpec(
        [
            BodySpec("box", (1.0, 1.0, 1.0), 1.0, (0.0, 0.0, 0.0), **drift),
            BodySpec("box", (1.0, 1.0, 1.0), 1.0, (0.0, 2.0, 0.0), **drift),
        ],
        gravity=0.0,
    )
