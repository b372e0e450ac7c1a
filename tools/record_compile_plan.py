"""Record the compile plan (src/thesis_rbd/compile_plan.json) from cold runs of the scenes.

    python tools/record_compile_plan.py [--jobs N]

Each built-in scene runs for a simulated second (with and without recording contacts) in a
fresh process on an empty numba cache of its own, recording each package kernel numba
compiles, for which argument types, in the order the compiles ended (callees before their
callers): what that scene's first run compiles. The scenes run ``--jobs`` at a time.

Run it after changing which kernels a scene calls or their argument types; a stale plan only
makes first runs slower (tests/test_compile_plan.py checks that it is current).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _key(module: str, qualname: str, args: list) -> str:
    return json.dumps([module, qualname, args], sort_keys=True)


def record_scene(name: str, out: Path) -> None:
    """Inside its process: what one scene's first run compiles."""
    from numba.core import event

    from thesis_rbd import scenes
    from thesis_rbd._numba.compile_plan import encode_type
    from thesis_rbd._numba.warmup import SCENE_SECONDS
    from thesis_rbd.trajectory import simulate

    entries = []

    class Recorder(event.Listener):
        def on_start(self, evt):
            pass

        def on_end(self, evt):
            function = evt.data["dispatcher"].py_func
            if function.__module__.startswith("thesis_rbd."):
                args = [encode_type(arg) for arg in evt.data["args"]]
                entries.append([function.__module__, function.__qualname__, args])

    event.register("numba:compile", Recorder())
    for record_contacts in (True, False):
        simulate(scenes.get(name).build(), SCENE_SECONDS, record_contacts=record_contacts)
    out.write_text(json.dumps(entries))


def _record_in_fresh_process(name: str, scratch: Path) -> list:
    out = scratch / f"{name}.json"
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(scratch / name)}
    environment["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])]
    )
    subprocess.run(
        [sys.executable, __file__, "--scene", name, str(out)], check=True, env=environment
    )
    return json.loads(out.read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2, help="scenes recorded at a time")
    parser.add_argument("--scene", nargs=2, help=argparse.SUPPRESS)
    options = parser.parse_args()
    if options.scene:
        return record_scene(options.scene[0], Path(options.scene[1]))

    sys.path.insert(0, str(ROOT / "src"))
    from thesis_rbd import scenes
    from thesis_rbd._numba.compile_plan import PLAN_PATH, CompilePlan, PlannedCompile

    names = scenes.names()
    with tempfile.TemporaryDirectory() as scratch:
        with ThreadPoolExecutor(options.jobs) as pool:
            runs = pool.map(lambda name: _record_in_fresh_process(name, Path(scratch)), names)
            recorded = dict(zip(names, runs, strict=True))
    index: dict[str, int] = {}
    compiles, plan_scenes = [], {}
    for name in names:
        order = []
        for module, qualname, args in recorded[name]:
            key = _key(module, qualname, args)
            if key not in index:
                index[key] = len(compiles)
                compiles.append([module, qualname, args])
            if index[key] not in order:
                order.append(index[key])
        plan_scenes[name] = order
        print(f"{name}: {len(order)} compiles", file=sys.stderr)
    plan = CompilePlan(
        [PlannedCompile(module, qualname, tuple(args)) for module, qualname, args in compiles],
        plan_scenes,
    )
    PLAN_PATH.write_text(json.dumps(plan.to_json(), separators=(",", ":")) + "\n")
    print(f"wrote {PLAN_PATH} ({len(compiles)} compiles)", file=sys.stderr)


if __name__ == "__main__":
    main()
