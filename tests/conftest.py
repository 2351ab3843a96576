"""Shared helpers for the tests (scenes come from ``penalty_env.scenarios``).

The main one measures single collisions against the closed forms (docs/physics.md, "Closed forms"): a
contact's coefficient of restitution and its duration, swept over where the contact starts within
the step grid (one batched World holds every phase), so a test can assert the WORST case.

Only helpers and fixtures live here; the assertions are in the test modules.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pytest

from penalty_env.physics import Bowl, Sphere, World, theory

# --------------------------------------------------------------------------------------------
# Single collisions: restitution and contact duration, worst case over the contact's phase
# --------------------------------------------------------------------------------------------

KS = 1.0e4  # contact stiffness of the collision scenes
M_EFF = 0.6  # every probe below has this effective mass, so one dt serves them all
APPROACH_SPEED = 1.0  # normal approach speed of every probe (peak overlap v / omega0 ~ 0.8% of r)


def _unit(vec, d):
    v = np.asarray(vec, dtype=np.float64)[:d]
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class _Probe:
    """One contact to watch: ``kind`` pair (balls i, j) or bowl / sphere (ball i, shape centre c,
    radius R)."""

    name: str
    kind: str
    i: int
    j: int = -1
    center: tuple = ()
    R: float = 0.0

    def overlap(self, x, radii):
        """Overlap (> 0 in contact) of every world, shape (B,)."""
        if self.kind == "pair":
            return radii[self.i] + radii[self.j] - np.linalg.norm(x[:, self.j] - x[:, self.i], axis=-1)
        dist = np.linalg.norm(x[:, self.i] - np.asarray(self.center), axis=-1)
        if self.kind == "bowl":
            return dist - (self.R - radii[self.i])
        return self.R + radii[self.i] - dist

    def separating_speed(self, x, v):
        """Normal speed at which the contact opens (> 0 when separating), shape (B,)."""
        if self.kind == "pair":
            rel = x[:, self.j] - x[:, self.i]
            n = rel / np.linalg.norm(rel, axis=-1, keepdims=True)
            return np.einsum("bk,bk->b", v[:, self.j] - v[:, self.i], n)
        rel = x[:, self.i] - np.asarray(self.center)
        n = rel / np.linalg.norm(rel, axis=-1, keepdims=True)
        vn = np.einsum("bk,bk->b", v[:, self.i], n)
        return -vn if self.kind == "bowl" else vn


def _pair_scene(d, gaps):
    """Two pairs far apart, each colliding along a line of centres that is no axis: pair A of
    equal masses (1.2, 1.2), pair B of unequal masses (0.75, 3.0) and radii; both m_eff = 0.6.
    Both pairs drift with the same centre-of-mass velocity (Galilean invariance)."""
    n_a = _unit([0.6, -0.48, 0.64], d) if d == 3 else _unit([0.6, 0.8], d)
    n_b = _unit([-0.36, 0.8, 0.48], d) if d == 3 else _unit([-0.8, 0.6], d)
    drift = 0.25 * _unit([0.3, 0.5, -0.81], d) if d == 3 else 0.25 * _unit([0.3, -0.95], d)
    radii = np.array([0.3, 0.3, 0.5, 0.2])
    masses = np.array([1.2, 1.2, 0.75, 3.0])
    B = gaps.size
    x = np.zeros((B, 4, d))
    v = np.zeros((B, 4, d))
    origin_b = np.full(d, 5.0)
    for (i, j), n, origin in (((0, 1), n_a, np.zeros(d)), ((2, 3), n_b, origin_b)):
        mi, mj = masses[i], masses[j]
        x[:, i] = origin
        x[:, j] = origin + (radii[i] + radii[j] + gaps)[:, None] * n
        # relative velocity -APPROACH_SPEED n, centre of mass moving with ``drift``
        v[:, i] = drift + (mj / (mi + mj)) * APPROACH_SPEED * n
        v[:, j] = drift - (mi / (mi + mj)) * APPROACH_SPEED * n
    probes = (_Probe("pair, equal masses", "pair", 0, 1), _Probe("pair, unequal masses", "pair", 2, 3))
    return x, v, radii, masses, (), probes


def _terrain_scene(d, gaps):
    """Ball 0 flies radially into the wall of a Bowl, ball 1 radially onto a Sphere that sits
    inside the bowl, well apart. Both masses are 0.6 (m_eff = m against static terrain)."""
    bowl_c = np.zeros(d)
    bowl_R = 6.0
    sph_c = np.array([-2.0, -1.0, 0.5])[:d]
    sph_R = 1.0
    n0 = _unit([0.6, 0.48, 0.64], d) if d == 3 else _unit([0.6, 0.8], d)  # away from the sphere
    n1 = _unit([-0.36, -0.48, 0.8], d) if d == 3 else _unit([-0.6, -0.8], d)
    radii = np.array([0.3, 0.2])
    masses = np.array([M_EFF, M_EFF])
    B = gaps.size
    x = np.zeros((B, 2, d))
    v = np.zeros((B, 2, d))
    x[:, 0] = bowl_c + (bowl_R - radii[0] - gaps)[:, None] * n0
    v[:, 0] = APPROACH_SPEED * n0
    x[:, 1] = sph_c + (sph_R + radii[1] + gaps)[:, None] * n1
    v[:, 1] = -APPROACH_SPEED * n1
    terrain = (Bowl(tuple(bowl_c), bowl_R), Sphere(tuple(sph_c), sph_R))
    probes = (
        _Probe("ball on Bowl", "bowl", 0, center=tuple(bowl_c), R=bowl_R),
        _Probe("ball on Sphere", "sphere", 1, center=tuple(sph_c), R=sph_R),
    )
    return x, v, radii, masses, terrain, probes


@dataclass(frozen=True)
class CollisionSweep:
    """Measured restitution and contact duration of every probe, one value per start phase."""

    integrator: str
    zeta: float
    steps_per_contact: float
    dt: float
    phases: np.ndarray  # where the contact starts, as a fraction of the step after step 1
    e_theory: float
    tc_theory: float
    restitution: dict  # probe name -> (P,) measured e
    duration: dict  # probe name -> (P,) measured contact time

    def e_error(self, name) -> np.ndarray:
        """Relative error of e (a zeta = 0 contact has e = 1)."""
        return self.restitution[name] / self.e_theory - 1.0

    def tc_error(self, name) -> np.ndarray:
        return self.duration[name] / self.tc_theory - 1.0

    def worst_e_error(self, name) -> float:
        return float(np.max(np.abs(self.e_error(name))))

    def worst_tc_error(self, name) -> float:
        return float(np.max(np.abs(self.tc_error(name))))

    @property
    def probe_names(self):
        return tuple(self.restitution)


def _crossing_times(overlaps: np.ndarray, dt: float):
    """Start and end of the single contact in each column of ``overlaps`` ((N+1, B), sampled at
    t = k dt), by linear interpolation of the overlap's zero crossings between steps."""
    inside = overlaps > 0.0
    n_rows = overlaps.shape[0]
    cols = np.arange(overlaps.shape[1])
    if not np.all(inside.any(axis=0)):
        raise AssertionError("a probe never made contact")
    first = np.argmax(inside, axis=0)
    last = n_rows - 1 - np.argmax(inside[::-1], axis=0)
    if np.any(first == 0) or np.any(last == n_rows - 1):
        raise AssertionError("a contact started before the first sample or outlived the run")
    if np.any(inside.sum(axis=0) != last - first + 1):
        raise AssertionError("a probe made more than one contact (the overlap changed sign twice)")
    o0, o1 = overlaps[first - 1, cols], overlaps[first, cols]  # o0 <= 0 < o1
    t_start = (first - 1 + (-o0) / (o1 - o0)) * dt
    o0, o1 = overlaps[last, cols], overlaps[last + 1, cols]  # o0 > 0 >= o1
    t_end = (last + o0 / (o0 - o1)) * dt
    return t_start, t_end


