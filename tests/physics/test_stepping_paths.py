"""Stepping paths, batching and threads change how the work is done, never the physics.

* every path (``scalar``, ``lanes``, ``neighbour_list``, and event location on ``scalar``) steps
  each world of a batch with its own buffers, so a batch is bit-identical to each world run alone,
  whether the batch is split over threads or not (one test, parametrized over the paths);
* the SIMD-lanes path computes each world's contacts with a mask instead of a branch, in the
  scalar path's order: it reproduces the scalar path bit for bit (any difference is a bug);
* the thread count (NUMBA_NUM_THREADS) changes nothing, bit for bit;
* a path that does not apply to a scene is refused with a message that says why.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from penalty_env.physics import Bowl, Sphere, World, lanes
from penalty_env.physics.world import LANES_MAX_BALLS, LANES_MIN_WORLDS, LARGE_WORLD_MIN_BALLS
from penalty_env.scenarios import balls_in_bowl

ALL_INTEGRATORS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler")

# (stepping, integrator, broadphase, events, balls per world, mu, forces)
PATH_CASES = (
    [
        pytest.param("scalar", integ, "all_pairs", False, 12, 0.0, False, id=f"scalar-{integ}-all_pairs")
        for integ in ALL_INTEGRATORS
    ]
    + [
        # explicit and implicit Euler on the grid with friction compile the most (about 2.5 min of the
        # default run between them): with the long tests
        pytest.param(
            "scalar",
            integ,
            "grid",
            False,
            12,
            0.3,
            True,
            id=f"scalar-{integ}-grid+friction+forces",
            marks=[pytest.mark.slow] if integ in ("explicit_euler", "implicit_euler") else [],
        )
        for integ in ALL_INTEGRATORS
    ]
    + [
        pytest.param("lanes", integ, "all_pairs", False, 12, 0.3, True, id=f"lanes-{integ}")
        for integ in ("symplectic_euler", "explicit_euler")
    ]
    + [
        pytest.param(
            "neighbour_list",
            "symplectic_euler",
            "grid",
            False,
            LARGE_WORLD_MIN_BALLS + 8,
            0.3,
            True,
            id="neighbour_list",
        )
    ]
    + [
        pytest.param("scalar", integ, "all_pairs", True, 8, 0.0, False, id=f"events-{integ}")
        for integ in ("velocity_verlet", "rk4")
    ]
)


@pytest.mark.parametrize("stepping, integrator, broadphase, events, n, mu, forces", PATH_CASES)
def test_batched_worlds_are_bit_identical_to_each_world_alone(
    contact_kwargs, stepping, integrator, broadphase, events, n, mu, forces
):
    d = 3
    B = LANES_MIN_WORLDS + 3 if stepping == "lanes" else 4
    x, v, radii, _, bowl = balls_in_bowl(
        n, d, worlds=B, seed=10, radius=0.06 if n > 100 else 0.12, speed=3.0 if events else 0.8, spacing=0.003
    )
    masses = np.random.default_rng(10).uniform(0.5, 1.5, n)
    kw = dict(
        terrain=bowl,
        integrator=integrator,
        broadphase=broadphase,
        stepping=stepping,
        events=events,
        mu=mu,
        **contact_kwargs(masses, zeta=0.3, omega_dt=0.1),
    )  # explicit Euler needs omega dt <= 2 zeta
    ext = np.random.default_rng(4).normal(0.0, 2.0, (B, n, d)) if forces else None
    batch = World(x, radii, masses, v, **kw)
    assert batch.stepping == stepping
    singles = [World(x[b], radii, masses, v[b], **kw) for b in range(B)]
    touched = np.zeros(B, dtype=bool)
    chunks = (150, 1, 149) if events else (300, 1, 99, 50, 50)  # the first call is above the threads' threshold
    for chunk in chunks:
        batch.step(chunk, forces=ext)
        for b, w in enumerate(singles):
            w.step(chunk, forces=None if ext is None else ext[b])
        touched |= batch.max_penetration() > 0.0
    assert touched.all(), "every world must have had contacts"
    for b, w in enumerate(singles):
        np.testing.assert_array_equal(batch.positions[b], w.positions)
        np.testing.assert_array_equal(batch.velocities[b], w.velocities)
        assert batch.energy()[b] == w.energy()


def _lanes_scene(d, B, n, seed):
    """n balls dropped in a bowl with a sphere sitting in it, random velocities: many contacts; with
    two edge cases: coincident centres (the normal falls back to the last axis) in world 0, a world
    at rest (no tangential speed: friction's 0 / 0) in world 1."""
    x, v, radii, masses, bowl = balls_in_bowl(
        n,
        d,
        worlds=B,
        seed=seed,
        radius=np.linspace(0.08, 0.11, n),
        mass=np.linspace(0.5, 1.5, n),
        bowl_radius=1.0,
        min_height=0.1,
        speed=1.0,
        spacing=0.0,
    )
    x[0, 1] = x[0, 0]
    v[1] = 0.0
    c = np.array(bowl.center)
    return x, v, radii, masses, (bowl, Sphere(tuple(c - np.eye(d)[-1] * 0.9), 0.15))


@pytest.mark.parametrize(
    "d, integrator, damping, mu, forces",
    [
        (3, "symplectic_euler", "linear", 0.0, False),
        (3, "symplectic_euler", "no_tension", 0.4, True),
        (2, "symplectic_euler", "linear", 0.3, True),
        (2, "explicit_euler", "no_tension", 0.0, False),
    ],
)
def test_lanes_match_the_scalar_path_bit_for_bit(d, integrator, damping, mu, forces):
    B, n = lanes.LANES + 5, 5  # a full block and a partial one
    x, v, radii, masses, terrain = _lanes_scene(d, B, n, seed=d)
    kw = dict(
        terrain=terrain,
        gravity=(0.0,) * (d - 1) + (-9.81,),
        ks=2e3,
        kd=3.0,
        damping=damping,
        mu=mu,
        start_check=False,  # (starts drawn without spacing: some overlap; the paths must agree anyway)
        integrator=integrator,
        broadphase="all_pairs",
    )
    probe = World(x, radii, masses, dt=1.0, allow_unstable=True, **kw)
    dt = 0.9 * probe.stability_limit() if integrator == "symplectic_euler" else 1e-4
    ext = np.random.default_rng(5).normal(0.0, 2.0, x.shape) if forces else None
    worlds = []
    for stepping in ("lanes", "scalar"):
        w = World(x, radii, masses, velocities=v, dt=dt, stepping=stepping, **kw)
        for _ in range(3):
            w.step(150, forces=ext)
        worlds.append(w)
    a, b = worlds
    assert np.isfinite(a.positions).all()
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)


