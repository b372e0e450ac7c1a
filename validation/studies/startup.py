"""Study: how long a new user waits, the first time and every time after.

numba compiles each kernel on its first call and keeps the machine code in its on-disk cache,
so the first run of a scene pays for compiling every kernel it touches and later runs only load
them. Each case starts fresh Python processes, as a user's shell would:

- a cold start: ``thesis-rbd run SCENE --seconds 1`` with ``NUMBA_CACHE_DIR`` pointed at an
  empty folder of its own, timed from process start to exit, with numba's compile events
  recorded (:class:`thesis_rbd._numba.compile_log.CompileLog`, through
  :mod:`validation.startup_probe`) for the time spent compiling and per kernel; at the
  command's default, helper processes compile shares of the scene's kernels on the spare
  cores (:mod:`thesis_rbd._numba.compile_helpers`), and the pyramid starts cold once more with none
  (``--compile-helpers 0``), which is where the per-kernel tables come from;
- warm starts: the same command again, on the cache the cold start filled (the fastest of a
  few), which is what every later run costs;
- ``thesis-rbd warmup`` on an empty cache, then every built-in scene for its own length, each
  in a fresh process on that cache, counting what they still compile (nothing, if the warm-up
  does its job); full scale only;
- the test suite (full scale only): ``pytest`` on an empty cache, then again on the cache it
  filled.

The smallest scale measures one warm start on the cache in use, primed by one run first.
"""

from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path
from time import perf_counter

from validation.cases import Case
from validation.formatting import format_number
from validation.section import Section, Table

NAME = "startup"
TITLE = "First run and later runs: numba's compile time, per scene and per kernel"

COLD_BUDGET_SECONDS = 30.0
COLD_AIM_SECONDS = 20.0
WARM_BUDGET_SECONDS = 2.0
RUN_SECONDS = 1.0
WARM_RUNS = 3
SLOWEST_KERNELS = 15
REPOSITORY = Path(__file__).resolve().parents[2]


def _scene_names() -> list[str]:
    import thesis_rbd as rbd

    return rbd.scenes.names()


def cases(scale: str) -> list[Case]:
    """Per scene a cold start and warm starts; at full scale, the test suite cold and warm."""
    serial = {"scene": "pyramid", "cold": True, "warm_runs": 1, "helpers": 0}
    if scale == "tiny":
        scenes = [{"scene": "projectile", "cold": False, "warm_runs": 1, "helpers": None}]
    elif scale == "quick":
        scenes = [{"scene": "pyramid", "cold": True, "warm_runs": WARM_RUNS, "helpers": None}]
        scenes.append(serial)
    else:
        scenes = [
            {"scene": name, "cold": True, "warm_runs": WARM_RUNS, "helpers": None}
            for name in _scene_names()
        ]
        scenes.append(serial)
    work = [
        Case(NAME, {"kind": "scene", "seconds": RUN_SECONDS, **scene}, timed=True)
        for scene in scenes
    ]
    if scale == "full":
        work.append(Case(NAME, {"kind": "warmup"}, timed=True))
        work.append(Case(NAME, {"kind": "test_suite"}, timed=True))
    return work


def run(params: dict) -> dict:
    """Time the starts of one case in fresh processes."""
    if params["kind"] == "test_suite":
        return _test_suite()
    if params["kind"] == "warmup":
        return _warmup_then_scenes()
    return _scene_starts(
        params["scene"], params["seconds"], params["cold"], params["warm_runs"], params["helpers"]
    )


def _environment(cache: Path | None) -> dict:
    environment = dict(os.environ)
    # Python keeps each module's bytecode beside it (pip writes it at install), as a user's
    # runs find it; a machine that turns that off would add compiling every module's source
    # to every start
    environment.pop("PYTHONDONTWRITEBYTECODE", None)
    if cache is not None:
        environment["NUMBA_CACHE_DIR"] = str(cache)
    # the probe lives in this checkout's validation package
    environment["PYTHONPATH"] = os.pathsep.join(
        filter(None, [str(REPOSITORY), environment.get("PYTHONPATH")])
    )
    return environment


