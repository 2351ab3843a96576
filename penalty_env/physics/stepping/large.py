"""Large worlds: a Verlet neighbour list per world, and the force loop parallel over balls.

A world of ``LARGE_WORLD_MIN_BALLS`` balls or more, with the grid and symplectic or explicit Euler,
is stepped here, through its own list (:mod:`..broadphase.verlet`). The pair law is the list's
twin, :func:`..contact.listed.listed_forces`.

The algorithm. A Verlet neighbour list, as LAMMPS and HOOMD keep: every pair within
r_i + r_j + skin is listed once (by its lower storage slot), found through a grid whose cells are
at least that wide. Until a ball has moved skin / 2 from where it was at the build, no pair outside
the list can touch, so a step visits only the list, and each pair's force is computed once and
applied to both balls (Newton's third law, as LAMMPS's "newton on"; measured at 100,000 balls,
1.3x faster than gathering every pair from both sides). The writes stay apart by slabs: with the
storage sorted by cell, one layer of cells along the last axis is a contiguous range of slots, and
its listed partners lie in the same layer or the next. So the even layers run in parallel, then the
odd ones, each layer serially in storage order. A layer's forces are complete once it and the
layer before it have run, and no later work of the step reads its state: so each odd layer, once
its forces are in, advances itself and the (even) layer after it while they are still in cache.
The terrain is tested only for the balls that were within a skin of it at the build (a ball that
has not escaped has moved less than skin / 2 since) and for the escaped ones.

A ball that has moved skin / 2 "escapes": the list no longer speaks for it, and its contacts are
found each step through the build's grid (:func:`_escaped_contacts`, before the layers, while
every ball is still where the step began). In a pile a few fast balls escape long before the rest
move; they no longer force the whole list to be rebuilt. Once ``escapes`` is full, the next step
re-sorts the storage by grid cell (balls that touch sit close in memory) and rebuilds the list.

Nothing depends on the thread count (what each ball receives, and in which order, is fixed by the
layers and the list; the escaped balls go in a serial pass), and the rebuilds depend only on the
state, so splitting the steps over calls changes nothing.

One algorithm, two compilations: :func:`run_large` runs its loops parallel over the balls (a single
large world), :func:`run_large_serial` (the same source without parallel regions, the GIL released)
runs them on the calling thread: the runner steps a batch so, a share of its worlds per thread, and
a world under ``SERIAL_MAX_BALLS`` alone (spinning balls: ``.large_spin.SERIAL_MAX_SPIN_BALLS``). The
result is the same bit for bit.
"""

from __future__ import annotations

from types import FunctionType
from typing import Any

import numpy as np

from ..._jit import njit, prange
from ..broadphase.grid import build_grid
from ..broadphase.partners import cell_partners
from ..broadphase.verlet import build_list, permute_rows
from ..contact.listed import listed_forces
from ..contact.pair import pair_force
from ..contact.terrain import has_summed_shapes, summed_terrain
from ..geometry.evaluate import advance_shapes, terrain_clearance
from .common import final_status

__all__ = [
    "run_large",
    "run_large_serial",
    "LARGE_WORLD_MIN_BALLS",
    "SERIAL_MAX_BALLS",
    "NEIGHBOUR_SKIN",
    "LARGE_WORLD_MAX_ESCAPES",
    "EXPLICIT_EULER",
    "SYMPLECTIC_EULER",
]

# A world this large is stepped with its force loop parallel over balls (symplectic / explicit
# Euler) instead of one world per thread.
LARGE_WORLD_MIN_BALLS = 128
# ... with a Verlet neighbour list: every pair within r_i + r_j + skin, skin = this fraction of the
# largest diameter (rebuilt, and the storage re-sorted by grid cell, once a ball has moved skin / 2)
NEIGHBOUR_SKIN = 0.1
# ... and up to n / 256 (at least 64, at most this many) balls that have moved skin / 2 since (their
# contacts are searched each step, escaped pairs pair by pair) before the list is rebuilt
LARGE_WORLD_MAX_ESCAPES = 256
# A single world below this many balls is stepped serially (:func:`run_large_serial`): a parallel
# region's launch, four per step, costs more than splitting the force loop saves (measured: see
# ``python -m penalty_env.bench scale``)
SERIAL_MAX_BALLS = 2_000
# the two integrators this path runs (``run_large``'s ``integ``)
EXPLICIT_EULER, SYMPLECTIC_EULER = 0, 1


