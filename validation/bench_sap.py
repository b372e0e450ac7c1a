"""Sweep-and-prune broad-phase benchmarks (issue 4): n = 1k, 10k, 100k boxes.

Run with ``pytest validation/bench_sap.py --benchmark-enable``. Measured in the same run as
peers: python-fcl's ``DynamicAABBTreeCollisionManager`` (set the new translations, ``update``,
``collide`` with a callback that records the pair) and a vectorised NumPy sort-and-sweep. Every
peer reports the same pair set, checked by ``test_peers_agree``.

Scene: boxes with edges uniform in [0.5, 1.5] m, centres uniform in a cube sized for about one
overlapping neighbour per box (edge 2 n^(1/3) m, constant density), bouncing off its walls.
"coherent": every box moves at a constant velocity, N(0, 0.6 m/s) per component, at 240 Hz,
i.e. about 4 mm (0.4 % of a box) per frame. "incoherent": every box is redrawn anywhere each
frame. Targets: coherent 10k at least 3x faster than fcl's manager; coherent 100k <= 20 ms.

The coherent motion is deliberately slow-to-moderate: about 1 m/s per body at dt = 1/240,
0.4 % of a box per frame, the slow end of a rigid-body scene. At constant density each
endpoint passes ~n^(2/3) others per metre of motion, so a single sorted list per axis makes
swaps grow like n^(5/3); the multi-SAP (each axis sorted per column of a coarse grid)
exists to bring that back to ~n, and this scene is where the difference shows.

Timings for the scaling figure and the peer table of ``__main__`` are CPU time of the thread
and minima over frames: on a machine shared with other jobs the spread comes from them, and
wall time would count their turns on the core. The measured figures live in the report
(``reports/``, study ``sap_benchmarks``) and in the commit messages of the changes they
judged, not here.

``python -m validation.bench_sap FIGURE.png`` times ``SweepAndPrune.update`` against n and
writes the log-log scaling figure with the fitted slopes.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import pytest

import thesis_rbd as rbd

SIZES = (1_000, 10_000, 100_000)
DT = 1.0 / 240.0
SPEED_SIGMA = 0.6  # m/s per component


class Scene:
    """Precomputed frames of a box scene, so the timed call does nothing but the broad phase.

    Attributes
    ----------
    half : (n, 3) float
        Half extents.
    centres : list of (n, 3) float
        Centre of every box at each frame.
    """

    def __init__(self, n: int, motion: str, frames: int, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.n = n
        self.side = 2.0 * n ** (1.0 / 3.0)
        self.half = rng.uniform(0.25, 0.75, (n, 3))
        centre = rng.uniform(0.0, self.side, (n, 3))
        velocity = rng.normal(0.0, SPEED_SIGMA, (n, 3))
        self.centres = [centre.copy()]
        for _ in range(frames):
            if motion == "coherent":
                centre = centre + velocity * DT
                # Bounce off the walls so the density stays uniform over any number of frames.
                out = (centre < 0.0) | (centre > self.side)
                velocity[out] = -velocity[out]
                centre = np.clip(centre, 0.0, self.side)
            elif motion == "incoherent":
                centre = rng.uniform(0.0, self.side, (n, 3))
            else:
                raise ValueError(motion)
            self.centres.append(centre.copy())
        self.lower = [c - self.half for c in self.centres]
        self.upper = [c + self.half for c in self.centres]


def numpy_sort_and_sweep(lower: np.ndarray, upper: np.ndarray, chunk: int = 4_000_000):
    """All overlapping pairs by sorting on x and sweeping with array operations.

    Candidates (boxes whose x-intervals overlap) are generated in chunks of at most ``chunk``
    to bound memory; the Python loop is over chunks, not boxes. Returns (k, 2) int64 sorted.
    """
    order = np.argsort(lower[:, 0], kind="stable")
    lo = lower[order]
    hi = upper[order]
    # Box s overlaps on x every later box t (in begin order) with lo_x[t] <= hi_x[s].
    stop = np.searchsorted(lo[:, 0], hi[:, 0], side="right")
    count = np.maximum(stop - np.arange(lo.shape[0]) - 1, 0)
    ends = np.cumsum(count)
    found = []
    first = 0
    while first < lo.shape[0]:
        last = int(np.searchsorted(ends, ends[first] - count[first] + chunk, side="right"))
        last = max(last, first + 1)
        s = np.repeat(np.arange(first, last), count[first:last])
        start = ends[first:last] - count[first:last]
        t = s + 1 + np.arange(s.shape[0]) - np.repeat(start - start[0], count[first:last])
        keep = (
            (lo[t, 1] <= hi[s, 1])
            & (lo[s, 1] <= hi[t, 1])
            & (lo[t, 2] <= hi[s, 2])
            & (lo[s, 2] <= hi[t, 2])
        )
        found.append(np.sort(np.stack([order[s[keep]], order[t[keep]]], axis=1), axis=1))
        first = last
    pairs = np.concatenate(found) if found else np.empty((0, 2), np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))].astype(np.int64)


class FclPeer:
    """python-fcl's dynamic AABB tree manager over fcl.Box objects of the scene."""

    def __init__(self, scene: Scene) -> None:
        import fcl

        self.fcl = fcl
        self.objects = [
            fcl.CollisionObject(fcl.Box(*(2.0 * h)), fcl.Transform(c))
            for h, c in zip(scene.half, scene.centres[0], strict=True)
        ]
        self.index = {id(o): i for i, o in enumerate(self.objects)}
        self.manager = fcl.DynamicAABBTreeCollisionManager()
        self.manager.registerObjects(self.objects)
        self.manager.setup()

    def frame(self, centres: np.ndarray) -> int:
        """Move every object (python-fcl's API takes one call per object), update, collide.

        The callback only counts the pairs: the cheapest consumer python-fcl allows (its
        wrappers of the colliding objects are fresh Python objects, so naming the pair costs
        more; that cost is left out in fcl's favour). Returns the number of pairs.
        """
        for obj, c in zip(self.objects, centres, strict=True):
            obj.setTranslation(c)
        self.manager.update()
        count = [0]

        def record(_o1, _o2, _data):
            count[0] += 1
            return False

        self.manager.collide(None, record)
        return count[0]

    def pairs(self, centres: np.ndarray) -> np.ndarray:
        """The pairs of one frame as (k, 2) int64 sorted, identified by their exact centres."""
        for obj, c in zip(self.objects, centres, strict=True):
            obj.setTranslation(c)
        self.manager.update()
        where = {tuple(c): i for i, c in enumerate(centres.tolist())}
        found = []

        def record(o1, o2, _data):
            found.append((where[tuple(o1.getTranslation().tolist())],
                          where[tuple(o2.getTranslation().tolist())]))  # fmt: skip
            return False

        self.manager.collide(None, record)
        pairs = np.sort(np.array(found, dtype=np.int64).reshape(-1, 2), axis=1)
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def _frames(scene: Scene):
    """Endless cycle over the precomputed frames 1 .. T (frame 0 is the setup)."""
    t = 0
    while True:
        t = t % (len(scene.centres) - 1) + 1
        yield t


