"""One run of a study: a world stepped for a span of time, its state sampled after every step.

What is sampled is what the error measures (:mod:`.measures`) compare: every body's pose, the
world's energy, the deepest penetration of the step's contacts, and the total linear and
angular momentum (worked out after the run from each step's copy of the bodies' state, so
that a step costs the sampling a few array copies). Only the steps are timed (a clock read
around each ``World.step``), so the sampling costs nothing in the wall time a study reports;
a run during which numba compiled a kernel is run again, warm, so compiling costs nothing in
it either.

A run is limited to one BLAS thread (:func:`sampled_run`): the solvers' few matrix products
and solves come out different in their last bits with more threads, which a chaotic scene
amplifies, and Dask's workers run with one; so every runner gets the same table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from time import perf_counter

import numpy as np
from scipy.spatial.transform import Rotation
from threadpoolctl import threadpool_limits

from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd.scene import Scene
from thesis_rbd.spatial.quaternion import quat_conjugate, quat_rotate
from thesis_rbd.world import NonFiniteStateError, World

__all__ = ["RunSamples", "conserves_momentum", "perturb", "sample_run", "sampled_run"]


@dataclass
class RunSamples:
    """A run's state after every step (and before the first).

    Attributes
    ----------
    times : (T,) ndarray
        Simulated time of each sample (s).
    positions : (T, n, 3) ndarray
        Centre-of-mass positions, world frame (m).
    orientations : (T, n, 4) ndarray
        Orientations, (x, y, z, w) unit quaternions.
    energy : (T,) ndarray
        Kinetic plus gravitational potential energy of the dynamic bodies (J).
    penetration : (T,) ndarray
        Deepest penetration among the contacts of the step that ended at the sample (m).
    linear_momentum, angular_momentum : (T, 3) ndarray
        Totals over the dynamic bodies (N s; N m s, about the world origin).
    """

    times: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    energy: np.ndarray
    penetration: np.ndarray
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray

    def __len__(self) -> int:
        return len(self.times)


def _totals(world: World, positions, orientations, momenta, angular_momenta) -> tuple:
    """Energy (T,), total linear and angular momentum (T, 3) of the sampled states, for all
    samples at once (what ``World.kinetic_energy`` and ``potential_energy`` give for one).

    Parameters
    ----------
    positions, momenta, angular_momenta : (T, n, 3) ndarray
        x, P and L of every body (world frame) at every sample.
    orientations : (T, n, 4) ndarray
    """
    b = world.bodies
    dynamic = ~b.static
    frames, n = positions.shape[:2]
    linear = 0.5 * np.einsum("tij,tij,i->t", momenta, momenta, b.inverse_mass)
    body_frame = quat_rotate(
        quat_conjugate(orientations.reshape(-1, 4)), angular_momenta.reshape(-1, 3)
    ).reshape(frames, n, 3)
    angular = 0.5 * np.einsum("tij,ijk,tik->t", body_frame, b.inverse_inertia_body, body_frame)
    potential = -np.einsum("tij,j,i->t", positions[:, dynamic], world.gravity, b.mass[dynamic])
    p, x = momenta[:, dynamic], positions[:, dynamic]
    return (
        linear + angular + potential,
        p.sum(axis=1),
        (angular_momenta[:, dynamic] + np.cross(x, p)).sum(axis=1),
    )


def sample_run(world: World, seconds: float) -> tuple[RunSamples, float, str | None]:
    """Step ``world`` for ``seconds`` (ceil(seconds / dt) steps), sampling after each step.

    Each step copies the bodies' state and reads its deepest contact (a few microseconds);
    the energy and the momenta are worked out from the copies after the run.

    Returns
    -------
    samples : RunSamples
        Up to the last finite state if the run failed.
    wall : float
        Seconds spent in ``World.step`` alone.
    failure : str or None
        The error a failed step raised (a non-finite state), None if the run finished.
    """
    steps = max(1, math.ceil(seconds / world.dt - 1e-9))
    n = len(world)
    times, penetration = np.empty(steps + 1), np.empty(steps + 1)
    x, q = np.empty((steps + 1, n, 3)), np.empty((steps + 1, n, 4))
    p, angular = np.empty((steps + 1, n, 3)), np.empty((steps + 1, n, 3))
    b = world.bodies
    wall, failure, taken = 0.0, None, steps + 1
    for k in range(steps + 1):
        if k:
            start = perf_counter()
            try:
                world.step()
            except NonFiniteStateError as exc:
                wall += perf_counter() - start
                failure, taken = str(exc), k
                break
            wall += perf_counter() - start
        times[k], penetration[k] = world.time, world.deepest_penetration
        x[k], q[k], p[k], angular[k] = (
            b.position,
            b.orientation,
            b.linear_momentum,
            b.angular_momentum,
        )
    x, q, p, angular = x[:taken], q[:taken], p[:taken], angular[:taken]
    energy, momentum, angular_momentum = _totals(world, x, q, p, angular)
    samples = RunSamples(
        times[:taken], x, q, energy, penetration[:taken], momentum, angular_momentum
    )
    return samples, wall, failure


def perturb(world: World, seed: int, amount: float) -> None:
    """Move each dynamic body of ``world`` by ``amount`` times its size and turn it by
    ``amount`` radians, in directions drawn from ``seed``; seed 0 leaves the world as built.

    A body's size is the radius of its bounding sphere about its centre of mass, so the
    perturbation is the same fraction of every body whatever the scene's units.
    """
    if seed == 0:
        return
    rng = np.random.default_rng(seed)
    b = world.bodies
    for body in range(len(world)):
        direction, axis = rng.normal(size=3), rng.normal(size=3)
        if b.static[body]:
            continue
        size = float(b.size[body])
        turn = Rotation.from_rotvec(amount * axis / np.linalg.norm(axis))
        world.set_body_state(
            body,
            position=b.position[body] + amount * size * direction / np.linalg.norm(direction),
            orientation=(turn * Rotation.from_quat(b.orientation[body])).as_quat(),
        )


def conserves_momentum(scene: Scene) -> bool:
    """Whether nothing outside the scene's bodies acts on them, so that their total linear
    and angular momentum must stay as they start: no gravity, drag, applied force, static
    or kinematic body, joint to the world, or model with a held base."""
    world = scene.world
    return (
        all(g == 0 for g in world.get("gravity", (0.0, 0.0, 0.0)))
        and all(
            world.get(key, 0.0) == 0 for key in ("linear_drag", "quadratic_drag", "angular_drag")
        )
        and not any(b.static or b.kinematic or b.forces for b in scene.bodies)
        and all(joint.body_b is not None for joint in scene.joints)
        and not any(model.fixed_base for model in scene.urdfs)
    )


def sampled_run(scene: Scene, seconds: float, seed: int, amount: float) -> dict:
    """Build ``scene``, perturb it for ``seed``, and sample a run of ``seconds``; a run
    during which a kernel compiled (here or, waited for, in another process) is run again
    from a new world, up to twice, so that the wall time is of compiled code.

    Returns
    -------
    dict
        ``samples`` (RunSamples), ``wall`` (s), ``failure`` (str or None).
    """
    for _attempt in range(3):
        with CompileLog() as log, threadpool_limits(limits=1):
            world = scene.build()
            perturb(world, seed, amount)
            samples, wall, failure = sample_run(world, seconds)
        if not (log.records or log.waits):  # nor waited for another process's compile
            break
    return {"samples": samples, "wall": wall, "failure": failure}
