"""Slow, obviously correct oracles for the narrow phase (plain Python, NumPy, SciPy LPs).

Nothing here is shared with ``thesis_rbd.collision``: triangle tests are written as loops over
Python floats (or exact ``Fraction``s), set-intersection questions are also answered by
independent linear programs, and the brute-force pair search tests every triangle pair.
"""

from __future__ import annotations

import math
from fractions import Fraction
from itertools import product

import numpy as np
from scipy.optimize import linprog

__all__ = [
    "MESH_KINDS",
    "boxes_overlap_lp",
    "brute_force_pairs",
    "cluster_reference",
    "covariance_axes_reference",
    "examples",
    "least_penetration_reference",
    "point_triangle_distance",
    "random_mesh",
    "random_pose",
    "tri_box_lp",
    "tri_tri_lp",
    "tri_tri_sat",
]


# ------------------------------------------------------------------ plain-Python vector ops
def _sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def tri_tri_sat(P, Q, exact: bool = False) -> tuple[bool, float]:
    """Triangle-triangle overlap by the separating-axis theorem, in plain Python.

    Every candidate axis is tried: both normals, all 9 edge-edge cross products, every edge
    crossed with either normal (in-plane normals for coplanar pairs), and for segment- or
    point-shaped triangles the edges, the corner-to-corner directions and their components
    perpendicular to each edge.
    With ``exact`` the arithmetic is done in ``Fraction``s (exact for float input).

    Returns
    -------
    overlap : bool
        True unless some axis shows a strictly positive gap.
    margin : float
        How clearly the answer holds: if apart, the largest gap over the axes; if
        overlapping, minus the smallest overlap over the non-zero axes (each divided by the
        axis length). Near zero means touching, where rounding may decide either way.
    """
    conv = Fraction if exact else float
    p = [[conv(float(x)) for x in row] for row in np.asarray(P)]
    q = [[conv(float(x)) for x in row] for row in np.asarray(Q)]
    e = [_sub(p[(i + 1) % 3], p[i]) for i in range(3)]
    f = [_sub(q[(i + 1) % 3], q[i]) for i in range(3)]
    n1 = _cross(e[0], e[1])
    n2 = _cross(f[0], f[1])
    axes = [n1, n2]
    axes += [_cross(a, b) for a, b in product(e, f)]
    axes += [_cross(n, a) for n in (n1, n2) for a in e + f]
    # Segment- and point-shaped triangles: edges, corner-to-corner directions, and those
    # directions' components perpendicular to each edge.
    # (Only needed when a normal vanishes: for two proper triangles the axes above are
    # already complete, and these would only slow the exact-arithmetic runs down.)
    if _dot(n1, n1) == 0 or _dot(n2, n2) == 0:
        axes += e + f
        for a in p:
            for b in q:
                w = _sub(b, a)
                axes.append(w)
                axes += [_cross(d, _cross(w, d)) for d in e + f]
    best_gap = -math.inf
    least_overlap = math.inf
    for axis in axes:
        length = math.sqrt(float(_dot(axis, axis)))
        if length == 0:
            continue
        sp = [_dot(axis, v) for v in p]
        sq = [_dot(axis, v) for v in q]
        gap = max(min(sq) - max(sp), min(sp) - max(sq))
        if gap > 0:
            best_gap = max(best_gap, float(gap) / length)
        else:
            least_overlap = min(least_overlap, float(-gap) / length)
    if best_gap > 0:
        return False, best_gap
    return True, -(least_overlap if least_overlap != math.inf else 0.0)


def _feasible(A_eq, b_eq, A_ub=None, b_ub=None, n=0) -> bool:
    res = linprog(
        np.zeros(n), A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=[(None, None)] * n
    )
    return res.status == 0


def tri_tri_lp(P, Q) -> bool:
    """Do triangles P and Q (3, 3) share a point? Feasibility LP over barycentric weights."""
    P = np.asarray(P, float)
    Q = np.asarray(Q, float)
    # Variables a (3), b (3): a, b >= 0, sum a = sum b = 1, P^T a - Q^T b = 0.
    A_eq = np.zeros((5, 6))
    A_eq[:3, :3] = P.T
    A_eq[:3, 3:] = -Q.T
    A_eq[3, :3] = 1
    A_eq[4, 3:] = 1
    b_eq = np.array([0, 0, 0, 1, 1], float)
    res = linprog(np.zeros(6), A_eq=A_eq, b_eq=b_eq, bounds=[(0, None)] * 6)
    return res.status == 0


def tri_box_lp(V, h) -> bool:
    """Does triangle V (3, 3) meet the box |x| <= h centred at the origin? (LP)."""
    V = np.asarray(V, float)
    h = np.asarray(h, float)
    # Variables a (3) >= 0, sum a = 1, -h <= V^T a <= h.
    A_ub = np.vstack([V.T, -V.T])
    b_ub = np.concatenate([h, h])
    res = linprog(
        np.zeros(3), A_ub=A_ub, b_ub=b_ub, A_eq=np.ones((1, 3)), b_eq=[1.0], bounds=[(0, None)] * 3
    )
    return res.status == 0


