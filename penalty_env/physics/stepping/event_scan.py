"""Event location's geometry: each contact's gap, its rate and its course over a step, and the scan
for the first contact that switches (:mod:`.events` drives it).

A contact is a ball pair (``KIND_PAIR``, balls i < j) or a ball and a terrain shape
(``KIND_TERRAIN``, ball i and the shape's row j). Its gap is |x_j - x_i| - (r_i + r_j) or
phi(c_i) - r_i (< 0 in contact); along a step it is followed on the cubic Hermite interpolant of
the positions from (x, v) at both ends. The static spheres and bowls keep their closed forms;
every other shape is evaluated through the shape table (its pose frozen over the step: kinematic
shapes move on after each step).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..._jit import njit
from ..broadphase.grid import build_grid, uses_cells
from ..broadphase.partners import cell_partners
from ..geometry.evaluate import is_direct, is_moving, shape_sdf, surface_velocity
from ..geometry.table import P0, SIGN

__all__ = [
    "EventBuffers",
    "allocate",
    "KIND_PAIR",
    "KIND_TERRAIN",
    "GAP_TOL",
    "NEAR",
    "START_ZONE",
    "RK4_MARGIN_FACTOR",
    "gap",
    "gap_rate",
    "tolerance",
    "margin",
    "scan",
]

KIND_PAIR, KIND_TERRAIN = 0, 1
GAP_TOL = 1e-11  # the switch's round-off zone (landing margin, crossing overshoot), a fraction of the radius
RK4_MARGIN_FACTOR = 0.25  # RK4 margin = factor x dt^3 |jerk_n| (3x the fourth stage's offset)
# The scan's hot loops touch every pair near contact once per step, so they test the status with
# squared distances inline and call ``_consider`` (root finding, margins) only for the few pairs
# that switch, or, for RK4, end within NEAR of the switch (its margin is far smaller).
NEAR = 0.05  # fraction of the contact distance
START_ZONE = 1e-6  # a start this close to a switch (fraction of the distance) is examined by consider


class EventBuffers(NamedTuple):
    """Scratch buffers of the event-located driver, allocated once per World (nothing is allocated
    while stepping)."""

    x0: np.ndarray  # (B, n, D) state saved at the start of the current sub-step
    v0: np.ndarray  # (B, n, D)
    a0: np.ndarray  # (B, n, D) velocity Verlet's cached acceleration at S0
    ints: np.ndarray  # (B, N_INTS) int64 per-world control state (columns I_*)
    flts: np.ndarray  # (B, N_FLTS) float64 per-world control state (columns F_*)
    counts: np.ndarray  # (B, N_COUNTS) int64 counters, cumulative (columns C_*)


I_PHASE, I_KIND, I_I, I_J, I_CALLS, I_LAND, I_A0VALID, I_HAS_LO, I_HAS_HI, I_HAS_PREV = range(10)
N_INTS = 10
(
    F_TLEFT,
    F_TAU,
    F_THETA,
    F_MARGIN,
    F_SIGN,
    F_TLO,
    F_SGLO,
    F_THI,
    F_SGHI,
    F_TPREV,
    F_SGPREV,
    F_DELTA,
    F_SCAN_MARGIN,
    F_SCAN_SIGN,
) = range(14)
N_FLTS = 14
C_CALLS, C_EVALS, C_EVENTS, C_FALLBACKS, C_STEPS = range(5)
N_COUNTS = 5


def allocate(B: int, n: int, d: int) -> EventBuffers:
    """Buffers for B worlds of n balls in d dimensions."""
    return EventBuffers(
        x0=np.zeros((B, n, d)),
        v0=np.zeros((B, n, d)),
        a0=np.zeros((B, n, d)),
        ints=np.zeros((B, N_INTS), dtype=np.int64),
        flts=np.zeros((B, N_FLTS)),
        counts=np.zeros((B, N_COUNTS), dtype=np.int64),
    )


@njit
def _round_d2(b, i, s, x, table, D):
    """A static sphere or bowl s: its sign and ball i's squared distance to its centre."""
    c = table.pose[0, s]
    d2 = 0.0
    for k in range(D):
        dx = x[b, i, k] - c[k]
        d2 += dx * dx
    return table.shape[s, SIGN], d2


@njit
def _terrain_gap_at(b, i, s, p0, p1, p2, model, D):
    """phi(p) - r_i of shape s at point p (any shape, through the table)."""
    return shape_sdf(model.shapes, b, s, p0, p1, p2, D)[0] - model.radii[i]


