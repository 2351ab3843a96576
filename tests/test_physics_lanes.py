"""SIMD across worlds (``physics.lanes``): the same trajectories as the scalar kernels, bit for bit.

``World`` steps small all-pairs worlds (symplectic / explicit Euler) one world per vector lane. The
lanes kernel computes each world's contacts with a mask instead of a branch, in the scalar kernel's
order, so it must reproduce the scalar kernel exactly: any difference is a bug, not round-off.
"""

from __future__ import annotations

import numpy as np
import pytest

from penalty_env.physics import Bowl, Sphere, World, lanes
from penalty_env.physics.world import LANES_MAX_BALLS, LANES_MIN_WORLDS


def _scene(d, B, n, seed):
    """n balls dropped in a bowl with a sphere sitting in it, random velocities: many contacts."""
    rng = np.random.default_rng(seed)
    R = 1.0
    c = np.zeros(d)
    c[-1] = R
    pos = np.empty((B, n, d))
    for b in range(B):
        k = 0
        while k < n:
            p = c + rng.uniform(-0.5, 0.5, d)
            p[-1] = rng.uniform(0.1, 0.6)
            if all(np.linalg.norm(p - pos[b, j]) > 0.19 for j in range(k)):
                pos[b, k] = p
                k += 1
    vel = rng.normal(0.0, 0.5, (B, n, d))
    # edge cases: coincident centres (the normal falls back to the last axis) in world 0, a world
    # at rest (no tangential speed: friction's 0 / 0) in world 1
    pos[0, 1] = pos[0, 0]
    vel[1] = 0.0
    terrain = (Bowl(tuple(c), R), Sphere(tuple(c - np.eye(d)[-1] * 0.9), 0.15))
    return pos, vel, terrain


CASES = [
    # d, integrator, damping, mu, forces
    (3, "symplectic_euler", "linear", 0.0, False),
    (3, "symplectic_euler", "no_tension", 0.4, True),
    (2, "symplectic_euler", "linear", 0.3, True),
    (2, "explicit_euler", "no_tension", 0.0, False),
]


@pytest.mark.parametrize("d, integrator, damping, mu, forces", CASES)
def test_lanes_match_scalar_kernel_bit_for_bit(d, integrator, damping, mu, forces):
    B, n = lanes.LANES + 5, 5  # a full block and a partial one
    pos, vel, terrain = _scene(d, B, n, seed=d)
    radii = np.linspace(0.08, 0.11, n)
    masses = np.linspace(0.5, 1.5, n)
    kw = dict(terrain=terrain, gravity=(0.0,) * (d - 1) + (-9.81,), ks=2e3, kd=3.0, damping=damping,
              mu=mu, integrator=integrator, broadphase="all_pairs")
    probe = World(pos, radii, masses, dt=1.0, allow_unstable=True, **kw)
    dt = 0.9 * probe.stability_limit() if integrator == "symplectic_euler" else 1e-4
    ext = np.random.default_rng(5).normal(0.0, 2.0, pos.shape) if forces else None
    worlds = []
    for use_lanes in (True, False):
        w = World(pos, radii, masses, velocities=vel, dt=dt, **kw)
        assert w._lanes  # few balls, all pairs: the lanes path is the default
        w._lanes = use_lanes
        for _ in range(3):
            w.step(150, forces=ext)
        worlds.append(w)
    a, b = worlds
    assert np.isfinite(a.positions).all()
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)


def test_lanes_used_only_where_they_pay():
    pos, vel, terrain = _scene(3, LANES_MIN_WORLDS, 4, seed=0)
    kw = dict(terrain=terrain, ks=2e3, kd=3.0, dt=1e-4)
    assert World(pos, [0.08] * 4, [1.0] * 4, **kw)._lanes
    assert not World(pos[: LANES_MIN_WORLDS - 1], [0.08] * 4, [1.0] * 4, **kw)._lanes
    assert not World(pos[0], [0.08] * 4, [1.0] * 4, **kw)._lanes
    assert not World(pos, [0.08] * 4, [1.0] * 4, integrator="rk4", **kw)._lanes
    assert not World(pos, [0.08] * 4, [1.0] * 4, broadphase="grid", **kw)._lanes
    big = np.random.default_rng(0).uniform(0.1, 3.0, (LANES_MIN_WORLDS, LANES_MAX_BALLS + 1, 3)) * [5, 5, 1]
    assert not World(big, [0.01] * big.shape[1], [1.0] * big.shape[1], ks=2e3, kd=3.0, dt=1e-4)._lanes


def test_lanes_report_a_blow_up_in_the_same_worlds_as_the_scalar_kernel():
    # three balls apart in a bowl, no gravity: a world at rest never touches anything; in every
    # third world ball 0 flies into ball 1 at a dt far beyond the stability limit and blows up
    B = LANES_MIN_WORLDS + 5
    pos = np.tile(np.array([[0.0, 0.0, 1.0], [0.3, 0.0, 1.0], [-0.3, 0.0, 1.0]]), (B, 1, 1))
    vel = np.zeros_like(pos)
    vel[::3, 0, 0] = 1.0
    status = []
    for use_lanes in (True, False):
        w = World(pos, [0.1] * 3, [1.0] * 3, velocities=vel, terrain=(Bowl((0.0, 0.0, 1.0), 1.0),),
                  gravity=(0.0, 0.0, 0.0), ks=1e4, kd=0.0, dt=0.05, allow_unstable=True)
        assert w._lanes
        w._lanes = use_lanes
        with pytest.raises(FloatingPointError, match="NaN or inf"):
            for _ in range(100):
                w.step(10)
        status.append(w._status.copy())
        finite = np.isfinite(w.positions).all(axis=(1, 2))
        assert np.array_equal(finite, w._status == 0)
    assert np.array_equal(status[0], status[1])
    assert np.array_equal(status[0] != 0, np.arange(B) % 3 == 0)