@pytest.mark.parametrize("d", [2, 3])
def test_static_planes_and_boxes_on_the_lanes_match_the_scalar_path_bit_for_bit_shared_or_not(d):
    """Balls in a box of static planes (a floor and the walls, as the arena) around a static box:
    where every world of a block holds a shape at one pose the lanes evaluate it vectorised, where
    a world holds it elsewhere (the floor tilted in world 3, a wall moved in world 70: one in each
    block; the box turned in world 5) one lane at a time; either way bit for bit the scalar path."""
    from penalty_env.physics import Box, Plane

    B, n = lanes.LANES + 10, 3
    rng = np.random.default_rng(d)
    up = np.eye(d)[-1]
    walls = [Plane(tuple(-0.5 * e), tuple(e)) for e in np.eye(d)[:-1]]
    walls += [Plane(tuple(0.5 * e), tuple(-e)) for e in np.eye(d)[:-1]]
    terrain = (Plane((0.0,) * d, tuple(up)), *walls, Box((0.0,) * d, (0.1,) * d))
    x = np.concatenate([rng.uniform(-0.35, 0.35, (B, n, d - 1)), rng.uniform(0.1, 0.6, (B, n, 1))], axis=-1)
    x[..., 0] += np.arange(n) * 0.001  # (no two balls at one point)
    v = rng.normal(0.0, 1.0, (B, n, d))
    kw = dict(terrain=terrain, gravity=tuple(-9.81 * up), ks=2e3, kd=3.0, mu=0.3, broadphase="all_pairs", dt=1e-3)
    kw.update(start_check=False)  # (random starts: some inside the box; the paths must agree anyway)
    tilt = np.eye(d)
    tilt[[0, -1], [0, -1]] = np.cos(0.2)
    tilt[0, -1], tilt[-1, 0] = -np.sin(0.2), np.sin(0.2)
    out = []
    for shared in (True, False):
        for stepping in ("lanes", "scalar"):
            w = World(x, [0.05] * n, [1.0] * n, velocities=v, stepping=stepping, **kw)
            if not shared:
                w.set_shape_pose(0, rotation=tilt, worlds=[3])
                w.set_shape_pose(1, position=-0.45 * np.eye(d)[0], worlds=[70])
                w.set_shape_pose(len(terrain) - 1, rotation=tilt, worlds=[5])
            touched = False
            for _ in range(4):
                w.step(100)
                touched |= bool(np.any(w.max_penetration() > 0.0))
            assert touched and np.isfinite(w.positions).all()
            out.append(w)
    for a, b in (out[0:2], out[2:4]):
        assert np.array_equal(a.positions, b.positions)
        assert np.array_equal(a.velocities, b.velocities)
    assert not np.array_equal(out[0].positions[3], out[2].positions[3])  # the tilt took effect


