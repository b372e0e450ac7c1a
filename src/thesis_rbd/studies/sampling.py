"""One run of a study: a world stepped for a span of time, its state sampled after every step.

What is sampled is what the error measures (:mod:`.measures`) compare: every body's pose, the
world's energy, the deepest penetration of the step's contacts, and the total linear and
angular momentum. Only the steps are timed (a clock read around each ``World.step``), so the
sampling costs nothing in the wall time a study reports; a run during which numba compiled a
kernel is run again, warm, so compiling costs nothing in it either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from time import perf_counter

import numpy as np
from scipy.spatial.transform import Rotation

from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd.scene import Scene
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

    def head(self, count: int) -> RunSamples:
        """The first ``count`` samples (what a run that failed got to)."""
        return RunSamples(*(getattr(self, name)[:count] for name in self.__dataclass_fields__))


def _record(world: World, samples: RunSamples, k: int) -> None:
    b = world.bodies
    dynamic = ~b.static
    samples.times[k] = world.time
    samples.positions[k] = b.position
    samples.orientations[k] = b.orientation
    samples.energy[k] = world.kinetic_energy() + world.potential_energy()
    samples.penetration[k] = world.deepest_penetration
    momentum = b.linear_momentum[dynamic]
    samples.linear_momentum[k] = momentum.sum(axis=0)
    samples.angular_momentum[k] = (
        b.angular_momentum[dynamic] + np.cross(b.position[dynamic], momentum)
    ).sum(axis=0)


def sample_run(world: World, seconds: float) -> tuple[RunSamples, float, str | None]:
    """Step ``world`` for ``seconds`` (ceil(seconds / dt) steps), sampling after each step.

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
    samples = RunSamples(
        np.empty(steps + 1), np.empty((steps + 1, n, 3)), np.empty((steps + 1, n, 4)),
        np.empty(steps + 1), np.empty(steps + 1), np.empty((steps + 1, 3)),
        np.empty((steps + 1, 3)),
    )  # fmt: skip
    _record(world, samples, 0)
    wall = 0.0
    for k in range(1, steps + 1):
        start = perf_counter()
        try:
            world.step()
        except NonFiniteStateError as exc:
            return samples.head(k), wall + perf_counter() - start, str(exc)
        wall += perf_counter() - start
        _record(world, samples, k)
    return samples, wall, None


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
        with CompileLog() as log:
            world = scene.build()
            perturb(world, seed, amount)
            samples, wall, failure = sample_run(world, seconds)
        if not (log.records or log.waits):  # nor waited for another process's compile
            break
    return {"samples": samples, "wall": wall, "failure": failure}
