"""Diagnostics of a world's state: its energy and its deepest contact.

Both visit every contact once with the contact laws' ENERGY and MAXPEN modes (:mod:`.contact`),
through the World's broad phase (the deepest contact of some worlds only, too: the World's check of
a starting state).
"""

from __future__ import annotations

from .._jit import njit
from .broadphase import build_grid, contacts
from .contact import ENERGY, MAXPEN

__all__ = ["world_energy", "world_max_penetration"]


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
def world_max_penetration(worlds, x, v, grid, model, g, out):
    """For each world in ``worlds``: the largest overlap as a fraction of the smaller radius in
    contact (``out[t]`` for ``worlds[t]``)."""
    for t in range(worlds.shape[0]):
        b = worlds[t]
        if grid is not None:
            build_grid(b, x, grid, model, g)
        out[t] = contacts(MAXPEN, b, x, v, x, 0.0, 0.0, grid, model, None, g)
