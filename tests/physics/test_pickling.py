"""A stepped World pickles and deep-copies on every stepping path, and the copy goes on bit for bit
as the original does (its compiled step kernel is not part of the state: the copy finds it again,
cached, on its first step; a user SDF's callbacks are looked up again in the new process)."""

from __future__ import annotations

import copy
import math
import pickle

import numba
import numpy as np
import pytest

from penalty_env.physics import SDF, Bowl, Box, Plane, World
from penalty_env.physics.world import LARGE_WORLD_MIN_BALLS

KS = 1e4
KD = 2 * 0.3 * math.sqrt(KS * 0.5)


@numba.njit
def _ground_phi(p):
    return p[2] + 0.05 * math.sin(3.0 * p[0])


def _pile(n: int, d: int = 3, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """n balls of radius 0.1 on a loose lattice above z = 0.2, with random velocities."""
    rng = np.random.default_rng(seed)
    side = math.ceil(n ** (1 / (d - 1)))
    cells = np.array(np.meshgrid(*[np.arange(side)] * (d - 1), indexing="ij")).reshape(d - 1, -1).T[:n]
    x = np.concatenate([0.25 * cells - 0.125 * side, np.full((n, 1), 0.2)], axis=1)
    x[:, -1] += 0.25 * (np.arange(n) % 3)
    return x, rng.normal(0.0, 0.5, x.shape)


def _worlds():
    kw = dict(ks=KS, kd=KD, dt=2e-4, gravity=(0.0, 0.0, -9.81))
    x, v = _pile(6)
    r, m = np.full(6, 0.1), np.ones(6)
    yield "scalar", World(x, r, m, v, terrain=Bowl((0, 0, 3.0), 3.0), stepping="scalar", **kw)
    xb = np.repeat(x[None], 8, axis=0) + np.linspace(0, 0.01, 8)[:, None, None]
    yield (
        "lanes",
        World(xb, r, m, np.repeat(v[None], 8, axis=0), terrain=Plane((0, 0, 0), (0, 0, 1)), stepping="lanes", **kw),
    )
    yield "events", World(x, r, m, v, terrain=Box((0, 0, -0.5), (2.0, 2.0, 0.5)), events=True, **kw)
    yield "rotation", World(x, r, m, v, terrain=Bowl((0, 0, 3.0), 3.0), rotation=True, mu=0.4, **kw)
    yield "user_sdf", World(x, r, m, v, terrain=SDF(_ground_phi, dim=3), mu=0.3, **kw)
    moving = Plane((0, 0, 0), (0, 0, 1), velocity=(0.0, 0.0, 0.05))
    yield "moving_shape", World(x, r, m, v, terrain=moving, **kw)
    n = LARGE_WORLD_MIN_BALLS
    xl, vl = _pile(n)
    big = World(xl, np.full(n, 0.1), np.ones(n), vl, terrain=Plane((0, 0, 0), (0, 0, 1)), broadphase="grid", **kw)
    yield "neighbour_list", big


def _state(w: World) -> list[np.ndarray]:
    out = [w.positions, w.velocities]
    if w.rotation:
        out.append(w.angular_velocities)
    return out


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_stepped_world_copies_and_goes_on_bit_for_bit(how):
    for name, w in _worlds():
        if name in ("scalar", "lanes", "neighbour_list"):
            assert w.runner.path == name
        w.step(50)
        c = pickle.loads(pickle.dumps(w)) if how == "pickle" else copy.deepcopy(w)
        w.step(200)
        c.step(200)
        for a, b in zip(_state(w), _state(c)):
            assert np.array_equal(a, b), name
        assert np.isfinite(w.positions).all(), name
