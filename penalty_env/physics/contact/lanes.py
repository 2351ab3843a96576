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
from ..geometry.evaluate import is_direct
from ..geometry.table import P0, SIGN
from .law import normal_force, regularised_ratio
from .terrain import has_summed_shapes, summed_terrain

__all__ = ["pair_lanes", "direct_terrain_lanes", "summed_terrain_lanes"]


@njit
def pair_lanes(i, j, X, V, A, F, W, model, g):
    """Sphere i against sphere j in every lane: :func:`.pair.pair_force`, masked."""
    D = len(g)
    l0 = model.radii[i] + model.radii[j]
    ks = model.ks
    kd = model.kd
    mu = model.mu
    for w in range(W):
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
        if mu > 0.0:
            vt2 = 0.0
            for k in range(D):
                nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
                vtk = (V[j, k, w] - V[i, k, w]) - vn * nk
                vt2 += vtk * vtk
            ratio = regularised_ratio(model.kf, mu, fn, vt2)
        for k in range(D):
            nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
            fk = fn * nk
            if mu > 0.0:
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
    r = model.radii[i]
    ks = model.ks_terrain
    kd = model.kd_terrain
    mu = model.mu
    sign = table.shape[s, SIGN]
    R = table.shape[s, P0]
    # the scalar kernel's early miss test, as a mask: a Sphere is touched only inside R + r, a
    # Bowl only outside R - r (kept: where R + r rounds down, pen can be ~1e-17 > 0 beyond it)
    is_sphere = sign > 0.0
    t_miss = (R + r) * (R + r) if is_sphere else ((R - r) * (R - r) if R > r else -1.0)
    for w in range(W):
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
        if mu > 0.0:
            t0 = V[i, 0, w] - vn * g0
            t1 = V[i, 1, w] - vn * g1
            vt2 = 0.0
            vt2 += t0 * t0
            vt2 += t1 * t1
            if D == 3:
                t2 = V[i, 2, w] - vn * g2
                vt2 += t2 * t2
            ratio = regularised_ratio(model.kf, mu, fn, vt2)
        f0 = fn * g0
        f1 = fn * g1
        f2 = fn * g2
        if mu > 0.0:
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
def summed_terrain_lanes(i, X, V, A, W, worlds, model, g):
    """Every other shape against sphere i in every lane: the scalar :func:`.terrain.summed_terrain`
    one lane at a time (bit for bit the scalar path's), its sum added to A."""
    D = len(g)
    table = model.shapes
    if not has_summed_shapes(table):
        return
    r = model.radii[i]
    for w in range(W):
        b = worlds[w]
        f0, f1, f2 = summed_terrain(
            table,
            b,
            X[i, 0, w],
            X[i, 1, w],
            X[i, 2, w] if D == 3 else 0.0,
            V[i, 0, w],
            V[i, 1, w],
            V[i, 2, w] if D == 3 else 0.0,
            r,
            model,
            D,
        )
        A[i, 0, w] += f0
        A[i, 1, w] += f1
        if D == 3:
            A[i, 2, w] += f2