def _children_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed_run(command: list[str], cache: Path | None, folder: Path):
    """Run ``command`` in a fresh process on the numba cache ``cache`` (None: the usual one)
    from ``folder``: (the finished process, its wall seconds, its processor seconds)."""
    cpu_start, start = _children_cpu_seconds(), perf_counter()
    finished = subprocess.run(
        command,
        env=_environment(cache),
        cwd=folder,
        capture_output=True,
        text=True,
        check=False,
    )
    return finished, perf_counter() - start, _children_cpu_seconds() - cpu_start


def _probe(
    scene: str, seconds: float, cache: Path | None, folder: Path, helpers: int | None = None
) -> dict:
    """One fresh process running the scene: its wall and processor time (its compile helpers'
    included), its compile record."""
    record_path = folder / f"probe-{len(list(folder.glob('probe-*.json')))}.json"
    command = [sys.executable, "-m", "validation.startup_probe", scene, str(seconds)]
    command.append(str(record_path))
    if helpers is not None:
        command.append(str(helpers))
    finished, wall, cpu = _timed_run(command, cache, folder)
    if finished.returncode != 0:
        raise RuntimeError(
            f"thesis-rbd run {scene} failed ({finished.returncode}): {finished.stderr[-2000:]}"
        )
    record = json.loads(record_path.read_text(encoding="utf-8"))
    record.update(wall_seconds=wall, cpu_seconds=cpu)
    return record


def _scene_starts(
    scene: str, seconds: float, cold: bool, warm_runs: int, helpers: int | None
) -> dict:
    from thesis_rbd._numba.compile_helpers import spare_cores

    with tempfile.TemporaryDirectory(prefix="thesis-rbd-startup-") as temporary:
        folder = Path(temporary)
        cache = folder / "numba-cache" if cold else None
        first = _probe(scene, seconds, cache, folder, helpers)
        warm = [_probe(scene, seconds, cache, folder, helpers) for _ in range(warm_runs)]
    fastest = min(warm, key=lambda record: record["wall_seconds"])
    result = {
        "warm_seconds": fastest["wall_seconds"],
        "warm_cpu_seconds": fastest["cpu_seconds"],
        "warm_import_seconds": fastest["import_seconds"],
        "warm_compile_seconds": fastest["compile_seconds"],
        "warm_runs": [record["wall_seconds"] for record in warm],
        "helpers": spare_cores() if helpers is None else helpers,
    }
    if cold:
        result.update(
            cold_seconds=first["wall_seconds"],
            cold_cpu_seconds=first["cpu_seconds"],
            cold_compile_seconds=first["compile_seconds"],
            cold_compile_cpu_seconds=first["compile_cpu_seconds"],
            kernels_compiled=first["kernels_compiled"],
            cold_wait_seconds=first["wait_seconds"],
            compiles=first["compiles"],
        )
    return result


def _warmup_then_scenes() -> dict:
    """Time the warm-up on an empty cache, then count what full runs still compile."""
    import thesis_rbd as rbd

    with tempfile.TemporaryDirectory(prefix="thesis-rbd-startup-") as temporary:
        folder = Path(temporary)
        cache = folder / "numba-cache"
        finished, wall, cpu = _timed_run(
            [sys.executable, "-m", "thesis_rbd.cli", "warmup", "--quiet"], cache, folder
        )
        if finished.returncode != 0:
            raise RuntimeError(f"thesis-rbd warmup failed: {finished.stderr[-2000:]}")
        after = {
            name: _probe(name, rbd.scenes.get(name).seconds, cache, folder)
            for name in rbd.scenes.names()
        }
    return {
        "warmup_seconds": wall,
        "warmup_cpu_seconds": cpu,
        "compiled_after": {name: record["kernels_compiled"] for name, record in after.items()},
        "runs_after": {name: record["wall_seconds"] for name, record in after.items()},
    }


def _pytest_once(cache: Path) -> dict:
    finished, wall, cpu = _timed_run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "-n",
            "2",
            "--dist",
            "loadfile",
        ],
        cache,
        REPOSITORY,  # the README's test command
    )
    tail = finished.stdout.strip().splitlines()[-1] if finished.stdout.strip() else ""
    counts = {
        outcome: int(count)
        for count, outcome in re.findall(r"(\d+) (passed|failed|skipped|errors?)", tail)
    }
    failures = [line for line in finished.stdout.splitlines() if line.startswith("FAILED ")]
    return {
        "seconds": wall,
        "cpu_seconds": cpu,
        "status": finished.returncode,
        "outcome": tail,
        "counts": counts,
        "failures": failures,
    }


