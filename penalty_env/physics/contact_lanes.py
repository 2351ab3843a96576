"""The contact laws' SIMD-across-worlds twin: one world per vector lane.

:func:`pair_contact_lanes` and :func:`terrain_contact_lanes` are :func:`.contact.pair_contact` and
:func:`.contact.terrain_contact` (FORCE mode) for a block of W worlds laid out world-innermost,
``(n, D, LANES)``: every operation runs as a loop over the block's worlds, which LLVM vectorises
(AVX2 / AVX-512). The contact test is a mask rather than a branch, and each lane computes the same
operations in the same order as the reference, so the results are bit-identical to it for every
world that stays finite (``tests/physics/test_stepping_paths.py``). The stepping path that uses
them is :mod:`.lanes`.
"""

from __future__ import annotations

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit
from .contact import FORCE, shape_sign
from .geometry import general_terrain, model_geometry_type

__all__ = ["pair_contact_lanes", "terrain_contact_lanes", "general_terrain_lanes"]


@njit(inline="always")
def pair_contact_lanes(i, j, X, V, A, F, W, model, friction, g):
    """Sphere i against sphere j in every lane: :func:`.contact.pair_contact` (FORCE), masked.

    The force goes to the (D, LANES) buffer F first and is then added to i and subtracted from j
    in separate loops: with both read-modify-write streams of A in one loop LLVM cannot prove them
    apart and runs its scalar fallback (measured 2.8x slower)."""
    D = len(g)
    l0 = model.radii[i] + model.radii[j]
    ks = model.ks
    kd = model.kd
    for w in range(W):
        dist2 = 0.0
        for k in range(D):
            dx = X[j, k, w] - X[i, k, w]
            dist2 += dx * dx
        touch = dist2 < l0 * l0
        dist = np.sqrt(dist2)
        overlap = l0 - dist
        inv = 1.0 / dist if dist > 0.0 else 0.0
        # coincident centres take the last axis as normal, as in the scalar kernel; written as an
        # addition (dx * inv is 0 there) because a per-component select defeats vectorisation
        e_last = 0.0 if dist > 0.0 else 1.0
        vn = 0.0
        for k in range(D):
            nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
            vn += (V[j, k, w] - V[i, k, w]) * nk
        fn = -ks * overlap + kd * vn
        if model.no_tension:
            fn = 0.0 if fn > 0.0 else fn
        fn = fn if touch else 0.0
        ft_over_vt = 0.0
        if friction is not None:
            vt2 = 0.0
            for k in range(D):
                nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
                vtk = (V[j, k, w] - V[i, k, w]) - vn * nk
                vt2 += vtk * vtk
            vt = np.sqrt(vt2)
            ft = min(friction[1] * vt, friction[0] * abs(fn)) / vt
            ft_over_vt = ft if vt2 > 0.0 else 0.0
        for k in range(D):
            nk = (X[j, k, w] - X[i, k, w]) * inv + (e_last if k == D - 1 else 0.0)
            fk = fn * nk
            if friction is not None:
                fk += ft_over_vt * ((V[j, k, w] - V[i, k, w]) - vn * nk)
            F[k, w] = fk if touch else 0.0  # (not 0 x the normal: NaN must not spread)
    for k in range(D):
        for w in range(W):
            A[i, k, w] += F[k, w]
    for k in range(D):
        for w in range(W):
            A[j, k, w] -= F[k, w]


