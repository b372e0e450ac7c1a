"""Study: distance along approach paths against python-fcl, and what its bounds cost.

``validation/distance_paths.py`` sets the scene: torus-capsule, torus-torus and hull-torus,
body B coming in from one bounding-box diagonal beyond touching to touching over 40 poses
while it turns. At each pose :func:`thesis_rbd.distance` and python-fcl's ``distance`` (its
default OBBRSS models, ``enable_nearest_points=True``) alternate within each repeat; each
pose's time is its median, Python wrappers included. The record also says at which poses the
convex hulls proved the distance (no box tested), and, for every mesh of the study, what the
two blocks a distance query adds to a tree cost: the hull and the nodes' supports along a
grid of directions (the descent's centre-line bounds), each block's bytes beside the tree's
and its build time beside the tree's build.
"""

from __future__ import annotations

import time

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "distance_paths"
TITLE = "Distance along approach paths against python-fcl, and the cost of its bounds"

REPEATS = {"full": 30, "quick": 10, "tiny": 2}
BUILDS = {"full": 7, "quick": 3, "tiny": 1}
COLORS = {"torus-capsule": "tab:blue", "torus-torus": "tab:green", "hull-torus": "tab:orange"}


def cases(scale: str) -> list[Case]:
    """One timed case: the three paths, then the build costs."""
    return [Case(NAME, {"repeats": REPEATS[scale], "builds": BUILDS[scale]}, timed=True)]


def _median_seconds(call, count):
    times = []
    for _ in range(count):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _build_costs(builds: int) -> list[dict]:
    """Bytes and build time of the tree and of its hull and support blocks, for each mesh of
    the study."""
    import thesis_rbd as rbd
    from thesis_rbd.collision.mesh.packed import hull_row, layout
    from thesis_rbd.collision.mesh.packed_hull import hull_block
    from thesis_rbd.collision.mesh.packed_support import SUPPORT_ROWS, support_block
    from validation.distance_paths import pair_meshes
    from validation.tori import tori_mesh

    meshes = {"tori demo torus": tori_mesh()}
    for pair in ("torus-capsule", "hull-torus"):
        for name, mesh in zip(pair.split("-"), pair_meshes(pair), strict=True):
            meshes.setdefault(name, mesh)
    rows = []
    for name, mesh in meshes.items():
        tree = rbd.OBBTree(mesh)
        packed = tree.query_array(hull=True)
        hull_rows = packed.shape[0] - hull_row(packed, layout(packed))
        nodes = len(tree.children)
        supports = (tree.centers + tree.origin, tree.children, tree.root, mesh.vertices, mesh.faces)
        rows.append(
            {
                "mesh": name,
                "triangles": len(mesh),
                "hull_vertices": int(packed[hull_row(packed, layout(packed)), 0]),
                "tree_bytes": tree.nbytes,
                "hull_bytes": int(hull_rows * 3 * 8),
                "build_s": _median_seconds(lambda mesh=mesh: rbd.OBBTree(mesh), builds),
                "hull_s": _median_seconds(
                    lambda mesh=mesh: hull_block(mesh.vertices, mesh.faces), builds
                ),
                "support_bytes": int(nodes * SUPPORT_ROWS * 3 * 8),
                "support_s": _median_seconds(lambda a=supports: support_block(*a), builds),
            }
        )
    return rows


def run(params: dict) -> dict:
    """Per-pose times and answers along each path; the hull and support blocks' costs."""
    from validation.distance_paths import PAIRS, time_path

    paths = {}
    for pair in PAIRS:
        r = time_path(pair, repeats=params["repeats"])
        paths[pair] = {key: value.tolist() for key, value in r.items()}
    return {"paths": paths, "builds": _build_costs(params["builds"])}


