"""Torque-free rotation keeps kinetic energy and angular momentum at any spin.

Oracles: the conserved quantities of the free rigid body (world angular momentum, and the
kinetic energy L . I^-1 L / 2), and a tight-tolerance ODE solution of Euler's equations
(scipy's DOP853) for where the body points. The thesis's explicit methods are kept selectable;
they do not conserve, which ``test_the_thesis_methods_let_a_tumbling_rod_gain_energy`` shows so
that the cases here are known to be hard ones.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.dynamics.free_rotation import turn_freely

DT = 1 / 240


def body_momentum(q, L):
    return Rotation.from_quat(q).inv().apply(L)


def reference_orientation(q, L, inverse_inertia, seconds):
    """Where the body points after ``seconds``: dq/dt = 1/2 [w, 0] q with w = R I^-1 R^T L,
    solved to 1e-13."""

    def rate(_, y):
        R = Rotation.from_quat(y / np.linalg.norm(y))
        w = R.apply(inverse_inertia @ R.inv().apply(L))
        return 0.5 * _left_multiply(w, y)

    result = solve_ivp(rate, (0, seconds), np.asarray(q), method="DOP853", rtol=1e-13, atol=1e-13)
    return result.y[:, -1] / np.linalg.norm(result.y[:, -1])


def _left_multiply(w, q):
    """[w, 0] q for (x, y, z, w) quaternions."""
    x, y, z, s = q
    return np.array(
        [
            w[0] * s + w[1] * z - w[2] * y,
            w[1] * s + w[2] * x - w[0] * z,
            w[2] * s + w[0] * y - w[1] * x,
            -w[0] * x - w[1] * y - w[2] * z,
        ]
    )


@st.composite
def spinning_bodies(draw):
    """(q, L, I^-1, h): principal moments with ratios up to 1000 in a random body frame, a
    random orientation, and a spin of up to 1 rad per step."""
    moments = np.array([1.0, draw(st.floats(1.0, 1000.0)), draw(st.floats(1.0, 1000.0))])
    axes = Rotation.random(random_state=draw(st.integers(0, 2**31))).as_matrix()
    inertia = axes @ np.diag(moments) @ axes.T
    q = Rotation.random(random_state=draw(st.integers(0, 2**31))).as_quat()
    direction = np.array([draw(st.floats(-1, 1)) for _ in range(3)])
    if np.linalg.norm(direction) < 1e-3:
        direction = np.array([0.3, 1.0, -0.2])
    w_body = direction / np.linalg.norm(direction)
    h = DT
    turn = draw(st.floats(1e-3, 1.0))  # |w| h, rad
    w_body = w_body * turn / h
    L = Rotation.from_quat(q).apply(inertia @ w_body)
    return q, L, np.linalg.inv(inertia), h


@settings(max_examples=30, deadline=None)
@given(spinning_bodies())
def test_a_free_turn_keeps_energy_and_momentum(case):
    """300 steps: |M| to 1e-12 relative, M . I^-1 M / 2 to 1e-10 (round-off in the
    orientation, amplified by inertia ratios up to 1000)."""
    q, L, A, h = case
    M0 = body_momentum(q, L)
    energy0 = 0.5 * M0 @ A @ M0
    for _ in range(300):
        q = turn_freely(q, L, A, h)
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=4e-16)
    M = body_momentum(q, L)
    assert np.linalg.norm(M) == pytest.approx(np.linalg.norm(M0), rel=1e-12)
    assert 0.5 * M @ A @ M == pytest.approx(energy0, rel=1e-10)


def test_a_free_turn_converges_at_second_order_to_the_reference():
    """A tumbling 1:200 rod over 0.05 s, in steps short enough to be one piece each: the
    angle to the DOP853 orientation shrinks 4x per halving of the step."""
    inertia = np.diag([1.0, 200.0, 200.5])
    A = np.linalg.inv(inertia)
    q = Rotation.from_euler("xyz", [0.3, -0.7, 1.1]).as_quat()
    L = Rotation.from_quat(q).apply(inertia @ np.array([3.0, 100.0, 5.0]))
    seconds = 0.05
    exact = Rotation.from_quat(reference_orientation(q, L, A, seconds))
    errors = []
    for steps in (160, 320, 640, 1280):
        turned = q
        for _ in range(steps):
            turned = turn_freely(turned, L, A, seconds / steps)
        errors.append((Rotation.from_quat(turned) * exact.inv()).magnitude())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.05)


def test_a_step_too_large_for_newton_is_split_and_still_exact():
    """A 1:1000 plate at 50 rad per step: no Newton iteration converges from the start; the
    turn still keeps energy and momentum."""
    inertia = np.diag([1.0, 500.0, 1000.0])
    A = np.linalg.inv(inertia)
    q = Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_quat()
    L = Rotation.from_quat(q).apply(inertia @ np.array([40.0, 1.0, 0.5]))
    M0 = body_momentum(q, L)
    turned = turn_freely(q, L, A, 1.0)
    M = body_momentum(turned, L)
    assert 0.5 * M @ A @ M == pytest.approx(0.5 * M0 @ A @ M0, rel=1e-12)


def tumbling_world(extents, spin, integrator="verlet"):
    """A box of ``extents`` (m, 1 kg) in zero gravity spinning at ``spin`` (rad/s, body frame)
    in an orientation off its principal axes."""
    world = rbd.World(dt=DT, integrator=integrator)
    body = world.add_body(
        rbd.shapes.box(extents), mass=1.0,
        orientation=Rotation.from_euler("xyz", [0.4, 0.9, -0.3]).as_quat(),
        angular_velocity=Rotation.from_euler("xyz", [0.4, 0.9, -0.3]).apply(spin),
    )  # fmt: skip
    return world, body


@pytest.mark.parametrize(
    "extents, spin",
    [
        ((0.01, 0.01, 0.2), (70.0, 0.0, 70.0)),  # rod, 1:200
        ((0.005, 0.005, 0.16), (240.0, 2.0, 1.0)),  # pencil, 1:1000 at 1 rad per step
        ((0.3, 0.3, 0.01), (0.5, 80.0, 30.0)),  # plate
    ],
    ids=["rod", "pencil", "plate"],
)
def test_a_tumbling_body_keeps_its_energy_over_1e5_steps(extents, spin):
    """The default integrator: kinetic energy within 1e-6 relative at every 100th of 10^5
    steps, angular momentum to round-off."""
    world, body = tumbling_world(extents, spin)
    energy0 = world.kinetic_energy()
    L0 = world.angular_momentum(body).copy()
    worst = 0.0
    for _ in range(1000):
        world.step(100)
        worst = max(worst, abs(world.kinetic_energy() / energy0 - 1.0))
    assert worst <= 1e-6
    np.testing.assert_allclose(
        world.angular_momentum(body), L0, rtol=0, atol=1e-13 * np.abs(L0).max()
    )


@pytest.mark.parametrize("integrator", ["euler", "symplectic_euler", "midpoint", "rk4"])
def test_the_thesis_methods_let_a_tumbling_rod_gain_energy(integrator):
    """The explicit methods stay as the thesis wrote them: the same rod gains more than
    its energy again within a second (the drift the default integrator removes)."""
    world, _ = tumbling_world((0.01, 0.01, 0.2), (70.0, 0.0, 70.0), integrator)
    energy0 = world.kinetic_energy()
    world.step(240)
    assert world.kinetic_energy() > 2.0 * energy0


def test_a_spin_beyond_any_step_comes_back_not_a_number():
    """Turning by more than 2048 rad in a step (as the energy bounds |w|: here 3^(1/4) |L|)
    is refused in bounded work: the orientation is not a number, which the integrator
    reports as a failed step."""
    A = np.diag([1.0, 1.0, 1.0])
    q = np.array([0.0, 0.0, 0.0, 1.0])
    assert np.isfinite(turn_freely(q, (0.0, 0.0, 3000.0), A, 0.5)).all()
    assert np.isnan(turn_freely(q, (0.0, 0.0, 4200.0), A, 0.5)).all()
