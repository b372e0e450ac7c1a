"""Study: what joint accuracy costs in time, against pybullet and MuJoCo (issue 34).

Two kinds of case, each timed alone:

``speed``
    A chain of ``links`` boxes (0.1 x 0.01 x 0.01 m, 50 g) jointed end to end, the first to the
    world, released horizontal (:func:`validation.joint_chains.straight_chain`), run for
    ``seconds`` at ``rate`` Hz in every engine of :data:`ENGINES`. After an untimed warm-up
    (numba's compile, the peers' first steps), ``repeats`` rounds each build every engine's
    chain afresh and run it, the engines in a different order each round, timing blocks of
    ``block`` steps; between blocks, untimed, the total energy is read, so a chain that gains
    energy (or blows up) shows beside its time. Time per step: the median over rounds.
``accuracy``
    The same chain with ball joints, or the built-in ``heavy_chain`` scene (1:100 mass
    ratio), for ours at each joint substep count and for pybullet's point-to-point chain at
    each solver iteration count. One pass steps once at a time and reads the largest anchor
    gap after every step (the first included); a run whose state turns non-finite, or whose
    gap passes :data:`DIVERGED_GAP`, is recorded as diverged at that step and stops there.
    Then ``repeats`` rounds rerun every setting afresh without the readout, in rotating
    order, over the steps the first pass completed, timed in blocks; time per step: the
    median over rounds. For pybullet at its default iteration count the gap pass is rerun
    with the constraints' force cap raised, to show whether the default cap limits it.
"""

from __future__ import annotations

import time

import numpy as np

import thesis_rbd as rbd
from validation import joint_chains as chains
from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "joint_benchmarks"
TITLE = "Joints: what accuracy costs in time, a 100-link chain against pybullet and MuJoCo"

RATE = 240
G = 9.81
BLOCK = 24  # steps per timed block: 0.1 s of simulated time
DIVERGED_GAP = 1.0  # m: a gap this large is a chain come apart
TARGET_RATIO = 1.0  # issue 34: ours no slower per step than pybullet's point-to-point chain
DEFAULT_ITERATIONS = 50  # pybullet's numSolverIterations
RAISED_FORCE_CAP = 1e12  # N, in place of pybullet's default 500 N per constraint

# engine -> its label in the report
ENGINES = {
    "ours_ball": "thesis_rbd, ball joints (auto substeps, collision mask 0)",
    "ours_hinge": "thesis_rbd, hinges (auto substeps, collision mask 0)",
    "ours_ball_uncollidable": "thesis_rbd, ball joints (auto substeps, collidable=False)",
    "pybullet_p2p": "pybullet point-to-point constraints (50 iterations, damping 0)",
    "pybullet_multibody": "pybullet multibody, hinges (damping 0, motors off)",
    "mujoco": "MuJoCo hinges (defaults: Euler integrator)",
    "mujoco_rk4": "MuJoCo hinges, RK4 integrator (not the default)",
}
MUJOCO_ENGINES = ("mujoco", "mujoco_rk4")
SCENES = ("chain", "heavy_chain")
SIZES = {
    "full": {
        "links": 100,
        "seconds": 2.0,
        "repeats": 5,
        "substeps": [1, 2, 4, 8, 16, "auto"],
        "iterations": [10, 50, 200],
    },
    "quick": {
        "links": 100,
        "seconds": 2.0,
        "repeats": 2,
        "substeps": [1, 4, 16, "auto"],
        "iterations": [10, 50, 200],
    },
    "tiny": {
        "links": 10,
        "seconds": 0.1,
        "repeats": 1,
        "substeps": [1, "auto"],
        "iterations": [10, 50],
    },
}


def cases(scale: str) -> list[Case]:
    """One speed case and one accuracy case per scene, all timed."""
    size = SIZES[scale]
    common = {
        "links": size["links"],
        "seconds": size["seconds"],
        "rate": RATE,
        "block": BLOCK,
        "repeats": size["repeats"],
    }
    speed = Case(NAME, {"kind": "speed", **common, "engines": list(ENGINES)}, timed=True)
    accuracy = [
        Case(
            NAME,
            {
                "kind": "accuracy",
                "scene": scene,
                **common,
                "substeps": size["substeps"],
                "iterations": size["iterations"],
            },
            timed=True,
        )
        for scene in SCENES
    ]
    return [speed, *accuracy]


def run(params: dict) -> dict:
    """Run one speed or accuracy case (see the module docstring)."""
    if params["kind"] == "speed":
        return _run_speed(params)
    return _run_accuracy(params)


# ------------------------------------------------------------------------------ running
def _mujoco_missing() -> str | None:
    """Why the MuJoCo engines cannot run here, or None."""
    try:
        from validation.mujoco_contact import require_mujoco

        require_mujoco()
    except ImportError as error:
        return str(error)
    return None