@njit(inline="always")
def terrain_contact_lanes(i, X, V, A, F, W, model, friction, g):
    """Sphere i against every terrain shape in every lane: :func:`.contact.terrain_contact`.
    Through the F buffer too, like :func:`pair_contact_lanes` (measured 7% faster than adding to A directly)."""
    D = len(g)
    r = model.radii[i]
    ks = model.ks_terrain
    kd = model.kd_terrain
    for s in range(model.shape_kind.shape[0]):
        sign = shape_sign(model, s)
        R = model.shape_radius[s]
        # the scalar kernel's early miss test, as a mask: a Sphere is touched only inside R + r, a
        # Bowl only outside R - r (kept: where R + r rounds down, pen can be ~1e-17 > 0 beyond it)
        is_sphere = sign > 0.0
        t_miss = (R + r) * (R + r) if is_sphere else ((R - r) * (R - r) if R > r else -1.0)
        for w in range(W):
            dist2 = 0.0
            for k in range(D):
                dx = X[i, k, w] - model.shape_center[s, k]
                dist2 += dx * dx
            dist = np.sqrt(dist2)
            phi = sign * (dist - R)
            pen = r - phi
            near = dist2 < t_miss if is_sphere else dist2 > t_miss
            touch = (pen > 0.0) & near
            inv = sign / dist if dist > 0.0 else 0.0
            e_last = 0.0 if dist > 0.0 else 1.0
            vn = 0.0
            for k in range(D):
                gk = (X[i, k, w] - model.shape_center[s, k]) * inv + (e_last if k == D - 1 else 0.0)
                vn += V[i, k, w] * gk
            fn = ks * pen - kd * vn
            if model.no_tension:
                fn = 0.0 if fn < 0.0 else fn
            fn = fn if touch else 0.0
            ft_over_vt = 0.0
            if friction is not None:
                vt2 = 0.0
                for k in range(D):
                    gk = (X[i, k, w] - model.shape_center[s, k]) * inv + (e_last if k == D - 1 else 0.0)
                    vtk = V[i, k, w] - vn * gk
                    vt2 += vtk * vtk
                vt = np.sqrt(vt2)
                ft = min(friction[1] * vt, friction[0] * abs(fn)) / vt
                ft_over_vt = ft if vt2 > 0.0 else 0.0
            for k in range(D):
                gk = (X[i, k, w] - model.shape_center[s, k]) * inv + (e_last if k == D - 1 else 0.0)
                fk = fn * gk
                if friction is not None:
                    fk -= ft_over_vt * (V[i, k, w] - vn * gk)
                F[k, w] = fk if touch else 0.0
        for k in range(D):
            for w in range(W):
                A[i, k, w] += F[k, w]


def lane_world(ids, c0, w):
    """The world in lane w: ``c0 + w`` for a contiguous block (``ids`` None), ``ids[w]`` for a
    listed one (jitted code only; resolved by the type of ``ids``)."""
    raise NotImplementedError


@overload(lane_world, inline="always")
def _lane_world(ids, c0, w):
    if isinstance(ids, (types.NoneType, types.Omitted)):
        return lambda ids, c0, w: c0 + w
    return lambda ids, c0, w: ids[w]


def general_terrain_lanes(i, X, V, A, W, ids, c0, model, friction, g):
    """Every general shape (:mod:`.geometry`) against sphere i in every lane (lane w is world
    ``ids[w]``, or ``c0 + w``): the reference's own :func:`.geometry.general_terrain`, one lane at a
    time (the shapes' code branches too much to vectorise), so bit for bit the scalar path's.
    Compiled away when the model has no general shapes (jitted code only)."""
    raise NotImplementedError


@overload(general_terrain_lanes, inline="always")
def _general_terrain_lanes(i, X, V, A, W, ids, c0, model, friction, g):
    if isinstance(model_geometry_type(model), types.NoneType):
        return lambda i, X, V, A, W, ids, c0, model, friction, g: None

    def impl(i, X, V, A, W, ids, c0, model, friction, g):
        D = len(g)
        r = model.radii[i]
        for w in range(W):
            b = lane_world(ids, c0, w)
            val, f0, f1, f2 = general_terrain(
                FORCE,
                model.geometry,
                b,
                X[i, 0, w],
                X[i, 1, w],
                X[i, 2, w] if D == 3 else 0.0,
                V[i, 0, w],
                V[i, 1, w],
                V[i, 2, w] if D == 3 else 0.0,
                r,
                0.0,
                model.ks_terrain,
                model.kd_terrain,
                model.no_tension,
                friction,
                D,
            )
            A[i, 0, w] += f0
            A[i, 1, w] += f1
            if D == 3:
                A[i, 2, w] += f2

    return impl
