"""Scenes the tests and the benchmarks share (built on the public ``World`` API only).

* :func:`balls_in_bowl`: n non-overlapping balls scattered in a bowl, B worlds: the general-purpose
  scene of the physics tests;
* :func:`packed_bowl`, :func:`large_world`: a bowl filled from the bottom on a close-packed lattice
  (the core benchmark's large worlds; they slump, then settle);
* the accuracy scenarios (:func:`pair_collision`, :func:`bowl_drop`, :func:`resting`,
  :func:`elastic_pile`, :func:`damped_pile`), each measuring its errors against the closed forms of
  :mod:`penalty_env.physics.theory`, worst case over where the contact starts in the step grid, and
  its cost (:class:`Measure`). They live in :mod:`penalty_env.scenarios_contact` (scenarios 1 to 3)
  and :mod:`penalty_env.scenarios_pile` (4 and 5) and are imported from here.
"""

from __future__ import annotations

import math

import numpy as np

from .physics import Bowl, World, theory

# the accuracy scenarios and their constants, importable from here as before the split
from .scenarios_contact import (  # noqa: F401
    BOWL,
    DROP_KS,
    DROP_MASS,
    DROP_RADIUS,
    DROP_SPEED,
    PAIR_KS,
    PAIR_MASSES,
    PAIR_RADII,
    PAIR_SPEED,
    PHASES,
    G,
    Measure,
    bowl_drop,
    pair_collision,
    resting,
)
from .scenarios_pile import (  # noqa: F401
    _REFERENCE_CACHE,  # the very dict pile_reference fills (bench.accuracy's Ray tasks seed it through here)
    PILE_BOWL,
    PILE_MASS,
    PILE_N,
    PILE_PENETRATION,
    PILE_RADIUS,
    PILE_SPEED,
    PILE_T_DAMPED,
    PILE_T_ELASTIC,
    PILE_WORLDS,
    count_pile_contacts,
    damped_pile,
    elastic_pile,
    pile_params,
    pile_reference,
    pile_scene,
)

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
