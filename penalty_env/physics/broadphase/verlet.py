"""The Verlet neighbour list of the large-world path (:mod:`..stepping.large`).

Every pair within r_i + r_j + skin is listed once, by its lower storage slot, found through a grid
whose cells are at least that wide (the pair-visiting service, :func:`.partners.cell_partners`).
Until a ball has moved skin / 2 from where it was at the build, no pair outside the list can
touch, so a step visits only the list. At every build the storage is re-sorted by grid cell, so a
ball's neighbours sit close in memory and one layer of cells along the last axis is a contiguous
range of slots (the large-world path's slabs).

:class:`SlimModel` is what the list's parallel passes read: Numba's parallel loops take a tuple
argument only one level deep, so the terrain's static spheres and bowls come as flat arrays and
the other shapes stay out of them (a serial pass of their own).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ..._jit import njit, prange
from ..geometry.table import DIRECT, P0, SIGN
from .grid import Grid, cell_span, new_grid
from .partners import later_slots

__all__ = ["SlimModel", "LargeWorld", "new_large_world", "build_list", "permute_rows"]


class SlimModel(NamedTuple):
    """The fields of a :class:`~..model.Model` that the neighbour list's parallel passes read: the
    balls, the contact law's parameters, and the static spheres and bowls as flat arrays. Numba
    passes a named tuple by value, every field a live value in the loops that use it: the full
    Model held enough more of them in the list's per-ball loops to spill registers (callgrind: the
    same instructions less 7%, but 4% more loads and 17% more stores per step, and 4 to 6% slower)."""

    radii: np.ndarray
    inv_mass: np.ndarray
    round_sign: np.ndarray  # (R,) +1 a sphere, -1 a bowl
    round_center: np.ndarray  # (R, d)
    round_radius: np.ndarray  # (R,)
    ks: float
    kd: float
    ks_terrain: float
    kd_terrain: float
    no_tension: bool
    mu: float
    kf: float
    cell_size: float
    # r_i + r_j of every pair when all the radii are equal (the list pass then reads no partner's
    # radius: one stream of random loads fewer per pair), else 0.0
    diameter: float

    @classmethod
    def of(cls, model: Any, **changes: Any) -> SlimModel:
        """The slim view of ``model`` (arrays shared), with ``changes`` applied; ``diameter`` is
        computed from the radii unless given."""
        table = model.shapes
        direct = [s for s in range(table.count) if table.flags[s] & DIRECT]
        d = model.dim
        fields = {name: getattr(model, name) for name in cls._fields if hasattr(model, name) and name != "diameter"}
        fields["round_sign"] = np.array([table.shape[s, SIGN] for s in direct], dtype=np.float64)
        fields["round_center"] = np.array([table.pose[0, s, :d] for s in direct], dtype=np.float64).reshape(-1, d)
        fields["round_radius"] = np.array([table.shape[s, P0] for s in direct], dtype=np.float64)
        fields.update(changes)
        if "diameter" not in fields:
            radii = np.asarray(fields["radii"])
            same = radii.size > 0 and bool(np.all(radii == radii.flat[0]))
            fields["diameter"] = float(radii.flat[0] + radii.flat[0]) if same else 0.0
        return cls(**fields)


class LargeWorld(NamedTuple):
    """One large world's private state: its balls in grid-cell order in memory, its own grid, and a
    Verlet neighbour list (every pair within r_i + r_j + skin at the last build)."""

    x: np.ndarray  # (1, n, D) state, accelerations and external force in storage order
    v: np.ndarray
    a: np.ndarray
    ext: np.ndarray
    grid: Grid  # (one row) of the storage at the last build
    perm: np.ndarray  # (n,) ball index of each storage slot
    order: np.ndarray  # (n,) int scratch
    itmp: np.ndarray  # (n,) int scratch
    tmp: np.ndarray  # (n, max(D, 2)) float scratch
    nbr: np.ndarray  # (n, cap) int32 storage slots of each ball's listed neighbours, in grid order
    count: np.ndarray  # (n,) int32 listed neighbours per ball
    near: (
        np.ndarray
    )  # (n,) int8: bit 1 if within a skin of a static sphere or bowl at the build, bit 2 of another shape
    xref: np.ndarray  # (n, D) positions at the last build
    escaped: np.ndarray  # (n,) int8: 1 once the slot has moved skin / 2 from xref
    escapes: np.ndarray  # (max_escapes,) the escaped slots, in the order they escaped
    moved: np.ndarray  # (threads,) per thread: how many slots escaped in the last step (-1: not finite)
    pairs: np.ndarray  # (threads, PAIR_ROWS, max(PAIR_BLOCK, cap)) per thread: the force pass's block of pairs
    candidates: np.ndarray  # (n,) int32: an escaped ball's partners from the grid (serial pass)
    skin: float  # list reach beyond contact
    state: np.ndarray  # (4,) int64: [list valid, largest count at the last build, builds so far, escaped]


def new_large_world(
    n: int, d: int, cap: int, threads: int, max_escapes: int, pair_rows: int, pair_block: int, skin: float
) -> LargeWorld:
    """The buffers of one large world (``cap`` listed neighbours per ball)."""
    return LargeWorld(
        x=np.zeros((1, n, d)),
        v=np.zeros((1, n, d)),
        a=np.zeros((1, n, d)),
        ext=np.zeros((1, n, d)),
        grid=new_grid(1, n),
        perm=np.arange(n),
        order=np.zeros(n, dtype=np.int64),
        itmp=np.zeros(n, dtype=np.int64),
        tmp=np.zeros((n, max(d, 2))),
        nbr=np.zeros((n, cap), dtype=np.int32),
        count=np.zeros(n, dtype=np.int32),
        near=np.zeros(n, dtype=np.int8),
        xref=np.zeros((n, d)),
        escaped=np.zeros(n, dtype=np.int8),
        escapes=np.zeros(max_escapes, dtype=np.int64),
        moved=np.zeros(threads, dtype=np.int64),
        pairs=np.zeros((threads, pair_rows, max(pair_block, cap))),
        candidates=np.zeros(n, dtype=np.int32),
        skin=skin,
        state=np.zeros(4, dtype=np.int64),
    )


@njit(parallel=True)
def permute_rows(src, order, tmp):
    """src[0, i] = src[0, order[i]] for every row i (through tmp, (n, D))."""
    n = order.shape[0]
    for i in prange(n):
        for k in range(src.shape[2]):
            tmp[i, k] = src[0, order[i], k]
    for i in prange(n):
        for k in range(src.shape[2]):
            src[0, i, k] = tmp[i, k]


@njit(hot=True)
def _list_neighbours(i, grid, xs, sm, nbr, skin, D):
    """Write ball i's neighbours j > i within r_i + r_j + skin to ``nbr[i]`` in the grid's order (as
    many as fit below its last column, which takes the rejects); return how many there are: each
    pair is listed once, by its lower slot. The storage is in the grid's cell order, so the
    candidates are the pair-visiting service's slot ranges (:func:`.partners.later_slots`).
    Branch-free: every candidate is written and the count advances only for a neighbour."""
    last = nbr.shape[1] - 1
    x0, x1, y0, y1, z0, z1, nx, ny = cell_span(0, i, xs, grid, D)
    count = 0
    reach = sm.radii[i] + skin
    p0 = xs[0, i, 0]
    p1 = xs[0, i, 1]
    p2 = xs[0, i, 2] if D == 3 else 0.0
    for qz in range(z0, z1):
        for qy in range(y0, y1):
            lo, hi = later_slots(grid, 0, (qz * ny + qy) * nx, x0, x1, i)
            for j in range(lo, hi):
                cut = reach + sm.radii[j]
                d0 = xs[0, j, 0] - p0
                d1 = xs[0, j, 1] - p1
                d2 = xs[0, j, 2] - p2 if D == 3 else 0.0
                near = d0 * d0 + d1 * d1 + d2 * d2 < cut * cut
                nbr[i, min(count, last)] = j
                count += 1 if near else 0
    return count


@njit(hot=True)
def _near_rounds(i, xs, sm, reach, D):
    """1 unless ball i's surface is at least ``reach`` clear of every static sphere and bowl
    (phi(c_i) - r_i >= reach; a position that is not finite counts as near)."""
    r = sm.radii[i]
    for s in range(sm.round_radius.shape[0]):
        dist2 = 0.0
        for k in range(D):
            dx = xs[0, i, k] - sm.round_center[s, k]
            dist2 += dx * dx
        if not sm.round_sign[s] * (math.sqrt(dist2) - sm.round_radius[s]) - r >= reach:
            return 1
    return 0


@njit(parallel=True)
def build_list(grid, xs, sm, lw, threads, g):
    """Every pair within r_i + r_j + skin, listed once by its lower slot in the grid's fixed order
    (the list, and so the force sums, do not depend on the thread count), and which balls are
    within a skin of a static sphere or bowl. Returns the largest count; a count at the list's
    capacity leaves the list invalid (the caller grows it and retries)."""
    D = len(g)
    n = xs.shape[1]
    nbr, cnt, near, xref = lw.nbr, lw.count, lw.near, lw.xref
    skin = lw.skin
    threads = max(1, min(threads, lw.moved.shape[0]))
    for t in prange(threads):
        # (an int64 copy of t: a prange index may be unsigned, and int64 with uint64 unifies to float)
        first = np.int64(t)
        for i in range(first, n, threads):
            cnt[i] = _list_neighbours(i, grid, xs, sm, nbr, skin, D)
            # a ball that has not escaped is within skin / 2 of xref, and phi is 1-Lipschitz: a
            # clearance of a skin at the build means no terrain contact until it escapes
            near[i] = _near_rounds(i, xs, sm, skin, D)
            for k in range(D):
                xref[i, k] = xs[0, i, k]
    most = 0
    for i in range(n):
        most = max(most, cnt[i])
    return most
