"""Scenes the tests and the benchmarks share (built on the public ``World`` API only).

* :func:`balls_in_bowl`: n non-overlapping balls scattered in a bowl, B worlds: the general-purpose
  scene of the physics tests;
* :func:`packed_bowl`, :func:`large_world`: a bowl filled from the bottom on a close-packed lattice
  (the core benchmark's large worlds; they slump, then settle);
* the accuracy scenarios (:func:`pair_collision`, :func:`bowl_drop`, :func:`resting`,
  :func:`elastic_pile`, :func:`damped_pile`), each measuring its errors against the closed forms of
  :mod:`penalty_env.physics.theory`, worst case over where the contact starts in the step grid, and
  its cost (:class:`Measure`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .physics import Bowl, World, theory
from .physics.stepping import events as EV

__all__ = [
    "balls_in_bowl",
    "packed_bowl",
    "large_world",
    "scene_params",
    "Measure",
    "pair_collision",
    "bowl_drop",
    "resting",
    "pile_scene",
    "pile_params",
    "elastic_pile",
    "damped_pile",
    "pile_reference",
    "count_pile_contacts",
    "PHASES",
]

PHASES = 1024  # start phases of the collision scenarios (worst case over them)


def balls_in_bowl(
    n: int,
    d: int = 3,
    worlds: int = 1,
    seed: int = 0,
    radius: float | np.ndarray = 0.1,
    bowl_radius: float = 1.0,
    spacing: float = 0.01,
    min_height: float | None = None,
    speed: float = 0.0,
    mass: float | np.ndarray = 1.0,
    lattice: bool = False,
    lift: float = 0.3,
    jitter: float = 0.002,
):
    """n balls inside a bowl of radius ``bowl_radius`` whose floor touches the origin, ``worlds``
    independent draws: scattered without overlap (rejection sampling, at least ``spacing`` apart
    and from the wall, centres above ``min_height``), or with ``lattice`` on a cubic lattice of
    pitch 2 r_max + ``spacing`` centred ``lift`` above the floor, jittered by ``jitter``.

    Returns ``(positions (worlds, n, d), velocities, radii (n,), masses (n,), bowl)``; velocities
    are uniform in a ball of radius ``speed``. ``radius`` and ``mass`` may be per ball.
    """
    rng = np.random.default_rng(seed)
    radii = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,)).copy()
    masses = np.broadcast_to(np.asarray(mass, dtype=np.float64), (n,)).copy()
    center = np.zeros(d)
    center[-1] = bowl_radius
    x = np.zeros((worlds, n, d))
    for b in range(worlds):
        if lattice:
            side = math.ceil(n ** (1.0 / d) - 1e-9)
            cell = 2.0 * radii.max() + spacing
            pts = np.array(np.meshgrid(*[np.arange(side)] * d, indexing="ij")).reshape(d, -1).T[:n] * cell
            pts = pts - pts.mean(0) + rng.normal(0.0, jitter, pts.shape)
            pts[:, -1] += lift + radii.max()
            x[b] = pts
            continue
        pts: list[np.ndarray] = []
        tries = 0
        while len(pts) < n:
            tries += 1
            if tries > 200_000:
                raise RuntimeError("could not place the balls: the bowl is too full")
            i = len(pts)
            p = center + rng.uniform(-1.0, 1.0, d) * bowl_radius
            if np.linalg.norm(p - center) > bowl_radius - radii[i] - spacing:
                continue
            if min_height is not None and p[-1] < min_height:
                continue
            if all(np.linalg.norm(p - q) > radii[i] + radii[j] + spacing for j, q in enumerate(pts)):
                pts.append(p)
        x[b] = pts
    dirs = rng.normal(size=(worlds, n, d))
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    v = dirs * speed * rng.uniform(0, 1, (worlds, n, 1)) ** (1 / d)
    return x, v, radii, masses, Bowl(tuple(center), bowl_radius)


def wall_collision_gains(
    integrator: str, omega_dt: float, zeta: float = 0.0, phases: int = 512, damping: str = "linear"
) -> np.ndarray:
    """e_num^2 - 1 of a ball hitting the floor of a large Bowl head on (along its axis, gravity
    off), one world per phase of the contact's start within the step: the World's own version of
    the collision ``theory.energy_gain_per_collision`` models (the same phases)."""
    r, m, ks, v0 = 0.1, 1.0, 1e4, 1.0
    omega = math.sqrt(ks / m)
    dt = omega_dt / omega
    phase = (np.arange(phases) + 0.5) / phases
    x = np.zeros((phases, 1, 3))
    x[:, 0, 2] = r + v0 * dt * phase  # the gap closes during the first step
    v = np.zeros_like(x)
    v[:, 0, 2] = -v0
    w = World(
        x,
        [r],
        [m],
        v,
        terrain=Bowl((0.0, 0.0, 50.0), 50.0),
        gravity=(0.0, 0.0, 0.0),
        ks=ks,
        kd=2.0 * zeta * math.sqrt(ks * m),
        damping=damping,
        integrator=integrator,
        dt=dt,
        allow_unstable=True,
    )
    w.step(int(2.0 * math.pi / omega_dt) + 10)
    vz = w.velocities[:, 0, 2]
    if not (np.all(w.positions[:, 0, 2] > r) and np.all(vz > 0)):
        raise RuntimeError("a ball has not left the floor")
    return (vz / v0) ** 2 - 1.0


def elastic_gas(worlds: int = 192, n: int = 8, seed: int = 0):
    """``worlds`` worlds of n balls of radius 0.1 inside a spherical cage of radius 1 about the
    origin, velocities normal with 1 m/s per axis, no gravity: a dense elastic gas. Returns
    ``(positions, velocities, radius, world_kwargs)`` (the cage, gravity off, ks = 1e4, kd = 0)."""
    x, _, _, _, cage = balls_in_bowl(n, 3, worlds=worlds, seed=seed, radius=0.1, bowl_radius=1.0, spacing=0.01)
    v = np.random.default_rng(seed).normal(0.0, 1.0, (worlds, n, 3))
    kw = dict(terrain=Bowl((0.0, 0.0, 0.0), 1.0), gravity=(0.0, 0.0, 0.0), ks=1e4, kd=0.0)
    return x - np.array(cage.center), v, 0.1, kw


def packed_bowl(n: int, d: int = 3, radius: float = 0.5, seed: int = 0, spacing: float = 2.02):
    """n balls of one radius filling the bottom of a bowl, lowest first, on a jittered close-packed
    lattice (face-centred cubic in 3D, hexagonal in 2D). Frictionless balls cannot hold it against
    the bowl's curved floor: the pile slumps and sloshes for a few seconds before it settles."""
    R = radius * (spacing**d * n / (0.6 * (np.pi if d == 2 else 2.0 * np.pi / 3.0))) ** (1.0 / d) + 2 * radius
    center = np.zeros(d)
    center[-1] = R
    a = spacing * radius  # nearest-neighbour distance
    if d == 3:  # face-centred cubic: cube edge a sqrt 2, four balls per cube
        basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]) * a * np.sqrt(2)
        cell = np.full(3, a * np.sqrt(2))
    else:  # hexagonal: rectangle a x a sqrt 3, two balls per rectangle
        basis = np.array([[0, 0], [0.5 * a, 0.5 * a * np.sqrt(3)]])
        cell = np.array([a, a * np.sqrt(3)])
    axes = [np.arange(int(np.ceil(2 * R / cell[k])) + 1) * cell[k] - R for k in range(d)]
    corners = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
    grid = (corners[:, None, :] + basis[None]).reshape(-1, d) + center
    inside = np.linalg.norm(grid - center, axis=1) < R - 1.5 * radius
    pts = grid[inside]
    pts = pts[np.argsort(pts[:, -1], kind="stable")][:n]
    if len(pts) < n:
        raise RuntimeError(f"packing failed: {len(pts)} < {n}")
    rng = np.random.default_rng(seed)
    pts = pts + rng.uniform(-0.005, 0.005, pts.shape) * radius
    return pts, Bowl(tuple(center), R)


