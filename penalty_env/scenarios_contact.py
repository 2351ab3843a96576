"""The single-contact accuracy scenarios (re-exported by :mod:`penalty_env.scenarios`).

* :func:`pair_collision` (scenario 1), :func:`bowl_drop` (scenario 2), :func:`resting` (scenario 3),
  each measuring its errors against the closed forms of :mod:`penalty_env.physics.theory`, worst
  case over where the contact starts in the step grid, and its cost (:class:`Measure`);
* the helpers the pile scenarios (:mod:`penalty_env.scenarios_pile`) share with them: the World of
  a scenario, its cost, its timed stepping.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .physics import Bowl, World, theory
from .physics.stepping import events as EV

PHASES = 1024  # start phases of the collision scenarios (worst case over them)

# scenario constants ------------------------------------------------------------------------
PAIR_MASSES = (1.0, 3.0)
PAIR_RADII = (0.1, 0.15)
PAIR_KS = 1.0e4
PAIR_SPEED = 1.0

DROP_MASS, DROP_RADIUS, DROP_KS, DROP_SPEED, G = 1.0, 0.1, 4.0e4, 2.0, 9.81
BOWL = Bowl((0.0, 0.0, 1.0), 1.0)  # floor at z = 0


@dataclass
class Measure:
    """One run: errors by metric, and its cost."""

    errors: dict
    diverged: bool
    wall_per_sim_s: float  # wall seconds per simulated second, per world
    evals_per_sim_s: float  # force evaluations per simulated second, per world
    events_per_sim_s: float = 0.0
    fallbacks: int = 0
    sim_time: float = math.nan  # simulated seconds per world
    extra: dict = field(default_factory=dict)


def _world(x, v, radii, masses, *, integrator, events, damping, ks, kd, dt, gravity, terrain=(), **kw):
    return World(
        x,
        radii,
        masses,
        v,
        terrain=terrain,
        gravity=gravity,
        ks=ks,
        kd=kd,
        damping=damping,
        integrator=integrator,
        dt=dt,
        allow_unstable=True,
        events=events,
        **kw,
    )


def _cost(w: World, nsteps: int, wall: float) -> tuple[float, float, float, int, float]:
    """(wall / sim s, evals / sim s, events / sim s, fallbacks, sim s), per world."""
    sim = nsteps * w.dt
    B = w.n_worlds
    if w.events:
        st = EV.stats(w)
        evals, n_ev, fb = st["force_evaluations"] / B, st["events"] / B, st["fallbacks"]
    else:
        evals, n_ev, fb = w.force_evaluations_per_step * nsteps, 0.0, 0
    return wall / (B * sim), evals / sim, n_ev / sim, fb, sim


def _timed_steps(w: World, nsteps: int, record=None):
    """Step ``nsteps``; with ``record`` (a callback of the World) call it after every step. Returns
    the wall time of the stepping alone, or None if the run produced NaN / inf."""
    try:
        if record is None:
            t = time.perf_counter()
            w.step(nsteps)
            return time.perf_counter() - t
        wall = 0.0
        for _ in range(nsteps):
            t = time.perf_counter()
            w.step(1)
            wall += time.perf_counter() - t
            record(w)
        return wall
    except FloatingPointError:
        return None


def _hermite_peak(d0, r0, d1, r1, h):
    """Largest value of the cubic Hermite interpolant of (d, d') over [0, h], per world."""
    # d(s) = a + b s + c s^2 + e s^3 on s in [0, 1], with d'(s) scaled by h
    a = d0
    b = h * r0
    c = 3.0 * (d1 - d0) - h * (2.0 * r0 + r1)
    e = 2.0 * (d0 - d1) + h * (r0 + r1)
    best = np.maximum(d0, d1)
    qa, qb, qc = 3.0 * e, 2.0 * c, b  # d'(s) = qa s^2 + qb s + qc
    disc = qb * qb - 4.0 * qa * qc
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        for s in ((-qb + sq) / (2.0 * qa), (-qb - sq) / (2.0 * qa), -qc / qb):
            ok = np.isfinite(s) & (s > 0.0) & (s < 1.0) & (disc >= 0.0)
            val = a + b * s + c * s * s + e * s * s * s
            best = np.where(ok, np.maximum(best, np.where(ok, val, -np.inf)), best)
    return best


# --------------------------------------------------------------------------------------------
# Scenario 1: pair collision
# --------------------------------------------------------------------------------------------


def pair_collision(
    integrator,
    events,
    damping,
    zeta,
    spc,
    phases=PHASES,
    *,
    masses=PAIR_MASSES,
    radii=PAIR_RADII,
    ks=PAIR_KS,
    speed=PAIR_SPEED,
    kd=None,
    dt=None,
) -> Measure:
    """Head-on collision along x, gravity off, one world per start phase. Errors: ``restitution``,
    ``duration`` (relative, worst over phases) and ``peak_overlap`` (relative to the exact peak;
    ``peak_ratio`` in extra: the worst peak overlap / the smaller radius)."""
    m1, m2 = masses
    me = theory.effective_mass(m1, m2)
    if kd is None:
        kd = 2.0 * zeta * math.sqrt(ks * me)
    zeta = theory.damping_ratio(ks, kd, me)
    omega = theory.natural_frequency(ks, me)
    tc = theory.contact_time(ks, kd, me)
    if dt is None:
        dt = tc / spc
    exact = theory.contact_response(zeta, damping)
    gaps, x, v = _pair_start(phases, masses, radii, speed, dt)
    n_steps = int(math.ceil((1.6 * exact.duration / omega) / dt)) + 8
    kw = dict(
        integrator=integrator,
        events=events,
        damping=damping,
        ks=ks,
        kd=kd,
        dt=dt,
        gravity=(0.0, 0.0, 0.0),
        broadphase="all_pairs",
    )
    l0 = radii[0] + radii[1]
    peak, record = _pair_peak_recorder(l0, gaps, speed, dt)

    w = _world(x, v, radii, masses, **kw)
    ok = _timed_steps(w, n_steps, record) is not None
    end = _pair_end(w, n_steps, dt, l0, speed, gaps) if ok else None
    if end is None:
        return Measure(
            {"restitution": math.inf, "duration": math.inf, "peak_overlap": math.inf}, True, math.nan, math.nan
        )
    gap_end, u, e_num, t_end, t_begin = end
    separated = (gap_end > 0) & (u > 0)
    e_err = np.abs(e_num / exact.restitution - 1.0)
    tc_err = np.where(separated, np.abs((t_end - t_begin) * omega / exact.duration - 1.0), 1.0)
    pk_err = np.abs(peak * omega / speed / exact.peak_overlap - 1.0)
    # timing: a fresh world stepped in one call
    w2 = _world(x, v, radii, masses, **kw)
    wall = _timed_steps(w2, n_steps)
    cost = _cost(w2, n_steps, wall if wall is not None else math.nan)
    errors = {"restitution": float(e_err.max()), "duration": float(tc_err.max()), "peak_overlap": float(pk_err.max())}
    diverged = not all(math.isfinite(e) for e in errors.values()) or errors["restitution"] > 1.0
    return Measure(
        errors,
        diverged,
        *cost,
        extra={"peak_ratio": float(peak.max() / min(radii)), "separated": bool(separated.all())},
    )


def _pair_start(phases, masses, radii, speed, dt):
    """The pair's start, one world per phase: the gaps (each closes during the second step),
    positions and velocities (the centre of mass at rest)."""
    m1, m2 = masses
    ph = np.arange(phases) / phases
    gaps = speed * dt * (1.0 + ph)
    x = np.zeros((phases, 2, 3))
    v = np.zeros((phases, 2, 3))
    x[:, 1, 0] = radii[0] + radii[1] + gaps
    v[:, 0, 0] = speed * m2 / (m1 + m2)
    v[:, 1, 0] = -speed * m1 / (m1 + m2)
    return gaps, x, v


def _pair_peak_recorder(l0, gaps, speed, dt):
    """The peak overlap per world (filled as the run goes) and the callback that records it after
    every step, from the cubic Hermite interpolant of the overlap over the step."""
    phases = gaps.shape[0]
    peak = np.zeros(phases)
    prev = {"d": -gaps, "r": np.full(phases, speed)}

    def record(w):
        xx, vv = w.positions, w.velocities
        d = l0 - (xx[:, 1, 0] - xx[:, 0, 0])
        r = -(vv[:, 1, 0] - vv[:, 0, 0])
        peak[:] = np.maximum(peak, _hermite_peak(prev["d"], prev["r"], d, r, dt))
        prev["d"], prev["r"] = d, r

    return peak, record


def _pair_end(w, n_steps, dt, l0, speed, gaps):
    """The pair after the run: (gap at the end, separation speed, numerical restitution, time the
    contact ended, time it began) per world; None if a restitution is not finite."""
    xx, vv = w.positions, w.velocities
    gap_end = (xx[:, 1, 0] - xx[:, 0, 0]) - l0
    u = vv[:, 1, 0] - vv[:, 0, 0]  # separation speed
    e_num = u / speed
    t_end = n_steps * dt - np.where(u > 0, gap_end / np.where(u > 0, u, 1.0), np.inf)
    t_begin = gaps / speed
    if not bool(np.all(np.isfinite(e_num))):
        return None
    return gap_end, u, e_num, t_end, t_begin


# --------------------------------------------------------------------------------------------
# Scenario 2: a ball dropped into the bowl
# --------------------------------------------------------------------------------------------


def bowl_drop(
    integrator,
    events,
    damping,
    zeta,
    spc,
    phases=PHASES,
    *,
    mass=DROP_MASS,
    radius=DROP_RADIUS,
    ks=DROP_KS,
    speed=DROP_SPEED,
    g=G,
    kd=None,
    dt=None,
    terrain=None,
) -> Measure:
    """Ball falling along the bowl's axis, arriving at the floor at ``speed`` at phase k/phases of
    the second step. Errors: rebound ``restitution`` (speed at the floor on the way up, from the
    first state after the contact, by energy in free flight) and ``peak_overlap``, against the exact
    solution with gravity. ``terrain``: another floor touched at the bowl's bottom (the origin,
    normal up), for instance a Plane."""
    if kd is None:
        kd = 2.0 * zeta * math.sqrt(ks * mass)
    zeta = theory.damping_ratio(ks, kd, mass)
    omega = theory.natural_frequency(ks, mass)
    tc = theory.contact_time(ks, kd, mass)
    if dt is None:
        dt = tc / spc
    exact = theory.contact_response(zeta, damping, g / (omega * speed))
    ph = np.arange(phases) / phases
    t_arrive = dt * (1.0 + ph)
    v0 = speed - g * t_arrive  # downward speed at the start
    h0 = speed * t_arrive - 0.5 * g * t_arrive**2  # height of the contact point above the floor
    x = np.zeros((phases, 1, 3))
    v = np.zeros((phases, 1, 3))
    x[:, 0, 2] = radius + h0
    v[:, 0, 2] = -v0
    n_steps = int(math.ceil(1.6 * exact.duration / omega / dt)) + 8
    kw = dict(
        integrator=integrator,
        events=events,
        damping=damping,
        ks=ks,
        kd=kd,
        dt=dt,
        gravity=(0.0, 0.0, -g),
        terrain=(BOWL,) if terrain is None else terrain,
    )
    peak = np.zeros(phases)
    v_exit = np.full(phases, np.nan)
    state = {"d": -h0, "r": v0.copy(), "touched": np.zeros(phases, dtype=bool)}

    def record(w):
        z, vz = w.positions[:, 0, 2], w.velocities[:, 0, 2]
        d = radius - z
        r = -vz
        peak[:] = np.maximum(peak, _hermite_peak(state["d"], state["r"], d, r, dt))
        state["touched"] |= d > 0
        out = state["touched"] & (d <= 0) & (vz > 0) & np.isnan(v_exit)
        v_exit[out] = np.sqrt(vz[out] ** 2 + 2.0 * g * (z[out] - radius))
        state["d"], state["r"] = d, r

    w = _world(x, v, [radius], [mass], **kw)
    wall = _timed_steps(w, n_steps, record)
    if wall is None or not np.all(np.isfinite(w.positions)):
        return Measure({"restitution": math.inf, "peak_overlap": math.inf}, True, math.nan, math.nan)
    e_num = np.where(np.isnan(v_exit), 0.0, v_exit) / speed
    e_err = np.abs(e_num / exact.restitution - 1.0)
    pk_err = np.abs(peak * omega / speed / exact.peak_overlap - 1.0)
    w2 = _world(x, v, [radius], [mass], **kw)
    wall = _timed_steps(w2, n_steps)
    cost = _cost(w2, n_steps, wall if wall is not None else math.nan)
    errors = {"restitution": float(e_err.max()), "peak_overlap": float(pk_err.max())}
    diverged = not all(math.isfinite(e) for e in errors.values()) or errors["restitution"] > 1.0
    return Measure(errors, diverged, *cost, extra={"peak_ratio": float(peak.max() / radius)})


# --------------------------------------------------------------------------------------------
# Scenario 3: resting contact
# --------------------------------------------------------------------------------------------


def resting(
    integrator,
    events,
    damping,
    zeta,
    spc,
    phases=16,
    *,
    mass=DROP_MASS,
    radius=DROP_RADIUS,
    ks=DROP_KS,
    g=G,
    kd=None,
    dt=None,
) -> Measure:
    """A ball set down (from rest, a fraction of g dt^2 above the floor) settles at the overlap
    m g / ks. Error: |overlap / (m g / ks) - 1| after 25 / (zeta omega0) (the exact transient has
    decayed below 1e-10 by then). Needs zeta > 0."""
    if kd is None:
        kd = 2.0 * zeta * math.sqrt(ks * mass)
    zeta = theory.damping_ratio(ks, kd, mass)
    if zeta <= 0.0:
        raise ValueError("resting contact needs damping (zeta > 0) to settle")
    omega = theory.natural_frequency(ks, mass)
    tc = theory.contact_time(ks, kd, mass)
    if dt is None:
        dt = tc / spc
    rest = mass * g / ks
    ph = np.arange(phases) / phases
    x = np.zeros((phases, 1, 3))
    x[:, 0, 2] = radius + ph * g * dt * dt
    v = np.zeros_like(x)
    n_steps = int(math.ceil(25.0 / (zeta * omega) / dt))
    kw = dict(
        integrator=integrator,
        events=events,
        damping=damping,
        ks=ks,
        kd=kd,
        dt=dt,
        gravity=(0.0, 0.0, -g),
        terrain=(BOWL,),
    )
    w = _world(x, v, [radius], [mass], **kw)
    wall = _timed_steps(w, n_steps)
    if wall is None:
        return Measure({"resting_overlap": math.inf}, True, math.nan, math.nan)
    overlap = radius - w.positions[:, 0, 2]
    err = np.abs(overlap / rest - 1.0)
    cost = _cost(w, n_steps, wall)
    e = float(err.max())
    return Measure({"resting_overlap": e}, not math.isfinite(e) or e > 1.0, *cost)