@pytest.mark.parametrize("d", [2, 3])
def test_walls_no_lane_of_a_block_touches_are_skipped_bit_for_bit(d):
    """The lanes skip a static plane that no lane of the block overlaps (an arena's walls, far from
    most blocks' balls): the first block's balls stay near the centre, clear of the walls, while
    the second block's are thrown at them (some lanes touch a wall, the others not, and that
    changes from step to step); both bit for bit the scalar path."""
    from penalty_env.physics import Plane

    B, n, r = 2 * lanes.LANES, 2, 0.05
    rng = np.random.default_rng(10 + d)
    up = np.eye(d)[-1]
    walls = [Plane(tuple(-s * 0.5 * e), tuple(s * e)) for e in np.eye(d)[:-1] for s in (1.0, -1.0)]
    terrain = (Plane((0.0,) * d, tuple(up)), *walls)
    x = np.zeros((B, n, d))
    x[..., :-1] = rng.uniform(-0.1, 0.1, (B, n, d - 1))
    x[:, 1, 0] += 0.25  # (the balls apart)
    x[..., -1] = r - 0.001
    v = np.zeros((B, n, d))
    v[lanes.LANES :, :, :-1] = rng.normal(0.0, 1.5, (lanes.LANES, n, d - 1))
    kw = dict(terrain=terrain, gravity=tuple(-9.81 * up), ks=2e3, kd=3.0, mu=0.3, broadphase="all_pairs", dt=1e-3)
    out, reached = [], []
    for stepping in ("lanes", "scalar"):
        w = World(x, [r] * n, [1.0] * n, velocities=v, stepping=stepping, start_check=False, **kw)
        near = np.zeros(B, dtype=bool)
        for _ in range(40):
            w.step(10)
            near |= np.any(np.abs(w.positions[..., :-1]) > 0.5 - r, axis=(1, 2))
        out.append(w)
        reached.append(near)
    assert not reached[0][: lanes.LANES].any() and 0 < reached[0][lanes.LANES :].sum() < lanes.LANES
    assert np.array_equal(reached[0], reached[1])
    assert np.isfinite(out[0].positions).all()
    assert np.array_equal(out[0].positions, out[1].positions)
    assert np.array_equal(out[0].velocities, out[1].velocities)


def test_auto_stepping_takes_the_lanes_only_where_they_pay():
    x, _, radii, masses, bowl = balls_in_bowl(4, 3, worlds=LANES_MIN_WORLDS, seed=0, radius=0.08)
    kw = dict(terrain=bowl, ks=2e3, kd=3.0, dt=1e-4)
    assert World(x, radii, masses, **kw).stepping == "lanes"
    assert World(x[: LANES_MIN_WORLDS - 1], radii, masses, **kw).stepping == "scalar"
    assert World(x[0], radii, masses, **kw).stepping == "scalar"
    assert World(x, radii, masses, integrator="rk4", **kw).stepping == "scalar"
    assert World(x, radii, masses, broadphase="grid", **kw).stepping == "scalar"
    big, _, r_big, m_big, bowl_big = balls_in_bowl(LANES_MAX_BALLS + 1, 3, worlds=LANES_MIN_WORLDS, radius=0.05)
    assert World(big, r_big, m_big, terrain=bowl_big, ks=2e3, kd=3.0, dt=1e-4).stepping == "scalar"


def test_a_stepping_path_that_does_not_apply_is_refused_with_the_reason():
    x, _, radii, masses, bowl = balls_in_bowl(4, 3, worlds=2, radius=0.08)
    kw = dict(terrain=bowl, ks=2e3, kd=3.0, dt=1e-4)
    with pytest.raises(ValueError, match="stepping='lanes' needs broadphase='all_pairs'.*rk4"):
        World(x, radii, masses, integrator="rk4", stepping="lanes", **kw)
    with pytest.raises(ValueError, match="stepping='neighbour_list' needs the grid"):
        World(x, radii, masses, stepping="neighbour_list", **kw)
    with pytest.raises(ValueError, match="events=True use stepping='scalar'"):
        World(x, radii, masses, events=True, stepping="lanes", **kw)
    with pytest.raises(ValueError, match="stepping must be one of"):
        World(x, radii, masses, stepping="gpu", **kw)