def boxes_overlap_lp(c1, R1, h1, c2, R2, h2) -> bool:
    """Do two OBBs (centre, axes as columns, half-extents) share a point? (LP)."""
    c1, R1, h1, c2, R2, h2 = (np.asarray(x, float) for x in (c1, R1, h1, c2, R2, h2))
    # Variables s1 (3), s2 (3) with |s| <= h and c1 + R1 s1 = c2 + R2 s2.
    A_eq = np.hstack([R1, -R2])
    bounds = [(-a, a) for a in h1] + [(-b, b) for b in h2]
    res = linprog(np.zeros(6), A_eq=A_eq, b_eq=c2 - c1, bounds=bounds)
    return res.status == 0


def brute_force_pairs(mesh_a, T_a, mesh_b, T_b) -> np.ndarray:
    """Every intersecting [face of A, face of B] pair, sorted: the O(n m) reference.

    Triangles are moved to the world frame; an axis-aligned box prefilter (NumPy, exact:
    boxes that miss cannot hold intersecting triangles) only saves time, then each remaining
    pair is decided by :func:`tri_tri_sat` in plain Python.
    """
    ta = mesh_a.triangles @ np.asarray(T_a)[:3, :3].T + np.asarray(T_a)[:3, 3]
    tb = mesh_b.triangles @ np.asarray(T_b)[:3, :3].T + np.asarray(T_b)[:3, 3]
    lo_a, hi_a = ta.min(axis=1), ta.max(axis=1)
    lo_b, hi_b = tb.min(axis=1), tb.max(axis=1)
    # Slightly widened boxes: the prefilter must never drop a touching pair to rounding.
    pad = 1e-9 * max(mesh_a.scale, mesh_b.scale)
    near = np.all((lo_a[:, None] <= hi_b[None] + pad) & (lo_b[None] <= hi_a[:, None] + pad), axis=2)
    out = []
    for i, j in zip(*np.nonzero(near), strict=True):
        if tri_tri_sat(ta[i], tb[j])[0]:
            out.append((int(i), int(j)))
    return np.array(sorted(out), dtype=np.int64).reshape(-1, 2)


def point_triangle_distance(x, T) -> float:
    """Distance from point x to the (possibly degenerate) triangle T (3, 3), plain Python."""
    x = [float(v) for v in x]
    a, b, c = ([float(v) for v in row] for row in np.asarray(T))

    def seg(p, q):
        d = _sub(q, p)
        dd = _dot(d, d)
        t = 0.0 if dd == 0 else min(max(_dot(_sub(x, p), d) / dd, 0.0), 1.0)
        y = [p[k] + t * d[k] for k in range(3)]
        return math.dist(x, y)

    best = min(seg(a, b), seg(b, c), seg(c, a))
    n = _cross(_sub(b, a), _sub(c, a))
    nn = _dot(n, n)
    if nn > 0:
        s = _dot(n, _sub(x, a)) / nn
        y = [x[k] - s * n[k] for k in range(3)]
        inside = all(
            _dot(_cross(_sub(v1, v0), _sub(y, v0)), n) >= 0 for v0, v1 in ((a, b), (b, c), (c, a))
        )
        if inside:
            best = min(best, math.dist(x, y))
    return best


