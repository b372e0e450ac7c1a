"""Hard cases a new user meets in the first hour, at the default settings: their answers
are conserved or analytic quantities, or bounds from the geometry.

* A thin rod dropped on a floor with e = 0 and no friction: no force in the scene adds
  energy, so the total energy never rises above its start.
* Rows of touching boxes and balls hit at one end: momentum along the row is kept, the
  kinetic energy never exceeds the impact's, every body moves after the impact, and five
  balls with e = 1 leave as Poisson's simultaneous impact says.
* Bodies that touch something at the start of a step and run into something else during it
  (a box sliding on a floor into a thin wall, two touching cubes into a third, two touching
  plates onto a third): no passing into the other beyond the suite's contact bound, 1 % of
  the thinner body, and every stack in its order.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd

DT = 1 / 240
G = 9.81


@pytest.mark.parametrize("seed", range(20))
def test_a_thin_rod_dropped_on_a_floor_never_gains_energy(seed):
    """A 1 x 1 x 20 cm rod of 0.1 kg dropped from 1 m in a random orientation, e = 0, mu = 0,
    for 2 s: total energy at most 1e-3 relative above its start at every step (an explicit
    turn of the bodies the contact stage moves gained up to 2000x)."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    world.add_body(
        rbd.shapes.box((4.0, 4.0, 0.2)), static=True, position=(0, 0, -0.1), restitution=0.0,
        friction=0.0,
    )  # fmt: skip
    world.add_body(
        rbd.shapes.box((0.01, 0.01, 0.2)), mass=0.1, position=(0, 0, 1.0),
        orientation=Rotation.random(random_state=seed).as_quat(), restitution=0.0,
        friction=0.0,
    )  # fmt: skip
    energy0 = world.kinetic_energy() + world.potential_energy()
    rise = -np.inf
    for _ in range(round(2.0 / DT)):
        world.step()
        rise = max(rise, world.kinetic_energy() + world.potential_energy() - energy0)
    assert rise <= 1e-3 * abs(energy0)


SIZE = 0.1  # m: the boxes' edge, the balls' diameter
SPEED = 2.0  # m/s


def ball_facing_x():
    """A 0.1 m icosphere turned so that two of its faces face +x and -x: a row of them
    touches face to face (at vertices, the contact normal of two polyhedra is not along the
    row)."""
    mesh = rbd.shapes.icosphere(SIZE / 2, 2)
    corners = mesh.vertices[mesh.faces]
    normal = np.cross(corners[0, 1] - corners[0, 0], corners[0, 2] - corners[0, 0])
    turn, _ = Rotation.align_vectors([[1.0, 0.0, 0.0]], [normal])
    return rbd.TriangleMesh(turn.apply(np.array(mesh.vertices)), mesh.faces)