@njit
def gap(kind, b, i, j, x, model, D):
    """Signed gap of a contact: |x_j - x_i| - (r_i + r_j) (pair) or phi(c_i) - r_i (terrain j)."""
    if kind == KIND_PAIR:
        d2 = 0.0
        for k in range(D):
            dx = x[b, j, k] - x[b, i, k]
            d2 += dx * dx
        return math.sqrt(d2) - (model.radii[i] + model.radii[j])
    table = model.shapes
    if is_direct(table, j):
        sign, d2 = _round_d2(b, i, j, x, table, D)
        return sign * (math.sqrt(d2) - table.shape[j, P0]) - model.radii[i]
    return _terrain_gap_at(b, i, j, x[b, i, 0], x[b, i, 1], x[b, i, 2] if D == 3 else 0.0, model, D)


@njit
def gap_rate(kind, b, i, j, x, v, model, D):
    """d(gap)/dt along the contact normal at (x, v)."""
    d2 = 0.0
    rate = 0.0
    if kind == KIND_PAIR:
        for k in range(D):
            dx = x[b, j, k] - x[b, i, k]
            d2 += dx * dx
        dist = math.sqrt(d2)
        if dist > 0.0:
            for k in range(D):
                rate += (x[b, j, k] - x[b, i, k]) * (v[b, j, k] - v[b, i, k])
            rate /= dist
        return rate
    table = model.shapes
    if is_direct(table, j):
        c = table.pose[0, j]
        for k in range(D):
            dx = x[b, i, k] - c[k]
            d2 += dx * dx
        dist = math.sqrt(d2)
        if dist > 0.0:
            for k in range(D):
                rate += (x[b, i, k] - c[k]) * v[b, i, k]
            rate *= table.shape[j, SIGN] / dist
        return rate
    p0 = x[b, i, 0]
    p1 = x[b, i, 1]
    p2 = x[b, i, 2] if D == 3 else 0.0
    phi, n0, n1, n2 = shape_sdf(table, b, j, p0, p1, p2, D)
    w0 = w1 = w2 = 0.0
    if is_moving(table, j):
        w0, w1, w2 = surface_velocity(table.pose[b, j], p0, p1, p2, phi, n0, n1, n2, D)
    rate = (v[b, i, 0] - w0) * n0 + (v[b, i, 1] - w1) * n1
    if D == 3:
        rate += (v[b, i, 2] - w2) * n2
    return rate


@njit
def hermite(p0, v0, p1, v1, h, t):
    """Cubic Hermite interpolant of one coordinate over a step of length h, at fraction t."""
    t2 = t * t
    t3 = t2 * t
    return (
        (2.0 * t3 - 3.0 * t2 + 1.0) * p0
        + (t3 - 2.0 * t2 + t) * h * v0
        + (3.0 * t2 - 2.0 * t3) * p1
        + (t3 - t2) * h * v1
    )


@njit
def _ball_at(b, i, x0, v0, x1, v1, h, t, k):
    return hermite(x0[b, i, k], v0[b, i, k], x1[b, i, k], v1[b, i, k], h, t)


@njit
def interp_gap(kind, b, i, j, x0, v0, x1, v1, h, t, model, D):
    """The gap at fraction t of the step, on the Hermite interpolant."""
    d2 = 0.0
    if kind == KIND_PAIR:
        for k in range(D):
            pi = _ball_at(b, i, x0, v0, x1, v1, h, t, k)
            pj = _ball_at(b, j, x0, v0, x1, v1, h, t, k)
            d2 += (pj - pi) * (pj - pi)
        return math.sqrt(d2) - (model.radii[i] + model.radii[j])
    table = model.shapes
    if is_direct(table, j):
        c = table.pose[0, j]
        for k in range(D):
            pi = _ball_at(b, i, x0, v0, x1, v1, h, t, k) - c[k]
            d2 += pi * pi
        return table.shape[j, SIGN] * (math.sqrt(d2) - table.shape[j, P0]) - model.radii[i]
    q0 = _ball_at(b, i, x0, v0, x1, v1, h, t, 0)
    q1 = _ball_at(b, i, x0, v0, x1, v1, h, t, 1)
    q2 = _ball_at(b, i, x0, v0, x1, v1, h, t, 2) if D == 3 else 0.0
    return _terrain_gap_at(b, i, j, q0, q1, q2, model, D)


