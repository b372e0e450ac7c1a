"""Study: agreement with python-fcl over thousands of generated mesh pairs.

Each generated case is a pair of meshes (random convex hulls, noisy spheres, tori, thin open
plates) at random poses, placed so that about half of them overlap. For each case
:func:`thesis_rbd.collide` answers "first" (yes/no) and "all" (every intersecting triangle
pair), with an OBBTree variant that cycles through leafless/leaf, triangle/hull fit and
float64/float32; python-fcl (OBBRSS) answers with ``num_max_contacts`` 1 and 100000. The AABB
tree of :mod:`validation.aabb_tree` answers "all" too, with its own traversal and its own
separating-axis triangle test (:mod:`validation.triangle_sat`), sharing no code with the
library's narrow phase. A case id
``family-seed`` regenerates any disagreement exactly (:func:`generate_case`).
"""

from __future__ import annotations

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.section import Section, Table

NAME = "fcl_crosscheck"
TITLE = "Narrow phase: agreement with python-fcl on generated cases"

FAMILIES = ("hull", "noisy_sphere", "torus", "thin_plate")
TREE_VARIANTS = (
    {"leafless": True, "fit": "triangles", "dtype": "float64"},
    {"leafless": False, "fit": "triangles", "dtype": "float64"},
    {"leafless": True, "fit": "hull", "dtype": "float64"},
    {"leafless": True, "fit": "triangles", "dtype": "float32"},
)
# (chunks per family, cases per chunk): full 4 x 4 x 250 = 4000 cases.
CHUNKS = {"full": (4, 250), "quick": (1, 60), "tiny": (1, 6)}


def cases(scale: str) -> list[Case]:
    """Chunks of generated cases per family (accuracy only, may run in parallel)."""
    chunks, size = CHUNKS[scale]
    return [
        Case(NAME, {"family": family, "first_seed": chunk * size, "count": size})
        for family in FAMILIES
        for chunk in range(chunks)
    ]


def _mesh(kind: str, rng):
    import trimesh

    from thesis_rbd import TriangleMesh, shapes

    if kind == "hull":
        points = rng.normal(size=(int(rng.integers(8, 60)), 3)) * rng.uniform(0.2, 1.0, 3)
        hull = trimesh.convex.convex_hull(points)
        return TriangleMesh(hull.vertices, hull.faces)
    if kind == "noisy_sphere":
        base = trimesh.creation.icosphere(subdivisions=int(rng.integers(1, 4)))
        radii = rng.uniform(0.85, 1.15, size=(len(base.vertices), 1))
        return TriangleMesh(base.vertices * radii * rng.uniform(0.4, 1.0), base.faces)
    if kind == "torus":
        major = rng.uniform(0.5, 1.0)
        return shapes.torus(
            major,
            major * rng.uniform(0.15, 0.5),
            int(rng.integers(8, 30)),
            int(rng.integers(6, 16)),
        )
    if kind == "thin_plate":
        n = int(rng.integers(2, 10))
        x, y = np.meshgrid(np.linspace(-1, 1, n + 1), np.linspace(-0.6, 0.6, n + 1))
        vertices = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
        vertices[:, :2] += rng.normal(scale=0.02, size=(len(vertices), 2))
        vertices[:, 2] += rng.normal(scale=0.01, size=len(vertices))
        index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]
        faces = np.concatenate([np.stack([a, b, d], -1), np.stack([a, d, c], -1)]).reshape(-1, 3)
        return TriangleMesh(vertices, faces)
    raise ValueError(f"unknown family {kind!r}")


def _pose(rng, reach):
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    direction = rng.normal(size=3)
    T[:3, 3] = direction / np.linalg.norm(direction) * reach
    return T


def generate_case(family: str, seed: int):
    """The meshes and poses of case ``family-seed``.

    Mesh A is of ``family``; mesh B of a family drawn from all four. B's centre lies at a
    random distance of 0 to 1.1 times the sum of the two meshes' radii from A's.

    Returns
    -------
    mesh_a, mesh_b : thesis_rbd.TriangleMesh
    T_a, T_b : (4, 4) float64
    """
    rng = np.random.default_rng([FAMILIES.index(family), seed])
    mesh_a = _mesh(family, rng)
    mesh_b = _mesh(FAMILIES[int(rng.integers(len(FAMILIES)))], rng)
    radius_a = np.linalg.norm(mesh_a.vertices, axis=1).max()
    radius_b = np.linalg.norm(mesh_b.vertices, axis=1).max()
    T_a = _pose(rng, 0.0)
    T_b = _pose(rng, rng.uniform(0.0, 1.1) * (radius_a + radius_b))
    return mesh_a, mesh_b, T_a, T_b


