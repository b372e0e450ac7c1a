"""Which recorded frames a playback shows: at most ``fps`` per simulated second."""

from __future__ import annotations

import numpy as np

__all__ = ["playback_frames"]


def playback_frames(times: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the frames to show at ``fps`` frames per simulated second.

    Parameters
    ----------
    times : (T,) float ndarray
        Non-decreasing frame times (s).
    fps : float
        Frames per simulated second, > 0.

    Returns
    -------
    (k,) int64 ndarray
        Increasing indices: for each tick of a 1/fps grid from ``times[0]``, the last frame at
        or before it; the last frame is always included.
    """
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps!r}")
    times = np.asarray(times, dtype=np.float64)
    if len(times) == 0:
        raise ValueError("a trajectory with no frames cannot be played")
    ticks = times[0] + np.arange(int(np.floor((times[-1] - times[0]) * fps + 1e-9)) + 1) / fps
    indices = np.searchsorted(times, ticks + 1e-12, side="right") - 1
    return np.unique(np.append(indices, len(times) - 1)).astype(np.int64)