def _speed_chain(engine: str, spec, dt: float):
    if engine == "ours_ball":
        return chains.OursChain(spec, "spherical", dt, G)
    if engine == "ours_hinge":
        return chains.OursChain(spec, "revolute", dt, G)
    if engine == "ours_ball_uncollidable":
        return chains.OursChain(spec, "spherical", dt, G, collidable=False)
    if engine == "pybullet_p2p":
        return chains.PybulletPointChain(spec, dt, G)
    if engine == "pybullet_multibody":
        return chains.PybulletHingeMultibody(spec, dt, G)
    if engine == "mujoco":
        return chains.MujocoHingeChain(spec, dt, G)
    return chains.MujocoHingeChain(spec, dt, G, integrator="RK4")


def _timed_run(chain, steps: int, block: int, read_energy: bool) -> dict:
    """Step ``chain`` ``steps`` times in timed blocks; between blocks, untimed, read its
    energy. Returns the timed seconds and steps of the blocks completed, the step a
    divergence was reported after (None if none) and the energy gains (J)."""
    start = chain.energy() if read_energy else 0.0
    seconds, done, diverged, gains = 0.0, 0, None, []
    while done < steps:
        n = min(block, steps - done)
        clock = time.perf_counter()
        try:
            chain.step(n)
        except chains.ChainDiverged:
            diverged = done + n  # reported within this block, which is left out of the time
            break
        seconds += time.perf_counter() - clock
        done += n
        if read_energy:
            gain = chain.energy() - start
            if not np.isfinite(gain):
                diverged = done
                break
            gains.append(gain)
    chain.close()
    return {"seconds": seconds, "steps": done, "diverged_after": diverged, "gains": gains}


def _run_speed(params: dict) -> dict:
    spec = chains.straight_chain(params["links"])
    dt = 1.0 / params["rate"]
    steps = round(params["seconds"] * params["rate"])
    missing = _mujoco_missing()
    engines = [e for e in params["engines"] if not (missing and e in MUJOCO_ENGINES)]
    for engine in engines:  # numba's compile and the peers' first steps, untimed
        _timed_run(_speed_chain(engine, spec, dt), params["block"], params["block"], False)
    rounds = {engine: [] for engine in engines}
    for r in range(params["repeats"]):
        order = engines[r % len(engines) :] + engines[: r % len(engines)]
        for engine in order:
            rounds[engine].append(
                _timed_run(_speed_chain(engine, spec, dt), steps, params["block"], True)
            )
    results = {}
    for engine, runs in rounds.items():
        first = runs[0]
        per_step = [run["seconds"] / run["steps"] if run["steps"] else None for run in runs]
        timed = [x for x in per_step if x is not None]
        results[engine] = {
            "ms_per_step": [None if x is None else 1e3 * x for x in per_step],
            "median_ms": 1e3 * float(np.median(timed)) if timed else None,
            "steps": first["steps"],
            "diverged_at": None
            if first["diverged_after"] is None
            else first["diverged_after"] * dt,
            "energy_gain_max": max(first["gains"], default=None),
            "energy_drift_max": max((abs(g) for g in first["gains"]), default=None),
            "energy_change_end": first["gains"][-1] if first["gains"] else None,
        }
    return {
        "engines": results,
        "mujoco_missing": missing,
        "released_energy": spec.released_energy(G),
        "steps": steps,
    }


def _accuracy_spec(params: dict):
    if params["scene"] == "heavy_chain":
        world = rbd.scenes.get("heavy_chain").world
        if not np.isclose(world["dt"] * params["rate"], 1.0) or world["gravity"][2] != -G:
            raise ValueError(f"heavy_chain no longer runs at 1/{params['rate']} s, g = {G}")
        return chains.heavy_chain()
    return chains.straight_chain(params["links"])


def _accuracy_chain(setting: dict, spec, dt: float, max_force=None):
    if setting["engine"] == "ours":
        return chains.OursChain(spec, "spherical", dt, G, substeps=setting["substeps"])
    return chains.PybulletPointChain(spec, dt, G, setting["iterations"], max_force)


def _gap_pass(chain, steps: int, dt: float) -> dict:
    """Step once at a time, reading the largest gap after every step: its maximum (m), when
    (s), the steps completed and when the run diverged (s, at the end of the step that did;
    None if none)."""
    worst, worst_at, done, diverged = 0.0, None, 0, None
    while done < steps:
        try:
            chain.step(1)
        except chains.ChainDiverged:
            diverged = done + 1
            break
        done += 1
        gap = chain.gap()
        if not np.isfinite(gap) or gap > DIVERGED_GAP:
            diverged = done
            break
        if gap >= worst:
            worst, worst_at = gap, done * dt
    extra = {}
    if isinstance(chain, chains.PybulletPointChain):  # the iterations pybullet says it ran
        extra["solver_iterations"] = chain.solver_iterations()
    chain.close()
    return {
        "max_gap": worst,
        "max_gap_at": worst_at,
        "steps": done,
        "diverged_at": None if diverged is None else diverged * dt,
        **extra,
    }