@njit
def _advance(integ, dt, i0, i1, xs, vs, a, es, has_ext, sm, xref, escaped, half2, g):
    """Symplectic / explicit Euler update of storage slots i0..i1-1 (leaving their forces zeroed for
    the next step); marks each slot that is now skin / 2 or more from where the list was built.
    Returns how many it marked, or -1 (after updating every slot) if a displacement is not finite:
    the caller rebuilds, and the rebuild's grid reports a position that is not finite."""
    D = len(g)
    marked = 0
    blown = False
    # flat views, unsigned slots: no negative-index wraparound, no runtime stride per element
    xf = xs.reshape(xs.size)
    vf = vs.reshape(vs.size)
    af = a.reshape(a.size)
    rf = xref.reshape(xref.size)
    ef = es.reshape(es.size)
    for i in range(i0, i1):
        im = sm.inv_mass[i]
        d2 = 0.0
        base = np.uint64(i) * np.uint64(D)
        for k in range(D):
            e = base + np.uint64(k)
            ak = (af[e] + (ef[e] if has_ext else 0.0)) * im + g[k]
            af[e] = 0.0  # ready for the next step's forces
            if integ == SYMPLECTIC_EULER:
                vf[e] += dt * ak
                xf[e] += dt * vf[e]
            else:
                xf[e] += dt * vf[e]
                vf[e] += dt * ak
            dk = xf[e] - rf[e]
            d2 += dk * dk
        if not d2 < half2:
            blown = blown or not np.isfinite(d2)
            if escaped[i] == 0:
                escaped[i] = 1
                marked += 1
    return -1 if blown else marked


@njit
def _escaped_contacts(xs, vs, a, grid, sm, escaped, escapes, ne, cand, D):
    """Pair forces of the escaped balls (serial, each pair once, applied to both balls; the list
    pass skipped them). An escaped ball meets the others through the grid of the last build: every
    ball that has not escaped is within skin / 2 of where that grid put it, and the grid's cells
    are wider than r_i + r_j + skin, so a ball in reach sits in the 3^D cells around the escaped
    ball's current position. Escaped balls meet each other pair by pair."""
    for e in range(ne):
        i = escapes[e]
        m = cell_partners(0, i, xs, grid, False, cand, D)
        for t in range(m):
            j = cand[t]
            if escaped[j] == 0:
                pair_force(0, i, j, xs, vs, a, sm, D)
        for f in range(e + 1, ne):
            pair_force(0, i, escapes[f], xs, vs, a, sm, D)


@njit
def _slab_forces(s, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf):
    """Listed pair forces and terrain contacts of every ball in slab s (serial, storage order:
    :func:`..contact.listed.listed_forces`, ``buf`` its block of the calling thread)."""
    listed_forces(start[s * layer], start[(s + 1) * layer], xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf)


@njit
def _shapes_near(full, lw, xs, D):
    """Flag (bit 2 of ``near``) every ball within a skin of a shape other than the static spheres
    and bowls at the build (each such shape's phi is 1-Lipschitz, or the clearance says -inf: then
    every ball is tested at every step)."""
    table = full.shapes
    if not has_summed_shapes(table):
        return
    near = lw.near
    for i in range(xs.shape[1]):
        p2 = xs[0, i, 2] if D == 3 else 0.0
        if not terrain_clearance(table, 0, xs[0, i, 0], xs[0, i, 1], p2, D) - full.radii[i] >= lw.skin:
            near[i] |= 2


@njit
def _shape_forces(full, xs, vs, a, near, escaped, ne, D):
    """The other shapes' forces on the balls flagged near them and on the escaped ones (serial)."""
    table = full.shapes
    if not has_summed_shapes(table):
        return
    for i in range(xs.shape[1]):
        if (near[i] & 2) != 0 or (ne > 0 and escaped[i] != 0):
            p2 = xs[0, i, 2] if D == 3 else 0.0
            u2 = vs[0, i, 2] if D == 3 else 0.0
            f0, f1, f2 = summed_terrain(
                table, 0, xs[0, i, 0], xs[0, i, 1], p2, vs[0, i, 0], vs[0, i, 1], u2, full.radii[i], full, D
            )
            a[0, i, 0] += f0
            a[0, i, 1] += f1
            if D == 3:
                a[0, i, 2] += f2