def scene_params(radius: float, mass: float, g: float = 9.81):
    # stiffness from a penetration tolerance: 5% of the radius at the speed of a fall of 2 radii
    v = np.sqrt(2 * g * 2 * radius)
    ks = theory.stiffness_for_penetration(mass / 2, v, 0.05 * radius)
    kd = theory.damping_for_restitution(0.5, ks, mass / 2)
    return ks, kd


def large_world(n: int, broadphase: str = "grid") -> World:
    radius, mass = 0.5, 1.0
    pos, bowl = packed_bowl(n, 3, radius)
    ks, kd = scene_params(radius, mass)
    probe = World(pos[:2], [radius] * 2, [mass] * 2, terrain=(bowl,), ks=ks, kd=kd, dt=1.0, allow_unstable=True)
    return World(
        pos,
        np.full(n, radius),
        np.full(n, mass),
        terrain=(bowl,),
        ks=ks,
        kd=kd,
        dt=probe.stability_limit(),
        broadphase=broadphase,
    )


# scenario constants ------------------------------------------------------------------------
PAIR_MASSES = (1.0, 3.0)
PAIR_RADII = (0.1, 0.15)
PAIR_KS = 1.0e4
PAIR_SPEED = 1.0

DROP_MASS, DROP_RADIUS, DROP_KS, DROP_SPEED, G = 1.0, 0.1, 4.0e4, 2.0, 9.81
BOWL = Bowl((0.0, 0.0, 1.0), 1.0)  # floor at z = 0

