"""Where a campaign ran: machine, library versions and the commit of the code."""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

__all__ = ["LIBRARIES", "describe_environment"]

# Distribution names whose versions the report states.
LIBRARIES = (
    "thesis_rbd",
    "numpy",
    "scipy",
    "numba",
    "trimesh",
    "python-fcl",
    "pybullet",
    "matplotlib",
    "dask",
    "distributed",
    "jinja2",
    "pytest-benchmark",
)


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _memory_gib() -> float | None:
    try:
        with open("/proc/meminfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) / 2**20
    except OSError:
        pass
    return None


def _git(args, cwd) -> str | None:
    try:
        out = subprocess.run(
            ["git", *args], cwd=cwd, capture_output=True, text=True, timeout=30, check=True
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip()


def describe_environment(repo: Path | None = None) -> dict:
    """Machine, Python, library versions and git state, as JSON-able data.

    Parameters
    ----------
    repo : Path, optional
        Git working tree of the code; the folder above this package by default.

    Returns
    -------
    dict
        ``machine`` (cpu, logical_cores, usable_cores, memory_gib, system), ``python``,
        ``libraries`` (name -> version or None), ``git`` (commit, short, dirty: whether
        tracked files differ from the commit; untracked files are not counted, nor is
        reports/, which the campaign itself rewrites).
    """
    repo = Path(repo) if repo is not None else Path(__file__).resolve().parents[1]
    versions = {}
    for name in LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    commit = _git(["rev-parse", "HEAD"], repo)
    status = _git(
        ["status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)reports"], repo
    )
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {
        "machine": {
            "cpu": _cpu_model(),
            "logical_cores": os.cpu_count(),
            "usable_cores": usable,
            "memory_gib": _memory_gib(),
            "system": f"{platform.system()} {platform.release()}",
        },
        "python": platform.python_version(),
        "libraries": versions,
        "git": {
            "commit": commit,
            "short": commit[:10] if commit else None,
            "dirty": bool(status) if status is not None else None,
        },
    }
