"""Fingerprints of whole trajectories: did a change to the step move any body by one bit?

A refactoring of the step (issue 37) must leave the trajectories of the step-benchmark scenes
and of every stability-suite case bit-identical. Run this module under each checkout, on the
same machine (numba compiles for the host processor, so bits may differ between machines),
and compare the two files::

    git worktree add /tmp/before <commit>
    PYTHONPATH=/tmp/before/src python -m validation.step_fingerprints --out before.json
    python -m validation.step_fingerprints --out after.json
    python -m validation.step_fingerprints --compare before.json after.json

After every step each case hashes what the public API reads out of its world: positions,
orientations, momenta, time, which bodies sleep, and the contacts with their impulses. A case's
fingerprint is the digest of that stream; the first step at which two runs differ is found by
running again with ``--every`` (a digest per step). Only the public API is read, so the module
runs unchanged against a checkout from before a refactoring.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from validation.bench_step import SCENES as STEP_SCENES
from validation.studies import contact_scenes as scenes
from validation.studies import stability_suite as suite

DT = 1.0 / 240.0
CONTACT_STEPS = 480  # the suite's quick scale: 2 s at 240 Hz
FREE_STEPS = {"high_spin": 2400, "long_run": 20_000}


def _world_hasher(world) -> Callable[[], bytes]:
    """A function giving the digest of what the public API reads from ``world`` now."""
    count = len(world)

    def digest() -> bytes:
        h = hashlib.sha256()
        h.update(np.float64(world.time).tobytes())
        h.update(np.ascontiguousarray(world.positions).tobytes())
        h.update(np.ascontiguousarray(world.orientations).tobytes())
        for body in range(count):
            h.update(world.linear_momentum(body).tobytes())
            h.update(world.angular_momentum(body).tobytes())
        h.update(world.sleeping.tobytes())
        contacts = world.contacts
        for key in sorted(contacts):
            h.update(key.encode())
            h.update(np.ascontiguousarray(contacts[key]).tobytes())
        return h.digest()

    return digest


def _cases() -> dict[str, Callable[[], tuple[object, int]]]:
    """Case name -> factory of (world, steps)."""
    cases = {}
    for name, (spec, _) in STEP_SCENES.items():
        for engine, narrow_phase in (("ours", "auto"), ("ours_mesh", "mesh")):
            cases[f"step/{name}/{engine}"] = lambda spec=spec, narrow_phase=narrow_phase: (
                scenes.build_world(spec(), DT, sleeping=False, narrow_phase=narrow_phase),
                CONTACT_STEPS,
            )
    for name, case in suite.CASES.items():
        if case["scene"] == "free":
            omega0 = suite.TUMBLE if name == "long_run" else suite.HIGH_SPIN
            cases[f"suite/{name}/ours"] = lambda omega0=omega0, name=name: (
                _free_world(omega0),
                FREE_STEPS[name],
            )
            continue
        for engine in case["engines"]:
            options = suite.ENGINES[engine]["options"]
            cases[f"suite/{name}/{engine}"] = lambda case=case, options=options: (
                scenes.build_world(case["scene"](), DT, **options),
                CONTACT_STEPS,
            )
    return cases


def _free_world(omega0):
    import thesis_rbd as rbd

    mesh, _ = suite._free_box()
    world = rbd.World(dt=DT)
    world.add_body(mesh, mass=1.0, angular_velocity=omega0)
    return world


def fingerprint(factory, every: bool) -> dict:
    """Run one case; its digest (and each step's, with ``every``)."""
    world, steps = factory()
    digest = _world_hasher(world)
    whole = hashlib.sha256(digest())
    per_step = []
    for _ in range(steps):
        world.step()
        d = digest()
        whole.update(d)
        if every:
            per_step.append(d.hex()[:16])
    result = {"steps": steps, "digest": whole.hexdigest()}
    if every:
        result["per_step"] = per_step
    return result


def compare(before: dict, after: dict) -> int:
    """Print the cases whose digests differ (and the first step, where both have per-step
    digests); return how many differ."""
    differ = 0
    for name in sorted(set(before["cases"]) | set(after["cases"])):
        a, b = before["cases"].get(name), after["cases"].get(name)
        if a is None or b is None:
            print(f"{name}: only in {'after' if a is None else 'before'}")
            differ += 1
            continue
        if a["digest"] == b["digest"]:
            continue
        differ += 1
        where = ""
        if "per_step" in a and "per_step" in b:
            pairs = enumerate(zip(a["per_step"], b["per_step"], strict=True))
            first = next((k for k, (x, y) in pairs if x != y), None)
            where = f" (first at step {first})"
        print(f"{name}: differs{where}")
    print(f"{differ} of {len(before['cases'])} cases differ")
    return differ


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="write the fingerprints here (JSON)")
    parser.add_argument("--only", default="", help="run the cases whose name contains this")
    parser.add_argument("--every", action="store_true", help="keep a digest per step")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    options = parser.parse_args(argv)
    if options.compare:
        before, after = (json.loads(path.read_text()) for path in options.compare)
        return 1 if compare(before, after) else 0
    import thesis_rbd

    results = {}
    for name, factory in _cases().items():
        if options.only not in name:
            continue
        start = time.perf_counter()
        results[name] = fingerprint(factory, options.every)
        print(f"{name}: {results[name]['digest'][:16]} ({time.perf_counter() - start:.1f} s)")
        sys.stdout.flush()
    record = {"package": str(Path(thesis_rbd.__file__).parent), "cases": results}
    if options.out:
        options.out.write_text(json.dumps(record, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
