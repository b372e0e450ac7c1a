"""Study: OBB trees against AABB trees on the tori demo, through thesis 4.2's cost function.

Gottschalk's cost of a query is ``t = nv*cv + np*cp + nu*cu``: box tests times their cost,
triangle tests times theirs, box updates times theirs (``nu = 0`` here: rigid meshes, B's boxes
are carried into A's frame inside each box test, so that cost is part of ``cv``). The same
"all" queries of the tori demo (thesis 5.4.1) run through the classic OBB tree (one triangle
per leaf), the library's default leafless OBB tree and the AABB tree of
:mod:`validation.aabb_tree` (same build, descent and triangle test, axis-aligned boxes,
6-axis SAT-lite test). ``nv`` and ``np`` are counted; ``cv`` and ``cp`` are measured by
replaying each query's recorded box tests alone and triangle tests alone; the measured query
time is compared with ``nv*cv + np*cp`` (the rest is traversal overhead: stack, descent, pair
output).
"""

from __future__ import annotations

import time

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "obb_vs_aabb"
TITLE = "Narrow phase: OBB trees against AABB trees (the cost function of thesis 4.2)"

POSE_STRIDE = {"full": 1, "quick": 4, "tiny": 20}
REPEATS = {"full": 5, "quick": 3, "tiny": 2}
TREES = {
    "obb_leaf": "OBB tree (leaf)",
    "obb_leafless": "OBB tree (leafless, default)",
    "aabb": "AABB tree",
}
STYLES = {
    "obb_leaf": {"color": "tab:blue", "marker": "o"},
    "obb_leafless": {"color": "tab:cyan", "marker": "s", "linestyle": ":"},
    "aabb": {"color": "tab:red", "marker": "^"},
}


def cases(scale: str) -> list[Case]:
    """One timed case: every selected pose through the three trees."""
    return [
        Case(
            NAME,
            {"pose_stride": POSE_STRIDE[scale], "repeats": REPEATS[scale]},
            timed=True,
        )
    ]


def _best_of(call, repeats):
    best = np.inf
    result = None
    for _ in range(repeats):
        start = time.perf_counter()
        result = call()
        best = min(best, time.perf_counter() - start)
    return best, result


