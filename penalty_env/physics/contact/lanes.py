"""The contact law over a block of worlds, one world per SIMD lane.

A block of W worlds is laid out world-innermost, ``(n, D, LANES)`` (:mod:`..stepping.lanes`), and
every operation runs as a loop over the block's worlds, which LLVM vectorises (AVX2 / AVX-512).
The contact test is a mask rather than a branch, and each lane computes the same operations in the
same order as the scalar functions (:mod:`.pair`, :mod:`.terrain`) with the same law
(:mod:`.law`), so the results are bit-identical to them for every world that stays finite
(``tests/physics/test_stepping_paths.py``).

Forces go to the (D, LANES) buffer F first and are then added to i and subtracted from j in
separate loops: with both read-modify-write streams of A in one loop LLVM cannot prove them apart
and runs its scalar fallback (measured 2.8x slower).
"""

from __future__ import annotations

import math

from ..._jit import njit
from ..geometry.evaluate import is_direct, is_moving, miss_test, to_local, to_parent
from ..geometry.sdf import BOX, PLANE, sdf_box, sdf_plane
from ..geometry.table import P0, SIGN
from ..per_world import friction_on, lane, lane_law
from .law import normal_force, regularised_ratio
from .terrain import shape_force, terrain_law

__all__ = ["pair_lanes", "direct_terrain_lanes", "summed_terrain_lanes", "shared_statics"]


@njit
def pair_lanes(i, j, X, V, A, F, W, model, g):
    """Sphere i against sphere j in every lane: :func:`.pair.pair_force`, masked."""
    D = len(g)
    ri = model.radii[i]
    rj = model.radii[j]
    for w in range(W):
        # (a fixed scene's parameters are floats, which ``lane`` returns as they are: LLVM hoists
        # them out of the loop; a per-world scene's are lane rows)
        l0 = lane(ri, w) + lane(rj, w)
        ks = lane(model.ks, w)
        kd = lane(model.kd, w)
        mu = lane(model.mu, w)
        dist2 = 0.0
        for k in range(D):
            dx = X[j, k, w] - X[i, k, w]
            dist2 += dx * dx
        touch = dist2 < l0 * l0
        dist = math.sqrt(dist2)
        overlap = l0 - dist
        inv = 1.0 / dist if dist > 0.0 else 0.0
        # coincident centres take the last axis as normal, as in the scalar kernel; written as an
        # addition (dx * inv is 0 there) because a per-component select defeats vectorisation
        e_last = 0.0 if dist > 0.0 else 1.0
        vn = 0.0
        for k in range(D):
            nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
            vn += (V[j, k, w] - V[i, k, w]) * nk
        fn = -normal_force(ks, kd, overlap, vn, model.no_tension)
        fn = fn if touch else 0.0
        ratio = 0.0
        if friction_on(model.mu):
            vt2 = 0.0
            for k in range(D):
                nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
                vtk = (V[j, k, w] - V[i, k, w]) - vn * nk
                vt2 += vtk * vtk
            ratio = regularised_ratio(lane(model.kf, w), mu, fn, vt2, False)
        for k in range(D):
            nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
            fk = fn * nk
            if friction_on(model.mu):
                fk += ratio * ((V[j, k, w] - V[i, k, w]) - vn * nk)
            F[k, w] = fk if touch else 0.0  # (not 0 x the normal: NaN must not spread)
    for k in range(D):
        for w in range(W):
            A[i, k, w] += F[k, w]
    for k in range(D):
        for w in range(W):
            A[j, k, w] -= F[k, w]


