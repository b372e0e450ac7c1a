"""The kernels' on-disk cache: an entry is loaded only while no module of the package changed."""

import importlib.util
import itertools

from thesis_rbd._numba import jit as _jit

_LOADS = itertools.count()

KERNEL = """
from thesis_rbd._numba.jit import njit


@njit
def double(x):
    return 2.0 * x
"""


def load_kernel(path):
    """A fresh dispatcher for the kernel in ``path`` (a new module object each time)."""
    spec = importlib.util.spec_from_file_location(f"cached_kernel_{next(_LOADS)}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.double


def test_a_cached_kernel_is_recompiled_once_any_module_of_the_package_changed(
    tmp_path, monkeypatch
):
    """numba alone would load the entry (its own file is unchanged) with whatever callees
    were linked into it when it was compiled."""
    path = tmp_path / "cached_kernel.py"
    path.write_text(KERNEL)
    first = load_kernel(path)
    assert first(1.5) == 3.0
    assert sum(first.stats.cache_misses.values()) == 1  # compiled and saved

    unchanged = load_kernel(path)
    assert unchanged(1.5) == 3.0
    assert sum(unchanged.stats.cache_hits.values()) == 1  # loaded

    monkeypatch.setattr(_jit, "package_source_hash", lambda: "another text of the package")
    edited = load_kernel(path)
    assert edited(1.5) == 3.0
    assert sum(edited.stats.cache_hits.values()) == 0
    assert sum(edited.stats.cache_misses.values()) == 1
