"""The compile plan: its argument types spelled and read back, its kernels found, kept
current with what a scene compiles, and compiled by helper processes into the cache a run then
loads from."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof
from numba.core import types

from thesis_rbd import scenes
from thesis_rbd._numba.compile_plan import (
    PlannedCompile,
    decode_type,
    encode_type,
    load_plan,
)
from thesis_rbd.collision.convex.hull_data import HullFields

ROOT = Path(__file__).resolve().parent.parent
RECORDER = ROOT / "tools" / "record_compile_plan.py"


def _environment(cache):
    return {**os.environ, "NUMBA_CACHE_DIR": str(cache)}


def test_every_scene_has_a_plan_of_package_kernels():
    plan = load_plan()
    assert sorted(plan.scenes) == sorted(scenes.names())
    for entry in plan.compiles:
        assert entry.dispatcher().py_func.__qualname__ == entry.qualname


def test_argument_types_read_back_as_written():
    for entry in load_plan().compiles:
        assert tuple(decode_type(encode_type(arg)) for arg in entry.args) == entry.args
    spelled = [
        types.Array(types.float64, 2, "C", readonly=True),
        types.Array(types.int32, 1, "A"),
        types.UniTuple(types.float64, 3),
        types.Tuple([types.int64, types.Array(types.uint8, 1, "C")]),
        types.Omitted(200),
        types.boolean,
        types.none,
        # the convex kernels' hull fields, by name: heterogeneous, and all alike
        typeof(
            HullFields(*[np.zeros((2, 3)) if k % 2 else np.zeros(2, np.int64) for k in range(20)])
        ),
        typeof(HullFields(*[np.zeros(2) for _ in range(20)])),
    ]
    assert [decode_type(json.loads(json.dumps(encode_type(t)))) for t in spelled] == spelled


def test_an_entry_older_than_the_code_is_a_lookup_error():
    """A plan naming a module or kernel the package no longer has (a kernel moved) costs a
    first run time, never the run: the helpers skip what they cannot find."""
    for module, qualname in [
        ("thesis_rbd.collision.bounds", "update_fat_bounds"),  # moved to broad_phase/
        ("thesis_rbd.world.step_kernel", "no_such_kernel"),
    ]:
        with pytest.raises(LookupError):
            PlannedCompile(module, qualname, ()).dispatcher()


def test_an_argument_type_the_plan_cannot_spell_is_refused():
    with pytest.raises(ValueError, match="cannot spell"):
        encode_type(types.complex128)
    with pytest.raises(ValueError, match="not an argument type"):
        decode_type({"set": "int64"})


def test_a_scene_plan_is_what_its_first_run_compiles(tmp_path):
    """The recorder's pass for one scene, on an empty cache: what projectile's first run
    compiles is exactly its plan (a stale plan fails here; re-record it with the tool)."""
    used_path = tmp_path / "used.json"
    subprocess.run(
        [sys.executable, str(RECORDER), "--scene", "projectile", str(used_path)],
        env=_environment(tmp_path / "cache"),
        check=True,
        timeout=600,
    )
    compiled = {
        (module, qualname, json.dumps(args))
        for module, qualname, args in json.loads(used_path.read_text())
    }
    planned = {
        (entry.module, entry.qualname, json.dumps([encode_type(a) for a in entry.args]))
        for entry in load_plan().for_scenes(["projectile"])
    }
    assert compiled == planned


RUN_PROJECTILE = """
import json

from thesis_rbd import scenes
from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd.trajectory import simulate

with CompileLog() as log:
    simulate(scenes.get("projectile").build(), 0.05)
print(json.dumps(sorted({record.name for record in log.records})))
"""


def test_a_run_loads_what_a_helper_compiled(tmp_path):
    """A helper compiles projectile's plan into an empty cache; the run that follows compiles
    none of the package's kernels: it loads them."""
    cache = tmp_path / "cache"
    helper = [sys.executable, "-m", "thesis_rbd._numba.compile_helpers", "--scene", "projectile"]
    subprocess.run(helper, env=_environment(cache), check=True, timeout=600)
    ran = subprocess.run(
        [sys.executable, "-c", RUN_PROJECTILE],
        env=_environment(cache),
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    compiled = json.loads(ran.stdout.strip().splitlines()[-1])
    assert [name for name in compiled if name.startswith("thesis_rbd.")] == []


def test_a_first_run_with_a_helper_says_so_and_a_second_starts_none(tmp_path):
    cache = tmp_path / "cache"
    command = [sys.executable, "-m", "thesis_rbd.cli", "run", "projectile", "-s", "0.1"]
    runs = [
        subprocess.run(
            [*command, "--compile-helpers", "1"],
            env=_environment(cache),
            capture_output=True,
            text=True,
            check=True,
            timeout=600,
        )
        for _ in range(2)
    ]
    assert "with 1 helper process compiling beside it" in runs[0].stdout
    assert "compiling kernels" not in runs[1].stdout + runs[1].stderr
