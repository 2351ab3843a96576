"""A world's contact passes and its accelerations (the scalar path's, which every integrator and
the event location use).

:func:`contact_forces` visits every contact of world b once, in the fixed order of the pair-visiting
service (each ball's later partners, then its terrain), and adds each contact law's force;
:func:`accelerations` turns that into ``a = (contact forces + external force) / m + g``. With
rotation (a :class:`~..model.Spin`, else None) the rotating law runs instead
(:func:`..contact.spin.spin_forces`), which also sets the angular accelerations; a scene whose
balls do not spin compiles none of it. ``buf`` is a (n,) int scratch for the partners.
"""

from __future__ import annotations

from ..._jit import njit
from ..broadphase.grid import build_grid, uses_cells
from ..broadphase.partners import partner, partners
from ..contact.pair import pair_force, pair_jacobian
from ..contact.spin import spin_forces
from ..contact.terrain import terrain_force, terrain_jacobian

__all__ = ["contact_forces", "contact_jacobian", "accelerations", "spin_kick"]


@njit(hot=True)
def contact_forces(b, x, v, out, grid, buf, model, D):
    """Add every contact force of world b to ``out`` (the grid, if it has cells, built for x)."""
    for i in range(x.shape[1]):
        rows, direct = partners(b, i, x, grid, buf, D)
        if direct:  # one range of later balls (all pairs, a lead ball): no test per pair
            for j in range(buf[0], buf[1]):
                pair_force(b, i, j, x, v, out, model, D)
        else:
            for r in range(rows):
                for idx in range(buf[2 * r], buf[2 * r + 1]):
                    j = partner(grid, b, idx, direct)
                    if j > i:
                        pair_force(b, i, j, x, v, out, model, D)
        terrain_force(b, i, x, v, out, model, D)


@njit(hot=True)
def contact_jacobian(b, x, p, out, coef_pair, coef_terrain, diag, grid, buf, model, D):
    """The linearised backward Euler step's products over every contact of world b
    (:func:`..contact.pair.pair_jacobian`, :func:`..contact.terrain.terrain_jacobian`)."""
    for i in range(x.shape[1]):
        rows, direct = partners(b, i, x, grid, buf, D)
        for r in range(rows):
            for idx in range(buf[2 * r], buf[2 * r + 1]):
                j = partner(grid, b, idx, direct)
                if j > i:
                    pair_jacobian(b, i, j, x, p, out, coef_pair, diag, model, D)
        terrain_jacobian(b, i, x, p, out, coef_terrain, diag, model, D)


@njit(hot=True)
def accelerations(b, x, v, a, ext, has_ext, grid, buf, model, spin, g):
    """a = (contact forces + ext) / m + g for world b at state (x, v) (``ext`` read only when
    ``has_ext``); with rotation also ``spin.alpha``. False if x is not finite."""
    D = len(g)
    n = x.shape[1]
    finite = True
    for i in range(n):
        for k in range(D):
            a[b, i, k] = 0.0
    if uses_cells(grid):
        finite = build_grid(b, x, grid, model.cell_size, D)
    if spin is None:
        contact_forces(b, x, v, a, grid, buf[b], model, D)
    else:
        spin_forces(b, x, v, a, grid, buf[b], model, spin, D)
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            if has_ext:
                a[b, i, k] = (a[b, i, k] + ext[b, i, k]) * im + g[k]
            else:
                a[b, i, k] = a[b, i, k] * im + g[k]
    return finite


@njit(hot=True)
def spin_kick(spin, b, dt):
    """w += dt alpha (explicit, symplectic and implicit Euler); nothing without rotation."""
    if spin is None:
        return
    w, al = spin.w, spin.alpha
    for i in range(w.shape[1]):
        for k in range(w.shape[2]):
            w[b, i, k] += dt * al[b, i, k]
