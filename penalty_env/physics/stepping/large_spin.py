"""Large worlds of spinning balls: :mod:`.large`'s Verlet-list stepping with rotation, the
tangential springs with history and rolling resistance.

The algorithm is :mod:`.large`'s, step for step (the list, the slabs stepped even then odd, the
escaped balls, the re-sorts and rebuilds), with what rotation adds:

* each ball's angular velocity and torque, in storage order (a :class:`~..model.Spin` of the
  list's own: ``w``, ``alpha``, ``inv_inertia``, re-sorted with the storage), advanced with the
  ball by symplectic or explicit Euler (w += dt torque / I, as the scalar path);
* the listed pairs and the static spheres and bowls through the scalar law
  (:func:`..contact.listed_spin.listed_spin_forces`), each spring stored per list slot and per
  ball and shape, and carried through every rebuild and re-sort (:mod:`..broadphase.history`);
* the escaped balls' pairs, and the other shapes, in serial passes with the same law, an escaped
  pair's spring where the list holds it or in the escaped ball's table (counted before the pass:
  when a table is short the step returns and the caller grows it, before anything is written).

It is a path of its own, so a scene without rotation compiles and runs exactly :mod:`.large`'s
code. Nothing depends on the thread count: a pair's spring is read and written by the thread of
its lower slot only, the escaped balls and the carry's compaction go serially, and the restore
writes each row from one thread. :func:`run_large_spin_serial` is the same source without parallel
regions (a batch, or a small world).
"""

from __future__ import annotations

import numpy as np

from ..._jit import njit, prange
from ..broadphase.history import (
    CARRY_NEEDED,
    OVERFLOW_NEEDED,
    PENDING,
    move_escaped_springs,
    overflow_slot,
    restore_springs,
    save_springs,
)
from ..broadphase.partners import cell_partners
from ..broadphase.verlet import permute_rows
from ..contact.listed_spin import listed_spin_forces
from ..contact.spin import spin_pair, spin_shapes
from ..contact.terrain import has_summed_shapes
from ..geometry.evaluate import advance_shapes
from .common import final_status
from .large import (
    _advance,
    _collect_escapes,
    _rebuild,
    _rebuild_serial,
    _serial_twin,
    permute_rows_serial,
)

__all__ = ["run_large_spin", "run_large_spin_serial", "LARGE_SPIN_MIN_BALLS", "SERIAL_MAX_SPIN_BALLS"]

# ``stepping="auto"`` steps a world of spinning balls (grid, symplectic or explicit Euler) on this
# path from this many balls (measured: ``python -m penalty_env.bench core``)
LARGE_SPIN_MIN_BALLS = 128
# A single world of spinning balls below this many is stepped serially (the same bits): its step
# has more parallel regions than the plain list's (the block pass, the spins' permutation), and on
# 2 cores two threads were slower than one at every size measured (settled beds of v1's grains,
# 2,000 to 64,000: 0.40x at 2,000, 0.53 at 8,000, 0.85 at 16,000, 0.72 at 32,000, 0.93 at 64,000;
# the plain list's crossover, ``.large.SERIAL_MAX_BALLS``, is 2,000)
SERIAL_MAX_SPIN_BALLS = 65_536


@njit
def _spin_advance(integ, dt, i0, i1, xs, vs, a, es, has_ext, sm, xref, escaped, half2, g, sp):
    """:func:`.large._advance` of slots i0..i1-1, then their spins: w += dt (torque / I), the
    torque zeroed for the next step (the scalar path's alpha = torque / I, then w += dt alpha)."""
    marked = _advance(integ, dt, i0, i1, xs, vs, a, es, has_ext, sm, xref, escaped, half2, g)
    w, alpha, inv_inertia = sp.w, sp.alpha, sp.inv_inertia
    for i in range(i0, i1):
        ii = inv_inertia[i]
        for k in range(w.shape[2]):
            w[0, i, k] += dt * (alpha[0, i, k] * ii)
            alpha[0, i, k] = 0.0
    return marked