def run(params: dict) -> dict:
    """Agreement counts of one chunk, and the ids of the disagreeing cases."""
    import thesis_rbd as rbd
    from validation.aabb_tree import AABBTree, aabb_collide
    from validation.fcl_adapter import fcl_collide, fcl_model, fcl_object

    family = params["family"]
    counts = {
        "cases": 0,
        "colliding": 0,
        "first_agrees": 0,
        "all_agrees": 0,
        "aabb_agrees": 0,
        "pairs": 0,
        "triangles": 0,
    }
    disagreements = []
    for seed in range(params["first_seed"], params["first_seed"] + params["count"]):
        mesh_a, mesh_b, T_a, T_b = generate_case(family, seed)
        options = TREE_VARIANTS[seed % len(TREE_VARIANTS)]
        tree_a = rbd.OBBTree(mesh_a, **options)
        tree_b = rbd.OBBTree(mesh_b, **options)
        first = rbd.collide(tree_a, T_a, tree_b, T_b, mode="first")
        everything = rbd.collide(tree_a, T_a, tree_b, T_b, mode="all")
        object_a = fcl_object(fcl_model(mesh_a), T_a)
        object_b = fcl_object(fcl_model(mesh_b), T_b)
        fcl_hit, _ = fcl_collide(object_a, object_b, max_contacts=1)
        _, fcl_pairs = fcl_collide(object_a, object_b)
        fcl_pairs = fcl_pairs[np.lexsort((fcl_pairs[:, 1], fcl_pairs[:, 0]))]
        aabb_pairs, _ = aabb_collide(AABBTree(mesh_a), T_a, AABBTree(mesh_b), T_b)
        first_agrees = first.colliding == fcl_hit
        all_agrees = np.array_equal(everything.pairs, fcl_pairs)
        aabb_agrees = np.array_equal(aabb_pairs, everything.pairs)
        counts["cases"] += 1
        counts["colliding"] += int(fcl_hit)
        counts["first_agrees"] += int(first_agrees)
        counts["all_agrees"] += int(all_agrees)
        counts["aabb_agrees"] += int(aabb_agrees)
        counts["pairs"] += len(fcl_pairs)
        counts["triangles"] += len(mesh_a) + len(mesh_b)
        if not (first_agrees and all_agrees and aabb_agrees):
            ours = {tuple(p) for p in everything.pairs.tolist()}
            theirs = {tuple(p) for p in fcl_pairs.tolist()}
            disagreements.append(
                {
                    "case": f"{family}-{seed}",
                    "tree": options,
                    "ours_colliding": bool(first.colliding),
                    "fcl_colliding": bool(fcl_hit),
                    "pairs_only_ours": len(ours - theirs),
                    "pairs_only_fcl": len(theirs - ours),
                    "aabb_agrees": bool(aabb_agrees),
                }
            )
    return {"counts": counts, "disagreements": disagreements}


def summarise(records: list[dict], figures_dir) -> Section:
    """Agreement counts per family and in total; one row per disagreeing case."""
    per_family = {}
    disagreements = []
    for record in records:
        family = record["params"]["family"]
        total = per_family.setdefault(family, dict.fromkeys(record["result"]["counts"], 0))
        for key, value in record["result"]["counts"].items():
            total[key] += value
        disagreements += record["result"]["disagreements"]
    overall = {
        key: sum(f[key] for f in per_family.values()) for key in next(iter(per_family.values()))
    }
    summary = {
        "families": per_family,
        "overall": overall,
        "disagreements": disagreements,
        "variants": len(TREE_VARIANTS),
    }
    rows = [
        [
            family,
            str(c["cases"]),
            str(c["colliding"]),
            f"{c['first_agrees']} / {c['cases']}",
            f"{c['all_agrees']} / {c['cases']}",
            f"{c['aabb_agrees']} / {c['cases']}",
            str(c["pairs"]),
            format_number(c["triangles"] / (2 * c["cases"])),
        ]
        for family, c in [*per_family.items(), ("all", overall)]
    ]
    tables = [
        Table(
            caption="Agreement with python-fcl (yes/no: 'first' against num_max_contacts 1; "
            "pair sets: 'all' against num_max_contacts 100000) and of the AABB tree's pair "
            "sets with the OBB tree's",
            columns=[
                "family of A",
                "cases",
                "colliding (fcl)",
                "yes/no agrees",
                "pair set agrees",
                "AABB = OBB pairs",
                "pairs (fcl)",
                "mean triangles per mesh",
            ],
            rows=rows,
        )
    ]
    if disagreements:
        tables.append(
            Table(
                caption="Disagreeing cases (regenerate with "
                "validation.studies.fcl_crosscheck.generate_case)",
                columns=[
                    "case",
                    "tree",
                    "ours colliding",
                    "fcl colliding",
                    "pairs only ours",
                    "pairs only fcl",
                    "AABB = OBB pairs",
                ],
                rows=[
                    [
                        d["case"],
                        "{}/{}/{}".format(
                            "leafless" if d["tree"]["leafless"] else "leaf",
                            d["tree"]["fit"],
                            d["tree"]["dtype"],
                        ),
                        format_number(d["ours_colliding"]),
                        format_number(d["fcl_colliding"]),
                        str(d["pairs_only_ours"]),
                        str(d["pairs_only_fcl"]),
                        format_number(d["aabb_agrees"]),
                    ]
                    for d in disagreements
                ],
            )
        )
    return Section(NAME, TITLE, summary, tables=tables)
