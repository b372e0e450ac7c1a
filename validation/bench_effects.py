"""What a scene does not use costs nothing (issue 6): a full step of far-apart bodies against
the integration stage alone.

Run with ``pytest validation/bench_effects.py --benchmark-enable``. Scene: 1000 boxes 1 x 2 x 3
m on a 100 m lattice, no gravity, random orientations, speeds up to 2 m/s and spins of about
3 rad/s, so that nothing touches for the benchmark's at most 2000 steps (``--benchmark-max-time``
worth of them at ~0.2 ms each, at least 100). The full step runs the
collision and sleep stages a collidable scene plans (bounds every step; broad phase only when
a body leaves its fat box; never a narrow phase, contact or sleep call); the peer, "integration
alone", is the same bodies added with ``collidable=False``, whose only stage is integration.
Target: the full step within 10 % of the peer (ratio peer / ours >= 0.91).

Each benchmark steps the other world, untimed, before each of its timed steps, so both run in
the same alternation; the full step's ``extra_info`` also holds the ratio against those
interleaved steps (``interleaved_ratio_to_integration_alone``).

``python -m validation.bench_effects`` prints the per-stage profile of interleaved blocks,
which shows where a full step's time goes; the figures are in the report (study
``effects_benchmarks``).
"""

from time import perf_counter

import numpy as np
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd

COUNT = 1000
SPACING = 100.0
STEPS = 2000
BOX = rbd.shapes.box((1.0, 2.0, 3.0))


def far_apart_world(count: int = COUNT, collidable: bool = True) -> rbd.World:
    """``count`` boxes on a ``SPACING`` lattice in free flight, no gravity, at most 2 m/s:
    they cannot meet within ``STEPS`` steps."""
    rng = np.random.default_rng(count)
    side = int(np.ceil(count ** (1 / 3)))
    lattice = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    velocities = rng.normal(size=(count, 3))
    velocities *= np.minimum(1.0, 2.0 / np.linalg.norm(velocities, axis=1))[:, None]
    orientations = Rotation.random(count, random_state=count).as_quat()
    world = rbd.World(dt=1 / 240)
    for i in range(count):
        world.add_body(
            BOX,
            mass=1.0,
            position=SPACING * lattice[i],
            orientation=orientations[i],
            linear_velocity=velocities[i],
            angular_velocity=rng.normal(scale=3.0, size=3),
            collidable=collidable,
        )
    world.step()  # compile or load the kernels, and fit the fat boxes, outside the timing
    return world


def _rounds(request) -> int:
    """Timed steps: ``--benchmark-max-time`` worth at ~0.2 ms a step, between 100 and
    ``STEPS`` (a fixed ceiling, so that the scene never runs into its own collisions)."""
    max_time = float(request.config.getoption("benchmark_max_time", 1.0) or 1.0)
    return int(min(max(max_time / 2e-4, 100), STEPS))


def _bench_interleaved(benchmark, world, other, rounds) -> np.ndarray:
    """Time ``rounds`` single steps of ``world``, each after an untimed step of ``other``:
    both worlds of the group run in the same alternation, and the load of the shared machine
    falls on both alike. Returns the seconds of ``other``'s steps before the timed ones."""
    other_seconds = []

    def step_other():
        start = perf_counter()
        other.step()
        other_seconds.append(perf_counter() - start)

    benchmark.pedantic(world.step, setup=step_other, rounds=rounds, warmup_rounds=20)
    return np.array(other_seconds[-rounds:])


def test_full_step_far_apart(benchmark, request):
    benchmark.group = f"far-apart bodies, no gravity, N = {COUNT}"
    benchmark.extra_info.update(bodies=COUNT, peer=False)
    world = far_apart_world()
    alone = _bench_interleaved(
        benchmark, world, far_apart_world(collidable=False), _rounds(request)
    )
    calls = {name: entry["calls"] for name, entry in world.profile.items()}
    assert calls["narrow_phase"] == calls["contacts"] == calls["sleep"] == 0
    benchmark.extra_info.update(broad_phase_calls=calls["broad_phase"], steps=calls["integrate"])
    if not benchmark.disabled:
        # the same ratio from the steps of the peer's world interleaved with ours
        ours = np.median(benchmark.stats.stats.data)
        benchmark.extra_info.update(interleaved_ratio_to_integration_alone=ours / np.median(alone))


def test_integration_alone_far_apart(benchmark, request):
    benchmark.group = f"far-apart bodies, no gravity, N = {COUNT}"
    benchmark.extra_info.update(bodies=COUNT, peer="integration alone")
    world = far_apart_world(collidable=False)
    assert world.stages == ["integrate"]
    _bench_interleaved(benchmark, world, far_apart_world(), _rounds(request))


def interleaved_profile(repeats: int = 20, steps: int = 100) -> dict:
    """Step the full and the integration-only world in alternating blocks.

    Returns
    -------
    dict
        ``full``, ``alone``: (repeats,) us per step of each block; ``stages``: us per step
        and calls per step of each stage of the full world.
    """
    full, alone = far_apart_world(), far_apart_world(collidable=False)
    for entry in full.profile.values():
        entry.update(calls=0, seconds=0.0)
    times = {"full": [], "alone": []}
    for r in range(repeats):
        order = [("full", full), ("alone", alone)]
        for name, world in order if r % 2 == 0 else order[::-1]:
            start = perf_counter()
            world.step(steps)
            times[name].append((perf_counter() - start) / steps * 1e6)
    integrated = full.profile["integrate"]["calls"]
    stages = {
        name: (entry["seconds"] / integrated * 1e6, entry["calls"] / integrated)
        for name, entry in full.profile.items()
    }
    return {"full": np.array(times["full"]), "alone": np.array(times["alone"]), "stages": stages}


def main() -> None:
    """Print the interleaved per-stage profile and the full / integration-alone ratio."""
    result = interleaved_profile()
    for name, (us, per_step) in result["stages"].items():
        print(f"{name:13s} {us:8.1f} us/step  called on {per_step:6.3f} of the steps")
    full, alone = result["full"], result["alone"]
    print(f"full step  min {full.min():7.1f}  median {np.median(full):7.1f} us")
    print(f"integrate  min {alone.min():7.1f}  median {np.median(alone):7.1f} us (alone)")
    print(
        f"ratio full / alone: of minima {full.min() / alone.min():.3f}, "
        f"median of pairs {np.median(full / alone):.3f}"
    )


if __name__ == "__main__":
    main()