def row_world(shape, count, e, on_floor):
    """A body of 0.2 kg at 2 m/s along x towards ``count`` bodies at rest that touch each
    other, in zero gravity or on a frictionless floor. Returns the world and its bodies (the
    moving one first)."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G) if on_floor else (0, 0, 0))
    mesh = rbd.shapes.box((SIZE,) * 3) if shape == "box" else ball_facing_x()
    span = np.ptp(mesh.vertices[:, 0])  # the balls touch face to face
    height = 0.0
    if on_floor:
        world.add_body(
            rbd.shapes.box((50.0, 2.0, 0.2)), static=True, position=(0, 0, -0.1),
            restitution=1.0, friction=0.0,
        )  # fmt: skip
        height = -mesh.vertices[:, 2].min()
    mover = world.add_body(
        mesh, mass=0.2, position=(-3 * span, 0, height), linear_velocity=(SPEED, 0, 0),
        restitution=e, friction=0.0,
    )  # fmt: skip
    row = [
        world.add_body(mesh, mass=0.2, position=(k * span, 0, height), restitution=e, friction=0.0)
        for k in range(count)
    ]
    bodies = [mover, *row]
    return world, bodies


@pytest.mark.parametrize("on_floor", [False, True], ids=["zero_gravity", "on_a_floor"])
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
@pytest.mark.parametrize("count", [2, 5, 20])
@pytest.mark.parametrize("shape", ["box", "ball"])
def test_a_row_of_touching_bodies_takes_the_impact(shape, count, e, on_floor):
    """The impact resolves in the step it happens: momentum along x kept to 1e-12 (nothing
    acts along x), kinetic energy (less the vertical motion the floor holds against gravity)
    never above its value before the impact, every body of the row moving by the step after
    the impact, and no contact deeper than 1 % of a body (the suite's contact bound)."""
    world, bodies = row_world(shape, count, e, on_floor)
    mass = 0.2
    momentum0 = mass * SPEED
    energy0 = 0.5 * mass * SPEED**2
    impact_step, most_energy, steps = None, 0.0, round(0.5 / DT)
    for step in range(steps):
        world.step()
        assert world.contacts["depths"].max(initial=0.0) <= 0.01 * SIZE
        velocity = np.array([world.linear_velocity(b) for b in bodies])
        momentum = mass * velocity[:, 0].sum()
        assert momentum == pytest.approx(momentum0, rel=1e-12)
        # the floor holds the bodies against gravity, a vertical motion of its own
        most_energy = max(
            most_energy, world.kinetic_energy() - 0.5 * mass * (velocity[:, 2] ** 2).sum()
        )
        if impact_step is None and velocity[0, 0] < SPEED - 1e-9:
            impact_step = step
        if impact_step is not None and step == impact_step + 1:
            assert (velocity[1:, 0] > 0.0).all(), velocity[:, 0]
    assert impact_step is not None
    # on a floor, a resting contact and an impact are told apart at the speed gravity gives
    # in a step: each body may keep the energy of g dt (its contact with the floor resting)
    resolution = (count + 1) * 0.5 * mass * (G * DT) ** 2 if on_floor else 0.0
    assert most_energy <= energy0 * (1 + 1e-9) + resolution


def test_five_touching_balls_with_e_1_leave_as_poisson_says():
    """One ball at v into four touching balls, e = 1, zero gravity: Poisson's simultaneous
    impact (every contact gives back what it took) sends them off at (-0.6, 0.4, 0.4, 0.4,
    0.4) v (momentum 1, energy 1: 0.36 + 4 x 0.16)."""
    world, bodies = row_world("ball", 4, 1.0, on_floor=False)
    world.step(round(0.5 / DT))
    velocity = np.array([world.linear_velocity(b)[0] for b in bodies]) / SPEED
    np.testing.assert_allclose(velocity, [-0.6, 0.4, 0.4, 0.4, 0.4], atol=0.01)


@pytest.mark.parametrize("x0", [0.0, 0.01])
@pytest.mark.parametrize("speed", [1.0, 5.0, 20.0, 50.0])
def test_a_box_sliding_on_a_floor_stops_at_a_thin_wall(speed, x0):
    """A 0.1 m box sliding on a frictionless floor (the contact stage moves it every step)
    into a static wall a tenth of its size thick: it never sinks into the wall by more than
    1 % of the wall's thickness (the suite's contact bound), and stays on its side."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    world.add_body(
        rbd.shapes.box((50.0, 2.0, 0.2)), static=True, position=(0, 0, -0.1), friction=0.0
    )
    wall = 0.01
    world.add_body(
        rbd.shapes.box((wall, 2.0, 1.0)), static=True, position=(1.0, 0, 0.5), friction=0.0
    )
    box = world.add_body(
        rbd.shapes.box((0.1, 0.1, 0.1)), mass=1.0, position=(x0, 0, 0.05),
        linear_velocity=(speed, 0, 0), friction=0.0, restitution=0.0,
    )  # fmt: skip
    face = 1.0 - wall / 2
    deepest = -np.inf
    for _ in range(round(1.0 / DT)):
        world.step()
        deepest = max(deepest, world.position(box)[0] + 0.05 - face)
    assert deepest <= 0.01 * wall
    assert world.position(box)[0] < face


@pytest.mark.parametrize("speed", [10.0, 100.0, 300.0])
def test_two_touching_cubes_never_pass_into_a_third(speed):
    """Zero gravity: two touching unit cubes at 10-300 m/s into a free unit cube (at 300 m/s
    each moves 1.25 cubes a step): no two cubes overlap by more than 1 % of their size, and
    they stay in their order."""
    world = rbd.World(dt=DT)
    cube = rbd.shapes.box((1.0, 1.0, 1.0))
    bodies = [
        world.add_body(cube, mass=1.0, position=(-3, 0, 0), linear_velocity=(speed, 0, 0)),
        world.add_body(cube, mass=1.0, position=(-2, 0, 0), linear_velocity=(speed, 0, 0)),
        world.add_body(cube, mass=1.0, position=(2, 0, 0)),
    ]
    worst = -np.inf
    for _ in range(round(1.0 / DT)):
        world.step()
        x = [world.position(b)[0] for b in bodies]
        worst = max(worst, x[0] + 1 - x[1], x[1] + 1 - x[2])
    assert worst <= 0.01


def settle_stack(world, bodies, seconds=2.0):
    """Step ``world`` for ``seconds``: the deepest contact after any step (m) and the
    ``bodies``' final heights (m)."""
    deepest = 0.0
    for _ in range(round(seconds / DT)):
        world.step()
        deepest = max(deepest, world.contacts["depths"].max(initial=0.0))
    return deepest, [world.position(b)[2] for b in bodies]


def test_two_touching_plates_land_on_a_plate_in_their_order():
    """Two 1 m x 1 m x 1 mm plates touching face to face fall at 0.4 m/s onto a plate on the
    floor: no contact deeper than 1 % of a plate, and the stack ends 0.5 / 1.5 / 2.5 mm."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    world.add_body(rbd.shapes.box((4.0, 4.0, 0.2)), static=True, position=(0, 0, -0.1))
    plate = rbd.shapes.box((1.0, 1.0, 0.001))
    bodies = [world.add_body(plate, mass=1.0, position=(0, 0, 0.0005))]
    bodies += [
        world.add_body(
            plate, mass=1.0, position=(0, 0, 0.0105 + 0.001 * k), linear_velocity=(0, 0, -0.4)
        )
        for k in range(2)
    ]
    deepest, heights = settle_stack(world, bodies)
    assert deepest <= 0.01 * 0.001
    np.testing.assert_allclose(heights, [0.0005, 0.0015, 0.0025], atol=0.01 * 0.001)


def test_ten_plates_dropped_one_above_another_stack_in_their_order():
    """Ten 1 m x 1 m x 1 mm plates 1 mm apart fall onto a floor: each lands on the one below
    within the step after that one landed (the impacts of one step come in rounds), so no
    contact is deeper than 1 % of a plate, and the stack ends 0.5 / 1.5 / ... / 9.5 mm."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    world.add_body(rbd.shapes.box((4.0, 4.0, 0.2)), static=True, position=(0, 0, -0.1))
    plate = rbd.shapes.box((1.0, 1.0, 0.001))
    bodies = [
        world.add_body(plate, mass=1.0, position=(0, 0, 0.0005 + 0.002 * k)) for k in range(10)
    ]
    deepest, heights = settle_stack(world, bodies)
    assert deepest <= 0.01 * 0.001
    np.testing.assert_allclose(heights, 0.0005 + 0.001 * np.arange(10), atol=0.01 * 0.001)