def _run_accuracy(params: dict) -> dict:
    spec = _accuracy_spec(params)
    dt = 1.0 / params["rate"]
    steps = round(params["seconds"] * params["rate"])
    settings = [{"engine": "ours", "substeps": s} for s in params["substeps"]] + [
        {"engine": "pybullet_p2p", "iterations": k} for k in params["iterations"]
    ]
    # the gap passes also load every kernel before anything is timed
    results = [{**s, **_gap_pass(_accuracy_chain(s, spec, dt), steps, dt)} for s in settings]
    for r in range(params["repeats"]):
        for k in range(len(settings)):
            index = (k + r) % len(settings)
            result = results[index]
            chain = _accuracy_chain(settings[index], spec, dt)
            timed = _timed_run(chain, result["steps"], params["block"], False)
            per_step = timed["seconds"] / timed["steps"] if timed["steps"] else None
            result.setdefault("ms_per_step", []).append(
                None if per_step is None else 1e3 * per_step
            )
    for result in results:
        timed = [x for x in result["ms_per_step"] if x is not None]
        result["median_ms"] = float(np.median(timed)) if timed else None
    default = {"engine": "pybullet_p2p", "iterations": DEFAULT_ITERATIONS}
    raised = _accuracy_chain(default, spec, dt, max_force=RAISED_FORCE_CAP)
    return {
        "settings": results,
        "raised_cap": {"max_force": RAISED_FORCE_CAP, **_gap_pass(raised, steps, dt)},
        "bodies": len(spec),
        "mass_ratio": float(spec.masses.max() / spec.masses.min()),
        "steps": steps,
    }


# -------------------------------------------------------------------------- summarising
def _setting_label(setting: dict) -> str:
    if setting["engine"] == "ours":
        return f"thesis_rbd, joint_substeps={setting['substeps']}"
    default = " (default)" if setting["iterations"] == DEFAULT_ITERATIONS else ""
    return f"pybullet point-to-point, {setting['iterations']} iterations{default}"


def summarise(records: list[dict], figures_dir) -> Section:
    """The speed table and ratio, the gap-against-time table and figure."""
    speed = next(r for r in records if r["params"]["kind"] == "speed")
    accuracy = [r for r in records if r["params"]["kind"] == "accuracy"]
    params = speed["params"]
    engines = speed["result"]["engines"]
    p2p = engines["pybullet_p2p"]["median_ms"]

    def over_p2p(engine):
        return engines[engine]["median_ms"] / p2p if engine in engines else None

    released = speed["result"]["released_energy"]
    speed_rows = {}
    for engine in ENGINES:  # the stored records' keys come back sorted
        if engine in engines:
            gain = engines[engine]["energy_gain_max"]
            speed_rows[engine] = {
                **engines[engine],
                "label": ENGINES[engine],
                "over_p2p": over_p2p(engine),
                "blew_up": gain is not None and gain > released,
            }
    scenes = {}
    for record in accuracy:
        scene, r = record["params"]["scene"], record["result"]
        rows = [{**s, "label": _setting_label(s)} for s in r["settings"]]
        default = next(s for s in rows if s.get("iterations") == DEFAULT_ITERATIONS)
        ours = [s for s in rows if s["engine"] == "ours"]
        held = [s for s in ours if s["diverged_at"] is None]
        scenes[scene] = {
            "label": "heavy_chain (1:100)"
            if scene == "heavy_chain"
            else f"{record['params']['links']}-link chain, ball joints",
            "bodies": r["bodies"],
            "mass_ratio": r["mass_ratio"],
            "settings": rows,
            "ours_auto": next(s for s in ours if s["substeps"] == "auto"),
            "ours_diverged": [s for s in ours if s["diverged_at"] is not None],
            "ours_best_held": min(held, key=lambda s: s["max_gap"], default=None),
            "p2p_default": default,
            "p2p_most": max(
                (s for s in rows if s["engine"] != "ours"), key=lambda s: s["iterations"]
            ),
            "raised_cap": r["raised_cap"],
            "cap_binds": r["raised_cap"]["max_gap"] != default["max_gap"]
            or r["raised_cap"]["diverged_at"] != default["diverged_at"],
        }
    summary = {
        "links": params["links"],
        "seconds": params["seconds"],
        "rate": params["rate"],
        "block": params["block"],
        "repeats": params["repeats"],
        "diverged_gap": DIVERGED_GAP,
        "released_energy": released,
        "mujoco_missing": speed["result"]["mujoco_missing"],
        "speed": speed_rows,
        "ours_over_p2p": over_p2p("ours_ball"),
        "ours_hinge_over_p2p": over_p2p("ours_hinge"),
        "ours_uncollidable_over_p2p": over_p2p("ours_ball_uncollidable"),
        "target_ratio": TARGET_RATIO,
        "meets_target": over_p2p("ours_ball") <= TARGET_RATIO,
        "default_iterations": DEFAULT_ITERATIONS,
        "accuracy": scenes,
    }
    tables = [_speed_table(summary), _accuracy_table(summary)]
    return Section(NAME, TITLE, summary, tables=tables, figures=[_figure(scenes, figures_dir)])


