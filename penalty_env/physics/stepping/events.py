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

from ..._jit import njit, overload_kernel
from ..geometry.evaluate import advance_shapes
from .common import STATUS_OK, step_forces
from .event_scan import (
    C_CALLS,
    C_EVALS,
    C_EVENTS,
    C_FALLBACKS,
    C_STEPS,
    F_DELTA,
    F_MARGIN,
    F_SCAN_MARGIN,
    F_SCAN_SIGN,
    F_SGHI,
    F_SGLO,
    F_SGPREV,
    F_SIGN,
    F_TAU,
    F_THETA,
    F_THI,
    F_TLEFT,
    F_TLO,
    F_TPREV,
    I_A0VALID,
    I_CALLS,
    I_HAS_HI,
    I_HAS_LO,
    I_HAS_PREV,
    I_I,
    I_J,
    I_KIND,
    I_LAND,
    I_PHASE,
    EventBuffers,
    allocate,
    gap,
    gap_rate,
    margin,
    scan,
    tolerance,
)
from .integrators import RK4Work, VelocityVerletWork, integrate, is_work, symplectic_euler_into
from .scalar import begin_world, external, world_status
from .spin_steps import spin_tick

__all__ = ["EventBuffers", "allocate", "run_worlds", "stats", "MAX_CALLS"]


PHASE_TRIAL, PHASE_LAND, PHASE_PLAIN = 0, 1, 2
ACT_STEP, ACT_CROSS, ACT_DONE = 0, 1, 2
CROSS_OK, CROSS_AFTER_STEP, CROSS_NO = 0, 1, 2

MAX_CALLS = 48  # integrator calls per step before the rest of the step is taken plainly
MAX_LAND = 10  # root-finding iterations per switch
CROSS_MAX = 0.1  # the crossing step may be at most this fraction of dt


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
# The control logic
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
    g0 = gap(kind, b, i, j, ev.x0, model, D)
    s = ev.flts[b, F_SCAN_SIGN]
    ev.flts[b, F_SIGN] = s
    ev.flts[b, F_MARGIN] = m
    m0 = tolerance(kind, b, i, j, ev.x0, model, D)
    if theta <= 0.0 or s * g0 <= m:
        # S0 is already within the margin: cross from S0
        rate0 = gap_rate(kind, b, i, j, ev.x0, ev.v0, model, D)
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
    g1 = gap(kind, b, i, j, x, model, D)
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
def _refine_landing(b, dt, x, v, ev, a0, a0_valid, tau, sg, rate, s, m, count):
    """A landing step from S0 over tau missed the margin (s gap = sg against m): update the bracket
    and take the next root-finding step on G(tau) = s gap - m (secant, Newton, or bisection), or
    after MAX_LAND tries give up on landing and step plainly."""
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
def decide(b, dt, x, v, rk4, grid, buf, model, D, ev, a0, a0_valid):
    """After an integrator call from S0 over F_TAU: accept, retry with another tau, or cross."""
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
        count = scan(b, ev.x0, ev.v0, x, v, tau, rk4, grid, buf, model, D, ev)
        if count == 0:
            return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)
        return _start_landing(b, dt, x, v, ev, rk4, model, D, a0, a0_valid)

    # PHASE_LAND: the step from S0 over tau is a candidate landing for the recorded contact
    kind, i, j = ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J]
    s = ev.flts[b, F_SIGN]
    count = scan(b, ev.x0, ev.v0, x, v, tau, rk4, grid, buf, model, D, ev) if tau > 0.0 else 0
    if count > 0 and not (ev.ints[b, I_KIND] == kind and ev.ints[b, I_I] == i and ev.ints[b, I_J] == j):
        # another contact switches first: land on that one instead
        return _start_landing(b, dt, x, v, ev, rk4, model, D, a0, a0_valid)
    # restore the event contact in the record (the scan may have left it unchanged anyway)
    ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J] = kind, i, j
    sg = s * gap(kind, b, i, j, x, model, D)
    rate = gap_rate(kind, b, i, j, x, v, model, D)
    m0 = tolerance(kind, b, i, j, x, model, D)
    if rk4 and sg > 0.0 and tau > 0.0:
        # a clean sub-step: a better estimate of RK4's margin from its own interpolant
        ev.flts[b, F_MARGIN] = margin(kind, b, i, j, ev.x0, ev.v0, x, v, tau, rk4, model, D)
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
    return _refine_landing(b, dt, x, v, ev, a0, a0_valid, tau, sg, rate, s, m, count)