ROUNDS = {1_000: 40, 10_000: 20, 100_000: 8}


def _rounds(n, motion, peer=False):
    # Incoherent frames at 100k take seconds (fcl's manager about a minute: one frame).
    if motion == "coherent" or n < 100_000:
        return ROUNDS[n]
    return 1 if peer == "fcl" else 3


@pytest.fixture(scope="module")
def scenes():
    cache = {}

    def get(n, motion):
        if (n, motion) not in cache:
            cache[(n, motion)] = Scene(n, motion, frames=_rounds(n, motion) + 2)
        return cache[(n, motion)]

    return get


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("motion", ["coherent", "incoherent"])
def test_sap_update(benchmark, scenes, motion, n):
    scene = scenes(n, motion)
    benchmark.group = f"broad phase, {motion}, n = {n}"
    sap = rbd.SweepAndPrune()
    sap.update(scene.lower[0], scene.upper[0])
    frames = _frames(scene)
    # The motion cycles back to frame 1 after the last frame; one warm-up lap makes every timed
    # frame a continuation of the last (a coherent scene stays coherent except that wrap).
    for _ in range(len(scene.centres) - 1):
        t = next(frames)
        sap.update(scene.lower[t], scene.upper[t])
    stats = []

    def step():
        t = next(frames)
        sap.update(scene.lower[t], scene.upper[t])
        stats.append(sap.stats)

    benchmark.pedantic(step, rounds=_rounds(n, motion), iterations=1, warmup_rounds=0)
    full = [s["full_resort"] for s in stats]
    benchmark.extra_info.update(
        boxes=n,
        motion=motion,
        peer=False,
        pairs=int(np.median([s["pairs"] for s in stats])),
        swaps=int(np.median([s["swaps"] for s in stats])),
        full_resort_fraction=float(np.mean(full)),
    )


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("motion", ["coherent", "incoherent"])
def test_fcl_manager(benchmark, scenes, motion, n):
    pytest.importorskip("fcl")
    scene = scenes(n, motion)
    benchmark.group = f"broad phase, {motion}, n = {n}"
    benchmark.extra_info.update(boxes=n, motion=motion, peer="python-fcl DynamicAABBTree")
    peer = FclPeer(scene)
    frames = _frames(scene)
    counts = []
    benchmark.pedantic(
        lambda: counts.append(peer.frame(scene.centres[next(frames)])),
        rounds=_rounds(n, motion, peer="fcl"),
        iterations=1,
        warmup_rounds=1 if _rounds(n, motion, peer="fcl") > 1 else 0,
    )
    benchmark.extra_info["pairs"] = int(np.median(counts))


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("motion", ["coherent", "incoherent"])
def test_numpy_sort_and_sweep(benchmark, scenes, motion, n):
    scene = scenes(n, motion)
    benchmark.group = f"broad phase, {motion}, n = {n}"
    benchmark.extra_info.update(boxes=n, motion=motion, peer="numpy sort-and-sweep")
    frames = _frames(scene)

    def step():
        t = next(frames)
        numpy_sort_and_sweep(scene.lower[t], scene.upper[t])

    benchmark.pedantic(step, rounds=_rounds(n, motion), iterations=1, warmup_rounds=0)


