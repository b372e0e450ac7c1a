"""pytest-benchmark suites: run one, read its JSON, and compare each benchmark with its peer.

A suite marks the measurements of peer libraries (NumPy, fcl, pybullet, ...) with
``benchmark.extra_info["peer"]``: ``True`` or the peer's name. Within one benchmark group
(``benchmark.group``, e.g. "free flight, N = 1000"), each of our benchmarks is compared with
every peer of the same group as the ratio ``peer median / our median``: above 1 means we are
faster. Suites that follow this convention (bench_dynamics.py, bench_obbtree.py,
bench_sap.py, ...) plug into the report without code of their own.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

__all__ = ["compare_with_peers", "read_benchmarks", "run_benchmark_suite"]

REPO = Path(__file__).resolve().parents[1]
_STATS = ("min", "max", "mean", "median", "stddev", "iqr", "rounds", "iterations", "ops")


def run_benchmark_suite(
    suite: str, select: str | None = None, max_time: float = 1.0, min_rounds: int = 5
) -> dict:
    """Run a pytest-benchmark file in a fresh interpreter and return its parsed JSON.

    Parameters
    ----------
    suite : str
        Path of the benchmark file relative to the repository root.
    select : str, optional
        A pytest ``-k`` expression choosing a subset.
    max_time, min_rounds
        pytest-benchmark's ``--benchmark-max-time`` and ``--benchmark-min-rounds``.

    Returns
    -------
    dict
        The JSON pytest-benchmark wrote.
    """
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.json"
        command = [
            sys.executable,
            "-m",
            "pytest",
            suite,
            "-q",
            "-p",
            "no:cacheprovider",
            "--benchmark-enable",
            "--benchmark-only",
            f"--benchmark-json={out}",
            f"--benchmark-max-time={max_time}",
            f"--benchmark-min-rounds={min_rounds}",
        ]
        if select:
            command += ["-k", select]
        env = dict(
            os.environ,
            PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
        )
        # run from a pytest-xdist worker (the test suite's campaign), the worker's variables
        # would make pytest-benchmark disable itself in the child
        for name in [name for name in env if name.startswith("PYTEST_XDIST")]:
            del env[name]
        done = subprocess.run(command, cwd=REPO, capture_output=True, text=True, env=env)
        if done.returncode != 0 or not out.is_file():
            raise RuntimeError(
                f"benchmark suite {suite} failed (exit {done.returncode}):\n"
                f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
            )
        return json.loads(out.read_text(encoding="utf-8"))


def read_benchmarks(data) -> list[dict]:
    """The benchmarks of a pytest-benchmark JSON, reduced to what the report uses.

    Parameters
    ----------
    data : dict or path-like
        Parsed JSON, or the path of the file.

    Returns
    -------
    list of dict
        ``{"name", "test", "group", "params", "extra_info", "stats"}`` per benchmark, where
        ``test`` is the test function's name and ``stats`` holds seconds (min, max, mean,
        median, stddev, iqr) and counts (rounds, iterations).
    """
    if not isinstance(data, dict):
        data = json.loads(Path(data).read_text(encoding="utf-8"))
    reduced = []
    for bench in data.get("benchmarks", []):
        stats = bench.get("stats", {})
        reduced.append(
            {
                "name": bench["name"],
                "test": bench["name"].split("[", 1)[0],
                "group": bench.get("group"),
                "params": bench.get("params") or {},
                "extra_info": bench.get("extra_info") or {},
                "stats": {key: stats[key] for key in _STATS if key in stats},
            }
        )
    return reduced


def _peer_name(bench: dict) -> str | None:
    peer = bench["extra_info"].get("peer")
    if not peer:
        return None
    return peer if isinstance(peer, str) else bench["test"]


def compare_with_peers(benchmarks: list[dict]) -> list[dict]:
    """Pair every benchmark of ours with every peer benchmark of the same group.

    Parameters
    ----------
    benchmarks : list of dict
        As returned by :func:`read_benchmarks`.

    Returns
    -------
    list of dict
        ``{"group", "name", "peer", "ours_median", "peer_median", "ratio"}`` with
        ``ratio = peer_median / ours_median`` (> 1: ours is faster), in input order.
    """
    peers: dict[str | None, list[dict]] = {}
    for bench in benchmarks:
        if _peer_name(bench):
            peers.setdefault(bench["group"], []).append(bench)
    rows = []
    for bench in benchmarks:
        if _peer_name(bench):
            continue
        for peer in peers.get(bench["group"], []):
            ours, theirs = bench["stats"]["median"], peer["stats"]["median"]
            rows.append(
                {
                    "group": bench["group"],
                    "name": bench["name"],
                    "peer": _peer_name(peer),
                    "ours_median": ours,
                    "peer_median": theirs,
                    "ratio": theirs / ours,
                }
            )
    return rows
