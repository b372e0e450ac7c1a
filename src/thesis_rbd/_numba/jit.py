"""The one numba policy of the package.

Every kernel is compiled with ``cache=True`` so that a warm interpreter loads machine code from
``__pycache__`` instead of recompiling, and without ``fastmath``: the collision and contact
kernels rely on IEEE comparisons (NaN propagation, exact ties in the broad phase) and nothing
has been measured that would justify giving that up. For the same reason a division by zero
follows IEEE arithmetic (``error_model="numpy"``: inf or NaN) instead of raising Python's
ZeroDivisionError from inside a kernel: a state that diverges (a quaternion whose norm
overflowed, then was divided by) shows as non-finite, which the stages check and report as
``NonFiniteStateError`` naming the body, and a step never stops half done on an exception.

A kernel called from another kernel is compiled once per argument *type*, not once per
constant value: numba's own dispatcher types a literal argument (``f(x, 0)``, ``g(True)``)
as ``Literal[int](0)`` and compiles a separate specialization for it, callees included, which
multiplied the first-run compile of the convex and contact kernels (measured in the report's
startup study). The specializations bought nothing here: the kernels branch on such flags at
run time at the cost of a predictable branch.

A kernel that allocates nothing (it reads and writes the arrays it is given) says so with
``allocates=False`` and is compiled without numba's reference counting. Called from another
kernel, a kernel with it skips an incref and a decref of each array argument (a call with 20
array arguments that returns at once costs about 170 ns with them, 0.1 ns without); called from
Python, numba unboxes its array arguments at about half the cost, which is most of what a small
scene's bounds and integration stages cost. The option reaches the kernel's callees: they are
compiled without reference counting too (a second time, if allocating kernels call them as
well), so such a kernel cannot call one that allocates.

Processes sharing the cache compile a kernel one at a time (:mod:`.kernel_lock`): the
second loads what the first compiled, which is what lets helper processes compile a first
run's kernels beside it (:mod:`.compile_helpers`).

A long kernel split into named steps for the reader declares its steps ``inline="always"``:
numba inlines them into the caller before typing, so a step costs no call and no reference
count of its array arguments (called, the steps of the contact solve cost a resting cube's
step a fifth more; a per-pair step taking the hull set, tripled a pyramid's narrow phase).

A large kernel that several kernels call is declared ``separate=True``: callers reach it through
a pointer cell instead of linking its code into theirs, so LLVM optimises and emits it once
instead of once per caller on every path above it (:mod:`.separate`).

numba keys a cached kernel on its own source file alone, so a kernel whose callee changed in
another module would load its old machine code, with the old callee linked in. Every kernel's
cache entry is therefore also keyed on the text of the whole package (a SHA-256 over its
modules, about 0.8 MB, computed once per process): an edit anywhere recompiles everything,
and nothing stale is ever loaded.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

import numba
from numba.core import sigutils, types
from numba.core.caching import (
    CompileResultCacheImpl,
    FunctionCache,
    InTreeCacheLocator,
    UserProvidedCacheLocator,
    UserWideCacheLocator,
    ZipCacheLocator,
)
from numba.core.registry import CPUDispatcher

from thesis_rbd._numba.kernel_lock import kernel_lock
from thesis_rbd._numba.separate import (
    MissingSeparateKernel,
    SeparateKernelType,
    register,
    resolve_cells,
)

__all__ = ["njit", "package_source_hash"]

_PACKAGE = Path(__file__).resolve().parent.parent


@functools.cache
def package_source_hash() -> str:
    """SHA-256 over the relative path and text of every module of the package."""
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE.rglob("*.py")):
        digest.update(path.relative_to(_PACKAGE).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


class _PackageStamp:
    """Locator mixin: a cache entry is fresh only while no module of the package changed."""

    def get_source_stamp(self):
        return (super().get_source_stamp(), package_source_hash())


class _UserProvidedLocator(_PackageStamp, UserProvidedCacheLocator):
    """NUMBA_CACHE_DIR, when set."""


class _InTreeLocator(_PackageStamp, InTreeCacheLocator):
    """The ``__pycache__`` beside the module."""


class _UserWideLocator(_PackageStamp, UserWideCacheLocator):
    """The user's cache directory, where ``__pycache__`` is not writable."""


class _ZipLocator(_PackageStamp, ZipCacheLocator):
    """The package imported from a zip archive."""


class _PackageCacheImpl(CompileResultCacheImpl):
    # numba's own order, without the IPython locator (no kernel is defined in a notebook cell)
    _locator_classes = (_UserProvidedLocator, _InTreeLocator, _UserWideLocator, _ZipLocator)

    def rebuild(self, target_context, payload):
        """A cached kernel, after filling the cells of the separate kernels it calls."""
        library = payload[0]  # (name, kind, data): numba's serialised code library
        if library[1] == "object":
            resolve_cells(library[2][0])
        return super().rebuild(target_context, payload)


class _PackageFunctionCache(FunctionCache):
    """numba's function cache with the package-wide source stamp."""

    _impl_class = _PackageCacheImpl

    def load_overload(self, sig, target_context):
        try:
            return super().load_overload(sig, target_context)
        except MissingSeparateKernel:
            return None  # compiled afresh, with its separate kernels


_POLICY = {"nopython": True, "fastmath": False, "error_model": "numpy"}


class _TypeDispatcher(CPUDispatcher):
    """numba's CPU dispatcher, resolving calls from other kernels by argument types alone and
    caching under the package-wide source stamp."""

    def get_call_template(self, args, kws):
        args = tuple(types.unliteral(a) for a in args)
        kws = {name: types.unliteral(t) for name, t in kws.items()}
        return super().get_call_template(args, kws)

    def enable_caching(self):
        self._cache = _PackageFunctionCache(self.py_func)

    def compile(self, sig):
        """numba's compile (or load from the cache), one process at a time per kernel and
        argument types (:mod:`.kernel_lock`)."""
        args = tuple(sigutils.normalize_signature(sig)[0])
        if args in self.overloads:
            return self.overloads[args].entry_point
        with kernel_lock(self, args):
            return super().compile(sig)

    def cached_signatures(self) -> list[tuple]:
        """Argument types of every version in the on-disk cache (fresh entries only): what a
        cached caller's cell may name, and what a first run need not compile."""
        return [key[0] for key in self._cache._cache_file._load_index()]


class _SeparateDispatcher(_TypeDispatcher):
    """A kernel that other kernels call through its cell, unlinked (:mod:`.separate`)."""

    @property
    def _numba_type_(self):
        return SeparateKernelType(self)


def njit(func=None, allocates=True, separate=False, **options):
    """``numba.njit`` with the package policy (``cache=True``, ``fastmath=False``, one
    specialization per argument types).

    Usable bare (``@njit``) or with options (``@njit(allocates=False)``);
    ``allocates=False`` for a kernel that creates no array (see the module docstring);
    ``separate=True`` for a large kernel that other kernels call without linking its code into
    theirs (:mod:`.separate`).
    """
    if not allocates:
        options = {**options, "_nrt": False}

    def compile_later(function):
        if numba.config.DISABLE_JIT:
            return function
        kind = _SeparateDispatcher if separate else _TypeDispatcher
        dispatcher = kind(py_func=function, locals={}, targetoptions={**_POLICY, **options})
        dispatcher.enable_caching()
        if separate:
            register(dispatcher)
        return dispatcher

    return compile_later if func is None else compile_later(func)
