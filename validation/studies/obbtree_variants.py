"""Study: OBBTree variants on the tori demo: box fit, leaf or leafless tree, float64 or float32.

Thesis 4.5.1 fits a box's axes to the covariance of the node's convex hull (Gottschalk);
RAPID uses the node's own triangles. Thesis 5.4.2 proposes dropping the leaf boxes and
testing a triangle against a box instead (m - 1 nodes instead of 2m - 1), and storing the
boxes with less memory. Each variant of :class:`thesis_rbd.OBBTree` is built on the torus of
the demo and answers the demo's poses in "all" and "first" mode: build time, nodes, bytes per
triangle, box tests, triangle-box tests and triangle tests per query, query times; python-fcl
(OBBRSS) is built and queried in the same run.
"""

from __future__ import annotations

import time

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "obbtree_variants"
TITLE = "Narrow phase: OBBTree variants (hull or triangle fit, leaf or leafless, float32)"

VARIANTS = (
    "leafless/triangles/f64",
    "leaf/triangles/f64",
    "leafless/hull/f64",
    "leaf/hull/f64",
    "leafless/triangles/f32",
    "leaf/triangles/f32",
)
POSE_STRIDE = {"full": 1, "quick": 4, "tiny": 20}
REPEATS = {"full": 5, "quick": 3, "tiny": 2}


def cases(scale: str) -> list[Case]:
    """One timed case per variant, and one for python-fcl."""
    params = {"pose_stride": POSE_STRIDE[scale], "repeats": REPEATS[scale]}
    return [Case(NAME, dict(params, variant=v), timed=True) for v in (*VARIANTS, "fcl")]


def _options(variant: str) -> dict:
    tree, fit, precision = variant.split("/")
    return {
        "leafless": tree == "leafless",
        "fit": fit,
        "dtype": np.float32 if precision == "f32" else np.float64,
    }


def _median_seconds(call, repeats):
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        samples.append(time.perf_counter() - start)
    return float(np.median(samples))


