"""Diagnostics of a world's state: its energy and its deepest contact.

They visit every contact once with the contact laws' ENERGY and MAXPEN modes (:mod:`.contact`),
through the World's broad phase; :func:`deepest_contacts` also says which balls the deepest joins
(the World's check of a starting state).
"""

from __future__ import annotations

from .._jit import njit
from .broadphase import build_grid, contacts, neighbour_rows
from .contact import ENERGY, MAXPEN, pair_contact, terrain_gap

__all__ = ["world_energy", "world_max_penetration", "deepest_contacts"]


@njit(nogil=True)
def world_energy(x, v, grid, model, g, out):
    """Per world: kinetic + gravitational (-m g . x) + penalty springs (1/2 ks overlap^2)."""
    D = len(g)
    for b in range(x.shape[0]):
        e = 0.0
        for i in range(x.shape[1]):
            m = 1.0 / model.inv_mass[i]
            for k in range(D):
                e += 0.5 * m * v[b, i, k] * v[b, i, k] - m * g[k] * x[b, i, k]
        if grid is not None:
            build_grid(b, x, grid, model, g)
        e += contacts(ENERGY, b, x, v, x, 0.0, 0.0, grid, model, None, g)
        out[b] = e


@njit(nogil=True)
def world_max_penetration(x, v, grid, model, g, out):
    """Per world: the largest overlap as a fraction of the smaller radius in contact."""
    for b in range(x.shape[0]):
        if grid is not None:
            build_grid(b, x, grid, model, g)
        out[b] = contacts(MAXPEN, b, x, v, x, 0.0, 0.0, grid, model, None, g)


@njit(nogil=True)
def deepest_contacts(worlds, x, grid, model, g, frac, kind, first, second):
    """For each world in ``worlds``: its deepest contact as a fraction of the smaller radius in it
    (``frac``; 0 without contact), its kind (0 pair, 1 terrain, -1 none) and its balls (``first``,
    ``second``: the ball pair, or the ball and the terrain shape's index). All pairs, or the grid
    (built here) when given."""
    D = len(g)
    n = x.shape[1]
    for t in range(worlds.shape[0]):
        b = worlds[t]
        best, bk, bi, bj = 0.0, -1, -1, -1
        if grid is not None:
            build_grid(b, x, grid, model, g)
        for i in range(n):
            if grid is not None:
                x0, x1, y0, y1, z0, z1, nx, ny = neighbour_rows(b, i, x, grid, D)
                for qz in range(z0, z1):
                    for qy in range(y0, y1):
                        row = (qz * ny + qy) * nx
                        for idx in range(grid.start[b, row + x0], grid.start[b, row + x1]):
                            j = grid.items[b, idx]
                            if j > i:
                                f = pair_contact(MAXPEN, b, i, j, x, x, x, 0.0, False, model, None, g)
                                if f > best:
                                    best, bk, bi, bj = f, 0, i, j
            else:
                for j in range(i + 1, n):
                    f = pair_contact(MAXPEN, b, i, j, x, x, x, 0.0, False, model, None, g)
                    if f > best:
                        best, bk, bi, bj = f, 0, i, j
            for s in range(model.shape_kind.shape[0]):
                pen = -terrain_gap(b, i, s, x, model, D) / model.radii[i]
                if pen > best:
                    best, bk, bi, bj = pen, 1, i, s
        frac[t] = best
        kind[t] = bk
        first[t] = bi
        second[t] = bj
