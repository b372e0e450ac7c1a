"""Study: every URDF file pybullet ships, loaded with ``rbd.load_urdf`` or refused.

pybullet_data installs with pybullet and holds 1095 URDF files (1000 of them the
``random_urdfs`` objects, the rest robots, grippers, trays and test models). Each is loaded
into a fresh world as a user would load it: with the defaults, and where that is refused
because the root link has no mass, with ``fixed_base=True`` (pybullet makes a zero-mass base
immovable without being asked), and where it is refused for a link's inertia tensor, with
``inertia="shapes"`` (pybullet computes inertia from the collision shapes unless told to
read the file's). A file is counted as loaded (and with which of these), or refused; a
refusal's message names the file and the element, and the report groups the refusals by
their reason. Anything else raised (a crash rather than a refusal) is counted as such, and
there should be none.
"""

from __future__ import annotations

import re
import time
from collections import Counter

import numpy as np

from validation.cases import Case
from validation.section import Section, Table

NAME = "urdf_survey"
TITLE = "Every URDF in pybullet_data: loaded or refused with a reason"

# files per case (the cases are independent and run in parallel where the campaign may)
CHUNK = 100
# every k-th file of the sorted list at each scale
STRIDE = {"full": 1, "quick": 5, "tiny": 200}
MASSLESS_ROOT = "loads with fixed_base=True"
OPTION_NAMES = {"fixed_base": ", fixed base", "inertia": ", inertia from its shapes"}


def _files() -> list[str]:
    """Every URDF file of pybullet_data, relative to its folder, sorted."""
    from pathlib import Path

    import pybullet_data

    root = Path(pybullet_data.getDataPath())
    return sorted(str(path.relative_to(root)) for path in root.rglob("*.urdf"))


def cases(scale: str) -> list[Case]:
    """Chunks of the file list (every file at full scale)."""
    files = _files()[:: STRIDE[scale]]
    return [Case(NAME, {"files": files[i : i + CHUNK]}) for i in range(0, len(files), CHUNK)]


def _attempts(path: str) -> dict:
    """Load a file at the defaults; where that is refused for a massless root, again with
    ``fixed_base=True``, and for an inertia tensor, again with ``inertia="shapes"`` (each
    as pybullet would load it unasked). The outcome's fields, or the last refusal."""
    import thesis_rbd as rbd

    options = {}
    refusals = []
    while True:
        world = rbd.World()
        try:
            robot = rbd.load_urdf(world, path, **options)
        except ValueError as exc:
            message = str(exc) if not refusals else str(exc).split(": ", 1)[-1]
            refusals.append(message + "".join(f" (with {k}={v!r})" for k, v in options.items()))
            if MASSLESS_ROOT in str(exc) and "fixed_base" not in options:
                options["fixed_base"] = True
            elif "inertia" in str(exc) and "inertia" not in options:
                options["inertia"] = "shapes"
            else:
                raise ValueError("; then ".join(refusals)) from exc
            continue
        status = "loaded" + "".join(OPTION_NAMES[k] for k in sorted(options))
        return {
            "status": status, "links": len(robot.bodies), "bodies": world.bodies.count,
            "joints": len(robot.joints),
        }  # fmt: skip


def run(params: dict) -> dict:
    """Each file's outcome: status, the refusal's reason, and what was built."""
    from pathlib import Path

    import pybullet_data

    root = Path(pybullet_data.getDataPath())
    rows = []
    for name in params["files"]:
        path = str(root / name)
        start = time.perf_counter()
        row = {"file": name, "status": "loaded", "reason": ""}
        try:
            row.update(_attempts(path))
        except (ValueError, ImportError) as exc:
            row["status"] = "refused"
            row["reason"] = str(exc).replace(path, name)
        except Exception as exc:
            row["status"] = "crashed"
            row["reason"] = f"{type(exc).__name__}: {exc}"
        row["seconds"] = time.perf_counter() - start
        rows.append(row)
    return {"rows": rows}


def _reason_kind(reason: str) -> str:
    """A refusal's reason without the file, link, joint and numbers it names."""
    text = reason.split(": ", 1)[1] if ": " in reason else reason
    text = re.sub(r"'[^']*'", "'...'", text)
    text = re.sub(r"\(looked for [^)]*\)", "", text)
    return re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "#", text).strip()


def summarise(records: list[dict], figures_dir) -> Section:
    """Counts by outcome, the refusals grouped by reason, and load times."""
    rows = [row for record in records for row in record["result"]["rows"]]
    status = Counter(row["status"] for row in rows)
    refused = [row for row in rows if row["status"] in ("refused", "crashed")]
    kinds = Counter(_reason_kind(row["reason"]) for row in refused)
    example = {}
    for row in refused:
        example.setdefault(_reason_kind(row["reason"]), row)
    seconds = np.array([row["seconds"] for row in rows])
    summary = {
        "files": len(rows),
        "loaded": status["loaded"],
        "loaded_with_options": sum(
            count for outcome, count in status.items() if outcome.startswith("loaded, ")
        ),
        "refused": status["refused"],
        "crashed": status["crashed"],
        "median_load_ms": float(np.median(seconds)) * 1e3,
        "slowest_load_s": float(seconds.max()),
        "slowest_file": rows[int(seconds.argmax())]["file"],
        "reasons": len(kinds),
    }
    outcome_table = Table(
        caption="pybullet_data's URDF files through rbd.load_urdf",
        columns=["outcome", "files"],
        rows=[[outcome, str(count)] for outcome, count in sorted(status.items())]
        + [["all", str(len(rows))]],
    )
    reason_table = Table(
        caption="Why the refused files were refused (names and numbers elided), with one "
        "file and its message each",
        columns=["reason", "files", "for example"],
        rows=[
            [kind, str(count), f"{example[kind]['reason']}"] for kind, count in kinds.most_common()
        ],
    )
    return Section(NAME, TITLE, summary, tables=[outcome_table, reason_table])
