"""Separate kernels (``njit(separate=True)``): called through a cell, never linked, in a fresh
compile and from the on-disk cache of another process."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

KERNELS = """
from thesis_rbd._numba.jit import njit


@njit(separate=True)
def weighted_sum(x, w):
    if w < 0.0:
        raise ValueError("negative weight")
    total = 0.0
    for value in x:
        total += w * value
    return total


@njit
def shifted(x, w):
    return weighted_sum(x, w) + 1.0


@njit
def doubled(x, w):
    return 2.0 * shifted(x, w) + weighted_sum(x, 0.5 * w)
"""

RUN = """
import json
import sys

import numpy as np

import separate_kernels as k

x = np.arange(5.0)
answer = k.doubled(x, 2.0)
try:
    k.doubled(x, -1.0)
    raised = ""
except ValueError as error:
    raised = str(error)
stats = {name: getattr(k, name).stats for name in ("weighted_sum", "shifted", "doubled")}
print(json.dumps({
    "answer": answer,
    "raised": raised,
    "hits": {name: sum(s.cache_hits.values()) for name, s in stats.items()},
    "misses": {name: sum(s.cache_misses.values()) for name, s in stats.items()},
}))
"""

EXPECTED = 2.0 * (2.0 * 10.0 + 1.0) + 1.0 * 10.0  # x = 0..4 sums to 10


@pytest.fixture
def kernels_dir(tmp_path):
    (tmp_path / "separate_kernels.py").write_text(textwrap.dedent(KERNELS))
    return tmp_path


def run_in_fresh_process(directory, cache):
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    environment["PYTHONPATH"] = os.pathsep.join(
        [str(directory), *filter(None, [environment.get("PYTHONPATH")])]
    )
    done = subprocess.run(
        [sys.executable, "-c", RUN], env=environment, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_separate_kernel_is_called_not_linked(kernels_dir, monkeypatch):
    monkeypatch.syspath_prepend(str(kernels_dir))
    import separate_kernels as k

    x = np.arange(5.0)
    assert k.doubled(x, 2.0) == EXPECTED
    with pytest.raises(ValueError, match="negative weight"):
        k.doubled(x, -1.0)  # raised two calls down, through a cell
    callee = next(iter(k.weighted_sum.overloads.values())).library
    for caller in (k.shifted, k.doubled):
        library = next(iter(caller.overloads.values())).library
        assert callee not in library._linking_libraries
    # A plain kernel is still linked into its caller: doubled links shifted.
    shifted = next(iter(k.shifted.overloads.values())).library
    assert shifted in next(iter(k.doubled.overloads.values())).library._linking_libraries


def test_a_cached_caller_finds_its_separate_kernel_in_another_process(kernels_dir, tmp_path):
    cache = tmp_path / "cache"
    first = run_in_fresh_process(kernels_dir, cache)
    assert first["answer"] == EXPECTED and first["raised"] == "negative weight"
    assert first["misses"] == {"weighted_sum": 1, "shifted": 1, "doubled": 1}

    second = run_in_fresh_process(kernels_dir, cache)
    assert second["answer"] == EXPECTED and second["raised"] == "negative weight"
    # doubled is loaded, and weighted_sum with it (its cell named in doubled's code);
    # shifted is linked into doubled, so it is not needed at all.
    assert second["hits"] == {"weighted_sum": 1, "shifted": 0, "doubled": 1}
    assert sum(second["misses"].values()) == 0


def test_a_cached_caller_whose_separate_kernel_is_gone_is_compiled_afresh(kernels_dir, tmp_path):
    cache = tmp_path / "cache"
    run_in_fresh_process(kernels_dir, cache)
    removed = [path for path in cache.rglob("*weighted_sum*")]
    assert removed
    for path in removed:
        path.unlink()
    again = run_in_fresh_process(kernels_dir, cache)
    assert again["answer"] == EXPECTED and again["raised"] == "negative weight"
    assert again["misses"]["weighted_sum"] == 1 and again["misses"]["doubled"] == 1
