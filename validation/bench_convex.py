"""Narrow-phase cost per candidate pair: convex-polyhedron contact against the mesh path.

Run with ``pytest validation/bench_convex.py --benchmark-enable``. The scene is the resting
part of the contact benchmark: 1000 bodies lying on one static floor box, each a candidate
pair with the floor, all pairs in one kernel call, as the world's narrow-phase stage makes
it. Bodies are unit cubes (box-box pairs) or icospheres of radius 0.5 with 2 subdivisions
(icosphere-box pairs), 0.1 mm into the floor and tilted by up to 1e-4 rad, as resting
bodies are. Both narrow phases answer the same pairs in the same run:

* convex: ``convex_contacts`` with its coherence cache filled by a first call, as
  from the step before;
* mesh: ``narrow_phase.contacts_for_pairs``, the OBBTree path every pair took before.

Targets (issue 11): at most 1 us per box-box pair and 3 us per icosphere-box pair.
``python -m validation.bench_convex`` prints the per-pair costs of interleaved blocks.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.convex.contacts import (
    SPECULATIVE_FRACTION,
    convex_contacts,
    empty_cache,
    query_scratch_for,
)
from thesis_rbd.collision.convex.hull_data import HullSet
from thesis_rbd.collision.mesh.narrow_phase import GeometrySet, contacts_for_pairs

COUNT = 1000
SHAPES = ("box", "icosphere")
# the speculative reach a world at 240 Hz under gravity gives (twice g dt^2, see World)
REACH = 2.0 * 9.81 / 240**2


class RestingPairs:
    """``count`` bodies of one shape resting on a floor box, as narrow-phase inputs."""

    def __init__(self, shape: str, count: int = COUNT, seed: int = 0):
        rng = np.random.default_rng(seed)
        body = rbd.shapes.box((1.0, 1.0, 1.0)) if shape == "box" else rbd.shapes.icosphere(0.5, 2)
        side = int(np.ceil(np.sqrt(count)))
        floor = rbd.shapes.box((1.5 * side + 2, 1.5 * side + 2, 1.0))
        i, j = np.divmod(np.arange(count), side)
        centres = np.stack(
            [(i - side / 2) * 1.5, (j - side / 2) * 1.5, np.full(count, 0.5 - 1e-4)], axis=1
        )
        tilt = rng.normal(size=(count, 3))
        tilt *= rng.uniform(0, 1e-4, count)[:, None] / np.linalg.norm(tilt, axis=1)[:, None]
        self.position = np.ascontiguousarray(np.vstack([[0.0, 0.0, -0.5], centres]))
        self.orientation = np.ascontiguousarray(
            np.vstack([[0.0, 0.0, 0.0, 1.0], Rotation.from_rotvec(tilt).as_quat()])
        )
        self.center_of_mass_local = np.zeros((count + 1, 3))
        self.pairs = np.column_stack([np.zeros(count, np.int64), np.arange(1, count + 1)])
        self.hulls = HullSet()
        self.hull_of_body = np.array(
            [self.hulls.hull_of(floor)] + [self.hulls.hull_of(body)] * count, np.int64
        )
        self.trees = GeometrySet()
        self.tree_of_body = np.array(
            [self.trees.geometry_of(floor)] + [self.trees.geometry_of(body)] * count, np.int64
        )
        self.query_scratch = query_scratch_for(self.hulls)
        self.cache = empty_cache()
        self.cache = self._convex()[1]

    def state(self):
        return self.position, self.orientation, self.center_of_mass_local

    def _convex(self):
        return convex_contacts(
            self.pairs, self.hull_of_body, self.hulls.arrays(), self.hulls.longest_loop,
            self.query_scratch, *self.state(), self.cache, SPECULATIVE_FRACTION, REACH,
        )  # fmt: skip

    def convex(self):
        """The contacts, unpacked as the world's narrow phase unpacks them."""
        return self._convex()[0]

    def mesh(self):
        return contacts_for_pairs(self.pairs, self.tree_of_body, self.trees.arrays(), *self.state())


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("path", ["convex", "mesh"])
def test_narrow_phase_per_pair(benchmark, path, shape):
    scene = RestingPairs(shape)
    run = scene.convex if path == "convex" else scene.mesh
    found = run()
    contacts = len(found[0]) if path == "mesh" else found.count
    assert contacts >= COUNT  # every body touches the floor
    benchmark.group = f"narrow phase, {COUNT} {shape}-floor pairs"
    benchmark.extra_info.update(pairs=COUNT, shape=shape, path=path)
    benchmark.pedantic(run, rounds=20, iterations=1, warmup_rounds=1)


def per_pair_costs(blocks: int = 7, calls: int = 5, count: int = COUNT) -> dict[str, float]:
    """Median per-pair cost (us) of each (shape, path) for ``count`` resting bodies, blocks
    of calls interleaved.

    Timed in thread CPU time, which a machine shared with other work disturbs less than
    wall time.
    """
    results: dict[str, list[float]] = {}
    scenes = {shape: RestingPairs(shape, count) for shape in SHAPES}
    for _ in range(blocks):
        for shape, scene in scenes.items():
            for path in ("convex", "mesh"):
                run = getattr(scene, path)
                start = time.thread_time()
                for _ in range(calls):
                    run()
                seconds = (time.thread_time() - start) / calls
                results.setdefault(f"{shape}-floor {path}", []).append(1e6 * seconds / count)
    return {key: float(np.median(values)) for key, values in results.items()}


if __name__ == "__main__":
    for key, cost in per_pair_costs().items():
        print(f"{key:24s} {cost:8.3f} us per pair")