@njit(hot=True)
def _touching(i, j, xs, sm, D):
    """Balls i and j overlap (the test of :func:`..contact.pair.pair_geometry`)."""
    l0 = sm.radii[i] + sm.radii[j]
    d0 = xs[0, j, 0] - xs[0, i, 0]
    d1 = xs[0, j, 1] - xs[0, i, 1]
    d2 = xs[0, j, 2] - xs[0, i, 2] if D == 3 else 0.0
    dist2 = d0 * d0 + d1 * d1
    if D == 3:
        dist2 += d2 * d2
    return dist2 < l0 * l0


@njit(hot=True)
def _escaped_pair(e, i, j, xs, vs, a, sm, sp, over, lh, D):
    """The pair of the e-th escaped ball i and ball j, from its lower slot's side; its spring in
    the escaped ball's table (where its listed springs moved as it escaped)."""
    lo = min(i, j)
    hi = max(i, j)
    if sp.kt > 0.0 and sm.mu > 0.0:
        if not _touching(lo, hi, xs, sm, D):
            return
        k = overflow_slot(over, lh.over_partner, e, j)
        spin_pair(0, lo, hi, e, k, xs, vs, a, sm, over, D)
    else:
        spin_pair(0, lo, hi, 0, 0, xs, vs, a, sm, sp, D)


@njit
def _escaped_spin_contacts(xs, vs, a, grid, sm, sp, over, lh, escaped, escapes, ne, cand, D):
    """The escaped balls' pairs (serial, each pair once), met as :func:`.large._escaped_contacts`
    meets them: through the last build's grid, and escaped balls pair by pair."""
    for e in range(ne):
        i = escapes[e]
        m = cell_partners(0, i, xs, grid, False, cand, D)
        for t in range(m):
            j = cand[t]
            if escaped[j] == 0:
                _escaped_pair(e, i, j, xs, vs, a, sm, sp, over, lh, D)
        for f in range(e + 1, ne):
            _escaped_pair(e, i, escapes[f], xs, vs, a, sm, sp, over, lh, D)


@njit
def _escape_room(xs, grid, sm, over, escaped, escapes, ne, cand, D):
    """The most springs an escaped ball's table must hold in this step: its live ones (written in
    the last step: they cannot be reused until the pass has met every pair) and its contacts now
    (a bound: it counts a continuing one twice)."""
    c = over.clock[0]
    most = 0
    for e in range(ne):
        need = 0
        for k in range(over.stamp.shape[2]):
            need += over.stamp[0, e, k] == c
        i = escapes[e]
        m = cell_partners(0, i, xs, grid, False, cand, D)
        for t in range(m):
            j = cand[t]
            if escaped[j] == 0:
                need += _touching(min(i, j), max(i, j), xs, sm, D)
        for f in range(e + 1, ne):
            j = escapes[f]
            need += _touching(min(i, j), max(i, j), xs, sm, D)
        most = max(most, need)
    return most


@njit
def _spin_shape_forces(full, sp, xs, vs, a, near, escaped, ne, first, D):
    """The other shapes' contacts (not the static spheres and bowls) of the balls flagged near them
    and of the escaped ones (serial), each spring at slot ``first`` + the shape's row."""
    if not has_summed_shapes(full.shapes):
        return
    for i in range(xs.shape[1]):
        if (near[i] & 2) != 0 or (ne > 0 and escaped[i] != 0):
            spin_shapes(0, i, xs, vs, a, full, sp, first, True, D)


@njit
def _permute_spins(lw, sp, lh):
    """The spin arrays follow a re-sort of the storage (``lw.order``, set by :func:`.large._rebuild`):
    the angular velocities, the inertia, and each ball's terrain springs."""
    order = lw.order
    n = order.shape[0]
    permute_rows(sp.w, order, lw.tmp)
    it = lh.inertia_tmp
    for i in range(n):
        it[i] = sp.inv_inertia[order[i]]
    for i in range(n):
        sp.inv_inertia[i] = it[i]
    if sp.kt > 0.0:
        S = sp.hist.shape[2]
        st, ht = lh.stamp_tmp, lh.shape_tmp
        for i in range(n):
            for s in range(S):
                st[i, s] = sp.stamp[0, order[i], s]
                for q in range(3):
                    ht[i, s, q] = sp.hist[0, order[i], s, q]
        for i in range(n):
            for s in range(S):
                sp.stamp[0, i, s] = st[i, s]
                for q in range(3):
                    sp.hist[0, i, s, q] = ht[i, s, q]