def _speed_table(summary) -> Table:
    rows = []
    for s in summary["speed"].values():
        rows.append(
            [
                s["label"],
                format_number(s["median_ms"]),
                format_number(s["over_p2p"]),
                "no" if s["diverged_at"] is None else f"at {format_number(s['diverged_at'])} s",
                format_number(s["energy_drift_max"]),
                format_number(s["energy_change_end"]),
            ]
        )
    return Table(
        caption=f"{summary['links']}-link chain released horizontal, {summary['seconds']:g} s "
        f"at {summary['rate']} Hz: wall time per step (median of {summary['repeats']} runs), "
        "ratio to pybullet's point-to-point chain, and the total energy's largest change "
        "from its start and its change at the end (J, read every 0.1 s; a diverged run's "
        "time counts the steps before it)",
        columns=[
            "engine",
            "ms per step",
            "/ pybullet p2p",
            "diverged",
            "largest energy change (J)",
            "energy change at the end (J)",
        ],
        rows=rows,
    )


def _accuracy_table(summary) -> Table:
    rows = []
    for scene in summary["accuracy"].values():
        for s in scene["settings"]:
            status = "held"
            if s["diverged_at"] is not None:
                status = f"diverged at {format_number(s['diverged_at'])} s"
            rows.append(
                [
                    scene["label"],
                    s["label"],
                    format_number(s["max_gap"]),
                    format_number(s["max_gap_at"]),
                    format_number(s["median_ms"]),
                    status,
                ]
            )
    return Table(
        caption=f"Largest anchor gap over every joint and step of {summary['seconds']:g} s "
        "(before a divergence, where there is one), when it occurred, and the wall time per "
        f"step (median of {summary['repeats']} runs)",
        columns=["scene", "engine and setting", "max gap (m)", "at (s)", "ms per step", "outcome"],
        rows=rows,
    )


def _figure(scenes, figures_dir) -> Figure:
    fig, ax = new_axes(
        "Joint error against time per step",
        "wall time per step (ms)",
        "largest anchor gap over the run (m)",
    )
    colors = {"chain": "tab:blue", "heavy_chain": "tab:red"}

    def gap(point):  # a diverged run drawn on the dotted line, a zero at 1e-16
        return DIVERGED_GAP if point["diverged_at"] is not None else max(point["max_gap"], 1e-16)

    for scene, s in scenes.items():
        for engine, key, marker, style, name in (
            ("ours", "substeps", "o", "-", "thesis_rbd, substeps"),
            ("pybullet_p2p", "iterations", "s", "--", "pybullet p2p, iterations"),
        ):
            points = [p for p in s["settings"] if p["engine"] == engine and p[key] != "auto"]
            for diverged, look in (
                (False, {"marker": marker, "linestyle": style}),
                (True, {"marker": "x", "linestyle": "none", "markersize": 9}),
            ):
                chosen = [p for p in points if (p["diverged_at"] is not None) == diverged]
                if chosen:
                    values = ", ".join(str(p[key]) for p in chosen)
                    ax.plot(
                        [p["median_ms"] for p in chosen],
                        [gap(p) for p in chosen],
                        color=colors[scene],
                        **look,
                        label=f"{s['label']}: {name} {values}" + (", diverged" if diverged else ""),
                    )
        auto = s["ours_auto"]
        ax.plot(
            auto["median_ms"],
            gap(auto),
            color=colors[scene],
            marker="*",
            markersize=13,
            linestyle="none",
            label=f"{s['label']}: thesis_rbd, substeps auto",
        )
    ax.axhline(DIVERGED_GAP, color="0.5", linewidth=0.8, linestyle=":")
    ax.legend(fontsize=7)
    file = f"{NAME}_gap_vs_time.png"
    save_figure(fig, figures_dir / file)
    return Figure(
        file,
        "Largest anchor gap over the run against wall time per step, one point per setting; "
        "crosses on the dotted line: runs that diverged (their time per step counts the steps "
        "before); zeros drawn at 1e-16.",
    )
