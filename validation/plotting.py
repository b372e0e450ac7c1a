"""Matplotlib, set up once for the report: headless backend, one style, PNG output."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

__all__ = ["METHOD_STYLES", "new_axes", "save_figure"]

# One look per method across every figure of the report.
METHOD_STYLES = {
    "euler": {"color": "tab:red", "marker": "o", "label": "explicit Euler"},
    "symplectic_euler": {"color": "tab:orange", "marker": "s", "label": "symplectic Euler"},
    "midpoint": {"color": "tab:green", "marker": "^", "label": "midpoint (RK2)"},
    "rk4": {"color": "tab:blue", "marker": "D", "label": "RK4"},
    "verlet": {
        "color": "tab:cyan",
        "marker": "P",
        "label": "velocity Verlet, free turn (default)",
    },
    "pybullet_multibody": {
        "color": "black",
        "marker": "x",
        "linestyle": "--",
        "label": "pybullet btMultiBody (defaults, damping 0)",
    },
    "pybullet_rigidbody": {
        "color": "tab:gray",
        "marker": "+",
        "linestyle": "--",
        "label": "pybullet btRigidBody (defaults, damping 0)",
    },
    "numpy_peer": {"color": "tab:purple", "marker": "v", "linestyle": ":", "label": "NumPy RK4"},
}


def new_axes(title: str, xlabel: str, ylabel: str, xlog=True, ylog=True):
    """A fresh figure and axes with the report's style."""
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if xlog:
        ax.set_xscale("log")
    if ylog:
        ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    return fig, ax


def save_figure(fig, path: Path) -> Path:
    """Write ``fig`` as a PNG at ``path`` and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
