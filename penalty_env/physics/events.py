"""Event-located stepping: restoring the order that contact switches destroy.

Why
---
The seed's contact force is switched by geometry: it acts while ``|x_j - x_i| < r_i + r_j``
(pair) or ``phi(c_i) - r_i < 0`` (terrain). At a switch the spring force has a kink and the
dashpot force jumps (by ``kd v_n`` when a contact begins and when it ends), so a step that straddles
a switch integrates a discontinuous right-hand side: every integrator is then first order in the
worst case over where the switch falls in the step (docs/physics.md section 4; RK4 at 64 steps per
contact is no better than 1% at zeta = 0.3). Hybrid-system solvers restore the order by stopping
at the switch. This module does that for the penalty core, with the core's own step functions.

How (per world and per step of dt, all inside one compiled driver)
------------------------------------------------------------------
1. Save the state S0 and take a *trial* step of the time left.
2. Scan every contact for a change of status between S0 and the end (all pairs, or one grid
   built at the end with cells grown by the step's largest displacement). No change: the step is
   accepted (the scan, about the cost of one force evaluation, is the only overhead of a step
   without a switch).
3. Otherwise find the earliest switch on the cubic Hermite interpolant of the positions from
   (x, v) at both ends, and *land* just before it: redo the step from S0 with a shorter step tau,
   and correct tau by Newton then safeguarded secant iterations on the overlap actually produced
   by the integrator, until the contact is on its old side by a small margin ``m``. Every force
   evaluation of the landing step then sees the old contact set, so the step has the
   integrator's full order. (The positions an integrator produces over tau depend only on force
   evaluations inside the step, so the overlap is a smooth function of tau near the switch.)
4. *Cross* the switch with one tiny symplectic Euler step of length
   ``delta = (margin + 3 tol) / |v_n|`` (``tol`` = GAP_TOL x radius, 1e-11, or more where the
   coordinates are large, so the state lands clear of the round-off zone where the force
   kernels' own contact test could disagree): its error is O(delta^2), far below the
   integrator's.
5. Continue from there with the time left (a loop; several switches per step are handled one by
   one, and ``MAX_CALLS`` integrator calls per step bound the work, after which the rest of the
   step is taken plainly and counted as a fallback). A contact found within ``tol`` of its
   switch at the start of a step is crossed at once, on the side its velocity points to.

The margin is ``tol``, except for RK4, whose fourth stage is evaluated at ``x + dt v_3``, which
differs from the step's end by about dt^3 (jerk) / 12: a landing closer to the switch than that
would let the fourth stage see the new contact set (this happens at the end of a contact when
zeta > 0.5). RK4's margin is therefore ``dt^3 |jerk_n| / 4`` (3x that estimate; the jerk along
the contact normal comes from the Hermite interpolant of the step), and an RK4 step that ends
inside that margin of a switch is treated as a switch too.

Not located: the no-tension clip (``damping="no_tension"`` clips the normal force at zero before
the contact ends geometrically: a kink in the force, so the order is limited to 2 there), the
friction law's kink, and a contact that begins and ends within one step (a graze).

Cost: a step without a switch costs one extra contact scan (no force evaluation); a step with a
switch costs the trial, about one to three landing steps, one crossing force evaluation and the
remainder. When switches are rare (a few balls) that is cheap; when many contacts switch in almost
every step (a pile of many balls) the cost grows several-fold: see the accuracy chart
(``python -m penalty_env.bench accuracy``), scenarios 4 and 5.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba.extending import overload

from .._jit import njit
from .broadphase import build_grid, neighbour_rows
from .contact import pair_gap, shape_sign, terrain_gap
from .integrators import (
    RK4Work,
    VelocityVerletWork,
    begin_world,
    integrate,
    is_work,
    symplectic_euler_into,
    world_status,
)

__all__ = ["EventBuffers", "allocate", "run_worlds", "stats", "GAP_TOL", "MAX_CALLS"]

# Scratch buffers of the event-located drivers, allocated once per World (nothing is allocated
# while stepping).
EventBuffers = namedtuple(
    "EventBuffers",
    [
        "x0",  # (B, n, D) state saved at the start of the current sub-step
        "v0",  # (B, n, D)
        "a0",  # (B, n, D) velocity Verlet's cached acceleration at S0
        "ints",  # (B, N_INTS) int64 per-world control state (columns I_*)
        "flts",  # (B, N_FLTS) float64 per-world control state (columns F_*)
        "counts",  # (B, N_COUNTS) int64 counters, cumulative (columns C_*)
    ],
)

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

PHASE_TRIAL, PHASE_LAND, PHASE_PLAIN = 0, 1, 2
ACT_STEP, ACT_CROSS, ACT_DONE = 0, 1, 2
CROSS_OK, CROSS_AFTER_STEP, CROSS_NO = 0, 1, 2
KIND_PAIR, KIND_TERRAIN = 0, 1

GAP_TOL = 1e-11  # the switch's round-off zone (landing margin, crossing overshoot), a fraction of the radius
MAX_CALLS = 48  # integrator calls per step before the rest of the step is taken plainly
MAX_LAND = 10  # root-finding iterations per switch
CROSS_MAX = 0.1  # the crossing step may be at most this fraction of dt
RK4_MARGIN_FACTOR = 0.25  # RK4 margin = factor x dt^3 |jerk_n| (3x the fourth stage's offset)


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


def stats(world_or_buffers) -> dict:
    """Counters of a ``World(..., events=True)`` (or its buffers), summed over its worlds since it
    was made: ``steps`` (steps of dt),
    ``integrator_calls``, ``force_evaluations`` (full contact passes, including the trial, landing and
    crossing steps), ``events`` (switches located and crossed) and ``fallbacks`` (steps finished
    plainly)."""
    buffers = getattr(world_or_buffers, "event_buffers", world_or_buffers)
    if buffers is None:
        raise ValueError("this World steps without event location (make it with events=True)")
    c = buffers.counts.sum(axis=0)
    return {
        "steps": int(c[C_STEPS]),
        "integrator_calls": int(c[C_CALLS]),
        "force_evaluations": int(c[C_EVALS]),
        "events": int(c[C_EVENTS]),
        "fallbacks": int(c[C_FALLBACKS]),
    }


# --------------------------------------------------------------------------------------------
# Geometry of one contact: the gap (< 0 in contact), its rate, and along the Hermite interpolant
# --------------------------------------------------------------------------------------------


@njit
def _gap(kind, b, i, j, x, model, D):
    """Signed gap of a contact: |x_j - x_i| - (r_i + r_j) (pair) or phi(c_i) - r_i (terrain j)."""
    if kind == KIND_PAIR:
        return pair_gap(b, i, j, x, model, D)
    return terrain_gap(b, i, j, x, model, D)


@njit
def _gap_rate(kind, b, i, j, x, v, model, D):
    """d(gap)/dt along the contact normal at (x, v)."""
    d2 = 0.0
    rate = 0.0
    if kind == KIND_PAIR:
        for k in range(D):
            dx = x[b, j, k] - x[b, i, k]
            d2 += dx * dx
        dist = np.sqrt(d2)
        if dist > 0.0:
            for k in range(D):
                rate += (x[b, j, k] - x[b, i, k]) * (v[b, j, k] - v[b, i, k])
            rate /= dist
        return rate
    for k in range(D):
        dx = x[b, i, k] - model.shape_center[j, k]
        d2 += dx * dx
    dist = np.sqrt(d2)
    sign = shape_sign(model, j)
    if dist > 0.0:
        for k in range(D):
            rate += (x[b, i, k] - model.shape_center[j, k]) * v[b, i, k]
        rate *= sign / dist
    return rate


@njit(inline="always")
def _hermite(p0, v0, p1, v1, h, t):
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
def _interp_gap(kind, b, i, j, x0, v0, x1, v1, h, t, model, D):
    d2 = 0.0
    if kind == KIND_PAIR:
        for k in range(D):
            pi = _hermite(x0[b, i, k], v0[b, i, k], x1[b, i, k], v1[b, i, k], h, t)
            pj = _hermite(x0[b, j, k], v0[b, j, k], x1[b, j, k], v1[b, j, k], h, t)
            d2 += (pj - pi) * (pj - pi)
        return np.sqrt(d2) - (model.radii[i] + model.radii[j])
    for k in range(D):
        pi = _hermite(x0[b, i, k], v0[b, i, k], x1[b, i, k], v1[b, i, k], h, t) - model.shape_center[j, k]
        d2 += pi * pi
    sign = shape_sign(model, j)
    return sign * (np.sqrt(d2) - model.shape_radius[j]) - model.radii[i]


@njit
def _interp_root(kind, b, i, j, x0, v0, x1, v1, h, target, model, D):
    """Fraction t in [0, 1] where the interpolated gap first reaches ``target`` (Illinois regula
    falsi on the bracket [0, 1]; the caller guarantees a sign change)."""
    lo, hi = 0.0, 1.0
    flo = _interp_gap(kind, b, i, j, x0, v0, x1, v1, h, 0.0, model, D) - target
    fhi = _interp_gap(kind, b, i, j, x0, v0, x1, v1, h, 1.0, model, D) - target
    if flo == 0.0:
        return 0.0
    if (flo > 0.0) == (fhi > 0.0):
        return 1.0
    side = 0
    for _ in range(100):
        t = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < t < hi):
            t = 0.5 * (lo + hi)
        f = _interp_gap(kind, b, i, j, x0, v0, x1, v1, h, t, model, D) - target
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
def _tol(kind, b, i, j, x, model, D):
    """The switch's round-off zone: GAP_TOL x the smaller radius, but at least 1e-13 x the size of
    the coordinates involved (well above the round-off of the gap computed from them)."""
    scale = 0.0
    for k in range(D):
        scale = max(scale, abs(x[b, i, k]))
        if kind == KIND_PAIR:
            scale = max(scale, abs(x[b, j, k]))
        else:
            scale = max(scale, abs(model.shape_center[j, k]) + model.shape_radius[j])
    r = model.radii[i] if kind == KIND_TERRAIN else min(model.radii[i], model.radii[j])
    return max(GAP_TOL * r, 1e-13 * scale)


@njit
def _margin(kind, b, i, j, x0, v0, x1, v1, h, rk4, model, D):
    """Landing margin of a contact: GAP_TOL r, plus for RK4 factor x h^3 |jerk along the normal|
    with the jerk of the Hermite interpolant, 6 (2 (x0 - x1) + h (v0 + v1)) / h^3."""
    base = _tol(kind, b, i, j, x0, model, D)
    if not rk4:
        return base
    d2 = 0.0
    jn = 0.0
    if kind == KIND_PAIR:
        for k in range(D):
            dx = x0[b, j, k] - x0[b, i, k]
            d2 += dx * dx
            jj = 2.0 * (x0[b, j, k] - x1[b, j, k]) + h * (v0[b, j, k] + v1[b, j, k])
            ji = 2.0 * (x0[b, i, k] - x1[b, i, k]) + h * (v0[b, i, k] + v1[b, i, k])
            jn += dx * (jj - ji)
    else:
        for k in range(D):
            dx = x0[b, i, k] - model.shape_center[j, k]
            d2 += dx * dx
            jn += dx * (2.0 * (x0[b, i, k] - x1[b, i, k]) + h * (v0[b, i, k] + v1[b, i, k]))
    dist = np.sqrt(d2)
    if dist > 0.0:
        jn = abs(jn) / dist
    else:
        jn = 0.0
    # h^3 |jerk| = 6 |2 (x0 - x1) + h (v0 + v1)|_n
    return base + RK4_MARGIN_FACTOR * 6.0 * jn


# --------------------------------------------------------------------------------------------
# Scanning every contact for a switch between two states
# --------------------------------------------------------------------------------------------


@njit
def _consider(kind, b, i, j, g0, g1, x0, v0, x1, v1, h, rk4, model, D, ev, best):
    """Is this contact switching (or, for RK4, ending within its margin of a switch) over the
    interval? If so and its landing comes before ``best``, record it. Returns (best, flagged)."""
    s = -1.0 if g0 < 0.0 else 1.0  # old side: +1 open, -1 in contact
    if abs(g0) <= _tol(kind, b, i, j, x0, model, D):
        # within round-off of the switch, where the force kernels' own test may disagree with the
        # sign of this gap: the contact is on the side it comes from, so it is crossed at once
        s = 1.0 if _gap_rate(kind, b, i, j, x0, v0, model, D) < 0.0 else -1.0
    if s * g1 > 0.0 and not rk4:
        return best, False
    if s * g1 > 0.0 and s * g1 > 0.5 * (model.radii[i] if kind == KIND_TERRAIN else model.radii[i] + model.radii[j]):
        return best, False  # far from the switch: no margin can matter
    m = _margin(kind, b, i, j, x0, v0, x1, v1, h, rk4, model, D)
    if s * g1 >= m:
        return best, False
    if s * g0 <= m:
        t = 0.0  # already within the margin at the start
    else:
        t = _interp_root(kind, b, i, j, x0, v0, x1, v1, h, s * m, model, D)
    if t < best:
        best = t
        ev.ints[b, I_KIND] = kind
        ev.ints[b, I_I] = i
        ev.ints[b, I_J] = j
        ev.flts[b, F_THETA] = t
        ev.flts[b, F_SCAN_MARGIN] = m
        ev.flts[b, F_SCAN_SIGN] = s
    return best, True


# The scan's hot loops touch every pair near contact once per step, so they test the status with
# squared distances inline and call ``_consider`` (root finding, margins) only for the few pairs
# that switch, or, for RK4, end within NEAR of the switch (its margin is far smaller).
NEAR = 0.05  # fraction of the contact distance
START_ZONE = 1e-6  # a start this close to a switch (fraction of the distance) is examined by _consider


@njit(inline="always")
def _pair_d2(b, i, j, x, D):
    d2 = 0.0
    for k in range(D):
        dx = x[b, j, k] - x[b, i, k]
        d2 += dx * dx
    return d2


@njit(inline="always")
def _pair_check(b, i, j, d0, d1, x0, v0, x1, v1, h, rk4, model, D, ev, best, count):
    """Status test of pair (i, j) from its squared distances at both ends."""
    l0 = model.radii[i] + model.radii[j]
    c0 = d0 < l0 * l0
    c1 = d1 < l0 * l0
    # a start within round-off of the switch goes to _consider too (it crosses it at once)
    if c0 == c1 and not abs(d0 - l0 * l0) <= START_ZONE * l0 * l0:
        if not rk4:
            return best, count
        near = (l0 * (1.0 - NEAR)) ** 2 if c1 else (l0 * (1.0 + NEAR)) ** 2
        if (c1 and d1 < near) or (not c1 and d1 > near):
            return best, count
    best, flagged = _consider(
        KIND_PAIR, b, i, j, np.sqrt(d0) - l0, np.sqrt(d1) - l0, x0, v0, x1, v1, h, rk4, model, D, ev, best
    )
    return best, count + (1 if flagged else 0)


# what ``kernels.build_grid`` reads of the model: the scan builds its grid with larger cells
_CellSize = namedtuple("_CellSize", ["cell_size"])


@njit
def _grid_pass(b, x0, v0, x1, v1, h, rk4, grid, model, g, ev, best, count):
    """Every pair in contact at either end, through one grid built at the end state with cells
    grown by twice the largest displacement of the step: a pair in contact at the start is then
    still within one cell of each other at the end. Each pair once, j > i."""
    D = len(g)
    n = x1.shape[1]
    disp2 = 0.0
    for i in range(n):
        d2 = 0.0
        for k in range(D):
            dx = x1[b, i, k] - x0[b, i, k]
            d2 += dx * dx
        disp2 = max(disp2, d2)
    build_grid(b, x1, grid, _CellSize(model.cell_size + 2.0 * np.sqrt(disp2)), g)
    for i in range(n):
        x0_, x1_, y0, y1, z0, z1, nx, ny = neighbour_rows(b, i, x1, grid, D)
        for qz in range(z0, z1):
            for qy in range(y0, y1):
                row = (qz * ny + qy) * nx
                for idx in range(grid.start[b, row + x0_], grid.start[b, row + x1_]):
                    j = grid.items[b, idx]
                    if j <= i:
                        continue
                    best, count = _pair_check(
                        b,
                        i,
                        j,
                        _pair_d2(b, i, j, x0, D),
                        _pair_d2(b, i, j, x1, D),
                        x0,
                        v0,
                        x1,
                        v1,
                        h,
                        rk4,
                        model,
                        D,
                        ev,
                        best,
                        count,
                    )
    return best, count


@njit
def scan(b, x0, v0, x1, v1, h, rk4, grid, model, g, ev):
    """Every contact of world b that switches between (x0, v0) and (x1, v1) over a step of h.

    Returns the number of contacts found; the one whose landing point comes first is recorded in
    ``ev`` (kind, i, j, landing fraction of the step, margin, old side).
    """
    D = len(g)
    n = x0.shape[1]
    best = 2.0
    count = 0
    if grid is None:
        for i in range(n):
            for j in range(i + 1, n):
                best, count = _pair_check(
                    b,
                    i,
                    j,
                    _pair_d2(b, i, j, x0, D),
                    _pair_d2(b, i, j, x1, D),
                    x0,
                    v0,
                    x1,
                    v1,
                    h,
                    rk4,
                    model,
                    D,
                    ev,
                    best,
                    count,
                )
    else:
        best, count = _grid_pass(b, x0, v0, x1, v1, h, rk4, grid, model, g, ev, best, count)
    for i in range(n):
        r = model.radii[i]
        for s in range(model.shape_kind.shape[0]):
            g0 = terrain_gap(b, i, s, x0, model, D)
            g1 = terrain_gap(b, i, s, x1, model, D)
            if (g0 < 0.0) == (g1 < 0.0) and not (rk4 and abs(g1) < NEAR * r) and not abs(g0) <= START_ZONE * r:
                continue
            best, flagged = _consider(KIND_TERRAIN, b, i, s, g0, g1, x0, v0, x1, v1, h, rk4, model, D, ev, best)
            if flagged:
                count += 1
    return count


# --------------------------------------------------------------------------------------------
# The control logic shared by every driver
# --------------------------------------------------------------------------------------------


@njit
def _save(b, x, v, ev, a0, a0_valid):
    for i in range(x.shape[1]):
        for k in range(x.shape[2]):
            ev.x0[b, i, k] = x[b, i, k]
            ev.v0[b, i, k] = v[b, i, k]
            if a0 is not None:
                ev.a0[b, i, k] = a0[b, i, k]
    if a0_valid is not None:
        ev.ints[b, I_A0VALID] = 1 if a0_valid[b] else 0


@njit
def _restore(b, x, v, ev, a0, a0_valid):
    for i in range(x.shape[1]):
        for k in range(x.shape[2]):
            x[b, i, k] = ev.x0[b, i, k]
            v[b, i, k] = ev.v0[b, i, k]
            if a0 is not None:
                a0[b, i, k] = ev.a0[b, i, k]
    if a0_valid is not None:
        a0_valid[b] = ev.ints[b, I_A0VALID] == 1


@njit
def begin_step(b, dt, x, v, ev, a0, a0_valid):
    """Start a step of dt: save S0, trial step of the whole dt next."""
    _save(b, x, v, ev, a0, a0_valid)
    ev.ints[b, I_PHASE] = PHASE_TRIAL
    ev.ints[b, I_CALLS] = 0
    ev.flts[b, F_TLEFT] = dt
    ev.flts[b, F_TAU] = dt
    ev.counts[b, C_STEPS] += 1


@njit
def _next_subgoal(b, dt, x, v, ev, a0, a0_valid):
    """The sub-step just taken is accepted: start the next from here, or finish the step."""
    tau = ev.flts[b, F_TAU]
    ev.flts[b, F_TLEFT] -= tau
    if ev.flts[b, F_TLEFT] <= 1e-12 * dt:
        return ACT_DONE
    _save(b, x, v, ev, a0, a0_valid)
    ev.ints[b, I_PHASE] = PHASE_TRIAL
    ev.flts[b, F_TAU] = ev.flts[b, F_TLEFT]
    return ACT_STEP


@njit
def _plain(b, dt, x, v, ev, a0, a0_valid):
    """Give up locating for the rest of this step: accept what was stepped, then step plainly."""
    ev.counts[b, C_FALLBACKS] += 1
    act = _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
    ev.ints[b, I_PHASE] = PHASE_PLAIN
    return act


@njit
def _set_cross(b, dt, gap, rate, s, m0, ev):
    """Crossing step from a state on the old side within the margin: delta = (s gap + 3 m0) / |rate|.
    Returns CROSS_OK, CROSS_AFTER_STEP (the switch falls after the end of this step: finish the
    step plainly, the next one crosses it) or CROSS_NO (not closing fast enough: a graze)."""
    closing = -s * rate
    if not closing > 0.0:
        return CROSS_NO
    delta = (s * gap + 3.0 * m0) / closing  # lands ~3 m0 past the switch: clear of the round-off zone
    if not delta <= CROSS_MAX * dt:
        return CROSS_NO
    if not delta < ev.flts[b, F_TLEFT]:
        return CROSS_AFTER_STEP
    ev.flts[b, F_DELTA] = delta
    return CROSS_OK


@njit
def _start_landing(b, dt, x, v, ev, rk4, model, D, a0, a0_valid):
    """The scan recorded the first switching contact over the interval (S0, x) of length tau:
    set up the root finding of its landing point (or cross at once if S0 is within its margin)."""
    tau = ev.flts[b, F_TAU]
    kind, i, j = ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J]
    theta = ev.flts[b, F_THETA]
    m = ev.flts[b, F_SCAN_MARGIN]
    g0 = _gap(kind, b, i, j, ev.x0, model, D)
    s = ev.flts[b, F_SCAN_SIGN]
    ev.flts[b, F_SIGN] = s
    ev.flts[b, F_MARGIN] = m
    m0 = _tol(kind, b, i, j, ev.x0, model, D)
    if theta <= 0.0 or s * g0 <= m:
        # S0 is already within the margin: cross from S0
        rate0 = _gap_rate(kind, b, i, j, ev.x0, ev.v0, model, D)
        _restore(b, x, v, ev, a0, a0_valid)
        ev.flts[b, F_TAU] = 0.0
        res = _set_cross(b, dt, g0, rate0, s, m0, ev)
        if res == CROSS_OK:
            return ACT_CROSS
        if res == CROSS_NO:
            # cannot cross in a short step (a graze): take the rest of the step plainly
            ev.counts[b, C_FALLBACKS] += 1
        ev.ints[b, I_PHASE] = PHASE_PLAIN
        ev.flts[b, F_TAU] = ev.flts[b, F_TLEFT]
        return ACT_STEP
    g1 = _gap(kind, b, i, j, x, model, D)
    ev.ints[b, I_PHASE] = PHASE_LAND
    ev.ints[b, I_LAND] = 0
    ev.ints[b, I_HAS_LO] = 1
    ev.flts[b, F_TLO] = 0.0
    ev.flts[b, F_SGLO] = s * g0
    ev.ints[b, I_HAS_PREV] = 0
    if s * g1 < m:  # the end of the interval is past the landing point: a valid upper bracket
        ev.ints[b, I_HAS_HI] = 1
        ev.flts[b, F_THI] = tau
        ev.flts[b, F_SGHI] = s * g1
    else:
        ev.ints[b, I_HAS_HI] = 0
    _restore(b, x, v, ev, a0, a0_valid)
    ev.flts[b, F_TAU] = theta * tau
    return ACT_STEP


@njit
def decide(b, dt, x, v, rk4, grid, model, g, ev, a0, a0_valid):
    """After an integrator call from S0 over F_TAU: accept, retry with another tau, or cross."""
    D = len(g)
    ev.ints[b, I_CALLS] += 1
    phase = ev.ints[b, I_PHASE]
    tau = ev.flts[b, F_TAU]
    if phase == PHASE_PLAIN:
        return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
    if ev.ints[b, I_CALLS] >= MAX_CALLS:
        return _plain(b, dt, x, v, ev, a0, a0_valid)
    if phase == PHASE_TRIAL:
        if tau <= 0.0:
            return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
        count = scan(b, ev.x0, ev.v0, x, v, tau, rk4, grid, model, g, ev)
        if count == 0:
            return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
        return _start_landing(b, dt, x, v, ev, rk4, model, D, a0, a0_valid)

    # PHASE_LAND: the step from S0 over tau is a candidate landing for the recorded contact
    kind, i, j = ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J]
    s = ev.flts[b, F_SIGN]
    count = scan(b, ev.x0, ev.v0, x, v, tau, rk4, grid, model, g, ev) if tau > 0.0 else 0
    if count > 0 and not (ev.ints[b, I_KIND] == kind and ev.ints[b, I_I] == i and ev.ints[b, I_J] == j):
        # another contact switches first: land on that one instead
        return _start_landing(b, dt, x, v, ev, rk4, model, D, a0, a0_valid)
    # restore the event contact in the record (the scan may have left it unchanged anyway)
    ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J] = kind, i, j
    sg = s * _gap(kind, b, i, j, x, model, D)
    rate = _gap_rate(kind, b, i, j, x, v, model, D)
    m0 = _tol(kind, b, i, j, x, model, D)
    if rk4 and sg > 0.0 and tau > 0.0:
        # a clean sub-step: a better estimate of RK4's margin from its own interpolant
        ev.flts[b, F_MARGIN] = _margin(kind, b, i, j, ev.x0, ev.v0, x, v, tau, rk4, model, D)
    m = ev.flts[b, F_MARGIN]
    if sg > 0.0 and 0.5 * m <= sg <= 2.0 * m:
        # landed: accept the sub-step, then cross the switch
        ev.flts[b, F_TLEFT] -= tau
        ev.flts[b, F_TAU] = 0.0
        res = _set_cross(b, dt, s * sg, rate, s, m0, ev)
        if res == CROSS_OK:
            return ACT_CROSS
        act = _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
        if res == CROSS_AFTER_STEP:
            ev.ints[b, I_PHASE] = PHASE_PLAIN  # the few ulps left of the step: step them plainly
        return act
    # not there yet: update the bracket and take the next root-finding step on G(tau) = s gap - m
    if sg > m:
        ev.ints[b, I_HAS_LO] = 1
        ev.flts[b, F_TLO] = tau
        ev.flts[b, F_SGLO] = sg
    else:
        ev.ints[b, I_HAS_HI] = 1
        ev.flts[b, F_THI] = tau
        ev.flts[b, F_SGHI] = sg
    ev.ints[b, I_LAND] += 1
    if ev.ints[b, I_LAND] > MAX_LAND:
        if count == 0 and sg > 0.0:
            # a clean sub-step that is not at the switch: accept it and look again from there
            ev.counts[b, C_FALLBACKS] += 1
            return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
        _restore(b, x, v, ev, a0, a0_valid)
        ev.flts[b, F_TAU] = ev.flts[b, F_TLEFT]
        ev.counts[b, C_FALLBACKS] += 1
        ev.ints[b, I_PHASE] = PHASE_PLAIN
        return ACT_STEP
    G = sg - m
    if ev.ints[b, I_HAS_PREV] == 1 and ev.flts[b, F_SGPREV] != sg:
        # secant through the last two samples
        tp = ev.flts[b, F_TPREV]
        Gp = ev.flts[b, F_SGPREV] - m
        tau_new = tau - G * (tau - tp) / (G - Gp)
    elif sg > 0.0 and s * rate < 0.0:
        tau_new = tau + G / (-s * rate)  # Newton with d(s gap)/dtau ~ s rate
    else:
        tau_new = -1.0
    lo = ev.flts[b, F_TLO]
    hi = ev.flts[b, F_THI] if ev.ints[b, I_HAS_HI] == 1 else ev.flts[b, F_TLEFT]
    if not (lo < tau_new < hi):
        tau_new = 0.5 * (lo + hi)  # safeguard: bisect the bracket
    ev.ints[b, I_HAS_PREV] = 1
    ev.flts[b, F_TPREV] = tau
    ev.flts[b, F_SGPREV] = sg
    _restore(b, x, v, ev, a0, a0_valid)
    ev.flts[b, F_TAU] = tau_new
    return ACT_STEP


@njit
def after_cross(b, dt, x, v, ev, a0, a0_valid, model, g):
    """The crossing step of F_DELTA was taken: continue with the time left. (If the crossing fell
    a few ulps short of the switch, the next trial crosses it at once.)"""
    kind, i, j = ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J]
    if ev.flts[b, F_SIGN] * _gap(kind, b, i, j, x, model, len(g)) < -_tol(kind, b, i, j, x, model, len(g)):
        ev.counts[b, C_EVENTS] += 1  # a switch located and crossed (clear of the round-off zone)
    ev.flts[b, F_TAU] = ev.flts[b, F_DELTA]
    return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)


# --------------------------------------------------------------------------------------------
# The driver (any integrator: its work buffers select the step, as in ``integrators.run_worlds``)
# --------------------------------------------------------------------------------------------


def cached_acceleration(work):
    """(a0, a0_valid) of velocity Verlet's cache, saved and restored with the state; (None, None)
    for the other integrators (jitted code only)."""
    raise NotImplementedError("cached_acceleration is called from jitted code")


@overload(cached_acceleration, inline="always")
def _cached_acceleration(work):
    if is_work(work, VelocityVerletWork):
        return lambda work: (work.a0, work.a0_valid)
    return lambda work: (None, None)


def forget_cache(work, b):
    """After the crossing step: velocity Verlet's cache belongs to the state before it."""
    raise NotImplementedError("forget_cache is called from jitted code")


