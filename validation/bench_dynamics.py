"""Free-flight step benchmarks (issue 2): N = 10 ... 10000 bodies for every integrator.

Run with ``pytest validation/bench_dynamics.py --benchmark-enable``. A vectorised NumPy RK4 of
the same equations is measured in the same run as the peer a fused kernel has to beat.
Targets: an rk4 step of 1000 bodies <= 0.3 ms; per-step Python overhead at N = 10 <= 30 us.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd

BODY_COUNTS = (10, 100, 1000, 10000)
BOX = rbd.shapes.box((1.0, 2.0, 3.0))


def tumbling_world(count: int, integrator: str) -> rbd.World:
    """``count`` boxes in free flight under gravity with drag, random spins (not collidable:
    this measures the integrator, not the collision pipeline)."""
    rng = np.random.default_rng(count)
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81), integrator=integrator, linear_drag=0.1)
    orientations = Rotation.random(count, random_state=count).as_quat()
    for i in range(count):
        world.add_body(
            BOX,
            mass=1.0,
            position=rng.uniform(-100, 100, 3),
            orientation=orientations[i],
            linear_velocity=rng.normal(size=3),
            angular_velocity=rng.normal(scale=3.0, size=3),
            collidable=False,
        )
    world.step()  # compile or load the kernels outside the timing
    return world


@pytest.mark.parametrize("count", BODY_COUNTS)
@pytest.mark.parametrize("integrator", ["euler", "symplectic_euler", "midpoint", "rk4"])
def test_free_flight_step(benchmark, integrator, count):
    benchmark.group = f"free flight, N = {count}"
    benchmark.extra_info.update(bodies=count, integrator=integrator, peer=False)
    world = tumbling_world(count, integrator)
    benchmark(world.step)


def numpy_rk4_step(x, q, P, L, inv_mass, inv_inertia, force, dt):
    """One RK4 step of (x, q, P, L) for all bodies at once with NumPy array operations."""

    def derivative(q, P, L):
        qn = q / np.linalg.norm(q, axis=1, keepdims=True)
        R = Rotation.from_quat(qn).as_matrix()
        omega = np.einsum("nij,njk,nlk,nl->ni", R, inv_inertia, R, L)
        wx, wy, wz = omega.T
        qx, qy, qz, qw = q.T
        dq = 0.5 * np.stack(
            [
                wx * qw + wy * qz - wz * qy,
                wy * qw - wx * qz + wz * qx,
                wz * qw + wx * qy - wy * qx,
                -wx * qx - wy * qy - wz * qz,
            ],
            axis=1,
        )
        return P * inv_mass[:, None], dq, force, np.zeros_like(L)

    k1 = derivative(q, P, L)
    k2 = derivative(q + 0.5 * dt * k1[1], P + 0.5 * dt * k1[2], L + 0.5 * dt * k1[3])
    k3 = derivative(q + 0.5 * dt * k2[1], P + 0.5 * dt * k2[2], L + 0.5 * dt * k2[3])
    k4 = derivative(q + dt * k3[1], P + dt * k3[2], L + dt * k3[3])
    out = []
    for y, a, b, c, d in zip((x, q, P, L), k1, k2, k3, k4, strict=True):
        out.append(y + dt / 6 * (a + 2 * b + 2 * c + d))
    out[1] /= np.linalg.norm(out[1], axis=1, keepdims=True)
    return out


@pytest.mark.parametrize("count", BODY_COUNTS)
def test_free_flight_step_numpy_peer(benchmark, count):
    benchmark.group = f"free flight, N = {count}"
    benchmark.extra_info.update(bodies=count, integrator="rk4", peer=True)
    world = tumbling_world(count, "rk4")
    b = world.bodies
    state = [
        b.position.copy(),
        b.orientation.copy(),
        b.linear_momentum.copy(),
        b.angular_momentum.copy(),
    ]
    force = b.mass[:, None] * world.gravity
    benchmark(numpy_rk4_step, *state, b.inverse_mass, b.inverse_inertia_body, force, world.dt)


def test_numpy_peer_agrees_with_the_kernel():
    """The peer integrates the same equations: one step agrees to round-off (no drag)."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    for w in ([1, 2, 3], [-2, 0.5, 1]):
        world.add_body(BOX, mass=1.0, angular_velocity=w, linear_velocity=(1, 0, 0))
    b = world.bodies
    state = [
        b.position.copy(),
        b.orientation.copy(),
        b.linear_momentum.copy(),
        b.angular_momentum.copy(),
    ]
    force = b.mass[:, None] * world.gravity
    x, q, _, _ = numpy_rk4_step(*state, b.inverse_mass, b.inverse_inertia_body, force, world.dt)
    world.step()
    np.testing.assert_allclose(world.positions, x, atol=1e-14)
    np.testing.assert_allclose(world.orientations, q, atol=1e-14)
