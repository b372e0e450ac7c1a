"""The coarse column grid of the sweep-and-prune broad phase (a multi-SAP in one array per axis).

Why: with one sorted list per axis, an endpoint moving by d passes every endpoint of the whole
scene's cross-section within d, ~n^(2/3) per metre at constant density, so the swaps of a
coherent frame grow like n^(5/3) (1.8M per frame at n = 10^5). Splitting the plane across
axis ``a`` into columns of a fixed size, one sorted list per column (Bullet's
btMultiSapBroadphase, after Terdiman), an endpoint passes only the endpoints of its own
column: swaps per endpoint stay bounded and the frame is O(n) again.

The grid: along each dimension ``d``, ``count[d]`` cells of equal size starting at
``origin[d]``; a coordinate outside the grid is clamped into the first or last cell. The
column of axis ``a`` is the pair of cells on the two other dimensions ``b = a + 1`` and
``c = a + 2`` (mod 3), numbered ``cell_b * count[c] + cell_c``. A box is listed in every
column its extent meets. The mapping from a coordinate to its cell is monotone, which is all
the exactness argument needs (``_sap_kernels``): the cell of ``max(lo_i, lo_j)`` is
``max(cell(lo_i), cell(lo_j))``, and lies in both boxes' cell ranges when they overlap.

``grid : (3, 3) float64``
    Row ``d`` is ``[origin, scale, count]``: ``cell = floor((v - origin) * scale)`` clamped to
    ``[0, count - 1]``; ``scale = 0`` and ``count = 1`` for a dimension with one cell.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["choose_grid", "compute_cells", "single_cell_grid"]

# A cell is this many median box edges wide. Swaps per endpoint grow with the column's
# cross-section, records per box with (1 + edge / cell)^2 (a box listed in every column it
# meets): at 8 edges a box is in 1.27 columns per axis on average, and at n = 10^5 a frame of
# the benchmark scene makes ~100 times fewer swaps than one column would.
_CELL_EDGES = 8.0
# Columns hold at least about this many boxes on average: in a small scene the bookkeeping
# of columns would cost more than the swaps it saves.
_BOXES_PER_COLUMN = 256
_MAX_CELLS = 256
# A grid that would list the boxes in more than this many columns per axis on average (many
# boxes far larger than the median) is coarsened until it does not.
_MAX_COLUMNS_PER_BOX = 2.0


def single_cell_grid() -> np.ndarray:
    """(3, 3) grid of one cell in every dimension: one column per axis, the plain SAP."""
    grid = np.zeros((3, 3), dtype=np.float64)
    grid[:, 2] = 1.0
    return grid


def choose_grid(
    box: np.ndarray, cell_edges: float = _CELL_EDGES, boxes_per_column: float = _BOXES_PER_COLUMN
) -> tuple[np.ndarray, np.ndarray]:
    """Grid for the boxes of a full rebuild.

    Parameters
    ----------
    box : (n, 6) float64
        Bounds ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]`` per object.
    cell_edges, boxes_per_column : float, optional
        Smallest cell in median box edges, fewest boxes per column on average (tests make
        both tiny to get many columns from a few boxes).

    Returns
    -------
    grid : (3, 3) float64
        ``[origin, scale, count]`` per dimension (see the module docstring).
    cells : (n, 6) int32
        The cells of ``box`` in it.
    """
    grid = single_cell_grid()
    n = box.shape[0]
    most = min(_MAX_CELLS, int(math.sqrt(n / boxes_per_column)))
    if most < 2:
        return grid, compute_cells(box, grid)
    lo = box[:, 0::2]
    hi = box[:, 1::2]
    origin = lo.min(axis=0)
    extent = hi.max(axis=0) - origin
    edge = np.median(hi - lo, axis=0)
    counts = np.ones(3, dtype=np.int64)
    for d in range(3):
        if extent[d] > 0.0 and np.isfinite(extent[d]):
            wanted = extent[d] / max(cell_edges * edge[d], extent[d] / most)
            counts[d] = max(1, min(most, int(wanted)))
    while True:
        scale = np.where(counts > 1, counts / np.where(extent > 0, extent, 1.0), 0.0)
        grid[:, 0] = origin
        grid[:, 1] = scale
        grid[:, 2] = counts
        cells = compute_cells(box, grid)
        spans = (cells[:, 1::2] - cells[:, 0::2] + 1).astype(np.float64)
        # Columns of axis a per box: spans on the two other dimensions.
        per_box = spans[:, [1, 2, 0]] * spans[:, [2, 0, 1]]
        if per_box.sum(axis=0).max() <= _MAX_COLUMNS_PER_BOX * n or counts.max() == 1:
            return grid, cells
        counts = np.maximum(counts // 2, 1)


@njit
def cell_of(v, origin, scale, count):
    """Cell of coordinate ``v`` on a dimension of the grid, clamped into ``[0, count - 1]``."""
    t = (v - origin) * scale
    # `not t >= 0` also catches NaN (trusted bounds that were not): cell 0, never garbage.
    if not t >= 0.0:
        return 0
    if t >= count:
        return np.int64(count) - 1
    return np.int64(t)


@njit
def compute_cells(box, grid):
    """Cells of every box's bounds: (n, 6) int32 ``[cl_x, ch_x, cl_y, ch_y, cl_z, ch_z]``."""
    n = box.shape[0]
    cells = np.empty((n, 6), dtype=np.int32)
    for i in range(n):
        for d in range(3):
            cells[i, 2 * d] = cell_of(box[i, 2 * d], grid[d, 0], grid[d, 1], grid[d, 2])
            cells[i, 2 * d + 1] = cell_of(box[i, 2 * d + 1], grid[d, 0], grid[d, 1], grid[d, 2])
    return cells
