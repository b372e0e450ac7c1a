"""Study: what each collision query costs per pose along the tori path, against python-fcl.

The queries beyond overlap (issue 15) on the thesis's tori demo (``validation/tori.py``): at
every selected pose of B's path, "first" overlap (:func:`thesis_rbd.collide`) and
:func:`thesis_rbd.distance` against python-fcl's ``collide`` (``num_max_contacts=1``) and
``distance`` (OBBRSS, ``enable_nearest_points``); the motion from each pose to the next by
:func:`thesis_rbd.continuous_collide` against python-fcl's ``continuousCollide`` (linear
motion, conservative advancement, its defaults otherwise), both checked against the first
contact of 101 sampled poses; 100 rays from above at torus B by :func:`thesis_rbd.ray_cast`
against trimesh's ray-triangle intersector (python-fcl casts no rays); and the whole path as
one :func:`thesis_rbd.collide_batch` call against the python-fcl loop. Ours and the peers'
calls alternate within each repeat; each pose's time is its median over the repeats, Python
wrappers included on both sides.
"""

from __future__ import annotations

import time

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "query_costs"
TITLE = "Collision queries beyond overlap: cost per pose along the tori path against peers"

QUERIES = ("first", "distance", "continuous", "rays")
PEERS = {
    "first": "python-fcl collide",
    "distance": "python-fcl distance",
    "continuous": "python-fcl continuousCollide",
    "rays": "trimesh ray_triangle",
}
POSE_STRIDE = {"full": 1, "quick": 4, "tiny": 25}
# python-fcl's continuous collision takes a quarter of a second per tori motion: a subset.
MOTION_STRIDE = {"full": 10, "quick": 20, "tiny": 100}
REPEATS = {"full": 5, "quick": 3, "tiny": 2}
RAYS = 100
SAMPLES = 101


def cases(scale: str) -> list[Case]:
    """One timed case: every selected pose and motion, ours and the peers interleaved."""
    params = {
        "pose_stride": POSE_STRIDE[scale],
        "motion_stride": MOTION_STRIDE[scale],
        "repeats": REPEATS[scale],
    }
    return [Case(NAME, params, timed=True)]


def _clock(call):
    start = time.perf_counter()
    value = call()
    return time.perf_counter() - start, value


class _Scene:
    """The tori path for thesis_rbd, python-fcl and trimesh."""

    def __init__(self, pose_stride, motion_stride):
        import thesis_rbd as rbd
        from validation.fcl_adapter import fcl_model, fcl_object, fcl_transform, require_fcl
        from validation.tori import tori_mesh, tori_poses

        self.rbd = rbd
        self.fcl = require_fcl()
        self.mesh = tori_mesh()
        self.tree = rbd.OBBTree(self.mesh)
        self.identity = np.eye(4)
        poses = tori_poses()
        self.all_poses = poses
        self.poses = poses[::pose_stride]
        self.motions = list(range(0, len(poses) - 1, motion_stride))
        model = fcl_model(self.mesh)
        self.fcl_a = fcl_object(model)
        self.fcl_b = fcl_object(model)
        self.fcl_poses = [fcl_transform(P) for P in poses]
        self.pose_index = list(range(0, len(poses), pose_stride))
        rng = np.random.default_rng(0)
        self.ray_origins = rng.normal(size=(RAYS, 3)) * 0.5 + (0.0, 0.0, 3.0)
        self.ray_directions = rng.normal(size=(RAYS, 3)) * 0.3 + (0.0, 0.0, -1.0)

    def ours(self, query, k):
        rbd, tree, identity, P = self.rbd, self.tree, self.identity, self.all_poses
        if query == "first":
            return _clock(lambda: rbd.collide(tree, identity, tree, P[k]).colliding)
        if query == "distance":
            return _clock(lambda: rbd.distance(tree, identity, tree, P[k]).distance)
        if query == "continuous":
            seconds, result = _clock(
                lambda: rbd.continuous_collide(tree, identity, identity, tree, P[k], P[k + 1])
            )
            return seconds, (bool(result.colliding), float(result.time))
        seconds, hits = _clock(
            lambda: rbd.ray_cast(tree, P[k], self.ray_origins, self.ray_directions)
        )
        return seconds, int(hits.hit.sum())

    def peer(self, query, k, intersectors):
        fcl = self.fcl
        if query == "first":

            def call():
                self.fcl_b.setTransform(self.fcl_poses[k])
                request = fcl.CollisionRequest(num_max_contacts=1)
                return bool(fcl.collide(self.fcl_a, self.fcl_b, request, fcl.CollisionResult()))

        elif query == "distance":

            def call():
                self.fcl_b.setTransform(self.fcl_poses[k])
                request = fcl.DistanceRequest(enable_nearest_points=True)
                return float(fcl.distance(self.fcl_a, self.fcl_b, request, fcl.DistanceResult()))

        elif query == "continuous":

            def call():
                self.fcl_b.setTransform(self.fcl_poses[k])
                request = fcl.ContinuousCollisionRequest(
                    ccd_motion_type=fcl.CCDMotionType.CCDM_LINEAR,
                    ccd_solver_type=fcl.CCDSolverType.CCDC_CONSERVATIVE_ADVANCEMENT,
                )
                result = fcl.ContinuousCollisionResult()
                fcl.continuousCollide(
                    self.fcl_a, fcl.Transform(), self.fcl_b, self.fcl_poses[k + 1], request, result
                )
                return bool(result.is_collide), float(result.time_of_contact)

        else:

            def call():
                _, rays, _ = intersectors[k].intersects_location(
                    self.ray_origins, self.ray_directions, multiple_hits=False
                )
                return len(rays)

        return _clock(call)

    def sampled_first_contact(self, k):
        """First contact time of the motion k -> k + 1 among evenly sampled poses (1.0 if
        none), with SciPy's Slerp interpolation."""
        from scipy.spatial.transform import Rotation, Slerp

        P0, P1 = self.all_poses[k], self.all_poses[k + 1]
        times = np.linspace(0.0, 1.0, SAMPLES)
        slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([P0[:3, :3], P1[:3, :3]])))
        stack = np.zeros((SAMPLES, 4, 4))
        stack[:, :3, :3] = slerp(times).as_matrix()
        stack[:, :3, 3] = (1 - times)[:, None] * P0[:3, 3] + times[:, None] * P1[:3, 3]
        stack[:, 3, 3] = 1.0
        touching = self.rbd.collide_batch(self.tree, self.identity, self.tree, stack)
        return float(times[np.argmax(touching)]) if touching.any() else 1.0