@njit
def _spin_rebuild(lw, sp, over, lh, xs, vs, es, has_ext, sm, threads, g, full):
    """:func:`.large._rebuild` with the springs carried (:mod:`..broadphase.history`): saved before
    the re-sort (unless already saved: a build that found the list too small), the spin arrays
    re-sorted with the storage, restored after a build. False if a position is not finite; leaves
    ``lw.state[0]`` at 0 when the list or the compact table is too small (``lh.state``)."""
    if sp.kt > 0.0 and lh.state[PENDING] == 0:
        total = save_springs(lw, over, lh)
        if total > lh.carry_partner.shape[0]:
            lh.state[CARRY_NEEDED] = total
            return True
        lh.state[PENDING] = 1
    if not _rebuild(lw, xs, vs, es, has_ext, sm, threads, g, full):
        return False
    _permute_spins(lw, sp, lh)
    if lw.state[0] != 0 and sp.kt > 0.0:
        restore_springs(lw, lh, threads)
        lh.state[PENDING] = 0
        for i in range(lh.slot_ball.shape[0]):
            lh.slot_ball[i] = lw.perm[i]
        over.stamp[:] = -1  # (their partners were old slots)
    return True


@njit
def _spin_slab_forces(
    s, layer, start, xs, vs, a, nbr, cnt, near, sm, sp, first, springs, round_row, escaped, ne, buf, D
):
    listed_spin_forces(
        start[s * layer],
        start[(s + 1) * layer],
        xs,
        vs,
        a,
        nbr,
        cnt,
        near,
        sm,
        sp,
        first,
        springs,
        round_row,
        escaped,
        ne,
        buf,
        D,
    )


