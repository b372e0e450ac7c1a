"""Study: both narrow phases on the same convex pairs: time per pair and error against the oracle.

Issue 11 gave convex bodies their own contact path (separating axes pruned by the Gauss map,
GJK and EPA for hulls of many edges, a clipped face manifold); every pair used to go through
the thesis's OBBTree path (triangle intersections, regions, manifold). ``World`` picks the
convex path for convex pairs (``narrow_phase="auto"``) and the OBBTree path for all of them
under ``narrow_phase="mesh"``. Here both answer the same pairs, each in one kernel call as
the world's narrow-phase stage makes it:

* pairs of random convex shapes (boxes of aspect ratio up to 30, hulls of 4 to 64 random
  points, icospheres, cylinders of 5 to 24 sides) under random rotations, B pressed into A
  along the exact least-penetration axis until that penetration is 0.1 %, 2 % or 10 % of
  the larger body's size;
* the error of each path's deepest contact against the exact least penetration of the two
  hulls (:mod:`validation.convex_oracle`: every face normal and edge-pair axis, plain NumPy):
  its depth, relative to the size, and the angle of its normal where the exact axis is
  unique (the runner-up axis deeper by more than 1e-8 of the size);
* the time per pair, in thread CPU time, of interleaved blocks of calls: the convex path with
  its coherence cache filled by the call before (as from one step to the next) and empty,
  and the mesh path.
"""

from __future__ import annotations

import math
import time

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from validation.cases import Case
from validation.convex_oracle import least_penetration
from validation.formatting import format_number
from validation.section import Section, Table

NAME = "narrow_phase_paths"
TITLE = "Convex path against the OBBTree path on the same convex pairs: error and time per pair"

KIND_PAIRS = (
    ("box", "box"),
    ("box", "hull"),
    ("hull", "hull"),
    ("icosphere", "box"),
    ("cylinder", "cylinder"),
)
PAIRS = {"full": 200, "quick": 60, "tiny": 6}
DEPTHS = (1e-3, 0.02, 0.1)  # of the larger body's size
BLOCKS, CALLS = 7, 3
UNIQUE = 1e-8  # the exact axis is unique when the runner-up is deeper by this much of the size
# bodies resting on one floor in the resting case (validation/bench_convex.py's scene)
RESTING_COUNT = {"full": 1000, "quick": 1000, "tiny": 20}
# issue 11's targets per resting pair (us)
RESTING_TARGETS = {"box": 1.0, "icosphere": 3.0}


def cases(scale: str) -> list[Case]:
    return [
        Case(NAME, {"kinds": list(kinds), "pairs": PAIRS[scale], "seed": n}, timed=True)
        for n, kinds in enumerate(KIND_PAIRS)
    ] + [Case(NAME, {"resting": RESTING_COUNT[scale]}, timed=True)]


def _shape(kind: str, rng: np.random.Generator):
    import thesis_rbd as rbd

    if kind == "box":
        return rbd.shapes.box(np.exp(rng.uniform(-1.0, 1.0, 3) * math.log(30.0) / 2))
    if kind == "hull":
        points = rng.normal(size=(int(rng.integers(4, 65)), 3))
        return rbd.TriangleMesh.from_trimesh(trimesh.convex.convex_hull(points))
    if kind == "icosphere":
        return rbd.shapes.icosphere(0.5, int(rng.integers(1, 3)))
    return rbd.shapes.cylinder(0.5, float(rng.uniform(0.3, 2.0)), int(rng.integers(5, 25)))