PILE_N, PILE_RADIUS, PILE_MASS, PILE_SPEED = 64, 0.08, 1.0, 5.0
PILE_BOWL = Bowl((0.0, 0.0, 0.6), 0.6)
PILE_PENETRATION = 0.05
PILE_T_ELASTIC = 320  # simulated time, in contact durations of a pair
PILE_T_DAMPED = 32
PILE_WORLDS = 2


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
    ph = np.arange(phases) / phases
    gaps = speed * dt * (1.0 + ph)
    x = np.zeros((phases, 2, 3))
    v = np.zeros((phases, 2, 3))
    x[:, 1, 0] = radii[0] + radii[1] + gaps
    v[:, 0, 0] = speed * m2 / (m1 + m2)
    v[:, 1, 0] = -speed * m1 / (m1 + m2)
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
    peak = np.zeros(phases)
    prev = {"d": -gaps, "r": np.full(phases, speed)}

    def record(w):
        xx, vv = w.positions, w.velocities
        d = l0 - (xx[:, 1, 0] - xx[:, 0, 0])
        r = -(vv[:, 1, 0] - vv[:, 0, 0])
        peak[:] = np.maximum(peak, _hermite_peak(prev["d"], prev["r"], d, r, dt))
        prev["d"], prev["r"] = d, r

    w = _world(x, v, radii, masses, **kw)
    ok = _timed_steps(w, n_steps, record) is not None
    if ok:
        xx, vv = w.positions, w.velocities
        gap_end = (xx[:, 1, 0] - xx[:, 0, 0]) - l0
        u = vv[:, 1, 0] - vv[:, 0, 0]  # separation speed
        e_num = u / speed
        t_end = n_steps * dt - np.where(u > 0, gap_end / np.where(u > 0, u, 1.0), np.inf)
        t_begin = gaps / speed
        ok = bool(np.all(np.isfinite(e_num)))
    if not ok:
        return Measure(
            {"restitution": math.inf, "duration": math.inf, "peak_overlap": math.inf}, True, math.nan, math.nan
        )
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


# --------------------------------------------------------------------------------------------
# Scenarios 4 and 5: a pile of balls in the bowl
# --------------------------------------------------------------------------------------------


def pile_scene(n=PILE_N, worlds=PILE_WORLDS, seed=0):
    """``worlds`` random initial states of n balls scattered (without overlap) in the spherical
    cavity of ``PILE_BOWL``, velocities uniform in a ball of radius 1.5 m/s."""
    rng = np.random.default_rng(seed)
    r = PILE_RADIUS
    c = np.array(PILE_BOWL.center)
    R = PILE_BOWL.radius
    x = np.zeros((worlds, n, 3))
    for b in range(worlds):
        pts = []
        while len(pts) < n:
            p = c + rng.uniform(-1.0, 1.0, 3) * R
            if np.linalg.norm(p - c) > R - r - 0.01:
                continue
            if all(np.linalg.norm(p - q) > 2 * r + 0.01 for q in pts):
                pts.append(p)
        x[b] = np.array(pts)
    dirs = rng.normal(size=(worlds, n, 3))
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    v = dirs * 1.5 * rng.uniform(0, 1, (worlds, n, 1)) ** (1 / 3)
    return x, v


