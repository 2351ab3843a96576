"""The pile accuracy scenarios (re-exported by :mod:`penalty_env.scenarios`).

:func:`elastic_pile` (scenario 4: energy drift) and :func:`damped_pile` (scenario 5: positions
against a reference run, :func:`pile_reference`): 64 balls in a bowl, measured as the
single-contact scenarios of :mod:`penalty_env.scenarios_contact` are (:class:`Measure`).
"""

from __future__ import annotations

import math

import numpy as np

from .physics import Bowl, theory
from .physics.stepping import events as EV
from .scenarios_contact import G, Measure, _cost, _timed_steps, _world

# scenario constants ------------------------------------------------------------------------
PILE_N, PILE_RADIUS, PILE_MASS, PILE_SPEED = 64, 0.08, 1.0, 5.0
PILE_BOWL = Bowl((0.0, 0.0, 0.6), 0.6)
PILE_PENETRATION = 0.05
PILE_T_ELASTIC = 320  # simulated time, in contact durations of a pair
PILE_T_DAMPED = 32
PILE_WORLDS = 2


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