class _Scene:
    """``count`` pairs (bodies 2k and 2k + 1), each far from the others.

    The library is imported here, not with the module: the campaign's modules are also
    imported beside earlier checkouts of the package (``validation.formulation_before``),
    which have no convex path.
    """

    def __init__(self, kinds, count, seed):
        from thesis_rbd.collision.convex import contacts as convex_contacts
        from thesis_rbd.collision.convex.hull_data import HullSet
        from thesis_rbd.collision.mesh import narrow_phase

        self._convex_contacts = convex_contacts.convex_contacts
        self._speculative = convex_contacts.SPECULATIVE_FRACTION
        self._empty_cache = convex_contacts.empty_cache
        self._mesh_kernel = narrow_phase.contacts_for_pairs
        rng = np.random.default_rng(seed)
        self.meshes, position, orientation, self.depth_fraction = [], [], [], []
        for k in range(count):
            mesh_a, mesh_b = _shape(kinds[0], rng), _shape(kinds[1], rng)
            ra, rb = Rotation.random(random_state=rng), Rotation.random(random_state=rng)
            va = mesh_a.vertices @ ra.as_matrix().T
            vb = mesh_b.vertices @ rb.as_matrix().T
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            fraction = DEPTHS[k % len(DEPTHS)]
            size = max(mesh_a.scale, mesh_b.scale)
            origin = np.array([100.0 * k, 0.0, 0.0])
            # B along u just touching A's extent, then moved along the exact axis until the
            # pair's least penetration is the fraction of the size asked for
            offset = u * ((va @ u).max() - (vb @ u).min())
            for _ in range(20):
                depth, normal = least_penetration(va, vb + offset)[:2]
                if abs(depth - fraction * size) <= 1e-6 * size:
                    break
                offset += (fraction * size - depth) * normal
            self.meshes += [mesh_a, mesh_b]
            position += [origin, origin + offset]
            orientation += [ra.as_quat(), rb.as_quat()]
            self.depth_fraction.append(fraction)
        self.position = np.array(position)
        self.orientation = np.array(orientation)
        self.center_of_mass_local = np.zeros_like(self.position)
        self.pairs = np.arange(2 * count, dtype=np.int64).reshape(count, 2)
        self.hulls, self.trees = HullSet(), narrow_phase.GeometrySet()
        self.hull_of_body = np.array([self.hulls.hull_of(m) for m in self.meshes], np.int64)
        self.query_scratch = convex_contacts.query_scratch_for(self.hulls)
        self.tree_of_body = np.array([self.trees.geometry_of(m) for m in self.meshes], np.int64)
        self.cache = self._empty_cache()
        self.cache = self._convex(self.cache)[1]

    def world(self, body: int) -> np.ndarray:
        R = Rotation.from_quat(self.orientation[body]).as_matrix()
        return self.meshes[body].vertices @ R.T + self.position[body]

    def _convex(self, cache):
        """(contacts, new cache), unpacked as the world's narrow phase unpacks them."""
        return self._convex_contacts(
            self.pairs, self.hull_of_body, self.hulls.arrays(), self.hulls.longest_loop,
            self.query_scratch, self.position, self.orientation,
            self.center_of_mass_local, cache,
            self._speculative, 0.0,
        )  # fmt: skip

    def convex_warm(self):
        return self._convex(self.cache)[0]

    def convex_cold(self):
        return self._convex(self._empty_cache())[0]

    def mesh(self):
        return self._mesh_kernel(
            self.pairs, self.tree_of_body, self.trees.arrays(), self.position, self.orientation,
            self.center_of_mass_local,
        )  # fmt: skip


def _deepest(found, pair_count):
    """Per pair, the deepest contact's (depth, normal); NaN where the pair has none.
    ``found`` is the convex path's ``ContactSet`` or the mesh kernel's tuple."""
    if isinstance(found, tuple):
        body_a, normals, depths = found[0], found[3], found[4]
    else:
        body_a, normals, depths = found["body_a"], found["normals"], found["depths"]
    depth = np.full(pair_count, -np.inf)
    normal = np.full((pair_count, 3), np.nan)
    for row in range(len(depths)):
        k = body_a[row] // 2
        if depths[row] > depth[k]:
            depth[k], normal[k] = depths[row], normals[row]
    depth[np.isneginf(depth)] = np.nan
    return depth, normal


def _run_resting(count: int) -> dict:
    """Per-pair cost of bodies resting on a floor (a box-floor and an icosphere-floor pair
    per body), both paths in interleaved blocks, as ``python -m validation.bench_convex``."""
    from validation.bench_convex import per_pair_costs

    return {"pairs": count, "us_per_pair": per_pair_costs(count=count)}


def run(params: dict) -> dict:
    if "resting" in params:
        return _run_resting(params["resting"])
    scene = _Scene(params["kinds"], params["pairs"], params["seed"])
    count = params["pairs"]
    paths = {"convex": scene.convex_warm, "convex_cold": scene.convex_cold, "mesh": scene.mesh}
    samples = {name: [] for name in paths}
    for _ in range(BLOCKS):
        for name, call in paths.items():
            start = time.thread_time()
            for _ in range(CALLS):
                call()
            samples[name].append((time.thread_time() - start) / CALLS / count)
    exact = [least_penetration(scene.world(2 * k), scene.world(2 * k + 1)) for k in range(count)]
    sizes = np.array([max(scene.meshes[2 * k].scale, scene.meshes[2 * k + 1].scale)
                      for k in range(count)])  # fmt: skip
    depth = np.array([e[0] for e in exact])
    axis = np.array([e[1] for e in exact])
    unique = np.array([e[2] for e in exact]) > depth + UNIQUE * sizes
    result = {"pairs": count, "unique_axes": int(unique.sum())}
    for name in ("convex", "mesh"):
        found_depth, found_normal = _deepest(paths[name](), count)
        missed = np.isnan(found_depth)
        depth_error = np.abs(found_depth - depth) / sizes
        cosine = np.clip(np.einsum("ij,ij->i", found_normal, axis), -1.0, 1.0)
        angle = np.arccos(cosine)
        checked = unique & ~missed
        result[name] = {
            "missed": int(missed.sum()),
            "max_depth_error": float(np.nanmax(depth_error)) if (~missed).any() else None,
            "median_depth_error": float(np.nanmedian(depth_error)) if (~missed).any() else None,
            "max_normal_error": float(angle[checked].max()) if checked.any() else None,
            "pairs_within_1e-9": int((depth_error[~missed] <= 1e-9).sum()),
        }
    for name, values in samples.items():
        result.setdefault(name, {})["us_per_pair"] = 1e6 * float(np.median(values))
    return result


