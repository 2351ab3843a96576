"""Diagnostics of a world's state: its energy and its deepest contact.

Both visit every contact once, in the pair-visiting order (:mod:`.broadphase.partners`), with the
pair's overlap and the terrain's (:func:`.contact.terrain.terrain_measure`), through the World's
broad phase (the deepest contact of some worlds only, too: the World's check of a starting state
and the environments' ``max_overlap``).
"""

from __future__ import annotations

from .._jit import njit
from .broadphase.grid import build_grid, uses_cells
from .broadphase.partners import partner, partners
from .contact.pair import pair_overlap
from .contact.terrain import terrain_measure
from .per_world import world_model

__all__ = ["contact_energy", "deepest_contact", "world_energy", "world_max_penetration"]


@njit
def contact_energy(b, x, grid, buf, model, D):
    """The penalty springs' energy of world b: 1/2 ks overlap^2 over every contact."""
    e = 0.0
    for i in range(x.shape[1]):
        rows, direct = partners(b, i, x, grid, buf, D)
        for r in range(rows):
            for idx in range(buf[2 * r], buf[2 * r + 1]):
                j = partner(grid, b, idx, direct)
                if j > i:
                    ov = pair_overlap(b, i, j, x, model, D)
                    e += 0.5 * model.ks * ov * ov
        e += terrain_measure(b, i, x, model, D)[0]
    return e


@njit(hot=True)
def deepest_contact(b, x, grid, buf, model, D):
    """World b's largest overlap as a fraction of the smaller radius in contact (0 without contact)."""
    deepest = 0.0
    for i in range(x.shape[1]):
        rows, direct = partners(b, i, x, grid, buf, D)
        for r in range(rows):
            for idx in range(buf[2 * r], buf[2 * r + 1]):
                j = partner(grid, b, idx, direct)
                if j > i:
                    ov = pair_overlap(b, i, j, x, model, D)
                    deepest = max(deepest, ov / min(model.radii[i], model.radii[j]))
        deepest = max(deepest, terrain_measure(b, i, x, model, D)[1])
    return deepest


@njit(entry=True, nogil=True)
def world_energy(x, v, grid, buf, model, g, out):
    """Per world: kinetic + gravitational (-m g . x) + penalty springs (1/2 ks overlap^2)."""
    D = len(g)
    for b in range(x.shape[0]):
        mb = world_model(model, b)
        e = 0.0
        for i in range(x.shape[1]):
            m = 1.0 / mb.inv_mass[i]
            for k in range(D):
                e += 0.5 * m * v[b, i, k] * v[b, i, k] - m * g[k] * x[b, i, k]
        if uses_cells(grid):
            build_grid(b, x, grid, model.cell_size, D)
        out[b] = e + contact_energy(b, x, grid, buf[b], mb, D)


@njit(entry=True, nogil=True)
def world_max_penetration(worlds, x, grid, buf, model, g, out):
    """For each world in ``worlds``: the largest overlap as a fraction of the smaller radius in
    contact (``out[t]`` for ``worlds[t]``)."""
    D = len(g)
    for t in range(worlds.shape[0]):
        b = worlds[t]
        if uses_cells(grid):
            build_grid(b, x, grid, model.cell_size, D)
        out[t] = deepest_contact(b, x, grid, buf[b], world_model(model, b), D)
