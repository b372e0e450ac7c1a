"""A set of contacts packed in two flat arrays, as the kernels write and read them.

The narrow phase hands its contacts to the contact stage every step. As seven separate arrays
that hand-over costs more than a one-body scene's whole narrow phase: each view of a kernel's
output is a NumPy object to build (a few hundred nanoseconds), each array argument of a kernel
call is one more to check and unbox. So a ``ContactSet`` keeps the contacts as the kernels
write them, one int64 and one float64 array, and kernels take those two arrays and the count
(``contact_views`` cuts them into fields inside the kernel, for free). Python code reads a field
by name (``contacts["depths"]``, a ``Mapping``); the view is made on first use and kept.

Layout of c contacts::

    ints   = [body_a (c) | body_b (c) | features (c) | faces (c, 2)]
    floats = [points (c, 3) | normals (c, 3) | depths (c)]

Fields: ``body_a``, ``body_b`` the pair of each contact; ``points`` world contact points;
``normals`` unit world normals from body_b towards body_a; ``depths`` > 0 penetration, < 0 a
gap; ``faces`` [face of a, face of b] (-1 where not a mesh triangle); ``features`` feature ids
(-1: none). A set is never written after it is made: every change makes a new one.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["CONTACT_KEYS", "FLOAT_WIDTH", "INT_WIDTH", "ContactSet", "contact_views"]

CONTACT_KEYS = ("body_a", "body_b", "points", "normals", "depths", "faces", "features")
# int64 and float64 entries per contact
INT_WIDTH = 5
FLOAT_WIDTH = 7


class ContactSet(Mapping):
    """Contacts packed as the kernels write them (see the module docstring).

    Parameters
    ----------
    ints : (>= 5 c,) int64
    floats : (>= 7 c,) float64
    count : int
        Number of contacts c.
    """

    __slots__ = ("_views", "count", "floats", "ints")

    def __init__(self, ints: np.ndarray, floats: np.ndarray, count: int):
        self.ints = ints
        self.floats = floats
        self.count = count
        self._views: dict[str, np.ndarray] = {}

    @classmethod
    def empty(cls) -> ContactSet:
        return cls(np.zeros(0, np.int64), np.zeros(0), 0)

    @classmethod
    def from_fields(cls, fields: Mapping) -> ContactSet:
        """Pack a mapping with every key of ``CONTACT_KEYS`` (arrays of c rows)."""
        c = len(fields["depths"])
        ints, floats = np.empty(INT_WIDTH * c, np.int64), np.empty(FLOAT_WIDTH * c)
        for name, view in zip(CONTACT_KEYS, _contact_views_in_numpy(ints, floats, c), strict=True):
            value = np.asarray(fields[name])
            if value.shape != view.shape:
                raise ValueError(
                    f"contact field {name!r} has shape {value.shape}, not {view.shape}"
                )
            view[...] = value
        return cls(ints, floats, c)

    @classmethod
    def concatenate(cls, sets) -> ContactSet:
        """One set holding the contacts of ``sets`` in order."""
        fields = {key: np.concatenate([s[key] for s in sets]) for key in CONTACT_KEYS}
        return cls.from_fields(fields)

    def select(self, rows: np.ndarray) -> ContactSet:
        """The contacts ``rows`` (a (c,) bool mask or indices) as a new set."""
        return ContactSet.from_fields({key: self[key][rows] for key in CONTACT_KEYS})

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in CONTACT_KEYS:
            raise KeyError(key)
        if not self._views:
            # the kernels' own slicing, run by NumPy: one layout, written once
            fields = _contact_views_in_numpy(self.ints, self.floats, self.count)
            for name, view in zip(CONTACT_KEYS, fields, strict=True):
                view.flags.writeable = False
                self._views[name] = view
        return self._views[key]

    def __iter__(self) -> Iterator[str]:
        return iter(CONTACT_KEYS)

    def __len__(self) -> int:
        return len(CONTACT_KEYS)

    def __repr__(self) -> str:
        return f"ContactSet({self.count} contacts)"


@njit
def contact_views(ints, floats, c):
    """The fields of a packed contact set inside a kernel: (body_a, body_b, points, normals,
    depths, faces, features), views of ``ints`` (>= 5 c,) and ``floats`` (>= 7 c,)."""
    return (
        ints[:c],
        ints[c : 2 * c],
        floats[: 3 * c].reshape((c, 3)),
        floats[3 * c : 6 * c].reshape((c, 3)),
        floats[6 * c : 7 * c],
        ints[3 * c : 5 * c].reshape((c, 2)),
        ints[2 * c : 3 * c],
    )


# ``contact_views``'s Python function (the function itself where numba's JIT is disabled)
_contact_views_in_numpy = getattr(contact_views, "py_func", contact_views)