def _test_suite() -> dict:
    with tempfile.TemporaryDirectory(prefix="thesis-rbd-startup-") as temporary:
        cache = Path(temporary) / "numba-cache"
        return {"cold": _pytest_once(cache), "warm": _pytest_once(cache)}


def _slowest_kernels(scene_records: list[dict]) -> list[dict]:
    """Per kernel and signature, its largest own compile time over the scenes' cold starts."""
    kernels: dict[tuple[str, str], dict] = {}
    for record in scene_records:
        for entry in record["result"].get("compiles", []):
            key = (entry["name"], entry["signature"])
            known = kernels.setdefault(
                key,
                {"name": entry["name"], "signature": entry["signature"], "scenes": 0},
            )
            known["scenes"] += 1
            for field in ("own_seconds", "seconds", "own_cpu_seconds", "cpu_seconds"):
                known[field] = max(known.get(field, 0.0), entry[field])
    ranked = sorted(kernels.values(), key=lambda kernel: kernel["own_cpu_seconds"], reverse=True)
    return ranked


def _by_module(scene_records: list[dict]) -> list[dict]:
    """Own compile processor time per module, the largest over the scenes' cold starts."""
    modules: dict[str, float] = {}
    for record in scene_records:
        spent: dict[str, float] = {}
        for entry in record["result"].get("compiles", []):
            module = entry["name"].rsplit(".", 1)[0]
            if not module.startswith("thesis_rbd."):
                module = "(numba's own library)"
            spent[module] = spent.get(module, 0.0) + entry["own_cpu_seconds"]
        for module, seconds in spent.items():
            modules[module] = max(modules.get(module, 0.0), seconds)
    ranked = sorted(modules.items(), key=lambda item: item[1], reverse=True)
    return [{"module": module, "own_cpu_seconds": seconds} for module, seconds in ranked]