def test_lanes_report_a_blow_up_in_the_same_worlds_as_the_scalar_path():
    # three balls apart in a bowl, no gravity: a world at rest never touches anything; in every
    # third world ball 0 flies into ball 1 at a dt far beyond the stability limit and blows up
    B = LANES_MIN_WORLDS + 5
    pos = np.tile(np.array([[0.0, 0.0, 1.0], [0.3, 0.0, 1.0], [-0.3, 0.0, 1.0]]), (B, 1, 1))
    vel = np.zeros_like(pos)
    vel[::3, 0, 0] = 1.0
    status = []
    for stepping in ("lanes", "scalar"):
        w = World(
            pos,
            [0.1] * 3,
            [1.0] * 3,
            velocities=vel,
            terrain=(Bowl((0.0, 0.0, 1.0), 1.0),),
            gravity=(0.0, 0.0, 0.0),
            ks=1e4,
            kd=0.0,
            dt=0.05,
            allow_unstable=True,
            stepping=stepping,
        )
        with pytest.raises(FloatingPointError, match="NaN or inf"):
            for _ in range(100):
                w.step(10)
        status.append(w.status.copy())
        finite = np.isfinite(w.positions).all(axis=(1, 2))
        assert np.array_equal(finite, w.status == 0)
    assert np.array_equal(status[0], status[1])
    assert np.array_equal(status[0] != 0, np.arange(B) % 3 == 0)


def test_resetting_one_world_of_a_batch_leaves_the_others_untouched(contact_kwargs):
    x, v, radii, masses, bowl = balls_in_bowl(10, 2, worlds=3, seed=20, radius=0.12, speed=0.8, spacing=0.005)
    kw = dict(terrain=bowl, integrator="velocity_verlet", **contact_kwargs(masses))
    batch = World(x, radii, masses, v, **kw)
    batch.step(50)
    before = batch.positions.copy()
    batch.set_state(positions=x[1:2], velocities=v[1:2], worlds=[1])
    np.testing.assert_array_equal(batch.positions[[0, 2]], before[[0, 2]])
    batch.step(50)
    fresh = World(x[1], radii, masses, v[1], **kw)
    fresh.step(50)
    np.testing.assert_array_equal(batch.positions[1], fresh.positions)  # Verlet's cached force was reset


_THREAD_SCRIPT = textwrap.dedent(
    """
    import hashlib, math, sys
    import numpy as np
    import numba
    from penalty_env.physics import Bowl, World

    out = [str(numba.config.NUMBA_NUM_THREADS)]
    rng = np.random.default_rng(0)
    kw = dict(ks=1e4, kd=2 * 0.2 * math.sqrt(1e4 * 0.5), dt=0.2 / math.sqrt(2e4))
    # a batch spread over the thread pool, on each path that takes one
    B, n, d = 133, 24, 3
    side = np.arange(3) * 0.25
    lattice = np.array([[a, b, c] for a in side for b in side for c in side])[:n] + [-0.25, -0.25, 0.2]
    x = lattice[None] + rng.normal(0, 0.01, (B, n, d))
    v = rng.normal(0, 0.5, (B, n, d))
    for stepping, integ in (("lanes", "symplectic_euler"), ("scalar", "symplectic_euler"), ("scalar", "rk4")):
        w = World(x, np.full(n, 0.11), np.ones(n), v, terrain=Bowl((0, 0, 1.0), 1.0), mu=0.3, stepping=stepping,
                  integrator=integ, **kw)
        w.step(100)
        out.append(hashlib.sha256(w.positions.tobytes() + w.velocities.tobytes()).hexdigest())
    # a large world: its force loop runs in parallel over balls
    k = 16
    g = np.arange(k) * 0.196
    big = np.array([[a, b, c] for a in g for b in g for c in g]) - [1.47, 1.47, -0.11]
    big = big + rng.normal(0, 0.005, big.shape)
    wl = World(big, np.full(k**3, 0.1), np.ones(k**3), terrain=Bowl((0, 0, 3.0), 3.0), broadphase="grid", **kw)
    for _ in range(3):  # past a re-sort of its storage
        wl.step(20)
    out.append(hashlib.sha256(wl.positions.tobytes() + wl.velocities.tobytes()).hexdigest())
    print(" ".join(out))
    """
)


def test_results_do_not_depend_on_the_thread_count():
    digests = {}
    for threads in (1, 2):
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
        res = subprocess.run(
            [sys.executable, "-c", _THREAD_SCRIPT], env=env, capture_output=True, text=True, timeout=600
        )
        assert res.returncode == 0, res.stderr[-3000:]
        seen, *hashes = res.stdout.split()
        assert seen == str(threads)
        digests[threads] = hashes
    assert digests[1] == digests[2]
