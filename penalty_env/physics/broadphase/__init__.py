"""Broad phases: which pairs of balls can touch.

=============  ================================================================================
module         what it holds
=============  ================================================================================
``grid``       the uniform grid (cell list), rebuilt at every force evaluation
``partners``   the pair-visiting service: every path's order of visiting a ball's partners
``verlet``     the Verlet neighbour list of the large-world path (pairs kept for many steps)
=============  ================================================================================
"""

from .grid import GRID_MIN_BALLS, Grid, build_grid, new_grid, no_grid
from .partners import cell_partners, partners

__all__ = ["GRID_MIN_BALLS", "Grid", "new_grid", "no_grid", "build_grid", "partners", "cell_partners"]