@njit
def _round_lanes(i, s, c0, c1, c2, X, V, A, F, W, model, g):
    """Sphere i against the static sphere or bowl s (centre c) in every lane: its force to A."""
    D = len(g)
    table = model.shapes
    ri = model.radii[i]
    sign = table.shape[s, SIGN]
    R = table.shape[s, P0]
    is_sphere = sign > 0.0
    for w in range(W):
        r = lane(ri, w)
        ks = lane(model.ks_terrain, w)
        kd = lane(model.kd_terrain, w)
        mu = lane(model.mu, w)
        # the scalar kernel's early miss test, as a mask: a Sphere is touched only inside R + r, a
        # Bowl only outside R - r (kept: where R + r rounds down, pen can be ~1e-17 > 0 beyond it)
        t_miss = (R + r) * (R + r) if is_sphere else ((R - r) * (R - r) if R > r else -1.0)
        d0 = X[i, 0, w] - c0
        d1 = X[i, 1, w] - c1
        d2 = X[i, 2, w] - c2 if D == 3 else 0.0
        dist2 = d0 * d0 + d1 * d1
        if D == 3:
            dist2 += d2 * d2
        dist = math.sqrt(dist2)
        phi = sign * (dist - R)
        pen = r - phi
        near = dist2 < t_miss if is_sphere else dist2 > t_miss
        touch = (pen > 0.0) & near
        inv = sign / dist if dist > 0.0 else 0.0
        e_last = 0.0 if dist > 0.0 else 1.0
        # the normal, the last axis at the centre (an addition: a select defeats vectorisation)
        g0 = d0 * inv + 0.0
        g1 = d1 * inv + (e_last if D == 2 else 0.0)
        g2 = d2 * inv + e_last if D == 3 else 0.0
        vn = 0.0
        vn += V[i, 0, w] * g0
        vn += V[i, 1, w] * g1
        if D == 3:
            vn += V[i, 2, w] * g2
        fn = normal_force(ks, kd, pen, vn, model.no_tension)
        fn = fn if touch else 0.0
        ratio = 0.0
        if friction_on(model.mu):
            t0 = V[i, 0, w] - vn * g0
            t1 = V[i, 1, w] - vn * g1
            vt2 = 0.0
            vt2 += t0 * t0
            vt2 += t1 * t1
            if D == 3:
                t2 = V[i, 2, w] - vn * g2
                vt2 += t2 * t2
            ratio = regularised_ratio(lane(model.kf, w), mu, fn, vt2, False)
        f0 = fn * g0
        f1 = fn * g1
        f2 = fn * g2
        if friction_on(model.mu):
            f0 -= ratio * (V[i, 0, w] - vn * g0)
            f1 -= ratio * (V[i, 1, w] - vn * g1)
            if D == 3:
                f2 -= ratio * (V[i, 2, w] - vn * g2)
        F[0, w] = f0 if touch else 0.0
        F[1, w] = f1 if touch else 0.0
        if D == 3:
            F[2, w] = f2 if touch else 0.0
    for k in range(D):
        for w in range(W):
            A[i, k, w] += F[k, w]


@njit
def direct_terrain_lanes(i, X, V, A, F, W, worlds, model, g):
    """Sphere i against every static sphere and bowl in every lane (their forces to A)."""
    D = len(g)
    table = model.shapes
    b = worlds[0]
    for s in range(table.kind.shape[0]):
        if is_direct(table, s):  # static: its centre is the same in every world
            pose = table.pose[b, s]
            _round_lanes(i, s, pose[0], pose[1], pose[2] if D == 3 else 0.0, X, V, A, F, W, model, g)


@njit
def shared_statics(table, worlds, W, D):
    """A bit mask of the table's static planes and boxes (among its first 64 rows) that every
    world of the block holds at world ``worlds[0]``'s pose (centre and rotation: what a static shape's distance
    reads), for :func:`summed_terrain_lanes`. Static shapes do not move while a block is stepped,
    so a block's mask holds for all its steps."""
    mask = 0
    b0 = worlds[0]
    for s in range(min(table.kind.shape[0], 64)):
        if (table.kind[s] != PLANE and table.kind[s] != BOX) or is_moving(table, s) or is_direct(table, s):
            continue
        same = True
        for w in range(1, W):
            for k in range(D + D * D):
                same &= table.pose[worlds[w], s, k] == table.pose[b0, s, k]
        if same:
            mask |= 1 << s
    return mask