def summarise(records: list[dict], figures_dir) -> Section:
    """Per-scene cold and warm starts against the budget, the slowest kernels, the suite."""
    scene_records = [r for r in records if r["params"]["kind"] == "scene"]
    # per kernel, the cold starts that compiled everything in their own process
    serial_records = [r for r in scene_records if r["params"].get("helpers") == 0]
    rows = []
    for record in scene_records:
        result = record["result"]
        helpers = result.get("helpers", 0)
        rows.append(
            {
                "scene": record["params"]["scene"],
                "helpers": helpers,
                "serial": record["params"].get("helpers") == 0,
                "cold": result.get("cold_seconds"),
                "cold_cpu": result.get("cold_cpu_seconds"),
                "compile": result.get("cold_compile_seconds"),
                "compile_cpu": result.get("cold_compile_cpu_seconds"),
                "kernels": result.get("kernels_compiled"),
                "warm": result["warm_seconds"],
                "warm_cpu": result["warm_cpu_seconds"],
                "warm_import": result["warm_import_seconds"],
            }
        )
    colds = [row["cold"] for row in rows if row["cold"] is not None and not row["serial"]]
    warms = [row["warm"] for row in rows]
    kernels = _slowest_kernels(serial_records or scene_records)
    modules = _by_module(serial_records or scene_records)
    suite = next((r["result"] for r in records if r["params"]["kind"] == "test_suite"), None)
    warmup = next((r["result"] for r in records if r["params"]["kind"] == "warmup"), None)
    summary = {
        "seconds": RUN_SECONDS,
        "budget": {
            "cold": COLD_BUDGET_SECONDS,
            "cold_aim": COLD_AIM_SECONDS,
            "warm": WARM_BUDGET_SECONDS,
        },
        "rows": rows,
        "worst_cold": max(colds) if colds else None,
        "helpers": max((row["helpers"] for row in rows if not row["serial"]), default=0),
        "pyramid_cold": next(
            (row["cold"] for row in rows if row["scene"] == "pyramid" and not row["serial"]), None
        ),
        "pyramid_cold_serial": next(
            (row["cold"] for row in rows if row["scene"] == "pyramid" and row["serial"]), None
        ),
        "worst_warm": max(warms) if warms else None,
        "cold_within_budget": bool(colds) and max(colds) <= COLD_BUDGET_SECONDS,
        "warm_within_budget": bool(warms) and max(warms) <= WARM_BUDGET_SECONDS,
        "distinct_kernels": len({kernel["name"] for kernel in kernels}),
        "package_kernels": len(
            {kernel["name"] for kernel in kernels if kernel["name"].startswith("thesis_rbd.")}
        ),
        "modules": modules,
        "compiled_signatures": len(kernels),
        "slowest_kernels": kernels[:SLOWEST_KERNELS],
        "test_suite": suite,
        "warmup": None
        if warmup is None
        else {
            "seconds": warmup["warmup_seconds"],
            "cpu_seconds": warmup["warmup_cpu_seconds"],
            "compiled_after": sum(warmup["compiled_after"].values()),
            "slowest_run_after": max(warmup["runs_after"].values()),
        },
    }
    tables = [
        Table(
            caption=f"thesis-rbd run SCENE --seconds {format_number(RUN_SECONDS)}, each in a "
            "fresh process: cold (empty numba cache) and warm (the cache the cold start filled, "
            f"fastest of the warm runs); budget {format_number(COLD_BUDGET_SECONDS)} s cold, "
            f"{format_number(WARM_BUDGET_SECONDS)} s warm. Processor time includes the helper "
            "processes'; compiling and kernels compiled are the run's own process's (its waits "
            "for a helper's kernel count as compiling)",
            columns=[
                "scene",
                "helper processes",
                "cold start (s)",
                "cold: processor (s)",
                "compiling (s)",
                "compiling: processor (s)",
                "kernels compiled",
                "warm start (s)",
                "warm: processor (s)",
                "warm: importing (s)",
            ],
            rows=[
                [
                    row["scene"] + (" (no helpers)" if row["serial"] else ""),
                    format_number(row["helpers"]),
                    format_number(row["cold"]),
                    format_number(row["cold_cpu"]),
                    format_number(row["compile"]),
                    format_number(row["compile_cpu"]),
                    format_number(row["kernels"]),
                    format_number(row["warm"]),
                    format_number(row["warm_cpu"]),
                    format_number(row["warm_import"]),
                ]
                for row in rows
            ],
        )
    ]
    if kernels:
        tables.append(
            Table(
                caption=f"The {min(SLOWEST_KERNELS, len(kernels))} slowest kernels to compile, "
                "in processor time (own: callees compiled on the way left out; the largest over "
                "the cold starts without helpers)",
                columns=[
                    "kernel",
                    "signature",
                    "own (s)",
                    "with callees (s)",
                    "own, wall (s)",
                    "cold starts compiling it",
                ],
                rows=[
                    [
                        kernel["name"].removeprefix("thesis_rbd."),
                        _shorten(kernel["signature"]),
                        format_number(kernel["own_cpu_seconds"]),
                        format_number(kernel["cpu_seconds"]),
                        format_number(kernel["own_seconds"]),
                        format_number(kernel["scenes"]),
                    ]
                    for kernel in kernels[:SLOWEST_KERNELS]
                ],
            )
        )
    if modules:
        tables.append(
            Table(
                caption="Own compile processor time per module (the largest over the cold "
                "starts without helpers); numba's own library functions (sorting, array methods) "
                "together",
                columns=["module", "own compile (s)"],
                rows=[
                    [
                        entry["module"].removeprefix("thesis_rbd."),
                        format_number(entry["own_cpu_seconds"]),
                    ]
                    for entry in modules
                ],
            )
        )
    if suite is not None:
        tables.append(
            Table(
                caption="The test suite (python -m pytest) on an empty numba cache, then again",
                columns=["run", "wall (s)", "processor (s)", "outcome"],
                rows=[
                    [
                        label,
                        format_number(suite[key]["seconds"]),
                        format_number(suite[key]["cpu_seconds"]),
                        suite[key]["outcome"],
                    ]
                    for label, key in (("first (cold cache)", "cold"), ("again (warm)", "warm"))
                ],
            )
        )
    return Section(NAME, TITLE, summary, tables=tables)


def _shorten(signature: str, limit: int = 60) -> str:
    return signature if len(signature) <= limit else signature[: limit - 3] + "..."