def run(params: dict) -> dict:
    """Per-pose median times and answers of each query, ours and the peer's."""
    from trimesh.ray.ray_triangle import RayMeshIntersector

    scene = _Scene(params["pose_stride"], params["motion_stride"])
    rbd = scene.rbd
    # Trimesh's intersector per pose (its acceleration tree built outside the timings, as
    # our OBBTree is).
    intersectors = {}
    for k in scene.pose_index:
        moved = scene.mesh.to_trimesh()
        moved.apply_transform(scene.all_poses[k])
        intersectors[k] = RayMeshIntersector(moved)
        intersectors[k].intersects_location(
            scene.ray_origins[:2], scene.ray_directions[:2], multiple_hits=False
        )
    plan = {q: scene.motions if q == "continuous" else scene.pose_index for q in QUERIES}
    for query in QUERIES:  # compile (or load) outside the timings
        scene.ours(query, plan[query][0])
    rbd.collide_batch(scene.tree, scene.identity, scene.tree, scene.poses[:2])
    seconds = {(side, q): [] for side in ("ours", "peer") for q in QUERIES}
    answers = {}
    for _ in range(params["repeats"]):
        for query in QUERIES:
            ours_row, peer_row = [], []
            for k in plan[query]:
                t, answers["ours", query, k] = scene.ours(query, k)
                ours_row.append(t)
                t, answers["peer", query, k] = scene.peer(query, k, intersectors)
                peer_row.append(t)
            seconds["ours", query].append(ours_row)
            seconds["peer", query].append(peer_row)
    batch_ours = min(
        _clock(lambda: rbd.collide_batch(scene.tree, scene.identity, scene.tree, scene.poses))[0]
        for _ in range(params["repeats"])
    )
    return {
        "triangles": len(scene.mesh),
        "rays": RAYS,
        "pose_x": {q: [float(scene.all_poses[k][0, 3]) for k in plan[q]] for q in QUERIES},
        "seconds": {
            f"{side}/{q}": np.median(seconds[side, q], axis=0).tolist()
            for side in ("ours", "peer")
            for q in QUERIES
        },
        "answers": {
            f"{side}/{q}": [answers[side, q, k] for k in plan[q]]
            for side in ("ours", "peer")
            for q in QUERIES
        },
        "sampled_contact": [scene.sampled_first_contact(k) for k in scene.motions],
        "batch_seconds": batch_ours,
        "batch_poses": len(scene.poses),
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Cost per pose of each query, ours against the peer; agreement; a per-pose figure."""
    record = records[0]
    result = record["result"]
    rows = {}
    for query in QUERIES:
        ours = np.array(result["seconds"][f"ours/{query}"])
        peer = np.array(result["seconds"][f"peer/{query}"])
        rows[query] = {
            "query": query,
            "peer": PEERS[query],
            "count": len(ours),
            "ours_median_us": float(np.median(ours)) * 1e6,
            "peer_median_us": float(np.median(peer)) * 1e6,
            "ours_total_ms": float(ours.sum()) * 1e3,
            "peer_total_ms": float(peer.sum()) * 1e3,
            "ratio": float(ours.sum() / peer.sum()),
        }
    first_ours = result["answers"]["ours/first"]
    first_peer = result["answers"]["peer/first"]
    distance_ours = np.array(result["answers"]["ours/distance"])
    distance_peer = np.array(result["answers"]["peer/distance"])
    separated = distance_peer > 0
    sampled = np.array(result["sampled_contact"])
    ccd = {}
    for side in ("ours", "peer"):
        hit = np.array([bool(a[0]) for a in result["answers"][f"{side}/continuous"]])
        when = np.array([a[1] for a in result["answers"][f"{side}/continuous"]])
        touched = sampled < 1.0
        ccd[side] = {
            "contacts": int(hit.sum()),
            "missed": int(np.sum(touched & ~hit)),
            "late": int(np.sum(touched & hit & (when > sampled + 1.0 / (SAMPLES - 1)))),
            "without_sampled_contact": int(np.sum(hit & ~touched)),
        }
    fcl_loop_s = float(np.sum(result["seconds"]["peer/first"]))
    summary = {
        "triangles": result["triangles"],
        "poses": rows["first"]["count"],
        "motions": rows["continuous"]["count"],
        "rays": result["rays"],
        "repeats": record["params"]["repeats"],
        "rows": rows,
        "first_agree": int(sum(a == b for a, b in zip(first_ours, first_peer, strict=True))),
        "separated_poses": int(separated.sum()),
        "distance_max_difference": float(np.abs(distance_ours - distance_peer)[separated].max())
        if separated.any()
        else 0.0,
        "zero_distance_agree": int(np.sum((distance_ours == 0) == (distance_peer <= 0))),
        "sampled_contacts": int(np.sum(sampled < 1.0)),
        "ccd": ccd,
        "batch_ms": result["batch_seconds"] * 1e3,
        "batch_fcl_loop_ms": fcl_loop_s * 1e3,
        "batch_ratio": result["batch_seconds"] / fcl_loop_s,
    }
    table = Table(
        caption=f"Cost per pose along the tori path ({summary['triangles']}-triangle tori); "
        "medians of the repeats per pose, totals over the selected poses; shared 2-core "
        "machine",
        columns=[
            "query",
            "peer",
            "poses or motions",
            "ours, median (us)",
            "peer, median (us)",
            "ours, total (ms)",
            "peer, total (ms)",
            "ours / peer",
        ],
        rows=[
            [
                row["query"],
                row["peer"],
                str(row["count"]),
                format_number(row["ours_median_us"]),
                format_number(row["peer_median_us"]),
                format_number(row["ours_total_ms"]),
                format_number(row["peer_total_ms"]),
                format_number(row["ratio"]),
            ]
            for row in rows.values()
        ],
    )
    ccd_table = Table(
        caption=f"Continuous collision of {summary['motions']} motions (pose k to k + 1) "
        f"against the first contact of {SAMPLES} sampled poses",
        columns=[
            "engine",
            "contacts reported",
            "sampled contacts missed",
            "reported later than sampled",
            "reported without a sampled contact",
        ],
        rows=[
            [
                "thesis_rbd" if side == "ours" else PEERS["continuous"],
                str(ccd[side]["contacts"]),
                str(ccd[side]["missed"]),
                str(ccd[side]["late"]),
                str(ccd[side]["without_sampled_contact"]),
            ]
            for side in ("ours", "peer")
        ],
    )
    return Section(
        NAME,
        TITLE,
        summary,
        tables=[table, ccd_table],
        figures=[_per_pose_figure(result, figures_dir)],
    )


QUERY_COLORS = {
    "first": "tab:green",
    "distance": "tab:blue",
    "continuous": "tab:purple",
    "rays": "tab:orange",
}


def _per_pose_figure(result, figures_dir):
    fig, ax = new_axes(
        "Cost of each query along the tori path",
        "x of torus B's centre (m)",
        "time per query (us)",
        xlog=False,
        ylog=True,
    )
    for query in QUERIES:
        x = result["pose_x"][query]
        for side, linestyle in (("ours", "-"), ("peer", "--")):
            seconds = np.array(result["seconds"][f"{side}/{query}"]) * 1e6
            label = f"thesis_rbd {query}" if side == "ours" else PEERS[query]
            ax.plot(
                x,
                seconds,
                color=QUERY_COLORS[query],
                linestyle=linestyle,
                linewidth=1,
                marker="o" if len(x) < 30 else None,
                markersize=3,
                label=label,
            )
    ax.legend(fontsize=7, ncol=2)
    save_figure(fig, figures_dir / "query_costs_per_pose.png")
    return Figure(
        "query_costs_per_pose.png",
        "Median time of each query at each pose (solid: thesis_rbd; dashed: the peer; "
        "continuous collision from each pose to the next).",
    )