@njit
def interp_root(kind, b, i, j, x0, v0, x1, v1, h, target, model, D):
    """Fraction t in [0, 1] where the interpolated gap first reaches ``target`` (Illinois regula
    falsi on the bracket [0, 1]; the caller guarantees a sign change)."""
    lo, hi = 0.0, 1.0
    flo = interp_gap(kind, b, i, j, x0, v0, x1, v1, h, 0.0, model, D) - target
    fhi = interp_gap(kind, b, i, j, x0, v0, x1, v1, h, 1.0, model, D) - target
    if flo == 0.0:
        return 0.0
    if (flo > 0.0) == (fhi > 0.0):
        return 1.0
    side = 0
    for _ in range(100):
        t = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < t < hi):
            t = 0.5 * (lo + hi)
        f = interp_gap(kind, b, i, j, x0, v0, x1, v1, h, t, model, D) - target
        if (f > 0.0) == (flo > 0.0):
            lo, flo = t, f
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = t, f
            if side == 1:
                flo *= 0.5
            side = 1
        if hi - lo < 1e-15 or f == 0.0:
            break
    # the old-side end of the bracket: never past the target
    return lo


@njit
def tolerance(kind, b, i, j, x, model, D):
    """The switch's round-off zone: GAP_TOL x the smaller radius, but at least 1e-13 x the size of
    the coordinates involved (well above the round-off of the gap computed from them)."""
    scale = 0.0
    table = model.shapes
    for k in range(D):
        scale = max(scale, abs(x[b, i, k]))
        if kind == KIND_PAIR:
            scale = max(scale, abs(x[b, j, k]))
        elif is_direct(table, j):
            scale = max(scale, abs(table.pose[0, j, k]) + table.shape[j, P0])
        else:
            scale = max(scale, abs(table.pose[b, j, k]))
    r = model.radii[i] if kind == KIND_TERRAIN else min(model.radii[i], model.radii[j])
    return max(GAP_TOL * r, 1e-13 * scale)


@njit
def margin(kind, b, i, j, x0, v0, x1, v1, h, rk4, model, D):
    """Landing margin of a contact: GAP_TOL r, plus for RK4 factor x h^3 |jerk along the normal|
    with the jerk of the Hermite interpolant, 6 (2 (x0 - x1) + h (v0 + v1)) / h^3."""
    base = tolerance(kind, b, i, j, x0, model, D)
    if not rk4:
        return base
    d2 = 0.0
    jn = 0.0
    table = model.shapes
    if kind == KIND_PAIR:
        for k in range(D):
            dx = x0[b, j, k] - x0[b, i, k]
            d2 += dx * dx
            jj = 2.0 * (x0[b, j, k] - x1[b, j, k]) + h * (v0[b, j, k] + v1[b, j, k])
            ji = 2.0 * (x0[b, i, k] - x1[b, i, k]) + h * (v0[b, i, k] + v1[b, i, k])
            jn += dx * (jj - ji)
    elif is_direct(table, j):
        c = table.pose[0, j]
        for k in range(D):
            dx = x0[b, i, k] - c[k]
            d2 += dx * dx
            jn += dx * (2.0 * (x0[b, i, k] - x1[b, i, k]) + h * (v0[b, i, k] + v1[b, i, k]))
    else:  # the normal: the shape's at the start
        nrm = shape_sdf(table, b, j, x0[b, i, 0], x0[b, i, 1], x0[b, i, 2] if D == 3 else 0.0, D)
        for k in range(D):
            jn += nrm[1 + k] * (2.0 * (x0[b, i, k] - x1[b, i, k]) + h * (v0[b, i, k] + v1[b, i, k]))
        d2 = 1.0
    dist = math.sqrt(d2)
    if dist > 0.0:
        jn = abs(jn) / dist
    else:
        jn = 0.0
    # h^3 |jerk| = 6 |2 (x0 - x1) + h (v0 + v1)|_n
    return base + RK4_MARGIN_FACTOR * 6.0 * jn


