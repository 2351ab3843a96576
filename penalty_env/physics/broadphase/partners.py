"""The pair-visiting service: which balls can touch ball i, in one fixed order.

Every path that visits pairs asks here (the scalar contact passes with and without rotation, event
location's scan, the neighbour list's build and its escaped balls), so the visiting order, which
fixes the order in which forces are summed, is defined once:

* all pairs (no grid cells), or i a lead ball: every j > i, ascending;
* through the grid: the balls of i's own and the adjacent cells, cell row by cell row (z, then y,
  then along x), ascending within a cell.

:func:`partners` writes them to a buffer and returns how many there are.
"""

from __future__ import annotations

from ..._jit import njit
from .grid import cell_span, uses_cells

__all__ = ["partners", "cell_partners"]


@njit
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
                if j > i or (not later and j != i):
                    out[count] = j
                    count += 1
    return count


@njit
def partners(b, i, x, grid, out, D):
    """The balls j > i that can touch ball i, in the visiting order (see the module docstring),
    written to ``out`` (at least n long). Returns how many."""
    n = x.shape[1]
    if not uses_cells(grid) or i < grid.lead[0]:
        for j in range(i + 1, n):
            out[j - i - 1] = j
        return n - i - 1
    return cell_partners(b, i, x, grid, True, out, D)
