"""Study: the KUKA iiwa's step against pybullet's multibody and MuJoCo's (issue 35).

The arm of pybullet_data's ``kuka_iiwa/model.urdf`` falls from a bent pose for 2 s at
dt = 1/240 with its URDF joint damping, no control, in each engine as
:mod:`validation.robot_peers` sets it up. After an untimed warm-up (numba's compile, the
peers' first steps), ``repeats`` rounds each build every engine afresh and run the 2 s fall,
the engines in a different order each round, timing each step as the user's loop would:

* ``ours``: ``World.step()`` once per step, from Python;
* ``ours_batched``: ``World.step(24)`` per call (one kernel call for 24 steps), per step;
* ``ours_maximal``: the same in maximal coordinates (``joint_coordinates="maximal"``), what
  the arm cost before it was stepped in joint coordinates;
* ``pybullet``: ``stepSimulation()`` once per step;
* ``mujoco``: ``mj_step`` once per step.

Time per step: the median over every timed step (or batch) of every round. The acceptance
bound (issue 35): ours at most twice pybullet's.

Accuracy, once, untimed: each engine's largest joint-angle difference over the fall from
pybullet at dt / 16 (its own discretisation converged; the reference of ``tests/test_urdf.py``),
per joint.
"""

from __future__ import annotations

import time

import numpy as np

from validation import robot_peers as peers
from validation.cases import Case
from validation.formatting import format_number
from validation.section import Section, Table

NAME = "robot_benchmarks"
TITLE = "Robots: the iiwa's step against pybullet's multibody and MuJoCo's"

TARGET_RATIO = 2.0  # issue 35: ours at most twice pybullet's step
BATCH = 24
WARM_UP = 24
ENGINES = {
    "ours": "thesis_rbd, World.step() per step",
    "ours_batched": f"thesis_rbd, World.step({BATCH}) per call",
    "ours_maximal": f"thesis_rbd in maximal coordinates, World.step({BATCH}) per call",
    "pybullet": "pybullet multibody, stepSimulation()",
    "mujoco": "MuJoCo, mj_step (contacts off)",
}
# pybullet's steps per dt in the accuracy reference
REFERENCE_SUBSTEPS = 16
REPEATS = {"full": 5, "quick": 3, "tiny": 1}
SECONDS = {"full": 2.0, "quick": 2.0, "tiny": 0.25}


def cases(scale: str) -> list[Case]:
    """One timed case: every engine, alternated over the rounds."""
    params = {"repeats": REPEATS[scale], "seconds": SECONDS[scale], "engines": list(ENGINES)}
    return [Case(NAME, params, timed=True)]


def _build(engine: str):
    if engine == "ours":
        return peers.iiwa_ours(1), 1
    if engine == "ours_batched":
        return peers.iiwa_ours(BATCH), BATCH
    if engine == "ours_maximal":
        return peers.iiwa_ours(BATCH, "maximal"), BATCH
    if engine == "pybullet":
        return peers.iiwa_pybullet(), 1
    return peers.iiwa_mujoco(), 1


def _available(engine: str) -> bool:
    import importlib.util

    needs = {"pybullet": "pybullet", "mujoco": "mujoco"}.get(engine, "yourdfpy")
    return importlib.util.find_spec(needs) is not None


def run(params: dict) -> dict:
    """Each engine's per-step times over every round, and its joint positions at the end."""
    engines = [e for e in params["engines"] if _available(e)]
    steps = round(params["seconds"] / peers.DT)
    times = {engine: [] for engine in engines}
    final = {}
    for engine in engines:  # warm-up: numba's compile, the peers' first steps
        (step, _), per_call = _build(engine)
        for _ in range(WARM_UP // per_call):
            step()
    for round_ in range(params["repeats"]):
        order = engines[round_ % len(engines) :] + engines[: round_ % len(engines)]
        for engine in order:
            (step, positions), per_call = _build(engine)
            for _ in range(steps // per_call):
                start = time.perf_counter()
                step()
                times[engine].append((time.perf_counter() - start) / per_call)
            final[engine] = positions().tolist()
    return {
        "steps": steps,
        "median_us": {e: float(np.median(t)) * 1e6 for e, t in times.items()},
        "mean_us": {e: float(np.mean(t)) * 1e6 for e, t in times.items()},
        "final_positions": final,
        "angle_errors": _angle_errors(engines, steps),
    }


def _angle_errors(engines: list[str], steps: int) -> dict:
    """Each engine's largest joint-angle difference (rad) from pybullet at dt / 16 over the
    fall, per joint."""
    if "pybullet" not in engines:
        return {}
    paths = {}
    # steps of one dt each: the batched engine's path is the per-step one's
    for engine in ["reference", *(e for e in engines if e != "ours_batched")]:
        if engine == "reference":
            step, positions = peers.iiwa_pybullet(REFERENCE_SUBSTEPS)
        elif engine.startswith("ours"):
            step, positions = peers.iiwa_ours(1, "maximal" if engine == "ours_maximal" else "auto")
        else:
            (step, positions), _ = _build(engine)
        path = []
        for _ in range(steps):
            step()
            path.append(positions())
        paths[engine] = np.array(path)
    return {
        engine: np.abs(path - paths["reference"]).max(axis=0).tolist()
        for engine, path in paths.items()
        if engine != "reference"
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Median time per step of each engine and its ratio to pybullet's and MuJoCo's."""
    result = records[0]["result"]
    median = result["median_us"]
    rows = []
    for engine, label in ENGINES.items():
        if engine not in median:
            continue
        rows.append([
            label, format_number(median[engine]), format_number(result["mean_us"][engine]),
            format_number(median[engine] / median["pybullet"]) if "pybullet" in median else "",
            format_number(median[engine] / median["mujoco"]) if "mujoco" in median else "",
        ])  # fmt: skip
    summary = {
        "steps_per_round": result["steps"],
        **{f"{engine}_us": value for engine, value in median.items()},
        "target_ratio_to_pybullet": TARGET_RATIO,
    }
    for ours in ("ours", "ours_batched"):
        for peer in ("pybullet", "mujoco"):
            if ours in median and peer in median:
                summary[f"{ours}_over_{peer}"] = median[ours] / median[peer]
    table = Table(
        caption="The iiwa's damped fall (2 s at 240 Hz), time per step: median and mean over "
        "every timed step of every round (us), and the median's ratio to each peer's",
        columns=["engine", "median (us)", "mean (us)", "/ pybullet", "/ MuJoCo"],
        rows=rows,
    )
    errors = result.get("angle_errors", {})
    labels = {"ours": "thesis_rbd (joint coordinates)", "ours_maximal": "thesis_rbd (maximal)",
              "pybullet": "pybullet multibody", "mujoco": "MuJoCo (contacts off)"}  # fmt: skip
    accuracy = Table(
        caption="The same fall at dt = 1/240: each engine's largest joint-angle difference from "
        f"pybullet at dt / {REFERENCE_SUBSTEPS} (rad), per joint, and the ratio of ours to "
        "pybullet's on the joint where it is largest (issue 35's accuracy bound: 2)",
        columns=["engine", *[f"joint {j + 1}" for j in range(7)], "worst / pybullet's"],
        rows=[
            [
                labels[engine],
                *[format_number(e) for e in error],
                format_number(max(np.divide(error, errors["pybullet"]))),
            ]
            for engine, error in errors.items()
        ],
    )
    if "ours" in errors:
        worst = max(np.divide(errors["ours"], errors["pybullet"]))
        summary["ours_worst_error_ratio"] = float(worst)
    return Section(NAME, TITLE, summary, tables=[table, accuracy] if errors else [table])