@njit
def consider(kind, b, i, j, g0, g1, x0, v0, x1, v1, h, rk4, model, D, ev, best):
    """Is this contact switching (or, for RK4, ending within its margin of a switch) over the
    interval? If so and its landing comes before ``best``, record it. Returns (best, flagged)."""
    s = -1.0 if g0 < 0.0 else 1.0  # old side: +1 open, -1 in contact
    if abs(g0) <= tolerance(kind, b, i, j, x0, model, D):
        # within round-off of the switch, where the force kernels' own test may disagree with the
        # sign of this gap: the contact is on the side it comes from, so it is crossed at once
        s = 1.0 if gap_rate(kind, b, i, j, x0, v0, model, D) < 0.0 else -1.0
    if s * g1 > 0.0 and not rk4:
        return best, False
    if s * g1 > 0.0 and s * g1 > 0.5 * (model.radii[i] if kind == KIND_TERRAIN else model.radii[i] + model.radii[j]):
        return best, False  # far from the switch: no margin can matter
    m = margin(kind, b, i, j, x0, v0, x1, v1, h, rk4, model, D)
    if s * g1 >= m:
        return best, False
    if s * g0 <= m:
        t = 0.0  # already within the margin at the start
    else:
        t = interp_root(kind, b, i, j, x0, v0, x1, v1, h, s * m, model, D)
    if t < best:
        best = t
        ev.ints[b, I_KIND] = kind
        ev.ints[b, I_I] = i
        ev.ints[b, I_J] = j
        ev.flts[b, F_THETA] = t
        ev.flts[b, F_SCAN_MARGIN] = m
        ev.flts[b, F_SCAN_SIGN] = s
    return best, True


@njit
def _pair_d2(b, i, j, x, D):
    d2 = 0.0
    for k in range(D):
        dx = x[b, j, k] - x[b, i, k]
        d2 += dx * dx
    return d2


@njit
def _pair_check(b, i, j, x0, v0, x1, v1, h, rk4, model, D, ev, best, count):
    """Status test of pair (i, j) from its squared distances at both ends."""
    d0 = _pair_d2(b, i, j, x0, D)
    d1 = _pair_d2(b, i, j, x1, D)
    l0 = model.radii[i] + model.radii[j]
    c0 = d0 < l0 * l0
    c1 = d1 < l0 * l0
    # a start within round-off of the switch goes to consider too (it crosses it at once)
    if c0 == c1 and not abs(d0 - l0 * l0) <= START_ZONE * l0 * l0:
        if not rk4:
            return best, count
        near = (l0 * (1.0 - NEAR)) ** 2 if c1 else (l0 * (1.0 + NEAR)) ** 2
        if (c1 and d1 < near) or (not c1 and d1 > near):
            return best, count
    best, flagged = consider(
        KIND_PAIR, b, i, j, math.sqrt(d0) - l0, math.sqrt(d1) - l0, x0, v0, x1, v1, h, rk4, model, D, ev, best
    )
    return best, count + (1 if flagged else 0)


@njit
def scan(b, x0, v0, x1, v1, h, rk4, grid, buf, model, D, ev):
    """Every contact of world b that switches between (x0, v0) and (x1, v1) over a step of h.

    Returns the number of contacts found; the one whose landing point comes first is recorded in
    ``ev`` (kind, i, j, landing fraction of the step, margin, old side). Pairs all to all, or through one grid built at the
    end state with cells grown by twice the largest displacement of the step (a pair in contact at
    the start is then still within one cell of each other at the end)."""
    n = x0.shape[1]
    best = 2.0
    count = 0
    if not uses_cells(grid):
        for i in range(n):
            for j in range(i + 1, n):
                best, count = _pair_check(b, i, j, x0, v0, x1, v1, h, rk4, model, D, ev, best, count)
    else:
        disp2 = 0.0
        for i in range(n):
            disp2 = max(disp2, _move2(b, i, x0, x1, D))
        build_grid(b, x1, grid, model.cell_size + 2.0 * math.sqrt(disp2), D)
        for i in range(n):
            m = cell_partners(b, i, x1, grid, True, buf, D)
            for t in range(m):
                best, count = _pair_check(b, i, buf[t], x0, v0, x1, v1, h, rk4, model, D, ev, best, count)
    table = model.shapes
    for i in range(n):
        r = model.radii[i]
        for s in range(table.kind.shape[0]):
            g0 = gap(KIND_TERRAIN, b, i, s, x0, model, D)
            g1 = gap(KIND_TERRAIN, b, i, s, x1, model, D)
            if (g0 < 0.0) == (g1 < 0.0) and not (rk4 and abs(g1) < NEAR * r) and not abs(g0) <= START_ZONE * r:
                continue
            best, flagged = consider(KIND_TERRAIN, b, i, s, g0, g1, x0, v0, x1, v1, h, rk4, model, D, ev, best)
            if flagged:
                count += 1
    return count


@njit
def _move2(b, i, x0, x1, D):
    """Ball i's squared displacement between x0 and x1."""
    d2 = 0.0
    for k in range(D):
        dx = x1[b, i, k] - x0[b, i, k]
        d2 += dx * dx
    return d2