@njit
def _rebuild(lw, xs, vs, es, has_ext, sm, threads, g, full):
    """Re-sort the storage by grid cell (balls that touch sit close in memory), then list every
    pair within reach. False if a position is not finite; leaves ``lw.state[0]`` at 0 when a ball
    has more neighbours than the list holds (its last column takes the rejects)."""
    D = len(g)
    grid, perm, escaped = lw.grid, lw.perm, lw.escaped
    n = xs.shape[1]
    if not build_grid(0, xs, grid, sm.cell_size, D):
        return False
    order = lw.order
    for i in range(n):
        order[i] = grid.items[0, i]
    permute_rows(xs, order, lw.tmp)
    permute_rows(vs, order, lw.tmp)
    if has_ext:
        permute_rows(es, order, lw.tmp)
    for i in range(n):
        j = order[i]
        lw.tmp[i, 0] = sm.radii[j]
        lw.tmp[i, 1] = sm.inv_mass[j]
        lw.itmp[i] = perm[j]
    items = grid.items
    for i in range(n):
        sm.radii[i] = lw.tmp[i, 0]
        sm.inv_mass[i] = lw.tmp[i, 1]
        perm[i] = lw.itmp[i]
        escaped[i] = 0
        items[0, i] = i  # the grid now speaks of storage slots
    most = build_list(grid, xs, sm, lw, threads, g)
    _shapes_near(full, lw, xs, D)
    lw.state[1] = most
    lw.state[2] += 1
    lw.state[3] = 0
    if most < lw.nbr.shape[1]:
        lw.state[0] = 1
    return True