def pile_params(zeta):
    """ks from a 5% penetration at 5 m/s for a pair (m_eff = m/2), kd for zeta on a pair; the
    contact duration of a pair (the shortest contact of the scene)."""
    me = PILE_MASS / 2
    ks = theory.stiffness_for_penetration(me, PILE_SPEED, PILE_PENETRATION * PILE_RADIUS)
    kd = 2.0 * zeta * math.sqrt(ks * me)
    tc = theory.contact_time(ks, kd, me)
    return ks, kd, tc


def _pile_world(integrator, events, damping, zeta, dt, x, v):
    ks, kd, _ = pile_params(zeta)
    n = x.shape[1]
    return _world(
        x,
        v,
        np.full(n, PILE_RADIUS),
        np.full(n, PILE_MASS),
        integrator=integrator,
        events=events,
        damping=damping,
        ks=ks,
        kd=kd,
        dt=dt,
        gravity=(0.0, 0.0, -G),
        terrain=(PILE_BOWL,),
    )


def elastic_pile(integrator, events, spc, *, t_end=PILE_T_ELASTIC, worlds=PILE_WORLDS) -> Measure:
    """kd = 0, for t_end contact durations: relative energy drift |E(T) - E(0)| / (E(0) - E_floor) (E_floor: every ball at
    the bowl's lowest point), worst over worlds."""
    _, _, tc = pile_params(0.0)
    dt = tc / spc
    x, v = pile_scene(worlds=worlds)
    w = _pile_world(integrator, events, "linear", 0.0, dt, x, v)
    e0 = w.energy()
    floor = PILE_N * PILE_MASS * G * PILE_RADIUS
    n_steps = int(t_end * spc)
    wall = _timed_steps(w, n_steps)
    if wall is None:
        return Measure({"energy_drift": math.inf}, True, math.nan, math.nan)
    e1 = w.energy()
    drift = np.abs(e1 - e0) / (e0 - floor)
    d = float(drift.max())
    return Measure({"energy_drift": d}, not math.isfinite(d) or d > 1.0, *_cost(w, n_steps, wall))


_REFERENCE_CACHE: dict = {}


def pile_reference(damping, zeta, spc_ref, t_end=PILE_T_DAMPED, worlds=PILE_WORLDS):
    """Positions after t_end contact durations of RK4 with event location at spc_ref (cached)."""
    key = (damping, zeta, spc_ref, t_end, worlds)
    if key not in _REFERENCE_CACHE:
        _, _, tc = pile_params(zeta)
        x, v = pile_scene(worlds=worlds)
        w = _pile_world("rk4", True, damping, zeta, tc / spc_ref, x, v)
        w.step(int(t_end * spc_ref))
        _REFERENCE_CACHE[key] = w.positions.copy()
    return _REFERENCE_CACHE[key]


def damped_pile(
    integrator, events, damping, zeta, spc, *, spc_reference, t_end=PILE_T_DAMPED, worlds=PILE_WORLDS
) -> Measure:
    """Position error after t_end contact durations against the reference, RMS over balls / radius, worst over worlds."""
    _, _, tc = pile_params(zeta)
    dt = tc / spc
    n_steps = int(t_end * spc)
    ref = pile_reference(damping, zeta, spc_reference, t_end, worlds)
    x, v = pile_scene(worlds=worlds)
    w = _pile_world(integrator, events, damping, zeta, dt, x, v)
    wall = _timed_steps(w, n_steps)
    if wall is None:
        return Measure({"trajectory": math.inf}, True, math.nan, math.nan)
    err = np.sqrt(np.mean(np.sum((w.positions - ref) ** 2, axis=-1), axis=-1)) / PILE_RADIUS
    e = float(err.max())
    return Measure({"trajectory": e}, not math.isfinite(e) or e > 1.0, *_cost(w, n_steps, wall))


def count_pile_contacts(spc=64, t_end=PILE_T_ELASTIC, worlds=PILE_WORLDS) -> float:
    """Contacts per world in the elastic pile over t_end (switches located by RK4 with events / 2)."""
    _, _, tc = pile_params(0.0)
    dt = tc / spc
    x, v = pile_scene(worlds=worlds)
    w = _pile_world("rk4", True, "linear", 0.0, dt, x, v)
    w.step(int(t_end * spc))
    return EV.stats(w)["events"] / 2.0 / worlds
