"""Study: the three collision report modes on the tori demo, against python-fcl in the same run.

Thesis 5.4.1 times its four report options on two 5000-triangle tori moving through each
other. Here every pose of the same scene (``validation/tori.py``) is queried
by :func:`thesis_rbd.collide` in "first" (yes/no and one intersecting pair), "all" (every
intersecting triangle pair) and "contacts" (the pairs plus contact points, normals and
depths) mode, and by python-fcl (OBBRSS ``BVHModel``) with ``num_max_contacts`` 1, 100000,
and 100000 with ``enable_contact``. Ours and fcl's sweeps alternate within each repeat; each
pose's time is its median over the repeats. Both sides include their Python wrapper.
"""

from __future__ import annotations

import time

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "collision_modes"
TITLE = "Narrow phase: report modes first / all / contacts against python-fcl"

MODES = ("first", "all", "contacts")
MODE_MEANING = {
    "first": "yes/no + one pair",
    "all": "every intersecting pair",
    "contacts": "pairs + points, normals, depths",
}
ENGINES = {"ours": "thesis_rbd", "fcl": "python-fcl"}
FCL_REQUEST = {"first": (1, False), "all": (100000, False), "contacts": (100000, True)}
POSE_STRIDE = {"full": 1, "quick": 4, "tiny": 20}
REPEATS = {"full": 5, "quick": 3, "tiny": 2}


def cases(scale: str) -> list[Case]:
    """One timed case: every selected pose in every mode, ours and fcl interleaved."""
    return [Case(NAME, {"pose_stride": POSE_STRIDE[scale], "repeats": REPEATS[scale]}, timed=True)]


def _our_sweep(tree, poses, mode):
    import thesis_rbd as rbd

    identity = np.eye(4)
    seconds = np.empty(len(poses))
    pairs = np.zeros(len(poses), dtype=np.int64)
    contacts = np.zeros(len(poses), dtype=np.int64)
    clock = time.perf_counter
    for k, P in enumerate(poses):
        start = clock()
        result = rbd.collide(tree, identity, tree, P, mode=mode)
        seconds[k] = clock() - start
        pairs[k] = len(result.pairs)
        if result.contacts is not None:
            contacts[k] = len(result.contacts)
    return seconds, pairs, contacts


def _fcl_sweep(demo, stride, mode):
    fcl = demo.fcl
    max_contacts, enable_contact = FCL_REQUEST[mode]
    transforms = demo.fcl_poses[::stride]
    seconds = np.empty(len(transforms))
    contacts = np.zeros(len(transforms), dtype=np.int64)
    clock = time.perf_counter
    for k, transform in enumerate(transforms):
        start = clock()
        demo.fcl_b.setTransform(transform)
        request = fcl.CollisionRequest(num_max_contacts=max_contacts, enable_contact=enable_contact)
        result = fcl.CollisionResult()
        fcl.collide(demo.fcl_a, demo.fcl_b, request, result)
        seconds[k] = clock() - start
        contacts[k] = len(result.contacts)
    return seconds, contacts, contacts


