"""One process at a time compiles a kernel: another process waits for it and loads what it
compiled, or (not waiting) is told the kernel is taken."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from thesis_rbd._numba.kernel_lock import kernel_lock

KERNEL = """
from thesis_rbd._numba.jit import njit


@njit
def cubed_sum(x):
    total = 0.0
    for value in x:
        total += value * value * value
    return total
"""

# The other process: says when it starts waiting, then calls the kernel and reports how many
# compiles and waits it saw.
CALLER = """
import sys

import numpy as np
from numba.core import event

from thesis_rbd._numba.kernel_lock import WAIT_EVENT
from thesis_rbd._numba.compile_log import CompileLog
import locked_kernel


class Announce(event.Listener):
    def on_start(self, evt):
        print("waiting", flush=True)

    def on_end(self, evt):
        pass


event.register(WAIT_EVENT, Announce())
with CompileLog() as log:
    answer = locked_kernel.cubed_sum(np.arange(4.0))
print(f"done {answer} compiles={len(log.records)} waits={len(log.waits)}", flush=True)
"""

PEEK = """
from numba.core import types

from thesis_rbd._numba.kernel_lock import kernel_lock
import locked_kernel

args = (types.Array(types.float64, 1, "C"),)
with kernel_lock(locked_kernel.cubed_sum, args, wait=False) as ours:
    print("free" if ours else "taken")
"""


@pytest.fixture
def kernel_module(tmp_path, monkeypatch):
    (tmp_path / "locked_kernel.py").write_text(textwrap.dedent(KERNEL))
    cache = tmp_path / "cache"
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    environment["PYTHONPATH"] = os.pathsep.join(
        [str(tmp_path), *filter(None, [environment.get("PYTHONPATH")])]
    )
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    monkeypatch.syspath_prepend(str(tmp_path))
    # numba reads NUMBA_CACHE_DIR when a kernel is declared: declare it after setting it
    sys.modules.pop("locked_kernel", None)
    import numba.core.config

    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(cache))
    import locked_kernel

    yield locked_kernel, environment
    sys.modules.pop("locked_kernel", None)


def _python(code, environment, **options):
    return subprocess.Popen(
        [sys.executable, "-c", code],
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **options,
    )


def test_a_kernel_being_compiled_elsewhere_is_waited_for_and_loaded(kernel_module):
    module, environment = kernel_module
    x = np.arange(4.0)
    args = (module.cubed_sum.typeof_pyval(x),)
    with kernel_lock(module.cubed_sum, args):
        other = _python(CALLER, environment)
        assert other.stdout.readline().strip() == "waiting", other.stderr.read()
        assert module.cubed_sum(x) == 36.0  # compiled here, into the shared cache
    out, err = other.communicate(timeout=600)
    assert other.returncode == 0, err
    # it waited once, then loaded this process's machine code instead of compiling
    assert out.strip() == "done 36.0 compiles=0 waits=1"


def test_a_kernel_taken_by_another_process_is_passed_over_without_waiting(kernel_module):
    module, environment = kernel_module
    args = (module.cubed_sum.typeof_pyval(np.arange(4.0)),)
    with kernel_lock(module.cubed_sum, args):
        taken = _python(PEEK, environment).communicate(timeout=600)
    free = _python(PEEK, environment).communicate(timeout=600)
    assert taken[0].strip() == "taken", taken[1]
    assert free[0].strip() == "free", free[1]