@njit
def after_cross(b, dt, x, v, ev, a0, a0_valid, model, D):
    """The crossing step of F_DELTA was taken: continue with the time left. (If the crossing fell
    a few ulps short of the switch, the next trial crosses it at once.)"""
    kind, i, j = ev.ints[b, I_KIND], ev.ints[b, I_I], ev.ints[b, I_J]
    if ev.flts[b, F_SIGN] * gap(kind, b, i, j, x, model, D) < -tolerance(kind, b, i, j, x, model, D):
        ev.counts[b, C_EVENTS] += 1  # a switch located and crossed (clear of the round-off zone)
    ev.flts[b, F_TAU] = ev.flts[b, F_DELTA]
    return _next_subgoal(b, dt, x, v, ev, a0, a0_valid)


# --------------------------------------------------------------------------------------------
# The driver (any integrator: its work buffers select the step, as in ``scalar.run_worlds``)
# --------------------------------------------------------------------------------------------


def cached_acceleration(work):
    """(a0, a0_valid) of velocity Verlet's cache, saved and restored with the state; (None, None)
    for the other integrators (jitted code only)."""
    raise NotImplementedError("cached_acceleration is called from jitted code")


@overload_kernel(cached_acceleration)
def _cached_acceleration(work):
    if is_work(work, VelocityVerletWork):
        return lambda work: (work.a0, work.a0_valid)
    return lambda work: (None, None)


def forget_cache(work, b):
    """After the crossing step: velocity Verlet's cache belongs to the state before it."""
    raise NotImplementedError("forget_cache is called from jitted code")


@overload_kernel(forget_cache)
def _forget_cache(work, b):
    if is_work(work, VelocityVerletWork):

        def impl(work, b):
            work.a0_valid[b] = False

        return impl
    return lambda work, b: None


def evaluations(work, b):
    """Full contact passes the next step of world b costs (counted before it is taken)."""
    raise NotImplementedError("evaluations is called from jitted code")


@overload_kernel(evaluations)
def _evaluations(work, b):
    if is_work(work, VelocityVerletWork):
        return lambda work, b: 1 if work.a0_valid[b] else 2
    if is_work(work, RK4Work):
        return lambda work, b: 4
    return lambda work, b: 1


def is_rk4(work):
    """True for RK4, whose look-ahead fourth stage needs a landing margin."""
    raise NotImplementedError("is_rk4 is called from jitted code")


@overload_kernel(is_rk4)
def _is_rk4(work):
    if is_work(work, RK4Work):
        return lambda work: True
    return lambda work: False


@njit
def _located_step(work, b, dt, x, v, ext, has_ext, grid, scratch, model, spin, g, ev, a0, a0_valid, rk4):
    """One located step of dt of world b (trial, landings, crossings). Returns whether it stayed finite."""
    D = len(g)
    buf = scratch.partners
    begin_step(b, dt, x, v, ev, a0, a0_valid)
    ok = True
    while True:
        evals = evaluations(work, b)
        ok = integrate(work, b, ev.flts[b, F_TAU], x, v, ext, has_ext, grid, buf, model, spin, g)
        ev.counts[b, C_CALLS] += 1
        ev.counts[b, C_EVALS] += evals
        if not ok:
            return ok
        act = decide(b, dt, x, v, rk4, grid, buf[b], model, D, ev, a0, a0_valid)
        if act == ACT_CROSS:
            ok = symplectic_euler_into(work[0], b, ev.flts[b, F_DELTA], x, v, ext, has_ext, grid, buf, model, spin, g)
            ev.counts[b, C_EVALS] += 1
            forget_cache(work, b)
            if not ok:
                return ok
            act = after_cross(b, dt, x, v, ev, a0, a0_valid, model, D)
        if act == ACT_DONE:
            return ok


@njit(entry=True, nogil=True)
def run_worlds(worlds, nsteps, dt, x, v, work, control, grid, scratch, model, spin, g, ev, status):
    """Event-located stepping of the listed worlds (serial, as ``scalar.run_worlds``). Returns how
    many blew up."""
    D = len(g)
    a0, a0_valid = cached_acceleration(work)
    rk4 = is_rk4(work)
    ext, has_ext = external(control, scratch, model.motors)
    has_motors = model.motors.ball.shape[0] > 0
    bad = 0
    for t in range(worlds.shape[0]):
        b = worlds[t]
        begin_world(work, b)
        ok = True
        for _ in range(nsteps):
            if has_motors:
                step_forces(b, v, control, model.motors, ext, D)
            ok = _located_step(work, b, dt, x, v, ext, has_ext, grid, scratch, model, spin, g, ev, a0, a0_valid, rk4)
            spin_tick(spin, b)
            advance_shapes(model.shapes, b, dt, D)
            if not ok:
                break
        status[b] = world_status(work, b, ok, x, v, D)
        bad += status[b] != STATUS_OK
    return bad
