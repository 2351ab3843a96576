"""The uniform grid (cell list): a world's balls counting-sorted into cells of edge >= the largest
diameter, so a ball's possible partners lie in its own and the 3^D adjacent cells. Cells adjacent
along x are adjacent in the sorted order, so each (y, z) row of a neighbourhood is one contiguous
range of the sorted balls (9 in 3D, 3 in 2D).

``World(broadphase="auto")`` uses the grid from ``GRID_MIN_BALLS`` balls per world (the measured
crossover); below that every pair is tested (:func:`.partners.partners` serves both). The grid is
rebuilt at every force evaluation; the neighbour list (:mod:`.verlet`) keeps its pairs for many
steps instead.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ... import _validate as V
from ..._jit import njit

__all__ = ["Grid", "new_grid", "no_grid", "build_grid", "uses_cells", "cell_span", "GRID_MIN_BALLS"]

# ``broadphase="auto"`` uses the grid from this many balls per world (measured crossover:
# ``python -m penalty_env.bench core``, section c).
GRID_MIN_BALLS = 64


class Grid(NamedTuple):
    """Uniform-grid buffers, one grid per world (capacity 0: every pair is tested instead)."""

    start: np.ndarray  # (B, cap + 1) first item of each cell
    items: np.ndarray  # (B, n) ball indices sorted by cell, ascending within a cell
    cell: np.ndarray  # (B, n) linear cell index of each ball
    geom: np.ndarray  # (B, 7) lower corner (3), upper corner (3), cell size
    dims: np.ndarray  # (B, 4) cells per axis (3) and their product
    lead: np.ndarray  # (1,) the first lead[0] balls meet every later ball directly, not through the grid


def new_grid(B: int, n: int, lead: int = 0, cells_per_ball: int = 4) -> Grid:
    """Grid buffers for B worlds of n balls (up to ``cells_per_ball`` n cells; the cells grow if a
    ball flies off).

    ``lead``: the first ``lead`` balls stay out of the grid; each meets every later ball directly
    (all pairs). For a few large balls among many small ones (the sand env's pusher and ball among
    its grains): the cells need only be as wide as the largest of the other balls
    (``Model.cell_size``), and the lead balls do not stretch the grid's box. 0: every ball in the
    grid (the order of the contacts is then exactly that of a grid without lead balls)."""
    n = V.integer("n", n, 1)
    lead = V.integer("lead", lead, 0, n, "balls kept out of the grid, first in index order")
    cells_per_ball = V.integer("cells_per_ball", cells_per_ball, 1)
    cap = max(cells_per_ball * n, 64)
    return Grid(
        start=np.zeros((B, cap + 1), dtype=np.int64),
        items=np.zeros((B, n), dtype=np.int64),
        cell=np.zeros((B, n), dtype=np.int64),
        geom=np.zeros((B, 7)),
        dims=np.ones((B, 4), dtype=np.int64),
        lead=np.array([lead], dtype=np.int64),
    )


def no_grid() -> Grid:
    """The grid of a scene without one: every pair is tested (the arrays' types are a grid's, so
    the kernels compile once for both)."""
    return Grid(
        start=np.zeros((0, 0), dtype=np.int64),
        items=np.zeros((0, 0), dtype=np.int64),
        cell=np.zeros((0, 0), dtype=np.int64),
        geom=np.zeros((0, 7)),
        dims=np.ones((0, 4), dtype=np.int64),
        lead=np.zeros(1, dtype=np.int64),
    )


@njit(hot=True)
def uses_cells(grid):
    """Whether the grid sorts balls into cells (else every pair is tested; None: no grid)."""
    if grid is None:
        return False
    return grid.start.shape[1] > 0


@njit(hot=True)
def _cell_coord(xk, lo, inv_h, nk):
    """Cell index along one axis, clamped to [0, nk); NaN lands in cell 0."""
    q = (xk - lo) * inv_h
    c = int(q) if q >= 0.0 else 0
    return c if c < nk else nk - 1


@njit
def build_grid(b, x, grid, cell_size, D):
    """Counting-sort the balls of world b into cells of edge >= ``cell_size``.

    The grid spans the balls' bounding box. If that box would need more cells than the buffer
    holds (a ball flung far away), the cells grow until it fits: slower, never wrong.
    Returns False if a coordinate is not finite (the caller reports the blow-up).
    """
    n = x.shape[1]
    first = grid.lead[0]  # the lead balls stay out of the grid
    cap = grid.start.shape[1] - 1
    finite = True
    for k in range(3):
        grid.geom[b, k] = 0.0  # lower corner
        grid.geom[b, 3 + k] = 0.0  # upper corner
        grid.dims[b, k] = 1
    for k in range(D):
        lo = np.inf
        hi = -np.inf
        for i in range(first, n):
            xk = x[b, i, k]
            if not math.isfinite(xk):
                finite = False
                continue
            lo = min(lo, xk)
            hi = max(hi, xk)
        if lo <= hi:
            grid.geom[b, k] = lo
            grid.geom[b, 3 + k] = hi
    h = cell_size
    while True:  # float arithmetic: a far-flung ball must not overflow the cell count
        total_f = 1.0
        for k in range(D):
            total_f *= np.floor((grid.geom[b, 3 + k] - grid.geom[b, k]) / h) + 1.0
        if total_f <= cap or not h < np.inf:  # cap >= 1 always holds for a real grid
            break
        h *= max(1.26, (total_f / cap) ** (1.0 / D))
    total = 1
    for k in range(D):
        nk = int((grid.geom[b, 3 + k] - grid.geom[b, k]) / h) + 1
        grid.dims[b, k] = nk
        total *= nk
    grid.geom[b, 6] = h
    grid.dims[b, 3] = total
    inv_h = 1.0 / h
    for c in range(total + 1):
        grid.start[b, c] = 0
    for i in range(first, n):
        c = 0
        stride = 1
        for k in range(D):
            ck = _cell_coord(x[b, i, k], grid.geom[b, k], inv_h, grid.dims[b, k])
            c += ck * stride
            stride *= grid.dims[b, k]
        grid.cell[b, i] = c
        grid.start[b, c] += 1
    running = 0
    for c in range(total):
        running += grid.start[b, c]
        grid.start[b, c] = running  # inclusive prefix: one past the last item of cell c
    grid.start[b, total] = n - first
    for i in range(n - 1, first - 1, -1):  # reverse fill leaves each cell ascending in i
        c = grid.cell[b, i]
        grid.start[b, c] -= 1
        grid.items[b, grid.start[b, c]] = i
    return finite


@njit(hot=True)
def cell_span(b, i, x, grid, D):
    """The 3^D cell neighbourhood of ball i as rows: each (y, z) row is one contiguous range of
    ``grid.items``. Returns x0, x1 (the row's cell span), the y and z spans, and the cells per x
    and y."""
    nx = grid.dims[b, 0]
    ny = grid.dims[b, 1]
    nz = grid.dims[b, 2]
    # cell coordinates of ball i (as build_grid computed them; no integer division needed)
    inv_h = 1.0 / grid.geom[b, 6]
    cx = _cell_coord(x[b, i, 0], grid.geom[b, 0], inv_h, nx)
    cy = _cell_coord(x[b, i, 1], grid.geom[b, 1], inv_h, ny)
    cz = _cell_coord(x[b, i, 2], grid.geom[b, 2], inv_h, nz) if D == 3 else 0
    return (max(cx - 1, 0), min(cx + 2, nx), max(cy - 1, 0), min(cy + 2, ny), max(cz - 1, 0), min(cz + 2, nz), nx, ny)
