"""The processor's cycle counter, readable inside kernels.

A kernel that runs several stages cannot call ``time.perf_counter`` between them; it counts
cycles instead (LLVM's ``readcyclecounter``: the time-stamp counter on x86, the virtual
counter on ARM) and its caller shares the call's wall time among the stages in proportion to
their cycles. Where a target has no counter LLVM returns 0, and callers must allow for that.
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["cycle_count"]


@intrinsic
def cycle_count(typingctx):
    """Cycles since an arbitrary origin (int64); 0 on a target without a counter."""

    def codegen(context, builder, signature, args):
        function_type = ir.FunctionType(ir.IntType(64), [])
        counter = cgutils.get_or_insert_function(
            builder.module, function_type, "llvm.readcyclecounter"
        )
        return builder.call(counter, [])

    return types.int64(), codegen
