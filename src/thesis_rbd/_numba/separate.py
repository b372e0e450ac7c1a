"""Kernels compiled on their own: other kernels call them through a named cell, unlinked.

numba compiles a kernel called from another kernel into its own library and then *links* that
library's code into the caller's, where LLVM optimises and emits it again: once for every
kernel on every path above it. A large kernel deep in the pipeline (the convex contact
query, the contact solver) is thus optimised and emitted a dozen times on a first run, which
is most of what the first run waits for.

A kernel declared ``njit(separate=True)`` is instead called through a pointer cell named
after it: the caller's code loads the cell and calls what it holds, as numba's own runtime
linker does for mutually recursive kernels (``BaseContext.call_unresolved``), so the callee's
code is compiled once, in its own library. The cell's name is stable across processes
(module, qualified name and a hash of the argument types), so a caller's machine code in the
on-disk cache refers to it too:

* when a caller is compiled, typing its call compiles (or loads) the callee first, and the
  cell holds the callee's address before the caller's code is loaded;
* when a caller is loaded from the cache, :func:`resolve_cells` finds the cells its machine
  code names, compiles (or loads) each callee for the cached argument types and fills the
  cell, before numba hands the code to LLVM. A callee that cannot be found raises
  :class:`MissingSeparateKernel`, which the package cache turns into a miss: the caller is
  compiled afresh.

The cost at run time is one load and an indirect call, and the callee is not inlined: the
option is for kernels whose own work is large against a call.
"""

from __future__ import annotations

import ctypes
import hashlib

import llvmlite.binding as llvm
from numba.core import types
from numba.core.datamodel import models, register_default
from numba.core.registry import cpu_target
from numba.core.runtime import rtsys

__all__ = ["MissingSeparateKernel", "SeparateKernelType", "register", "resolve_cells"]

# numba's prefix for the pointer cells of unresolved calls, and ours within it.
_CELL_PREFIX = ".numba.unresolved$"
_SYMBOL_PREFIX = "thesis_rbd.separate$"
_CELLS: dict[str, ctypes.c_void_p] = {}
_FILLED: set[str] = set()
_DISPATCHERS: dict[str, object] = {}


class MissingSeparateKernel(LookupError):
    """A cached caller names a separate kernel or argument types that cannot be found."""


def _name(dispatcher) -> str:
    function = dispatcher.py_func
    return f"{function.__module__}.{function.__qualname__}"


def register(dispatcher) -> None:
    """Make ``dispatcher``'s cells resolvable by name (called when it is declared)."""
    _DISPATCHERS[_name(dispatcher)] = dispatcher


def _symbol(dispatcher, args) -> str:
    digest = hashlib.sha256(repr(tuple(args)).encode()).hexdigest()[:16]
    return f"{_SYMBOL_PREFIX}{_name(dispatcher)}${digest}"


def _cell(symbol: str) -> ctypes.c_void_p:
    """The process's cell for ``symbol``, made known to LLVM (and to numba's linker, which
    would otherwise give the caller a cell of its own). Until it is filled it holds numba's
    abort for unresolved calls, which names the fault instead of jumping to nowhere."""
    cell = _CELLS.get(symbol)
    if cell is None:
        engine = cpu_target.target_context.codegen()._engine  # (initialises numba's runtime)
        cell = ctypes.c_void_p(rtsys.library.get_pointer_to_function("nrt_unresolved_abort"))
        _CELLS[symbol] = cell
        name = _CELL_PREFIX + symbol
        llvm.add_symbol(name, ctypes.addressof(cell))
        engine._defined_symbols.add(name)
    return cell


def _fill(dispatcher, args) -> tuple[str, object]:
    """Compile (or load) ``dispatcher`` for ``args``; point its cell at the machine code."""
    args = tuple(args)
    dispatcher.compile(args)
    result = dispatcher.overloads[args]
    symbol = _symbol(dispatcher, args)
    address = result.library.get_pointer_to_function(result.fndesc.mangled_name)
    _cell(symbol).value = address
    _FILLED.add(symbol)
    return symbol, result


def resolve_cells(object_code: bytes) -> None:
    """Fill every separate kernel's cell that ``object_code`` (a cached library) names.

    Raises
    ------
    MissingSeparateKernel
        If a named kernel is not declared, or none of its compiled or cached argument types
        gives the name.
    """
    marker = (_CELL_PREFIX + _SYMBOL_PREFIX).encode()
    start = object_code.find(marker)
    while start >= 0:
        end = object_code.find(b"\0", start)
        symbol = object_code[start + len(_CELL_PREFIX) : end].decode()
        if symbol not in _FILLED:
            _resolve(symbol)
        start = object_code.find(marker, end)


def _resolve(symbol: str) -> None:
    name = symbol[len(_SYMBOL_PREFIX) :].rsplit("$", 1)[0]
    dispatcher = _DISPATCHERS.get(name)
    if dispatcher is None:
        raise MissingSeparateKernel(f"no separate kernel {name}")
    for args in [*dispatcher.overloads, *dispatcher.cached_signatures()]:
        if _symbol(dispatcher, args) == symbol:
            _fill(dispatcher, args)
            return
    raise MissingSeparateKernel(f"{name} has no compiled or cached version for {symbol}")


class SeparateKernelType(types.Dispatcher):
    """numba's type of a separate kernel: typed as any kernel, called through its cell."""

    def get_impl_key(self, sig):
        symbol, result = _fill(self.dispatcher, sig.args)
        key = ("separate kernel", symbol)
        context = cpu_target.target_context
        if key not in context._defns:
            signature = result.signature

            def call(context, builder, _, args):
                return context.call_unresolved(builder, symbol, signature, args)

            context._defns[key].append(call, sig.args)
        return key


register_default(SeparateKernelType)(models.OpaqueModel)