def run(params: dict) -> dict:
    """Per-pose median times, pairs and contacts of each mode, ours and fcl's."""
    import thesis_rbd as rbd
    from validation.bench_obbtree import Demo

    demo = Demo()
    stride, repeats = params["pose_stride"], params["repeats"]
    poses = demo.poses[::stride]
    tree = rbd.OBBTree(demo.mesh)
    for mode in MODES:  # compile (or load) outside the timings
        _our_sweep(tree, poses[:3], mode)
    times = {(engine, mode): [] for engine in ENGINES for mode in MODES}
    counts = {}
    for _ in range(repeats):
        for mode in MODES:
            seconds, pairs, contacts = _our_sweep(tree, poses, mode)
            times["ours", mode].append(seconds)
            counts["ours", mode] = (pairs, contacts)
            seconds, pairs, contacts = _fcl_sweep(demo, stride, mode)
            times["fcl", mode].append(seconds)
            counts["fcl", mode] = (pairs, contacts)
    return {
        "triangles": len(demo.mesh),
        "pose_x": [float(P[0, 3]) for P in poses],
        "series": {
            f"{engine}/{mode}": {
                "seconds": np.median(times[engine, mode], axis=0).tolist(),
                "pairs": counts[engine, mode][0].tolist(),
                "contacts": counts[engine, mode][1].tolist(),
            }
            for engine in ENGINES
            for mode in MODES
        },
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Per-mode cost and yield, ours against fcl; a Pareto-style figure and a per-pose one."""
    record = records[0]
    result = record["result"]
    overlapping = np.array(result["series"]["ours/all"]["pairs"]) > 0
    rows = {}
    for engine, engine_label in ENGINES.items():
        for mode in MODES:
            series = result["series"][f"{engine}/{mode}"]
            seconds = np.array(series["seconds"])
            pairs = int(sum(series["pairs"]))
            overlap_seconds = float(seconds[overlapping].sum())
            rows[f"{engine}/{mode}"] = {
                "engine": engine_label,
                "mode": mode,
                "meaning": MODE_MEANING[mode],
                "median_us": float(np.median(seconds)) * 1e6,
                "mean_overlapping_us": float(seconds[overlapping].mean()) * 1e6
                if overlapping.any()
                else None,
                "sweep_ms": float(seconds.sum()) * 1e3,
                "pairs": pairs,
                "contacts": int(sum(series["contacts"])),
                "pairs_per_ms": pairs / (overlap_seconds * 1e3) if overlap_seconds else None,
                "overlapping_found": int(sum(np.array(series["pairs"]) > 0)),
            }
    for mode in MODES:
        ours, fcl = rows[f"ours/{mode}"], rows[f"fcl/{mode}"]
        ours["fcl_over_ours"] = (
            fcl["mean_overlapping_us"] / ours["mean_overlapping_us"]
            if ours["mean_overlapping_us"]
            else None
        )
    summary = {
        "poses": len(result["pose_x"]),
        "overlapping_poses": int(overlapping.sum()),
        "triangles": result["triangles"],
        "repeats": record["params"]["repeats"],
        "rows": rows,
        "ours": {mode: rows[f"ours/{mode}"] for mode in MODES},
        "fcl": {mode: rows[f"fcl/{mode}"] for mode in MODES},
    }
    table = Table(
        caption=f"Report modes over {summary['poses']} poses ({summary['overlapping_poses']} "
        "overlapping); medians of the repeats per pose; shared 2-core machine",
        columns=[
            "engine",
            "mode",
            "reports",
            "median per pose (us)",
            "mean per overlapping pose (us)",
            "sweep (ms)",
            "pairs",
            "contacts",
            "pairs per ms",
            "overlapping poses found",
        ],
        rows=[
            [
                row["engine"],
                row["mode"],
                row["meaning"],
                format_number(row["median_us"]),
                format_number(row["mean_overlapping_us"]),
                format_number(row["sweep_ms"]),
                str(row["pairs"]),
                str(row["contacts"]),
                format_number(row["pairs_per_ms"]),
                str(row["overlapping_found"]),
            ]
            for row in rows.values()
        ],
    )
    figures = [_pareto_figure(rows, figures_dir), _per_pose_figure(result, figures_dir)]
    return Section(NAME, TITLE, summary, tables=[table], figures=figures)


ENGINE_STYLES = {
    "ours": {"color": "tab:blue", "marker": "o"},
    "fcl": {"color": "black", "marker": "x", "linestyle": "--"},
}


def _pareto_figure(rows, figures_dir):
    fig, ax = new_axes(
        "What each mode tells you against what it costs",
        "mean time per overlapping pose (us)",
        "",
        xlog=True,
        ylog=False,
    )
    levels = np.arange(len(MODES))
    for engine, style in ENGINE_STYLES.items():
        x = [rows[f"{engine}/{mode}"]["mean_overlapping_us"] for mode in MODES]
        ax.plot(x, levels, label=ENGINES[engine], markersize=8, **style)
        for xi, level in zip(x, levels, strict=True):
            ax.annotate(
                format_number(xi),
                (xi, level),
                textcoords="offset points",
                xytext=(0, 8),
                ha="center",
                fontsize=8,
            )
    ax.set_yticks(levels, [f"{mode}:\n{MODE_MEANING[mode]}" for mode in MODES], fontsize=8)
    ax.set_ylim(-0.5, len(MODES) - 0.4)
    ax.legend(fontsize=8, loc="lower right")
    save_figure(fig, figures_dir / "collision_modes_pareto.png")
    return Figure(
        "collision_modes_pareto.png",
        "Information reported (up) against mean time per overlapping pose (right): each "
        "mode, ours and python-fcl's (first: num_max_contacts 1; all: 100000; contacts: "
        "100000 with enable_contact).",
    )


def _per_pose_figure(result, figures_dir):
    fig, ax = new_axes(
        "Query time per pose along the tori demo",
        "x of torus B's centre (m)",
        "time per query (us)",
        xlog=False,
        ylog=True,
    )
    colors = {"first": "tab:green", "all": "tab:blue", "contacts": "tab:purple"}
    x = result["pose_x"]
    for mode in MODES:
        for engine, linestyle in (("ours", "-"), ("fcl", "--")):
            seconds = np.array(result["series"][f"{engine}/{mode}"]["seconds"]) * 1e6
            ax.plot(
                x,
                seconds,
                color=colors[mode],
                linestyle=linestyle,
                linewidth=1,
                label=f"{ENGINES[engine]} {mode}",
            )
    ax.legend(fontsize=7, ncol=2)
    save_figure(fig, figures_dir / "collision_modes_per_pose.png")
    return Figure(
        "collision_modes_per_pose.png",
        "Median query time of each pose (solid: thesis_rbd; dashed: python-fcl).",
    )