@pytest.mark.parametrize("teleport", [0.0, 0.001, 0.01, 0.1])
@pytest.mark.parametrize("strategy", ["auto", "incremental", "full"])
def test_fallback_pricing(benchmark, strategy, teleport):
    """10k boxes with a fraction teleporting each frame: is "auto" near the better of the two?"""
    n = 10_000
    benchmark.group = f"fallback, n = {n}, teleport = {teleport}"
    benchmark.extra_info.update(boxes=n, teleport=teleport, strategy=strategy, peer=False)
    scene = Scene(n, "coherent", frames=1)
    rng = np.random.default_rng(3)
    frames = []
    centre = scene.centres[0].copy()
    for _ in range(12):
        centre = centre + rng.normal(0, SPEED_SIGMA, centre.shape) * DT
        jump = rng.random(n) < teleport
        centre[jump] = rng.uniform(0, scene.side, (int(jump.sum()), 3))
        frames.append((centre - scene.half, centre + scene.half))
    sap = rbd.SweepAndPrune(strategy)
    sap.update(scene.lower[0], scene.upper[0])
    it = iter(frames)
    full = []

    def step():
        sap.update(*next(it))
        full.append(sap.stats["full_resort"])

    benchmark.pedantic(step, rounds=len(frames), iterations=1, warmup_rounds=0)
    benchmark.extra_info["full_resort_fraction"] = float(np.mean(full))


@pytest.mark.parametrize("motion", ["coherent", "incoherent"])
def test_peers_agree(motion):
    """The three implementations find the same pairs on the benchmark scenes (n = 2000)."""
    scene = Scene(2_000, motion, frames=3)
    sap = rbd.SweepAndPrune()
    peer = FclPeer(scene) if _has_fcl() else None
    for t in range(len(scene.centres)):
        sap.update(scene.lower[t], scene.upper[t])
        np.testing.assert_array_equal(
            sap.pairs, numpy_sort_and_sweep(scene.lower[t], scene.upper[t])
        )
        if peer is not None:
            np.testing.assert_array_equal(sap.pairs, peer.pairs(scene.centres[t]))
            assert peer.frame(scene.centres[t]) == len(sap.pairs)


def _has_fcl() -> bool:
    try:
        import fcl  # noqa: F401
    except ImportError:
        return False
    return True


# ---------------------------------------------------------------- the scaling figure