@njit
def _spin_even_slabs(
    t, threads, slabs, layer, start, xs, vs, a, nbr, cnt, near, sm, sp, first, springs, round_row, escaped, ne, buf, D
):
    """Thread t's share of the even pass (as :func:`.large._even_slabs`; ``buf`` its block)."""
    for q in range(t, (slabs + 1) // 2, threads):
        _spin_slab_forces(
            2 * q, layer, start, xs, vs, a, nbr, cnt, near, sm, sp, first, springs, round_row, escaped, ne, buf, D
        )


@njit
def _spin_odd_slabs_and_advance(
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
    sp,
    first,
    springs,
    round_row,
    g,
    xref,
    escaped,
    ne,
    buf,
    half2,
):
    """Thread t's share of the odd pass (as :func:`.large._odd_slabs_and_advance`), the spins
    advanced with the balls."""
    D = len(g)
    marked = 0
    q = -1 if t == 0 else np.int64(t)
    while q < slabs // 2:
        s0 = 0
        s1 = 1
        if q >= 0:
            s0 = 1 + 2 * q
            _spin_slab_forces(
                s0, layer, start, xs, vs, a, nbr, cnt, near, sm, sp, first, springs, round_row, escaped, ne, buf, D
            )
            s1 = min(s0 + 2, slabs)
        m = _spin_advance(
            integ, dt, start[s0 * layer], start[s1 * layer], xs, vs, a, es, has_ext, sm, xref, escaped, half2, g, sp
        )
        marked = -1 if (m < 0 or marked < 0) else marked + m
        q = np.int64(t) if q < 0 else q + threads
    return marked


@njit(entry=True, parallel=True)
def run_large_spin(integ, nsteps, dt, x, v, w, ext, has_ext, sm, g, status, lw, sp, over, lh, threads, full):
    """:func:`.large.run_large` for spinning balls (the module's docstring). ``w`` is the world's
    ``(1, n, R)`` angular velocities in ball order (gathered into ``sp.w`` on entry, scattered back
    on exit); ``sp`` the list's :class:`~..model.Spin` (storage order, its springs per list slot,
    ``sp.clock`` the world's step counter), ``over`` the escaped balls' tables (a Spin sharing
    sp's arrays but the springs), ``lh`` the rest of the list's history. Returns the steps taken:
    fewer than ``nsteps`` when the world blew up (``status``), or when the list, the compact table
    or an escaped ball's table is too small (``lw.state[1]``, ``lh.state``: the caller grows it
    and goes on)."""
    D = len(g)
    n = x.shape[1]
    xs, vs, a, es, grid = lw.x, lw.v, lw.a, lw.ext, lw.grid
    perm, nbr, cnt, near, moved = lw.perm, lw.nbr, lw.count, lw.near, lw.moved
    xref, escaped, escapes = lw.xref, lw.escaped, lw.escapes
    ws, alpha, clock, round_row, blocks = sp.w, sp.alpha, sp.clock, lh.round_row, lh.blocks
    first, springs = lh.pair_first, lh.pair_springs
    threads = max(1, min(threads, moved.shape[0]))
    half2 = 0.25 * lw.skin * lw.skin
    R = ws.shape[2]
    for i in prange(n):
        u = perm[i]
        for k in range(D):
            xs[0, i, k] = x[0, u, k]
            vs[0, i, k] = v[0, u, k]
            a[0, i, k] = 0.0
            if has_ext:
                es[0, i, k] = ext[0, u, k]
        for k in range(R):
            ws[0, i, k] = w[0, u, k]
            alpha[0, i, k] = 0.0
    ok = True
    taken = 0
    while taken < nsteps:
        if lw.state[0] == 0:
            ok = _spin_rebuild(lw, sp, over, lh, xs, vs, es, has_ext, sm, threads, g, full)
            if not ok or lw.state[0] == 0:
                break  # a position that is not finite, or a list or table too small: the caller grows it
        ne = lw.state[3]
        if ne > 0:
            if sp.kt > 0.0:
                need = _escape_room(xs, grid, sm, over, escaped, escapes, ne, lw.candidates, D)
                if need > over.stamp.shape[2]:
                    lh.state[OVERFLOW_NEEDED] = need
                    break
            _escaped_spin_contacts(xs, vs, a, grid, sm, sp, over, lh, escaped, escapes, ne, lw.candidates, D)
        _spin_shape_forces(full, sp, xs, vs, a, near, escaped, ne, 0, D)
        layer = grid.dims[0, 0] * grid.dims[0, 1] if D == 3 else grid.dims[0, 0]
        slabs = grid.dims[0, D - 1]
        start = grid.start[0]
        for t in prange(threads):
            _spin_even_slabs(
                t,
                threads,
                slabs,
                layer,
                start,
                xs,
                vs,
                a,
                nbr,
                cnt,
                near,
                sm,
                sp,
                first,
                springs,
                round_row,
                escaped,
                ne,
                blocks[t],
                D,
            )
        for t in prange(threads):
            moved[t] = _spin_odd_slabs_and_advance(
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
                sp,
                first,
                springs,
                round_row,
                g,
                xref,
                escaped,
                ne,
                blocks[t],
                half2,
            )
        taken += 1
        clock[0] += 1  # the step is done: its springs are now the live ones
        _collect_escapes(lw, moved, threads, ne)
        if sp.kt > 0.0 and lw.state[0] != 0 and lw.state[3] > ne:
            # the balls that escaped in this step take their springs into their tables, or the list
            # is rebuilt at the next step when one does not fit
            if not move_escaped_springs(lw, over, lh, ne, lw.state[3], lw.candidates, D):
                lw.state[0] = 0
        advance_shapes(full.shapes, 0, dt, D)
    for i in prange(n):
        u = perm[i]
        for k in range(D):
            x[0, u, k] = xs[0, i, k]
            v[0, u, k] = vs[0, i, k]
        for k in range(R):
            w[0, u, k] = ws[0, i, k]
    status[0] = final_status(0, ok, x, v, D)
    return taken


restore_springs_serial = _serial_twin(restore_springs, "restore_springs_serial")
_spin_rebuild_serial = _serial_twin(
    _spin_rebuild,
    "_spin_rebuild_serial",
    _rebuild=_rebuild_serial,
    restore_springs=restore_springs_serial,
    _permute_spins=_serial_twin(_permute_spins, "_permute_spins_serial", permute_rows=permute_rows_serial),
)
# ``run_large_spin`` on the calling thread alone (see ``.large.run_large_serial``): the same result,
# bit for bit
run_large_spin_serial = _serial_twin(
    run_large_spin, "run_large_spin_serial", entry=True, _spin_rebuild=_spin_rebuild_serial
)
