"""Which kernels each built-in scene compiles on a first run, for which argument types.

numba learns a kernel's argument types only when it is called, so a first run compiles its
kernels one after the other as the run reaches them. The plan lets helper processes compile
a scene's kernels while the run itself compiles others (:mod:`.compile_helpers`). It is
recorded ahead by ``tools/record_compile_plan.py`` (each scene on an empty cache, in the
order numba finished compiling its kernels: callees before their callers) and shipped in
``compile_plan.json``. A plan that is out of date costs time, never correctness: a run
compiles whatever it needs that is not in the cache.

An entry's argument types are numba types, written in JSON as their names (``"float64"``,
``"bool"``, ``"none"``) or as objects for arrays, tuples and omitted arguments.
"""

from __future__ import annotations

import importlib
import json
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path

from numba.core import types

__all__ = [
    "CompilePlan",
    "PlannedCompile",
    "decode_type",
    "encode_type",
    "load_plan",
]

PLAN_PATH = Path(__file__).with_name("compile_plan.json")

_SCALARS = {
    str(scalar): scalar
    for scalar in (
        types.boolean,
        types.none,
        types.float32,
        types.float64,
        types.int8,
        types.int16,
        types.int32,
        types.int64,
        types.uint8,
        types.uint16,
        types.uint32,
        types.uint64,
    )
}


def encode_type(numba_type) -> str | dict:
    """A numba argument type as JSON.

    Raises
    ------
    ValueError
        For a type the plan has no spelling for.
    """
    if isinstance(numba_type, types.Array):
        return {
            "array": encode_type(numba_type.dtype),
            "ndim": numba_type.ndim,
            "layout": numba_type.layout,
            "readonly": not numba_type.mutable,
        }
    if isinstance(numba_type, types.BaseNamedTuple):
        cls = numba_type.instance_class
        return {
            "namedtuple": f"{cls.__module__}:{cls.__qualname__}",
            "fields": [encode_type(member) for member in numba_type.types],
        }
    if isinstance(numba_type, types.UniTuple):
        return {"unituple": encode_type(numba_type.dtype), "count": numba_type.count}
    if isinstance(numba_type, types.Tuple):
        return {"tuple": [encode_type(member) for member in numba_type.types]}
    if isinstance(numba_type, types.Omitted):
        return {"omitted": numba_type.value}
    if _SCALARS.get(str(numba_type)) == numba_type:
        return str(numba_type)
    raise ValueError(f"the compile plan cannot spell the argument type {numba_type}")


def decode_type(spelled: str | dict):
    """The numba type that :func:`encode_type` spelled.

    Raises
    ------
    ValueError
        For a spelling :func:`encode_type` does not write.
    """
    if isinstance(spelled, str):
        if spelled in _SCALARS:
            return _SCALARS[spelled]
    elif "array" in spelled:
        return types.Array(
            decode_type(spelled["array"]),
            spelled["ndim"],
            spelled["layout"],
            readonly=spelled["readonly"],
        )
    elif "namedtuple" in spelled:
        module, qualname = spelled["namedtuple"].split(":")
        cls = getattr(importlib.import_module(module), qualname)
        return types.BaseTuple.from_types([decode_type(f) for f in spelled["fields"]], cls)
    elif "unituple" in spelled:
        return types.UniTuple(decode_type(spelled["unituple"]), spelled["count"])
    elif "tuple" in spelled:
        return types.Tuple([decode_type(member) for member in spelled["tuple"]])
    elif "omitted" in spelled:
        return types.Omitted(spelled["omitted"])
    raise ValueError(f"not an argument type of the compile plan: {spelled!r}")


@dataclass(frozen=True)
class PlannedCompile:
    """One kernel and the argument types a run compiles it for.

    Attributes
    ----------
    module, qualname : str
        Where the kernel's Python function is defined.
    spelled_args : tuple
        The argument types as the plan writes them (:func:`encode_type`).
    """

    module: str
    qualname: str
    spelled_args: tuple

    @cached_property
    def args(self) -> tuple:
        """The argument types as numba types, decoded on first use: a warm run decodes only
        the entry it checks the cache for."""
        return tuple(decode_type(arg) for arg in self.spelled_args)

    @property
    def kernel(self) -> str:
        """``module.qualname``, as :class:`~thesis_rbd._numba.compile_log.CompileLog` names it."""
        return f"{self.module}.{self.qualname}"

    def dispatcher(self):
        """The kernel's numba dispatcher.

        Raises
        ------
        LookupError
            If the package has no such kernel or module (the plan is older than the code).
        """
        try:
            found = importlib.import_module(self.module)
        except ImportError as missing:
            raise LookupError(f"no module {self.module}") from missing
        for name in self.qualname.split("."):
            found = getattr(found, name, None)
        if not hasattr(found, "overloads"):
            raise LookupError(f"no kernel {self.kernel}")
        return found

    def to_json(self) -> dict:
        return {"module": self.module, "qualname": self.qualname, "args": list(self.spelled_args)}

    @classmethod
    def from_json(cls, entry: dict) -> PlannedCompile:
        return cls(entry["module"], entry["qualname"], tuple(entry["args"]))


@dataclass(frozen=True)
class CompilePlan:
    """Every planned compile, and which of them each scene's first run compiles.

    Attributes
    ----------
    compiles : list of PlannedCompile
    scenes : dict of str to list of int
        Per built-in scene, indices into ``compiles`` in the order its first run finished
        compiling them (callees before their callers).
    """

    compiles: list
    scenes: dict

    def for_scenes(self, names: list[str] | None = None) -> list[PlannedCompile]:
        """The compiles that the named scenes (every scene: None) need: each scene's in its
        own order, a compile that an earlier scene has already listed left out."""
        chosen: dict[int, None] = {}
        for name in self.scenes if names is None else names:
            chosen.update(dict.fromkeys(self.scenes.get(name, ())))
        return [self.compiles[index] for index in chosen]

    def to_json(self) -> dict:
        return {"compiles": [entry.to_json() for entry in self.compiles], "scenes": self.scenes}

    @classmethod
    def from_json(cls, data: dict) -> CompilePlan:
        return cls([PlannedCompile.from_json(entry) for entry in data["compiles"]], data["scenes"])


@cache
def load_plan() -> CompilePlan:
    """The plan shipped with the package (an empty one if the file is missing)."""
    if not PLAN_PATH.exists():
        return CompilePlan([], {})
    return CompilePlan.from_json(json.loads(PLAN_PATH.read_text()))
