"""Adapter to python-fcl, the peer the narrow phase is validated and timed against.

Not library API: it lives with the cross-checks that use it.

python-fcl is an optional (test) dependency, imported lazily with a clear error. fcl's
quaternions are (w, x, y, z); the package's are (x, y, z, w): the reorder lives here only.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "fcl_collide",
    "fcl_model",
    "fcl_object",
    "fcl_transform",
    "quat_wxyz_to_xyzw",
    "quat_xyzw_to_wxyz",
    "require_fcl",
]


def require_fcl():
    """Import and return the ``fcl`` module, or raise ImportError saying how to get it."""
    try:
        import fcl
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "python-fcl is needed for the fcl cross-checks: pip install python-fcl "
            "(or the package's 'test' extra)"
        ) from exc
    return fcl


def quat_xyzw_to_wxyz(q) -> np.ndarray:
    """(..., 4) quaternions from (x, y, z, w) to fcl's (w, x, y, z)."""
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def quat_wxyz_to_xyzw(q) -> np.ndarray:
    """(..., 4) quaternions from fcl's (w, x, y, z) to (x, y, z, w)."""
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def fcl_transform(T):
    """``fcl.Transform`` of a (4, 4) rigid transform (rotation passed as a quaternion)."""
    from scipy.spatial.transform import Rotation

    fcl = require_fcl()
    T = np.asarray(T, dtype=np.float64)
    q_xyzw = Rotation.from_matrix(T[:3, :3]).as_quat()
    return fcl.Transform(quat_xyzw_to_wxyz(q_xyzw), T[:3, 3].copy())


def fcl_model(mesh):
    """``fcl.BVHModel`` (OBBRSS boxes, python-fcl's only kind) over a TriangleMesh."""
    fcl = require_fcl()
    model = fcl.BVHModel()
    model.beginModel(len(mesh.vertices), len(mesh.faces))
    model.addSubModel(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    model.endModel()
    return model


def fcl_object(model, T=None):
    """``fcl.CollisionObject`` of a model at pose ``T`` (identity if None)."""
    fcl = require_fcl()
    if T is None:
        return fcl.CollisionObject(model, fcl.Transform())
    return fcl.CollisionObject(model, fcl_transform(T))


def fcl_collide(obj_a, obj_b, max_contacts: int = 100000):
    """Run ``fcl.collide``; return (colliding, pairs (k, 2) int64 [face of A, face of B]).

    With ``max_contacts=1`` fcl stops at the first intersecting triangle pair.
    """
    fcl = require_fcl()
    request = fcl.CollisionRequest(num_max_contacts=max_contacts)
    result = fcl.CollisionResult()
    hit = fcl.collide(obj_a, obj_b, request, result)
    pairs = np.array([(c.b1, c.b2) for c in result.contacts], dtype=np.int64).reshape(-1, 2)
    return bool(hit), pairs