def run(params: dict) -> dict:
    """Build and query statistics of one variant (or of python-fcl's OBBRSS model)."""
    import thesis_rbd as rbd
    from validation.tori import tori_mesh, tori_poses

    mesh = tori_mesh()
    poses = list(tori_poses()[:: params["pose_stride"]])
    repeats = params["repeats"]
    if params["variant"] == "fcl":
        return _run_fcl(mesh, poses, repeats)
    options = _options(params["variant"])
    rbd.OBBTree(mesh, **options)  # compile (or load) the build kernels
    build = _median_seconds(lambda: rbd.OBBTree(mesh, **options), repeats)
    tree = rbd.OBBTree(mesh, **options)
    identity = np.eye(4)
    for mode in ("first", "all"):
        rbd.collide(tree, identity, tree, poses[len(poses) // 2], mode=mode)
    counts = {"bv_tests": [], "tri_box_tests": [], "tri_tests": [], "pairs": []}
    for P in poses:
        result = rbd.collide(tree, identity, tree, P, mode="all")
        for key in ("bv_tests", "tri_box_tests", "tri_tests"):
            counts[key].append(result.stats[key])
        counts["pairs"].append(len(result.pairs))

    def sweep(mode):
        for P in poses:
            rbd.collide(tree, identity, tree, P, mode=mode)

    return {
        "build_seconds": build,
        "node_count": tree.node_count,
        "bytes_per_triangle": tree.nbytes / len(mesh),
        "depth": tree.depth,
        "poses": len(poses),
        "counts": counts,
        "all_seconds_per_pose": _median_seconds(lambda: sweep("all"), repeats) / len(poses),
        "first_seconds_per_pose": _median_seconds(lambda: sweep("first"), repeats) / len(poses),
    }


def _run_fcl(mesh, poses, repeats):
    from validation.fcl_adapter import fcl_model, fcl_object, fcl_transform, require_fcl

    fcl = require_fcl()
    build = _median_seconds(lambda: fcl_model(mesh), repeats)
    model = fcl_model(mesh)
    obj_a, obj_b = fcl_object(model), fcl_object(model)
    transforms = [fcl_transform(P) for P in poses]

    def sweep(max_contacts):
        for transform in transforms:
            obj_b.setTransform(transform)
            request = fcl.CollisionRequest(num_max_contacts=max_contacts)
            fcl.collide(obj_a, obj_b, request, fcl.CollisionResult())

    return {
        "build_seconds": build,
        "poses": len(poses),
        "all_seconds_per_pose": _median_seconds(lambda: sweep(100000), repeats) / len(poses),
        "first_seconds_per_pose": _median_seconds(lambda: sweep(1), repeats) / len(poses),
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Table of every variant and python-fcl; memory against query time; tests per query."""
    results = {r["params"]["variant"]: r["result"] for r in records}
    repeats = records[0]["params"]["repeats"]
    rows = []
    for variant in VARIANTS:
        res = results[variant]
        counts = res["counts"]
        overlapping = np.array(counts["pairs"]) > 0
        rows.append(
            {
                "variant": variant,
                "build_ms": res["build_seconds"] * 1e3,
                "node_count": res["node_count"],
                "bytes_per_triangle": res["bytes_per_triangle"],
                "bv_per_query": float(np.mean(counts["bv_tests"])),
                "tri_box_per_query": float(np.mean(counts["tri_box_tests"])),
                "tri_per_query": float(np.mean(counts["tri_tests"])),
                "tests_per_overlapping_query": float(
                    np.mean(
                        np.add(
                            np.add(counts["bv_tests"], counts["tri_box_tests"]),
                            counts["tri_tests"],
                        )[overlapping]
                    )
                )
                if overlapping.any()
                else None,
                "pairs": int(sum(counts["pairs"])),
                "all_us": res["all_seconds_per_pose"] * 1e6,
                "first_us": res["first_seconds_per_pose"] * 1e6,
            }
        )
    fcl = results["fcl"]
    by_name = {row["variant"]: row for row in rows}
    default = by_name["leafless/triangles/f64"]
    fastest_all = min(rows, key=lambda row: row["all_us"])
    summary = {
        "poses": fcl["poses"],
        "repeats": repeats,
        "rows": by_name,
        "fcl": {
            "build_ms": fcl["build_seconds"] * 1e3,
            "all_us": fcl["all_seconds_per_pose"] * 1e6,
            "first_us": fcl["first_seconds_per_pose"] * 1e6,
        },
        "default": default,
        "fastest_all": fastest_all["variant"],
        "hull_build_ratio": by_name["leafless/hull/f64"]["build_ms"] / default["build_ms"],
        "leaf_test_ratio": by_name["leaf/triangles/f64"]["tests_per_overlapping_query"]
        / default["tests_per_overlapping_query"]
        if default["tests_per_overlapping_query"]
        else None,
        "same_pairs": len({row["pairs"] for row in rows}) == 1,
    }
    table = Table(
        caption=f"OBBTree variants on the tori demo ({summary['poses']} poses; times: medians "
        f"of {repeats}, per pose; shared 2-core machine)",
        columns=[
            "variant",
            "build (ms)",
            "nodes",
            "bytes/triangle",
            "box tests/query",
            "triangle-box tests/query",
            "triangle tests/query",
            "pairs found",
            "all (us/pose)",
            "first (us/pose)",
        ],
        rows=[
            [
                row["variant"],
                format_number(row["build_ms"]),
                str(row["node_count"]),
                format_number(row["bytes_per_triangle"]),
                format_number(row["bv_per_query"]),
                format_number(row["tri_box_per_query"]),
                format_number(row["tri_per_query"]),
                str(row["pairs"]),
                format_number(row["all_us"]),
                format_number(row["first_us"]),
            ]
            for row in rows
        ]
        + [
            [
                "python-fcl (OBBRSS)",
                format_number(summary["fcl"]["build_ms"]),
                "n/a",
                "n/a",
                "n/a",
                "n/a",
                "n/a",
                "n/a",
                format_number(summary["fcl"]["all_us"]),
                format_number(summary["fcl"]["first_us"]),
            ]
        ],
    )
    figures = [
        _memory_time_figure(rows, summary["fcl"], figures_dir),
        _tests_figure(rows, figures_dir),
    ]
    return Section(NAME, TITLE, summary, tables=[table], figures=figures)


def _memory_time_figure(rows, fcl, figures_dir):
    fig, ax = new_axes(
        "OBBTree variants: memory against query time",
        "bytes per triangle",
        "'all' query time per pose (us)",
        xlog=False,
        ylog=False,
    )
    for row in rows:
        marker = "o" if "/triangles/" in row["variant"] else "s"
        color = "tab:blue" if row["variant"].startswith("leafless") else "tab:orange"
        fill = "full" if row["variant"].endswith("f64") else "none"
        ax.plot(
            row["bytes_per_triangle"], row["all_us"], marker=marker, color=color, fillstyle=fill
        )
        ax.annotate(
            row["variant"],
            (row["bytes_per_triangle"], row["all_us"]),
            textcoords="offset points",
            xytext=(5, 3),
            fontsize=7,
        )
    ax.axhline(fcl["all_us"], color="black", linestyle="--", linewidth=0.8, label="python-fcl")
    ax.set_xlim(0, 1.25 * max(row["bytes_per_triangle"] for row in rows))
    ax.set_ylim(0, 1.15 * max(fcl["all_us"], *(row["all_us"] for row in rows)))
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "obbtree_variants_memory_time.png")
    return Figure(
        "obbtree_variants_memory_time.png",
        "Bytes per triangle against 'all' query time per pose (circles: triangle fit, squares: "
        "hull fit; blue: leafless, orange: leaf; hollow: float32); dashed: python-fcl.",
    )


def _tests_figure(rows, figures_dir):
    fig, ax = new_axes(
        "Tests per 'all' query", "", "mean tests per query (all poses)", xlog=False, ylog=False
    )
    x = np.arange(len(rows))
    width = 0.27
    parts = (
        ("bv_per_query", "box-box", "tab:blue"),
        ("tri_box_per_query", "triangle-box", "tab:green"),
        ("tri_per_query", "triangle-triangle", "tab:orange"),
    )
    for i, (key, label, color) in enumerate(parts):
        ax.bar(x + (i - 1) * width, [row[key] for row in rows], width, label=label, color=color)
    ax.set_xticks(x, [row["variant"] for row in rows], rotation=30, ha="right", fontsize=8)
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "obbtree_variants_tests.png")
    return Figure(
        "obbtree_variants_tests.png",
        "Mean box-box, triangle-box and triangle-triangle tests per 'all' query of each variant.",
    )