@njit
def _static_lanes(i, s, X, V, G, W, pose, model, g, sdf):
    """Shape s, static and at ``pose`` in every world of the block, of the primitive kind whose
    local distance is ``sdf`` (:func:`..geometry.sdf.sdf_plane`, ``sdf_box``: inlined, branches
    LLVM turns into selects), against sphere i in every lane, its force summed into G: the
    arithmetic of :func:`.terrain.shape_force`, written out with no call and no per-lane load of
    the pose in the loop (the miss and contact tests as masks), so LLVM vectorises it; bit for bit
    the scalar's. Compiled once per ``sdf``."""
    D = len(g)
    table = model.shapes
    ri = model.radii[i]
    par = table.shape[s]
    sg, a0, a1, a2 = par[SIGN], par[P0], par[P0 + 1], par[P0 + 2]
    clip = model.no_tension
    for w in range(W):
        r = lane(ri, w)
        ks, kd, mu, kf = lane(model.ks_terrain, w), lane(model.kd_terrain, w), lane(model.mu, w), lane(model.kf, w)
        p0, p1, p2 = X[i, 0, w], X[i, 1, w], (X[i, 2, w] if D == 3 else 0.0)
        miss = miss_test(pose, par, p0, p1, p2, r, D)
        q0, q1, q2 = to_local(pose, p0, p1, p2, D)
        phi, n0, n1, n2 = sdf(q0, q1, q2, a0, a1, a2, D)
        m0, m1, m2 = to_parent(pose, n0, n1, n2, D)
        phi, m0, m1, m2 = sg * phi, sg * m0, sg * m1, sg * m2
        pen = r - phi
        r0, r1, r2 = V[i, 0, w], V[i, 1, w], (V[i, 2, w] if D == 3 else 0.0)
        f0, f1, f2 = terrain_law(pen, m0, m1, m2, r0, r1, r2, ks, kd, clip, mu, kf, D)
        touch = (not miss) & (pen > 0.0)
        G[0, w] += f0 if touch else 0.0  # (+0.0 leaves a sum that started at +0.0 as it was)
        G[1, w] += f1 if touch else 0.0
        if D == 3:
            G[2, w] += f2 if touch else 0.0


@njit
def summed_terrain_lanes(i, X, V, A, G, W, worlds, statics, model, g):
    """Every other shape against sphere i in every lane, summed in the (D, LANES) buffer G in the
    table's order and then added to A, as the scalar :func:`.terrain.summed_terrain` sums them
    (bit for bit): a static plane or box at one pose in every world of the block (``statics``, the
    block's :func:`shared_statics`) vectorised (:func:`_static_lanes`), the other shapes (whose code branches too much to vectorise, or whose
    pose differs between lanes) through the scalar function one lane at a time."""
    D = len(g)
    table = model.shapes
    ri = model.radii[i]
    for k in range(D):
        for w in range(W):
            G[k, w] = 0.0
    for s in range(table.kind.shape[0]):
        if is_direct(table, s):
            continue
        if s < 64 and (statics >> s) & 1:
            if table.kind[s] == PLANE:
                _static_lanes(i, s, X, V, G, W, table.pose[worlds[0], s], model, g, sdf_plane)
            else:
                _static_lanes(i, s, X, V, G, W, table.pose[worlds[0], s], model, g, sdf_box)
            continue
        for w in range(W):
            b = worlds[w]
            p2 = X[i, 2, w] if D == 3 else 0.0
            u2 = V[i, 2, w] if D == 3 else 0.0
            touching, f0, f1, f2 = shape_force(
                table, b, s, X[i, 0, w], X[i, 1, w], p2, V[i, 0, w], V[i, 1, w], u2, lane(ri, w), lane_law(model, w), D
            )
            if touching:
                G[0, w] += f0
                G[1, w] += f1
                if D == 3:
                    G[2, w] += f2
    for k in range(D):
        for w in range(W):
            A[i, k, w] += G[k, w]
