"""The pair-visiting service: which balls can touch ball i, in one fixed order.

Every path that visits pairs asks here (the scalar contact passes with and without rotation, event
location's scan, the neighbour list's build and its escaped balls), so the visiting order, which
fixes the order in which forces are summed, is defined once:

* all pairs (no grid cells), or i a lead ball: every j > i, ascending;
* through the grid: the balls of i's own and the adjacent cells, cell row by cell row (z, then y,
  then along x), ascending within a cell.

:func:`partners` gives them as ranges, in that order, without copying a ball index: one range of
ball indices (all pairs, a lead ball) or, through the grid, one range of ``grid.items`` per cell
row; :func:`partner` turns an entry of a range into the ball, and the caller keeps the j > i.
:func:`cell_partners` writes the balls themselves to a buffer (event location, escaped balls).

Where the storage itself is sorted by cell (each grid item is its own slot: the neighbour list
after a rebuild), the later partners of i are, row by row in the same order, contiguous slot
ranges: :func:`later_slots` gives each row's range (the rows before i's own hold only smaller
slots, its own resumes after i), so the list build reads them without a buffer.
"""

from __future__ import annotations

from ..._jit import njit
from .grid import cell_span, uses_cells

__all__ = ["PARTNER_ROWS", "partners", "partner", "cell_partners", "later_slots"]

# the most cell rows a ball's neighbourhood spans (3 x 3 in 3D): :func:`partners` needs twice as
# many slots of scratch
PARTNER_ROWS = 9


@njit(hot=True)
def cell_partners(b, i, x, grid, later, out, D):
    """The balls j of ball i's own and adjacent cells (the grid built for x), in the grid's order,
    written to ``out``: only j > i when ``later``, else every j != i. Returns how many."""
    x0, x1, y0, y1, z0, z1, nx, ny = cell_span(b, i, x, grid, D)
    count = 0
    for qz in range(z0, z1):
        for qy in range(y0, y1):
            row = (qz * ny + qy) * nx
            for idx in range(grid.start[b, row + x0], grid.start[b, row + x1]):
                j = grid.items[b, idx]
                out[count] = j  # written always, kept by advancing (no branch)
                count += 1 if (j > i or (not later and j != i)) else 0
    return count


@njit(hot=True)
def partners(b, i, x, grid, out, D):
    """Where the balls j > i that can touch ball i are, in the visiting order (see the module
    docstring; ``grid`` None: every pair, as a grid without cells): returns (rows, direct), the ranges in ``out`` (``out[2 r]`` to ``out[2 r + 1]``,
    at least ``PARTNER_ROWS`` pairs long). ``direct``: one range of ball indices (all pairs, or i
    a lead ball), else ranges of ``grid.items``, whose entries j <= i the caller skips. Read them
    with :func:`partner`::

        rows, direct = partners(b, i, x, grid, buf, D)
        for r in range(rows):
            for idx in range(buf[2 * r], buf[2 * r + 1]):
                j = partner(grid, b, idx, direct)
                if j > i:
                    ...
    """
    if grid is None:  # (a path without a grid: compiled away)
        out[0] = i + 1
        out[1] = x.shape[1]
        return 1, True
    if not uses_cells(grid) or i < grid.lead[0]:
        out[0] = i + 1
        out[1] = x.shape[1]
        return 1, True
    x0, x1, y0, y1, z0, z1, nx, ny = cell_span(b, i, x, grid, D)
    rows = 0
    for qz in range(z0, z1):
        for qy in range(y0, y1):
            row = (qz * ny + qy) * nx
            out[2 * rows] = grid.start[b, row + x0]
            out[2 * rows + 1] = grid.start[b, row + x1]
            rows += 1
    return rows, False


@njit(hot=True)
def partner(grid, b, idx, direct):
    """The ball at entry ``idx`` of a range of :func:`partners`."""
    if grid is None:
        return idx
    return idx if direct else grid.items[b, idx]


@njit(hot=True)
def later_slots(grid, b, row, x0, x1, i):
    """For storage sorted by cell (grid item = slot): the slots j > i of the cells ``x0`` to
    ``x1 - 1`` of the cell row starting at ``row`` (one row of :func:`cell_partners`' visit), as a
    range (lo, hi)."""
    return max(grid.start[b, row + x0], i + 1), grid.start[b, row + x1]