def covariance_axes_reference(triangles) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (descending) and eigenvectors of the thesis 4.5.1 covariance, via eigh.

    The covariance is built term by term from the formula (a loop over triangles).
    """
    tris = np.asarray(triangles, float)
    total = 0.0
    csum = np.zeros(3)
    msum = np.zeros((3, 3))
    for p, q, r in tris:
        area = 0.5 * np.linalg.norm(np.cross(p - q, p - r))
        c = (p + q + r) / 3
        total += area
        csum += area * c
        msum += area / 12 * (9 * np.outer(c, c) + np.outer(p, p) + np.outer(q, q) + np.outer(r, r))
    cH = csum / total
    C = msum / total - np.outer(cH, cH)
    w, v = np.linalg.eigh(C)
    return w[::-1], v[:, ::-1]


def cluster_reference(points, tolerance) -> list[set[int]]:
    """Connected components of the graph 'distance <= tolerance' (O(c^2) plain loops)."""
    pts = np.asarray(points, float)
    n = len(pts)
    label = list(range(n))

    def find(i):
        while label[i] != i:
            i = label[i]
        return i

    for i in range(n):
        for j in range(i + 1, n):
            if np.linalg.norm(pts[i] - pts[j]) <= tolerance:
                ri, rj = find(i), find(j)
                if ri != rj:
                    label[max(ri, rj)] = min(ri, rj)
    groups: dict[int, set[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), set()).add(i)
    return list(groups.values())


# ------------------------------------------------------------------ random test geometry
MESH_KINDS = ("hull", "noisy_sphere", "torus", "thin_plate", "degenerate")


def random_mesh(kind: str, seed: int):
    """A small random TriangleMesh of the given kind (deterministic in ``seed``).

    hull: convex hull of random points; noisy_sphere: icosphere with radial noise; torus:
    random radii and sections; thin_plate: a flat, open grid of triangles (zero thickness);
    degenerate: an icosphere plus zero-area faces (a repeated vertex, three collinear corners,
    a point).
    """
    import trimesh

    from thesis_rbd import TriangleMesh, shapes

    rng = np.random.default_rng(seed)
    if kind == "hull":
        pts = rng.normal(size=(int(rng.integers(8, 40)), 3)) * rng.uniform(0.3, 1.0, 3)
        hull = trimesh.convex.convex_hull(pts)
        return TriangleMesh(hull.vertices, hull.faces)
    if kind == "noisy_sphere":
        base = trimesh.creation.icosphere(subdivisions=int(rng.integers(1, 3)))
        v = base.vertices * rng.uniform(0.8, 1.2, size=(len(base.vertices), 1))
        return TriangleMesh(v * rng.uniform(0.4, 1.0), base.faces)
    if kind == "torus":
        R = rng.uniform(0.5, 1.0)
        return shapes.torus(R, R * rng.uniform(0.15, 0.6), int(rng.integers(6, 16)), 6)
    if kind == "thin_plate":
        n = int(rng.integers(2, 8))
        x, y = np.meshgrid(np.linspace(-1, 1, n + 1), np.linspace(-0.6, 0.6, n + 1))
        v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
        v[:, :2] += rng.normal(scale=0.02, size=(len(v), 2))
        idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
        faces = np.concatenate([np.stack([a, b, d], -1), np.stack([a, d, c], -1)]).reshape(-1, 3)
        return TriangleMesh(v, faces)
    if kind == "degenerate":
        base = trimesh.creation.icosphere(subdivisions=1)
        v = np.asarray(base.vertices) * rng.uniform(0.4, 1.0)
        f = np.asarray(base.faces)
        e0, e1 = f[0, 0], f[0, 1]
        mid = 0.5 * (v[e0] + v[e1])
        v = np.vstack([v, mid])
        extra = np.array(
            [
                [e0, e0, f[5, 2]],
                [e0, len(v) - 1, e1],
                [f[9, 1], f[9, 1], f[9, 1]],
                [f[12, 0], f[20, 1], f[20, 1]],
            ]
        )
        faces = np.vstack([f, extra])
        rng.shuffle(faces)
        return TriangleMesh(v, faces)
    raise ValueError(kind)


def random_pose(seed: int, reach: float) -> np.ndarray:
    """A random rigid (4, 4) transform: uniform rotation, translation within ``reach``."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    direction = rng.normal(size=3)
    T[:3, 3] = direction / np.linalg.norm(direction) * reach * rng.uniform(0.0, 1.0)
    return T


def least_penetration_reference(P, Q) -> tuple[np.ndarray, float]:
    """Normal (B -> A) and depth of the feature pair of least penetration, by enumeration.

    Candidates: Q's unit normal, minus P's unit normal (of a triangle that is not flat), and
    the 9 unit edge-edge directions oriented to point out of Q (positive on Q's normal minus
    P's normal); depth along u is ``max(Q.u) - min(P.u)``. Mirrors the documented definition
    with plain NumPy.
    """
    P = np.asarray(P, float)
    Q = np.asarray(Q, float)
    na = np.cross(P[1] - P[0], P[2] - P[1])
    nb = np.cross(Q[1] - Q[0], Q[2] - Q[1])
    side = np.zeros(3)
    candidates = []

    def has_plane(T, n):
        # a triangle whose height is below 1e-9 of its longest edge is a segment or point
        longest = max(np.sum((T[(i + 1) % 3] - T[i]) ** 2) for i in range(3))
        return n @ n > 1e-18 * longest**2

    if has_plane(Q, nb):
        candidates.append(nb / np.linalg.norm(nb))
        side += candidates[-1]
    if has_plane(P, na):
        candidates.append(-na / np.linalg.norm(na))
        side += candidates[-1]
    apart = P.mean(0) - Q.mean(0)
    for i in range(3):
        for j in range(3):
            e = P[(i + 1) % 3] - P[i]
            f = Q[(j + 1) % 3] - Q[j]
            c = np.cross(e, f)
            if np.linalg.norm(c) <= 1e-9 * np.linalg.norm(e) * np.linalg.norm(f) or not c.any():
                continue
            u = c / np.linalg.norm(c)
            s = u @ side
            if s < 0 or (s == 0 and u @ apart < 0):
                u = -u
            candidates.append(u)
    if not candidates:
        candidates = [apart / np.linalg.norm(apart) if apart.any() else np.array([0, 0, 1.0])]
    depths = [max(Q @ u) - min(P @ u) for u in candidates]
    k = int(np.argmin(depths))
    return candidates[k], max(depths[k], 0.0)


def examples(n: int) -> int:
    """Hypothesis example count ``n`` scaled by the loaded profile (default profile: 60).

    Tests ask for counts that keep the default run short; ``HYPOTHESIS_PROFILE=thorough``
    (see conftest.py) scales every one of them up in proportion.
    """
    from hypothesis import settings

    return max(1, n * settings.default.max_examples // 60)
