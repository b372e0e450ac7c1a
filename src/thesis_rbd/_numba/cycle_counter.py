"""A cheap clock that kernels can read: the processor's cycle counter.

A kernel that runs several stages cannot call ``time.perf_counter`` between them; it reads
this counter instead, and its caller shares the call's wall time among the stages in
proportion to their counts (the counter's rate does not matter, only that it is steady over
one call). On x86-64 it is the time-stamp counter (LLVM's ``readcyclecounter``, the ``rdtsc``
instruction). Elsewhere it is the value 0, and callers must
allow for that: on 64-bit ARM, for one, ``readcyclecounter`` reads the performance-monitor
counter, which the operating system usually keeps from user code.
"""

from __future__ import annotations

import platform

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["cycle_count"]

_MACHINE = platform.machine().lower()


@intrinsic
def cycle_count(typingctx):
    """Cycles since an arbitrary origin (int64); 0 off x86-64."""

    def codegen(context, builder, signature, args):
        function_type = ir.FunctionType(ir.IntType(64), [])
        if _MACHINE in ("x86_64", "amd64"):
            counter = cgutils.get_or_insert_function(
                builder.module, function_type, "llvm.readcyclecounter"
            )
            return builder.call(counter, [])
        return ir.Constant(ir.IntType(64), 0)

    return types.int64(), codegen