@functools.cache
def collision_sweep(
    geometry: str,
    integrator: str,
    zeta: float,
    steps_per_contact: float,
    d: int,
    phases: int = 1024,
    damping: str = "linear",
    offset: float = 0.0,
    options: tuple = (),
) -> CollisionSweep:
    """Collide every probe of ``geometry`` ("pairs" or "terrain") with damping ratio ``zeta``, gravity
    off, dt = t_c / steps_per_contact, once per start phase (the B worlds of one World).

    The initial gap is ``v dt (1 + phase)``, phase = (k + offset) / phases, so the contact starts
    during the second step at every point of the step grid. With ``offset`` 0 and ``phases`` a power
    of two the sweep holds the phases 0 and 1/2 exactly. Results are cached (the convergence and the
    bound tests share them). ``options``: extra World keyword arguments as (name, value) pairs.
    """
    kd = 2.0 * zeta * math.sqrt(KS * M_EFF)
    tc = theory.contact_time(KS, kd, M_EFF)
    dt = tc / steps_per_contact
    phase = (np.arange(phases) + offset) / phases
    gaps = APPROACH_SPEED * dt * (1.0 + phase)
    build = {"pairs": _pair_scene, "terrain": _terrain_scene}[geometry]
    x, v, radii, masses, terrain, probes = build(d, gaps)
    world = World(
        x,
        radii,
        masses,
        v,
        terrain=terrain,
        gravity=np.zeros(d),
        ks=KS,
        kd=kd,
        damping=damping,
        integrator=integrator,
        dt=dt,
        broadphase="all_pairs",
        # isolated contacts, so the guard's margin for balls in many contacts at once (a pile)
        # does not apply; explicit Euler is refused outright when undamped
        allow_unstable=True,
        **dict(options),
    )
    n_steps = int(math.ceil(1.3 * steps_per_contact)) + 6
    overlaps = {p.name: np.empty((n_steps + 1, phases)) for p in probes}
    for k in range(n_steps + 1):
        if k:
            world.step(1)
        pos = world.positions
        for p in probes:
            overlaps[p.name][k] = p.overlap(pos, radii)
    e_meas, tc_meas = {}, {}
    for p in probes:
        t0, t1 = _crossing_times(overlaps[p.name], dt)
        tc_meas[p.name] = t1 - t0
        e_meas[p.name] = p.separating_speed(world.positions, world.velocities) / APPROACH_SPEED
    return CollisionSweep(
        integrator, zeta, steps_per_contact, dt, phase, theory.restitution(KS, kd, M_EFF), tc, e_meas, tc_meas
    )