def summarise(records: list[dict], figures_dir) -> Section:
    """Per path: summed times, the worst pose, the poses the hulls proved, agreement."""
    record = records[0]
    result = record["result"]
    pairs = {}
    for pair, r in result["paths"].items():
        ours, fcl = np.array(r["ours"]), np.array(r["fcl"])
        ratio = ours / fcl
        pairs[pair] = {
            "pair": pair,
            "poses": len(ours),
            "ours_ms": float(ours.sum()) * 1e3,
            "fcl_ms": float(fcl.sum()) * 1e3,
            "ratio": float(ours.sum() / fcl.sum()),
            "worst": float(ratio.max()),
            "worst_pose": int(ratio.argmax()),
            "poses_above_fcl": int(np.sum(ratio > 1.0)),
            "by_hulls": int(np.sum(r["by_hulls"])),
            "max_difference": float(
                np.abs(np.array(r["ours_distance"]) - np.array(r["fcl_distance"])).max()
            ),
        }
    builds = result["builds"]
    summary = {"repeats": record["params"]["repeats"], "pairs": pairs, "builds": builds}
    table = Table(
        caption="rbd.distance against python-fcl's distance along 40-pose approach paths "
        "(medians per pose, alternated; shared 2-core machine)",
        columns=[
            "pair",
            "ours, summed (ms)",
            "python-fcl, summed (ms)",
            "ours / fcl",
            "worst pose (ours / fcl)",
            "poses slower than fcl",
            "poses the hulls proved",
            "largest |d - d_fcl|",
        ],
        rows=[
            [
                p["pair"],
                format_number(p["ours_ms"]),
                format_number(p["fcl_ms"]),
                format_number(p["ratio"]),
                f"{format_number(p['worst'])} (pose {p['worst_pose']})",
                str(p["poses_above_fcl"]),
                f"{p['by_hulls']} of {p['poses']}",
                format_number(p["max_difference"]),
            ]
            for p in pairs.values()
        ],
    )
    build_table = Table(
        caption="What the distance bounds cost: the hull block's and the support block's bytes "
        "and build times beside the tree's (default leafless float64 tree); both blocks are "
        "built on a tree's first distance query, not with the tree",
        columns=[
            "mesh",
            "triangles",
            "hull vertices",
            "tree bytes",
            "hull bytes",
            "hull bytes per triangle",
            "support bytes per triangle",
            "tree build (ms)",
            "hull build (ms)",
            "support build (ms)",
        ],
        rows=[
            [
                b["mesh"],
                str(b["triangles"]),
                str(b["hull_vertices"]),
                str(b["tree_bytes"]),
                str(b["hull_bytes"]),
                format_number(b["hull_bytes"] / b["triangles"]),
                format_number(b["support_bytes"] / b["triangles"]),
                format_number(b["build_s"] * 1e3),
                format_number(b["hull_s"] * 1e3),
                format_number(b["support_s"] * 1e3),
            ]
            for b in builds
        ],
    )
    return Section(
        NAME,
        TITLE,
        summary,
        tables=[table, build_table],
        figures=[_per_pose_figure(result, figures_dir)],
    )


def _per_pose_figure(result, figures_dir):
    fig, ax = new_axes(
        "Distance per pose against separation",
        "planned separation beyond touching (m)",
        "time per query (us)",
        xlog=False,
        ylog=True,
    )
    for pair, r in result["paths"].items():
        separation = np.array(r["separation"])
        for side, linestyle, label in (
            ("ours", "-", f"thesis_rbd {pair}"),
            ("fcl", "--", f"python-fcl {pair}"),
        ):
            ax.plot(
                separation,
                np.array(r[side]) * 1e6,
                color=COLORS[pair],
                linestyle=linestyle,
                linewidth=1,
                marker="o",
                markersize=2,
                label=label,
            )
    ax.invert_xaxis()
    ax.legend(fontsize=7, ncol=2)
    save_figure(fig, figures_dir / "distance_paths_per_pose.png")
    return Figure(
        "distance_paths_per_pose.png",
        "Median time of one distance query at each pose of the three approach paths, from "
        "one bounding-box diagonal apart (left) to touching (right); solid: thesis_rbd, "
        "dashed: python-fcl.",
    )
