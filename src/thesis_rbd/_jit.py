"""The one numba policy of the package.

Every kernel is compiled with ``cache=True`` so that a warm interpreter loads machine code from
``__pycache__`` instead of recompiling, and without ``fastmath``: the collision and contact
kernels rely on IEEE comparisons (NaN propagation, exact ties in the broad phase) and nothing
has been measured that would justify giving that up.

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
"""

from __future__ import annotations

import numba
from numba.core import types
from numba.core.registry import CPUDispatcher

__all__ = ["njit"]

_POLICY = {"nopython": True, "fastmath": False}


class _TypeDispatcher(CPUDispatcher):
    """numba's CPU dispatcher, resolving calls from other kernels by argument types alone."""

    def get_call_template(self, args, kws):
        args = tuple(types.unliteral(a) for a in args)
        kws = {name: types.unliteral(t) for name, t in kws.items()}
        return super().get_call_template(args, kws)


def njit(func=None, allocates=True, **options):
    """``numba.njit`` with the package policy (``cache=True``, ``fastmath=False``, one
    specialization per argument types).

    Usable bare (``@njit``) or with options (``@njit(allocates=False)``);
    ``allocates=False`` for a kernel that creates no array (see the module docstring).
    """
    if not allocates:
        options = {**options, "_nrt": False}

    def compile_later(function):
        if numba.config.DISABLE_JIT:
            return function
        dispatcher = _TypeDispatcher(
            py_func=function, locals={}, targetoptions={**_POLICY, **options}
        )
        dispatcher.enable_caching()
        return dispatcher

    return compile_later if func is None else compile_later(func)