@pytest.fixture(scope="session")
def collisions():
    """``collisions(geometry, integrator, zeta, steps_per_contact, d)`` -> :class:`CollisionSweep`."""
    return collision_sweep


# --------------------------------------------------------------------------------------------
# A ball oscillating about its resting overlap on a bowl floor (stability tests)
# --------------------------------------------------------------------------------------------


@dataclass
class FloorOscillator:
    """One ball on the floor of a Bowl under gravity, moving only along the vertical through the
    bowl's centre (a 1D linear oscillator while in contact).

    ``oscillation_energy()`` is the World's energy minus that of the ball at rest at the resting
    overlap m g / ks. While in contact it equals 1/2 m v^2 + 1/2 ks (delta - m g / ks)^2 exactly.
    """

    world: World
    rest_energy: float
    rest_overlap: float
    omega: float

    def oscillation_energy(self) -> float:
        return self.world.energy() - self.rest_energy

    def overlap(self) -> float:
        return float(-self.world.positions[0, -1] + self.world.radii[0])


def floor_oscillator(integrator, omega_dt, zeta=0.0, displacement=0.05, d=3, allow_unstable=True):
    """The ball displaced from its resting overlap by ``displacement`` x (m g / ks), at rest.

    The bowl's floor is at height 0 (centre (0, .., R)), so the overlap is r - z.
    """
    R, r, m, g, ks = 4.0, 0.25, 2.0, 9.81, 2.0e4
    kd = 2.0 * zeta * math.sqrt(ks * m)
    omega = math.sqrt(ks / m)
    center = np.zeros(d)
    center[-1] = R
    gravity = np.zeros(d)
    gravity[-1] = -g
    rest = m * g / ks
    x = np.zeros((1, d))
    x[0, -1] = r - rest
    world = World(
        x,
        [r],
        [m],
        terrain=Bowl(tuple(center), R),
        gravity=gravity,
        ks=ks,
        kd=kd,
        integrator=integrator,
        dt=omega_dt / omega,
        allow_unstable=allow_unstable,
    )
    e_rest = world.energy()
    x[0, -1] = r - rest * (1.0 + displacement)
    world.set_state(positions=x, velocities=np.zeros((1, d)))
    return FloorOscillator(world, e_rest, rest, omega)


@pytest.fixture(scope="session")
def oscillator():
    return floor_oscillator


# --------------------------------------------------------------------------------------------
# Many balls in a bowl
# --------------------------------------------------------------------------------------------


def _contact_kwargs(masses, ks=1e4, zeta=0.2, omega_dt=0.2):
    """World keyword arguments for balls of these masses: ks, kd at damping ratio ``zeta`` for the
    lightest pair, and dt at ``omega_dt`` of that pair's natural frequency."""
    m_eff = np.min(masses) / 2
    return dict(ks=ks, kd=2 * zeta * math.sqrt(ks * m_eff), dt=omega_dt / math.sqrt(ks / m_eff))


@pytest.fixture(scope="session")
def contact_kwargs():
    return _contact_kwargs