def time_per_frame(n: int, motion: str, frames: int = 10, speed_scale: float = 1.0) -> float:
    """Fewest CPU seconds of ``SweepAndPrune.update`` over the frames of the benchmark scene.

    CPU time of the thread and the minimum, not wall time and the median: on a machine shared
    with other jobs the spread is all from them (the frames of one scene cost the same to
    within a few per cent), and wall time counts the time they hold the core.
    """
    scene = Scene(n, motion, frames=frames)
    if speed_scale != 1.0:
        base = scene.centres[0]
        scene.lower = [base + (c - base) * speed_scale - scene.half for c in scene.centres]
        scene.upper = [base + (c - base) * speed_scale + scene.half for c in scene.centres]
    sap = rbd.SweepAndPrune()
    sap.update(scene.lower[0], scene.upper[0])
    times = []
    for t in range(1, len(scene.lower)):
        start = time.thread_time()
        sap.update(scene.lower[t], scene.upper[t])
        times.append(time.thread_time() - start)
    return float(np.min(times))


def scaling_figure(path, sizes=(1_000, 3_000, 10_000, 30_000, 100_000)) -> dict:
    """Write the log-log figure of update time against n; return the times and fitted slopes.

    Two coherent series: the benchmark scene (fixed speed, constant density, so each endpoint
    crosses ~n^(2/3) others per second of motion and swaps grow like n^(5/3)), and the same
    scene with the speed scaled by (n / 1000)^(-2/3) so that every endpoint crosses a bounded
    number of neighbours per frame: the coherence that thesis 4.7's O(n + k) assumes.
    Plus the incoherent scene (full re-sort every frame).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = np.asarray(sizes)
    series = {
        "coherent, fixed speed": [time_per_frame(int(n), "coherent") for n in sizes],
        "coherent, bounded crossings": [
            time_per_frame(int(n), "coherent", speed_scale=(n / 1000.0) ** (-2.0 / 3.0))
            for n in sizes
        ],
        "incoherent": [time_per_frame(int(n), "incoherent", frames=4) for n in sizes],
    }
    slopes = {k: float(np.polyfit(np.log(sizes), np.log(v), 1)[0]) for k, v in series.items()}
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for (name, times), marker in zip(series.items(), "osd", strict=True):
        ax.loglog(sizes, np.asarray(times) * 1e3, marker=marker,
                  label=f"{name} (slope {slopes[name]:.2f})")  # fmt: skip
    ax.loglog(sizes, sizes / sizes[0] * series["coherent, bounded crossings"][0] * 1e3, "k:",
              label="slope 1")  # fmt: skip
    ax.set_xlabel("boxes n")
    ax.set_ylabel("SweepAndPrune.update, ms per frame")
    ax.set_title("Sweep and prune: time per frame against n")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return {"sizes": sizes.tolist(), "seconds": series, "slopes": slopes}


def peer_table(sizes=SIZES, frames: int = 5) -> list[tuple]:
    """Fewest CPU ms per frame of ours, fcl's manager and the NumPy sweep, interleaved in one run.

    Incoherent fcl at 100k is left out (about a minute per frame). Rows are
    ``(motion, n, ours, fcl or nan, numpy)``.
    """
    rows = []
    for motion in ("coherent", "incoherent"):
        for n in sizes:
            scene = Scene(n, motion, frames=frames)
            sap = rbd.SweepAndPrune()
            sap.update(scene.lower[0], scene.upper[0])
            ours, fcl_t, np_t = [], [], []
            peer = FclPeer(scene) if _has_fcl() and (motion == "coherent" or n < 100_000) else None
            for t in range(1, frames + 1):
                start = time.thread_time()
                sap.update(scene.lower[t], scene.upper[t])
                ours.append(time.thread_time() - start)
                start = time.thread_time()
                numpy_sort_and_sweep(scene.lower[t], scene.upper[t])
                np_t.append(time.thread_time() - start)
                if peer is not None:
                    start = time.thread_time()
                    peer.frame(scene.centres[t])
                    fcl_t.append(time.thread_time() - start)
            best = [float(np.min(x)) * 1e3 if x else float("nan") for x in (ours, fcl_t, np_t)]
            rows.append((motion, n, *best))
    return rows


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -m validation.bench_sap FIGURE.png")
    result = scaling_figure(sys.argv[1])
    for name, slope in result["slopes"].items():
        times = ", ".join(f"{t * 1e3:.3g}" for t in result["seconds"][name])
        print(f"{name}: slope {slope:.2f}; ms per frame at n = {result['sizes']}: {times}")
    print("motion      n        ours ms   fcl ms    numpy ms  (minima over 5 frames)")
    for motion, n, ours, fcl_ms, numpy_ms in peer_table():
        print(f"{motion:<11} {n:<8} {ours:<9.3g} {fcl_ms:<9.3g} {numpy_ms:<9.3g}")
