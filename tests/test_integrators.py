"""Free rigid-body motion against closed forms and a tight scipy reference (thesis 3.2-3.4)."""

import numpy as np
import pytest
from reference_dynamics import rotation_angle_between, sign_change_times, torque_free_reference

import thesis_rbd as rbd

G = np.array([0.0, 0.0, -9.81])
BOX_123 = rbd.shapes.box((1.0, 2.0, 3.0))  # I = diag(13, 10, 5) / 12 for mass 1


def projectile_with_linear_drag(t, x0, v0, mass, k):
    """Closed form of m dv/dt = m g - k v."""
    v_inf = mass * G / k
    decay = np.exp(-k * t / mass)
    return x0 + v_inf * t + (v0 - v_inf) * (mass / k) * (1 - decay), v_inf + (v0 - v_inf) * decay


def run_projectile(integrator, dt, seconds, drag):
    world = rbd.World(dt=dt, gravity=G, integrator=integrator, linear_drag=drag)
    body = world.add_body(
        rbd.shapes.icosphere(0.1, 1), mass=2.0, position=(1, 2, 3), linear_velocity=(3, -1, 8)
    )
    world.step(round(seconds / dt))
    return world, body


def test_free_fall_is_exact_with_rk4():
    world, body = run_projectile("rk4", 1 / 240, 2.0, drag=0.0)
    t = world.time
    expected = np.array([1, 2, 3]) + np.array([3, -1, 8]) * t + 0.5 * G * t**2
    assert t == pytest.approx(2.0)
    np.testing.assert_allclose(world.position(body), expected, atol=1e-9, rtol=0)
    np.testing.assert_allclose(world.linear_velocity(body), [3, -1, 8] + G * t, atol=1e-9, rtol=0)


def test_projectile_with_linear_drag_matches_closed_form():
    world, body = run_projectile("rk4", 1 / 240, 2.0, drag=0.7)
    x, v = projectile_with_linear_drag(
        world.time, np.array([1, 2, 3]), np.array([3, -1, 8]), 2.0, 0.7
    )
    assert np.abs(world.position(body) - x).max() <= 1e-9
    assert np.abs(world.linear_velocity(body) - v).max() <= 1e-9


def test_quadratic_drag_reaches_terminal_velocity():
    """m g = k2 v^2 at terminal speed."""
    world = rbd.World(dt=1 / 240, gravity=G, quadratic_drag=0.5)
    body = world.add_body(rbd.shapes.icosphere(0.1, 1), mass=1.0)
    world.step(240 * 20)
    assert world.linear_velocity(body)[2] == pytest.approx(-np.sqrt(9.81 / 0.5), rel=1e-9)


def tumbling_box(integrator, dt, omega0):
    world = rbd.World(dt=dt, integrator=integrator)
    body = world.add_body(BOX_123, mass=1.0, angular_velocity=omega0)
    return world, body


def test_torque_free_asymmetric_body_matches_reference():
    """10 s at dt = 1/240: orientation <= 1e-5 rad, |L| to 1e-12, energy drift <= 1e-8."""
    omega0 = np.array([0.4, 2.0, -1.1])
    dt, steps = 1 / 240, 2400
    world, body = tumbling_box("rk4", dt, omega0)
    inertia = rbd.mass_properties(BOX_123, mass=1.0).inertia
    times = np.arange(steps + 1) * dt
    _, q_ref = torque_free_reference(inertia, omega0, [0, 0, 0, 1], times)
    L0, E0 = world.angular_momentum(body), world.kinetic_energy()
    orientations = np.empty((steps + 1, 4))
    orientations[0] = world.orientation(body)
    for k in range(steps):
        world.step()
        orientations[k + 1] = world.orientation(body)
    assert rotation_angle_between(orientations, q_ref).max() <= 1e-5
    assert abs(np.linalg.norm(world.angular_momentum(body)) / np.linalg.norm(L0) - 1) <= 1e-12
    assert abs(world.kinetic_energy() / E0 - 1) <= 1e-8


def test_dzhanibekov_flip_times():
    """1 x 2 x 3 box spun at 2 pi rad/s about its intermediate axis, 1e-3 rad/s perturbed."""
    omega0 = np.array([1e-3, 2 * np.pi, 1e-3])
    dt, seconds = 1 / 240, 11.0
    steps = round(seconds / dt)
    world, body = tumbling_box("rk4", dt, omega0)
    times = np.arange(steps + 1) * dt
    reference_omega, _ = torque_free_reference(
        np.diag([13, 10, 5]) / 12, omega0, [0, 0, 0, 1], times
    )
    reference_flips = sign_change_times(times, reference_omega[:, 1])[:2]
    # the reference is the physics: the published flip times of this set-up
    np.testing.assert_allclose(reference_flips, [3.04, 9.85], atol=0.01)

    spin_axis_component = np.empty(steps + 1)
    for k in range(steps + 1):
        # body y axis in world, against the constant world angular momentum
        spin_axis_component[k] = rbd.spatial.quat_rotate(world.orientation(body), [0, 1, 0]) @ (
            world.angular_momentum(body)
        )
        world.step()
    flips = sign_change_times(times, spin_axis_component)[:2]
    np.testing.assert_allclose(flips, reference_flips, atol=0.01)


def orientation_error(integrator, dt, seconds=1.0):
    omega0 = np.array([0.4, 2.0, -1.1])
    world, body = tumbling_box(integrator, dt, omega0)
    world.step(round(seconds / dt))
    times = np.array([0.0, world.time])
    _, q_ref = torque_free_reference(np.diag([13, 10, 5]) / 12, omega0, [0, 0, 0, 1], times)
    return rotation_angle_between(world.orientation(body)[None], q_ref[-1:])[0]


def drag_error(integrator, dt):
    world, body = run_projectile(integrator, dt, 1.0, drag=0.9)
    x, _ = projectile_with_linear_drag(
        world.time, np.array([1, 2, 3]), np.array([3, -1, 8]), 2.0, 0.9
    )
    return np.abs(world.position(body) - x).max()


@pytest.mark.parametrize(
    ("integrator", "order"), [("euler", 1), ("symplectic_euler", 1), ("midpoint", 2), ("rk4", 4)]
)
def test_order_of_convergence(integrator, order):
    """Halving dt divides the global error by ~2^order, for rotation and for drag."""
    dt = 1 / 32
    for error in (orientation_error, drag_error):
        coarse, fine = error(integrator, dt), error(integrator, dt / 2)
        measured = np.log2(coarse / fine)
        assert abs(measured - order) < 0.25, (error.__name__, measured)


def test_quaternion_norm_after_a_million_steps_of_fast_spin():
    world = rbd.World(dt=1 / 240, integrator="rk4")
    body = world.add_body(BOX_123, mass=1.0, angular_velocity=(30.0, 0.0, 40.0))  # 50 rad/s
    world.step(1_000_000)
    assert abs(np.linalg.norm(world.orientation(body)) - 1.0) <= 1e-12


def test_symplectic_euler_updates_momentum_before_position():
    """Semi-implicit Euler in free fall, discrete closed form: x_N = x0 + v0 T + g h^2 N(N+1)/2."""
    dt, steps = 0.01, 50
    world = rbd.World(dt=dt, gravity=G, integrator="symplectic_euler")
    body = world.add_body(rbd.shapes.box((1, 1, 1)), mass=1.0, linear_velocity=(1, 0, 2))
    world.step(steps)
    expected = np.array([1, 0, 2]) * dt * steps + G * dt**2 * steps * (steps + 1) / 2
    np.testing.assert_allclose(world.position(body), expected, atol=1e-13)