@njit
def _even_slabs(t, threads, slabs, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf):
    """Thread t's share of the even pass: the forces of even slabs t, t + threads, ... (round
    robin: the slabs differ in size)."""
    for q in range(t, (slabs + 1) // 2, threads):
        _slab_forces(2 * q, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf)


@njit
def _odd_slabs_and_advance(
    integ,
    dt,
    t,
    threads,
    slabs,
    layer,
    start,
    xs,
    vs,
    a,
    es,
    has_ext,
    nbr,
    cnt,
    near,
    sm,
    g,
    xref,
    escaped,
    ne,
    buf,
    half2,
):
    """Thread t's share of the odd pass: each of its odd slabs' forces, then that slab and the next
    advanced (thread 0 first advances slab 0, complete after the even pass). Returns how many slots
    it marked as escaped, or -1 if a displacement is not finite."""
    marked = 0
    # (an int64 copy of t: a prange index may be unsigned, and int64 with uint64 unifies to float)
    q = -1 if t == 0 else np.int64(t)
    while q < slabs // 2:
        s0 = 0
        s1 = 1
        if q >= 0:
            s0 = 1 + 2 * q
            _slab_forces(s0, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf)
            s1 = min(s0 + 2, slabs)  # this slab and the next, contiguous in storage
        m = _advance(
            integ, dt, start[s0 * layer], start[s1 * layer], xs, vs, a, es, has_ext, sm, xref, escaped, half2, g
        )
        marked = -1 if (m < 0 or marked < 0) else marked + m
        q = np.int64(t) if q < 0 else q + threads
    return marked


@njit
def _collect_escapes(lw, moved, threads, ne):
    """Collect the step's newly escaped slots in storage order; ask for a rebuild when they no
    longer fit, or at once when a position is not finite."""
    escaped, escapes = lw.escaped, lw.escapes
    fresh = 0
    for t in range(threads):
        if moved[t] < 0:
            lw.state[0] = 0
        fresh += moved[t]
    if lw.state[0] != 0 and fresh > 0:
        for i in range(escaped.shape[0]):
            if escaped[i] == 1:
                escaped[i] = 2
                if ne < escapes.shape[0]:
                    escapes[ne] = i
                ne += 1
        if ne > escapes.shape[0]:
            lw.state[0] = 0
    lw.state[3] = ne


@njit(entry=True, parallel=True)
def run_large(integ, nsteps, dt, x, v, ext, has_ext, sm, g, status, lw, threads, full):
    """Symplectic or explicit Euler for a world too large to run one per thread (the module's
    docstring gives the algorithm). Returns the number of steps taken: fewer than ``nsteps`` when
    the world blew up (``status``) or when a ball has more neighbours than the list holds
    (``lw.state[1]`` says how many; the caller grows it and goes on).

    ``x``, ``v``, ``ext``, ``status`` are the world's own ``(1, n, D)`` / ``(1,)`` slices, in ball
    order: gathered into storage order on entry, scattered back on exit. ``sm`` is a Model whose
    radii / inv_mass arrays are the world's own, permuted with the storage, with the static spheres
    and bowls only; ``full`` is the same as a :class:`~..model.Model` with the world's whole shape
    table: the other shapes run in two serial passes (:func:`_shapes_near`, :func:`_shape_forces`).
    ``threads``: how many ways to split the slabs (the thread count, at most ``len(lw.moved)``; the
    result does not depend on it).

    One function (over 80 lines): its parallel loops take the world's arrays one by one, since
    Numba 0.68's parallel regions cannot take them as a tuple (a store through a NamedTuple field
    in a ``prange`` loop is silently dropped; a captured NamedTuple of arrays fails to lower).
    """
    D = len(g)
    n = x.shape[1]
    # (namedtuple fields are bound to locals before the prange loops: Numba 0.68 silently drops
    # stores through ``tuple.field[i] = ...`` inside a parallel loop; reads are fine)
    xs, vs, a, es, grid = lw.x, lw.v, lw.a, lw.ext, lw.grid
    perm, nbr, cnt, near, moved = lw.perm, lw.nbr, lw.count, lw.near, lw.moved
    xref, escaped, escapes, pairs = lw.xref, lw.escaped, lw.escapes, lw.pairs
    threads = max(1, min(threads, moved.shape[0]))
    half2 = 0.25 * lw.skin * lw.skin
    for i in prange(n):
        u = perm[i]
        for k in range(D):
            xs[0, i, k] = x[0, u, k]
            vs[0, i, k] = v[0, u, k]
            a[0, i, k] = 0.0
            if has_ext:
                es[0, i, k] = ext[0, u, k]
    ok = True
    taken = 0
    while taken < nsteps:
        if lw.state[0] == 0:
            ok = _rebuild(lw, xs, vs, es, has_ext, sm, threads, g, full)
            if not ok or lw.state[0] == 0:
                break  # a position that is not finite, or a list too small: the caller grows it
        ne = lw.state[3]
        # the escaped balls' pairs first (serial), then the slabs: each pair once, its force added
        # to both balls; a slab (one layer of cells along the last axis, a contiguous range of the
        # sorted storage) writes only to itself and the next slab, so the even slabs run in
        # parallel, then the odd ones, each advancing itself and the next once its forces are in.
        # What a ball receives, and in which order, depends on the slabs, never on the threads.
        if ne > 0:
            _escaped_contacts(xs, vs, a, grid, sm, escaped, escapes, ne, lw.candidates, D)
        _shape_forces(full, xs, vs, a, near, escaped, ne, D)
        # cells in one layer along the last axis (not "layer = 1; layer *= ...": the literal 1 typed
        # one of the two passes' calls of _slab_forces apart, and compiled it twice)
        layer = grid.dims[0, 0] * grid.dims[0, 1] if D == 3 else grid.dims[0, 0]
        slabs = grid.dims[0, D - 1]
        start = grid.start[0]
        for t in prange(threads):
            _even_slabs(t, threads, slabs, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, pairs[t])
        for t in prange(threads):
            moved[t] = _odd_slabs_and_advance(
                integ,
                dt,
                t,
                threads,
                slabs,
                layer,
                start,
                xs,
                vs,
                a,
                es,
                has_ext,
                nbr,
                cnt,
                near,
                sm,
                g,
                xref,
                escaped,
                ne,
                pairs[t],
                half2,
            )
        taken += 1
        _collect_escapes(lw, moved, threads, ne)
        advance_shapes(full.shapes, 0, dt, D)  # kinematic shapes move on (nothing if none)
    for i in prange(n):
        u = perm[i]
        for k in range(D):
            x[0, u, k] = xs[0, i, k]
            v[0, u, k] = vs[0, i, k]
    status[0] = final_status(0, ok, x, v, D)
    return taken


def _serial_twin(fn: Any, name: str, entry: bool = False, **callees: Any) -> Any:
    """A jitted function of ``fn``'s Python source compiled without ``parallel`` (its ``prange``
    loops run as plain loops, so it launches no parallel region) and with the GIL released, under
    its own name (so its own Numba cache entry), its calls to ``callees`` (name: jitted function)
    replaced. The same source, so the same arithmetic in the same order: the same result."""
    py = fn.py_func
    scope = dict(py.__globals__, **callees)
    twin = FunctionType(py.__code__, scope, name, py.__defaults__, py.__closure__)
    twin.__qualname__ = name
    twin.__module__ = py.__module__
    twin.__doc__ = f"{py.__name__} run serially on the calling thread (see _serial_twin)."
    return njit(entry=entry, nogil=True)(twin)


permute_rows_serial = _serial_twin(permute_rows, "permute_rows_serial")
build_list_serial = _serial_twin(build_list, "build_list_serial")
_rebuild_serial = _serial_twin(
    _rebuild, "_rebuild_serial", permute_rows=permute_rows_serial, build_list=build_list_serial
)
# ``run_large`` on the calling thread alone, ``threads`` = 1: no parallel region, the GIL released;
# the same result as ``run_large``, bit for bit (the runner steps a batch of worlds so, a share of
# the worlds per thread, and a small world alone)
run_large_serial = _serial_twin(run_large, "run_large_serial", entry=True, _rebuild=_rebuild_serial)