def run(params: dict) -> dict:
    """Per pose: tests, query times and replayed test costs of each tree."""
    import thesis_rbd as rbd
    from validation.aabb_tree import (
        AABBTree,
        aabb_collide,
        record_aabb_traversal,
        record_obb_traversal,
        time_aabb_tests,
        time_obb_tests,
        time_triangle_tests,
    )
    from validation.tori import tori_mesh, tori_poses

    mesh = tori_mesh()
    poses = list(tori_poses()[:: params["pose_stride"]])
    repeats = params["repeats"]
    identity = np.eye(4)
    build_seconds = {}
    start = time.perf_counter()
    obb_leaf = rbd.OBBTree(mesh, leafless=False)
    build_seconds["obb_leaf"] = time.perf_counter() - start
    start = time.perf_counter()
    obb_leafless = rbd.OBBTree(mesh, leafless=True)
    build_seconds["obb_leafless"] = time.perf_counter() - start
    start = time.perf_counter()
    aabb = AABBTree(mesh)
    build_seconds["aabb"] = time.perf_counter() - start
    queries = {
        "obb_leaf": lambda P: rbd.collide(obb_leaf, identity, obb_leaf, P, mode="all"),
        "obb_leafless": lambda P: rbd.collide(obb_leafless, identity, obb_leafless, P, "all"),
        # the library's triangle test in both trees: the comparison is of the boxes alone
        "aabb": lambda P: aabb_collide(aabb, identity, aabb, P, "all", triangle_test="library"),
    }
    for query in queries.values():  # compile (or load) every kernel outside the timings
        query(poses[len(poses) // 2])
    warm = poses[len(poses) // 2]
    boxes, triangles = record_obb_traversal(obb_leaf, identity, obb_leaf, warm)
    time_obb_tests(obb_leaf, identity, obb_leaf, warm, boxes, 1)
    time_triangle_tests(mesh, identity, mesh, warm, triangles, 1)
    boxes, _ = record_aabb_traversal(aabb, identity, aabb, warm)
    time_aabb_tests(aabb, identity, aabb, warm, boxes, 1)

    per_pose = {
        key: {"seconds": [], "bv_tests": [], "tri_tests": [], "tri_box_tests": []} for key in TREES
    }
    replay = {key: {"box_seconds": [], "triangle_seconds": []} for key in ("obb_leaf", "aabb")}
    pairs, same_pairs = [], []
    for P in poses:
        seconds, result = _best_of(lambda P=P: queries["obb_leaf"](P), repeats)
        reference = result.pairs
        for key in TREES:
            if key != "obb_leaf":
                seconds, result = _best_of(lambda P=P, key=key: queries[key](P), repeats)
            if key == "aabb":
                found, stats = result
            else:
                found, stats = result.pairs, result.stats
            per_pose[key]["seconds"].append(seconds)
            per_pose[key]["bv_tests"].append(stats["bv_tests"])
            per_pose[key]["tri_tests"].append(stats["tri_tests"])
            per_pose[key]["tri_box_tests"].append(stats.get("tri_box_tests", 0))
            if key == "aabb":
                same_pairs.append(bool(np.array_equal(found, reference)))
        pairs.append(len(reference))
        boxes, triangles = record_obb_traversal(obb_leaf, identity, obb_leaf, P)
        replay["obb_leaf"]["box_seconds"].append(
            time_obb_tests(obb_leaf, identity, obb_leaf, P, boxes, repeats)
        )
        replay["obb_leaf"]["triangle_seconds"].append(
            time_triangle_tests(mesh, identity, mesh, P, triangles, repeats)
        )
        boxes, triangles = record_aabb_traversal(aabb, identity, aabb, P)
        replay["aabb"]["box_seconds"].append(
            time_aabb_tests(aabb, identity, aabb, P, boxes, repeats)
        )
        replay["aabb"]["triangle_seconds"].append(
            time_triangle_tests(mesh, identity, mesh, P, triangles, repeats)
        )
    trees = {"obb_leaf": obb_leaf, "obb_leafless": obb_leafless, "aabb": aabb}
    return {
        "triangles": len(mesh),
        "pose_x": [float(P[0, 3]) for P in poses],
        "pairs": pairs,
        "aabb_same_pairs": same_pairs,
        "per_pose": per_pose,
        "replay": replay,
        "build_seconds": build_seconds,
        "node_count": {key: tree.node_count for key, tree in trees.items()},
        "bytes_per_triangle": {key: tree.nbytes / len(mesh) for key, tree in trees.items()},
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Totals, measured per-test costs, the cost-function decomposition; two figures."""
    record = records[0]
    result = record["result"]
    repeats = record["params"]["repeats"]
    per_pose = result["per_pose"]
    trees = {}
    for key, label in TREES.items():
        series = per_pose[key]
        nv = int(sum(series["bv_tests"]))
        n_triangle = int(sum(series["tri_tests"]))
        measured = float(sum(series["seconds"]))
        row = {
            "label": label,
            "nv": nv,
            "np": n_triangle,
            "tri_box_tests": int(sum(series["tri_box_tests"])),
            "seconds": measured,
            "node_count": result["node_count"][key],
            "bytes_per_triangle": result["bytes_per_triangle"][key],
            "build_seconds": result["build_seconds"][key],
        }
        if key in result["replay"]:
            replay = result["replay"][key]
            cv = sum(replay["box_seconds"]) / nv
            cp = sum(replay["triangle_seconds"]) / n_triangle if n_triangle else None
            box_part = nv * cv
            triangle_part = n_triangle * cp if cp is not None else 0.0
            row.update(
                cv_ns=cv * 1e9,
                cp_ns=cp * 1e9 if cp is not None else None,
                box_seconds=box_part,
                triangle_seconds=triangle_part,
                overhead_seconds=measured - box_part - triangle_part,
                predicted_fraction=(box_part + triangle_part) / measured,
            )
        trees[key] = row
    obb, aabb = trees["obb_leaf"], trees["aabb"]
    summary = {
        "poses": len(result["pose_x"]),
        "triangles": result["triangles"],
        "repeats": repeats,
        "total_pairs": int(sum(result["pairs"])),
        "overlapping_poses": int(sum(1 for n in result["pairs"] if n > 0)),
        "aabb_same_pairs": int(sum(result["aabb_same_pairs"])),
        "trees": trees,
        "nv_ratio": aabb["nv"] / obb["nv"],
        "np_ratio": aabb["np"] / obb["np"] if obb["np"] else None,
        "cv_ratio": aabb["cv_ns"] / obb["cv_ns"],
        "time_ratio": aabb["seconds"] / obb["seconds"],
        "leafless_time_ratio": trees["obb_leafless"]["seconds"] / obb["seconds"],
    }
    table = Table(
        caption=f"Totals over {summary['poses']} poses of the tori demo, 'all' mode (times: "
        f"best of {repeats} per pose, summed; shared 2-core machine)",
        columns=[
            "tree",
            "nodes",
            "bytes/triangle",
            "nv (box tests)",
            "np (triangle tests)",
            "triangle-box tests",
            "cv (ns)",
            "cp (ns)",
            "nv*cv (ms)",
            "np*cp (ms)",
            "measured (ms)",
            "overhead (ms)",
        ],
        rows=[
            [
                row["label"],
                str(row["node_count"]),
                format_number(row["bytes_per_triangle"]),
                str(row["nv"]),
                str(row["np"]),
                str(row["tri_box_tests"]),
                format_number(row.get("cv_ns")),
                format_number(row.get("cp_ns")),
                format_number(row["box_seconds"] * 1e3 if "box_seconds" in row else None),
                format_number(row["triangle_seconds"] * 1e3 if "triangle_seconds" in row else None),
                format_number(row["seconds"] * 1e3),
                format_number(row["overhead_seconds"] * 1e3 if "overhead_seconds" in row else None),
            ]
            for row in trees.values()
        ],
    )
    figures = [
        _per_pose_figure(result, figures_dir),
        _decomposition_figure(trees, figures_dir),
    ]
    return Section(NAME, TITLE, summary, tables=[table], figures=figures)


def _per_pose_figure(result, figures_dir):
    import matplotlib.pyplot as plt

    x = result["pose_x"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 6.4), sharex=True)
    for key, label in TREES.items():
        style = dict(STYLES[key], markersize=3, linewidth=1)
        top.plot(x, np.maximum(result["per_pose"][key]["bv_tests"], 1), label=label, **style)
        bottom.plot(x, np.array(result["per_pose"][key]["seconds"]) * 1e6, **style)
    top.set_yscale("log")
    bottom.set_yscale("log")
    top.set_ylabel("box tests nv per query")
    bottom.set_ylabel("query time (us)")
    bottom.set_xlabel("x of torus B's centre (m)")
    top.set_title("OBB vs AABB trees along the tori demo ('all' mode)")
    for ax in (top, bottom):
        ax.grid(True, which="both", alpha=0.3)
    top.legend(fontsize=8)
    save_figure(fig, figures_dir / "obb_vs_aabb_per_pose.png")
    return Figure(
        "obb_vs_aabb_per_pose.png",
        "Box tests and query time per pose as torus B slides through torus A.",
    )


def _decomposition_figure(trees, figures_dir):
    fig, ax = new_axes(
        "Cost function t = nv*cv + np*cp (+ overhead)", "", "summed query time (ms)", False, False
    )
    keys = ["obb_leaf", "aabb"]
    labels = [trees[key]["label"] for key in keys]
    bottom = np.zeros(len(keys))
    parts = (
        ("box_seconds", "nv*cv (box tests)", "tab:blue"),
        ("triangle_seconds", "np*cp (triangle tests)", "tab:orange"),
        ("overhead_seconds", "traversal overhead", "0.7"),
    )
    for field, label, color in parts:
        values = np.array([max(trees[key][field], 0.0) * 1e3 for key in keys])
        ax.bar(labels, values, bottom=bottom, label=label, color=color, width=0.5)
        bottom += values
    ax.plot(
        labels,
        [trees[key]["seconds"] * 1e3 for key in keys],
        "k_",
        markersize=40,
        label="measured query time",
    )
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "obb_vs_aabb_cost.png")
    return Figure(
        "obb_vs_aabb_cost.png",
        "Summed query time split by the cost function: counted tests times measured per-test "
        "costs, and the remainder.",
    )