def _resting_table(records: list[dict]) -> tuple[list[dict], Table]:
    rows = []
    for record in records:
        r = record["result"]
        for shape, target in RESTING_TARGETS.items():
            convex = r["us_per_pair"][f"{shape}-floor convex"]
            mesh = r["us_per_pair"][f"{shape}-floor mesh"]
            rows.append({"shape": shape, "pairs": r["pairs"], "convex_us": convex,
                         "mesh_us": mesh, "target_us": target})  # fmt: skip
    table = Table(
        caption="Bodies resting on a floor (validation/bench_convex.py: 0.1 mm deep, tilted by "
        "up to 1e-4 rad, all pairs in one call, the coherence cache from the call before): "
        "time per pair (us, thread CPU time, median of interleaved blocks) and issue 11's "
        "target",
        columns=["pair", "pairs", "convex (us)", "mesh (us)", "mesh / convex", "target (us)"],
        rows=[
            [f"{row['shape']}-floor", str(row["pairs"])]
            + [format_number(row[k]) for k in ("convex_us", "mesh_us")]
            + [format_number(row["mesh_us"] / row["convex_us"]), format_number(row["target_us"])]
            for row in rows
        ],
    )
    return rows, table


def summarise(records: list[dict], figures_dir) -> Section:
    resting = [record for record in records if "resting" in record["params"]]
    records = [record for record in records if "resting" not in record["params"]]
    resting_rows, resting_table = _resting_table(resting)
    rows, table = [], []
    for record in records:
        kinds = "-".join(record["params"]["kinds"])
        r = record["result"]
        row = {
            "kinds": kinds,
            "pairs": r["pairs"],
            "convex_us": r["convex"]["us_per_pair"],
            "convex_cold_us": r["convex_cold"]["us_per_pair"],
            "mesh_us": r["mesh"]["us_per_pair"],
            **{f"{path}_{key}": r[path][key] for path in ("convex", "mesh")
               for key in ("missed", "max_depth_error", "max_normal_error", "pairs_within_1e-9")},
        }  # fmt: skip
        row["speedup"] = row["mesh_us"] / row["convex_us"]
        rows.append(row)
        table.append(
            [kinds, str(row["pairs"])]
            + [format_number(row[k]) for k in ("convex_us", "convex_cold_us", "mesh_us", "speedup")]
            + [
                f"{format_number(row[f'{path}_max_depth_error'])} "
                f"({row[f'{path}_pairs_within_1e-9']} of {row['pairs']} within 1e-9)"
                for path in ("convex", "mesh")
            ]
            + [format_number(row[f"{path}_max_normal_error"]) for path in ("convex", "mesh")]
            + [str(row["convex_missed"]), str(row["mesh_missed"])]
        )
    summary = {
        "rows": rows,
        "depths": list(DEPTHS),
        "least_speedup": min(r["speedup"] for r in rows),
        "most_speedup": max(r["speedup"] for r in rows),
        "convex_worst_depth_error": max(r["convex_max_depth_error"] or 0.0 for r in rows),
        "mesh_worst_depth_error": max(r["mesh_max_depth_error"] or 0.0 for r in rows),
        "convex_missed": sum(r["convex_missed"] for r in rows),
        "mesh_missed": sum(r["mesh_missed"] for r in rows),
        "resting": resting_rows,
    }
    return Section(
        study=NAME,
        title=TITLE,
        summary=summary,
        tables=[
            Table(
                caption="Per kind of pair: time per pair (us, thread CPU time, median of "
                "interleaved blocks; convex with its coherence cache filled and empty), and "
                "the deepest contact's error against the exact least penetration (depth "
                "relative to the size; normal angle in rad where the exact axis is unique)",
                columns=[
                    "pair",
                    "pairs",
                    "convex (us)",
                    "convex, no cache (us)",
                    "mesh (us)",
                    "mesh / convex",
                    "convex depth error",
                    "mesh depth error",
                    "convex normal error",
                    "mesh normal error",
                    "convex: no contact",
                    "mesh: no contact",
                ],
                rows=table,
            ),
            resting_table,
        ],
    )