@overload(forget_cache, inline="always")
def _forget_cache(work, b):
    if is_work(work, VelocityVerletWork):

        def impl(work, b):
            work.a0_valid[b] = False

        return impl
    return lambda work, b: None


def evaluations(work, b):
    """Full contact passes the next step of world b costs (counted before it is taken)."""
    raise NotImplementedError("evaluations is called from jitted code")


@overload(evaluations, inline="always")
def _evaluations(work, b):
    if is_work(work, VelocityVerletWork):
        return lambda work, b: 1 if work.a0_valid[b] else 2
    if is_work(work, RK4Work):
        return lambda work, b: 4
    return lambda work, b: 1


def is_rk4(work):
    """True for RK4, whose look-ahead fourth stage needs a landing margin."""
    raise NotImplementedError("is_rk4 is called from jitted code")


@overload(is_rk4, inline="always")
def _is_rk4(work):
    if is_work(work, RK4Work):
        return lambda work: True
    return lambda work: False


@njit(nogil=True)
def run_worlds(b0, b1, nsteps, dt, x, v, work, ext, grid, model, friction, g, ev, status):
    """Event-located stepping of worlds b0..b1-1 (serial, as ``integrators.run_worlds``)."""
    a0, a0_valid = cached_acceleration(work)
    rk4 = is_rk4(work)
    for b in range(b0, b1):
        begin_world(work, b)
        ok = True
        for _ in range(nsteps):
            begin_step(b, dt, x, v, ev, a0, a0_valid)
            while True:
                evals = evaluations(work, b)
                ok = integrate(work, b, ev.flts[b, F_TAU], x, v, ext, grid, model, friction, g)
                ev.counts[b, C_CALLS] += 1
                ev.counts[b, C_EVALS] += evals
                if not ok:
                    break
                act = decide(b, dt, x, v, rk4, grid, model, g, ev, a0, a0_valid)
                if act == ACT_CROSS:
                    ok = symplectic_euler_into(work[0], b, ev.flts[b, F_DELTA], x, v, ext, grid, model, friction, g)
                    ev.counts[b, C_EVALS] += 1
                    forget_cache(work, b)
                    if not ok:
                        break
                    act = after_cross(b, dt, x, v, ev, a0, a0_valid, model, g)
                if act == ACT_DONE:
                    break
            if not ok:
                break
        status[b] = world_status(work, b, ok, x, v, g)
