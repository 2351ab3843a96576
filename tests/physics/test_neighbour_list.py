"""Large worlds (from LARGE_WORLD_MIN_BALLS balls, grid, symplectic or explicit Euler) step through a
Verlet neighbour list in parallel over balls, with their storage sorted by grid cell: the same
physics as the serial all-pairs world, to round-off, whatever the storage order, the escapes and
rebuilds, the list's size or how the steps are split into calls (bit for bit there). (Batched
lists: ``test_stepping_paths.py``.)"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from penalty_env.physics import Bowl, Sphere, World
from penalty_env.physics.contact.listed import PAIR_BLOCK
from penalty_env.physics.world import LARGE_WORLD_MIN_BALLS
from penalty_env.scenarios import balls_in_bowl


def test_large_world_parallel_force_loop_matches_the_serial_all_pairs_world():
    """From LARGE_WORLD_MIN_BALLS balls a grid world gathers each ball's forces in parallel (every
    pair visited twice, once from each side): the same physics as the serial all-pairs loop."""
    rng = np.random.default_rng(5)
    k = 16
    g = np.arange(k) * 0.196  # spacing < 2 r: every neighbour pair starts in contact
    x = np.array([[a, b, c] for a in g for b in g for c in g]) - [1.47, 1.47, -0.11]
    x = x + rng.normal(0, 0.005, x.shape)
    n = x.shape[0]
    # (a lattice packed into the bowl: the corners start inside its wall, on purpose)
    kw = dict(ks=1e4, kd=2 * 0.2 * math.sqrt(1e4 * 0.5), dt=0.2 / math.sqrt(2e4), start_check=False)
    bowl = Bowl((0, 0, 3.0), 3.0)
    par = World(x, np.full(n, 0.1), np.ones(n), terrain=bowl, broadphase="grid", **kw)
    ser = World(x, np.full(n, 0.1), np.ones(n), terrain=bowl, broadphase="all_pairs", **kw)
    par.step(20)
    ser.step(20)
    assert par.max_penetration() > 0.0
    np.testing.assert_allclose(par.positions, ser.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(par.velocities, ser.velocities, rtol=0, atol=1e-10)


def test_large_world_storage_order_changes_only_round_off():
    """One large world keeps its balls sorted by grid cell in memory (re-sorted at every rebuild of
    its neighbour list). The user sees balls in their own order; the physics is the same whatever
    order they were given in, and splitting the steps into calls changes nothing, bit for bit."""
    rng = np.random.default_rng(7)
    k = 16
    g = np.arange(k) * 0.196
    x = np.array([[a, b, c] for a in g for b in g for c in g]) - [1.47, 1.47, -0.11]
    x = x + rng.normal(0, 0.005, x.shape)
    n = x.shape[0]
    v = rng.normal(0, 0.2, x.shape)
    radii = rng.uniform(0.095, 0.1, n)
    masses = rng.uniform(0.8, 1.2, n)
    kw = dict(
        ks=1e4,
        kd=2 * 0.2 * math.sqrt(1e4 * 0.4),
        dt=0.2 / math.sqrt(1e4 / 0.4),
        terrain=Bowl((0, 0, 3.0), 3.0),
        broadphase="grid",
        mu=0.2,
        start_check=False,  # (a lattice packed into the bowl: the corners start inside its wall)
    )
    steps = 53
    forces = rng.normal(0.0, 1.0, x.shape)
    ref = World(x, radii, masses, v, **kw)
    assert ref.stepping == "neighbour_list"  # the sorted large-world path
    ref.step(steps, forces=forces)
    assert ref.neighbour_list_stats()["builds"] > 2  # the list was rebuilt (and the storage re-sorted) on the way
    shuffle = rng.permutation(n)
    mixed = World(x[shuffle], radii[shuffle], masses[shuffle], v[shuffle], **kw)
    mixed.step(steps, forces=forces[shuffle])
    np.testing.assert_allclose(mixed.positions, ref.positions[shuffle], rtol=0, atol=1e-10)
    np.testing.assert_allclose(mixed.velocities, ref.velocities[shuffle], rtol=0, atol=1e-8)
    split = World(x, radii, masses, v, **kw)
    for chunk in (1, 23, 7, 22):
        split.step(chunk, forces=forces)
    np.testing.assert_array_equal(split.positions, ref.positions)
    np.testing.assert_array_equal(split.velocities, ref.velocities)
    assert ref.max_penetration() > 0.0
    # new state: the world steps exactly as a new World made from that state
    x1, v1 = ref.positions.copy(), ref.velocities.copy()
    split.set_state(positions=x1, velocities=v1)
    split.step(29, forces=forces)
    fresh = World(x1, radii, masses, v1, **kw)
    fresh.step(29, forces=forces)
    np.testing.assert_array_equal(split.positions, fresh.positions)
    np.testing.assert_array_equal(split.velocities, fresh.velocities)


@pytest.mark.parametrize("d", [2, 3])
def test_coincident_centres_in_a_listed_world_get_the_all_pairs_force(d):
    """Two balls at the same centre: the list pass masks the pair (its normal is 0 / 0) and hands it
    to the reference law after the ball's other pairs; the first step equals the all-pairs world's
    to round-off, and the pair is pushed apart along the reference's fallback normal."""
    n = LARGE_WORLD_MIN_BALLS + 40
    x, radii, masses, bowl = _pile(n, d, seed=4)
    x[1] = x[0]  # coincident, and both in contact with their lattice neighbours
    kw = dict(ks=1e4, kd=20.0, dt=1e-3, terrain=bowl, broadphase="grid", allow_unstable=True)
    lst = World(x, radii, masses, **kw)
    ref = World(x, radii, masses, **dict(kw, broadphase="all_pairs"))
    assert lst.stepping == "neighbour_list"
    lst.step(1)
    ref.step(1)
    np.testing.assert_allclose(lst.velocities, ref.velocities, rtol=0, atol=1e-12)
    np.testing.assert_allclose(lst.positions, ref.positions, rtol=0, atol=1e-14)
    apart = lst.positions[1] - lst.positions[0]
    assert np.linalg.norm(apart) > 0.0, "the coincident pair must be pushed apart"


def _pile(n, d, seed, radii=0.05):
    """n balls on a loose cubic lattice in a bowl (they settle), with their radii, masses and bowl."""
    x, _, radii, _, bowl = balls_in_bowl(n, d, seed=seed, radius=radii, lattice=True, spacing=0.05 * np.max(radii))
    masses = np.random.default_rng(seed).uniform(0.8, 1.2, n)
    return x[0], radii, masses, bowl


@pytest.mark.parametrize(
    "d,mu,damping",
    [pytest.param(2, 0.0, "linear", marks=pytest.mark.slow), (3, 0.0, "no_tension"), (3, 0.3, "linear")],
)
def test_neighbour_list_world_matches_all_pairs_while_balls_escape_and_lists_rebuild(d, mu, damping, contact_kwargs):
    """From LARGE_WORLD_MIN_BALLS balls a grid world steps through a Verlet neighbour list. Balls
    that move half the skin "escape" (their contacts are searched each step) and, once too many
    have, the list is rebuilt. A pile stirred by one fast ball shot through it exercises all of it:
    the trajectories equal the all-pairs world's to round-off."""
    n = LARGE_WORLD_MIN_BALLS + 72
    x, radii, masses, bowl = _pile(n, d, seed=d)
    kw = contact_kwargs(masses, zeta=0.3)
    rng = np.random.default_rng(11)
    v = rng.normal(0.0, 0.05, x.shape)
    v[0] = 0.0
    v[0, 0] = 3.0  # a fast ball through the pile
    worlds = {
        bp: World(x, radii, masses, v, terrain=bowl, mu=mu, damping=damping, broadphase=bp, **kw)
        for bp in ("all_pairs", "grid")
    }
    g, a = worlds["grid"], worlds["all_pairs"]
    assert g.stepping == "neighbour_list"
    escaped, contacts = 0, 0
    for _ in range(15):  # (chaos amplifies round-off about 10x per 100 steps here)
        for w in worlds.values():
            w.step(20)
        escaped = max(escaped, g.neighbour_list_stats()["escaped"])
        contacts += g.max_penetration() > 0.0
        np.testing.assert_allclose(g.positions, a.positions, rtol=0, atol=1e-10)
        np.testing.assert_allclose(g.velocities, a.velocities, rtol=0, atol=1e-8)
    assert contacts == 15
    assert escaped > 0, "some balls must have escaped their list"
    assert g.neighbour_list_stats()["builds"] > 1, "the list must have been rebuilt"


def _step_alike(one, other, chunks):
    """Step two list worlds 20 steps at a time, ``chunks`` times: balls escaped and the lists were
    rebuilt on the way, and the two are the same bit for bit."""
    escaped = 0
    for _ in range(chunks):
        for w in (one, other):
            w.step(20)
        escaped = max(escaped, other.neighbour_list_stats()["escaped"])
    assert escaped > 0 and other.neighbour_list_stats()["builds"] > 1
    np.testing.assert_array_equal(one.positions, other.positions)
    np.testing.assert_array_equal(one.velocities, other.velocities)


@pytest.mark.parametrize("d", [2, 3])
def test_equal_radii_skip_the_partner_radius_and_change_no_bit(d, contact_kwargs):
    """With every radius equal, the list pass takes r_i + r_j as the World's one diameter (the
    list's SlimModel.diameter) instead of reading the partner's radius: bit for bit the general
    path's trajectories (the same world with the diameter cleared), escapes and rebuilds included;
    unequal radii leave the diameter 0 (the general path)."""
    n = LARGE_WORLD_MIN_BALLS + 72
    x, radii, masses, bowl = _pile(n, d, seed=d)
    assert np.all(radii == radii[0])
    kw = contact_kwargs(masses, zeta=0.3)
    v = np.random.default_rng(5).normal(0.0, 0.05, x.shape)
    v[0, 0] = 3.0
    same, general = (
        World(x, radii, masses, v, terrain=bowl, broadphase="grid", allow_unstable=True, **kw) for _ in range(2)
    )
    lists = general.runner.lists
    assert same.runner.lists.worlds[0][1].diameter == 2.0 * radii[0]
    lists.worlds[0] = (lists.worlds[0][0], lists.worlds[0][1]._replace(diameter=0.0))
    _step_alike(same, general, 15)
    mixed = radii * np.where(np.arange(n) % 2 == 0, 1.0, 0.9)
    poly = World(x, mixed, masses, v, terrain=bowl, broadphase="grid", allow_unstable=True, **kw)
    assert poly.runner.lists.worlds[0][1].diameter == 0.0


@pytest.mark.parametrize("d", [2, 3])
def test_the_block_buffer_stride_changes_no_bit(d, contact_kwargs):
    """The frictionless pass reads its block buffer's rows at a compile-time stride when the buffer
    is PAIR_BLOCK long (the usual case) and at the buffer's length when the list is wider than a
    block: the same world with a list (and so a buffer) wider than a block steps bit for bit
    alike, escapes and rebuilds included, equal and unequal radii."""
    n = LARGE_WORLD_MIN_BALLS + 72
    x, radii, masses, bowl = _pile(n, d, seed=d + 4)
    kw = contact_kwargs(masses, zeta=0.3)
    v = np.random.default_rng(6).normal(0.0, 0.05, x.shape)
    v[0, 0] = 3.0
    for r in (radii, radii * np.where(np.arange(n) % 3 == 0, 1.0, 0.85)):
        usual, wide = (
            World(x, r, masses, v, terrain=bowl, broadphase="grid", allow_unstable=True, **kw) for _ in range(2)
        )
        lists = wide.runner.lists
        lists.worlds[0] = (lists._new(PAIR_BLOCK + 37), lists.worlds[0][1])  # a list as wide as that
        lists.reset()
        _step_alike(usual, wide, 12)
        assert usual.runner.lists.worlds[0][0].pairs.shape[2] == PAIR_BLOCK
        assert wide.runner.lists.worlds[0][0].pairs.shape[2] == PAIR_BLOCK + 37


def test_a_ball_listed_far_from_the_terrain_still_bounces_off_it_after_escaping(contact_kwargs):
    """A list world tests the terrain only for balls that were within a skin of it at the build
    (and for escaped balls). A ball shot from the side of a pile, listed far from every shape,
    escapes on its way and must then bounce off a Sphere obstacle exactly as in the all-pairs
    world, before any rebuild could have refreshed its flag."""
    n = LARGE_WORLD_MIN_BALLS + 88
    x, radii, masses, bowl = _pile(n, 3, seed=7)
    x = (x - x.mean(0)) * 1.2 + [0.0, 0.0, 0.55]  # apart: no other ball moves (nor escapes)
    bowl = Bowl((0.0, 0.0, 1.5), 1.5)
    x[np.argmin(np.linalg.norm(x - [0.0, 0.0, 0.0], axis=1))] = [0.0, 0.0, radii[0] + 0.005]  # near the floor
    assert np.all(bowl.phi(x) > radii)
    shot = int(np.argmin(np.linalg.norm(x - [x[:, 0].max(), 0.0, 0.55], axis=1)))
    v = np.zeros_like(x)
    v[shot, 0] = 2.0
    terrain = (bowl, Sphere((0.55, x[shot, 1], x[shot, 2]), 0.1))  # head on
    kw = contact_kwargs(masses, zeta=0.3)
    worlds = {
        bp: World(x, radii, masses, v, terrain=terrain, gravity=(0.0, 0.0, 0.0), broadphase=bp, **kw)
        for bp in ("all_pairs", "grid")
    }
    g, a = worlds["grid"], worlds["all_pairs"]
    g.step(1)
    a.step(1)
    near = g.neighbour_list_stats()["near_terrain"]
    assert not near[shot] and near.any(), "the shot ball is listed clear of the terrain, some others are not"
    for _ in range(15):
        for w in worlds.values():
            w.step(10)
        np.testing.assert_allclose(g.positions, a.positions, rtol=0, atol=1e-10)
        np.testing.assert_allclose(g.velocities, a.velocities, rtol=0, atol=1e-8)
    assert a.velocities[shot, 0] < -0.2, "the shot ball bounced back off the Sphere"
    assert g.neighbour_list_stats()["builds"] == 1, "no rebuild: the escaped path alone found the terrain"


def test_a_ball_with_more_neighbours_than_the_list_holds_grows_the_list(contact_kwargs):
    """A big ball pressed among many small ones has more neighbours than the list's first
    capacity: the world grows the list and carries on, with the all-pairs world's physics."""
    n = LARGE_WORLD_MIN_BALLS + 40
    rng = np.random.default_rng(3)
    radii = np.full(n, 0.04)
    radii[0] = 0.2
    u = rng.normal(size=(n - 1, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    x = np.vstack([[0.0, 0.0, 0.6], [0.0, 0.0, 0.6] + u * rng.uniform(0.2, 0.45, (n - 1, 1))])
    masses = np.ones(n)
    kw = contact_kwargs(masses, zeta=0.3)
    bowl = Bowl((0.0, 0.0, 1.0), 1.0)
    # (the small balls start packed around the big one, some overlapping: on purpose)
    worlds = {
        bp: World(x, radii, masses, terrain=bowl, broadphase=bp, start_check=False, **kw)
        for bp in ("all_pairs", "grid")
    }
    g = worlds["grid"]
    first = g.neighbour_list_stats()["capacity"]
    for w in worlds.values():
        w.step(50)
    stats = g.neighbour_list_stats()
    assert stats["largest"] > first  # the big ball's neighbours did not fit at first
    assert stats["capacity"] > stats["largest"]
    np.testing.assert_allclose(g.positions, worlds["all_pairs"].positions, rtol=0, atol=1e-10)


def test_state_written_directly_is_seen_after_invalidate_cache(contact_kwargs):
    """Writing positions into ``World.state`` and calling ``invalidate_cache`` restarts a large
    world's neighbour list: a contact made by the write is felt at the next step."""
    n = LARGE_WORLD_MIN_BALLS + 8
    x, radii, masses, bowl = _pile(n, 2, seed=9)
    kw = contact_kwargs(masses, zeta=0.3)
    worlds = {bp: World(x, radii, masses, gravity=(0.0, 0.0), broadphase=bp, **kw) for bp in ("all_pairs", "grid")}
    assert worlds["grid"].stepping == "neighbour_list"
    for w in worlds.values():
        w.step(1)
        x = w.state.positions
        x[0, 1] = x[0, 0] + [0.09, 0.0]  # ball 1 now overlaps ball 0 (radii 0.05)
        w.invalidate_cache()
        w.step(1)
    a, g = worlds["all_pairs"], worlds["grid"]
    assert np.abs(a.velocities[1]).max() > 0.0
    np.testing.assert_allclose(g.velocities, a.velocities, rtol=0, atol=1e-12)


def test_a_huge_finite_displacement_still_advances_every_other_ball(contact_kwargs):
    """A ball flung at 1e160 m/s overflows its squared displacement; the rest of the world steps on
    exactly as the all-pairs world does (the overflow only asks for a rebuild)."""
    n = LARGE_WORLD_MIN_BALLS + 8
    x, radii, masses, bowl = _pile(n, 3, seed=4)
    v = np.zeros_like(x)
    v[5, 0] = 1e160
    kw = contact_kwargs(masses, zeta=0.3)
    worlds = {
        bp: World(x, radii, masses, v, gravity=(0.0, 0.0, -9.81), broadphase=bp, **kw) for bp in ("all_pairs", "grid")
    }
    for w in worlds.values():
        w.step(2)
    keep = np.arange(n) != 5
    np.testing.assert_allclose(worlds["grid"].positions[keep], worlds["all_pairs"].positions[keep], rtol=0, atol=1e-12)


def test_a_single_large_world_steps_serially_when_numba_runs_one_thread(monkeypatch):
    """``numba.set_num_threads(1)``: a parallel region would run on one thread and only cost its
    launch, so a large world steps serially (the same result bit for bit: the test below); with
    two threads it steps in parallel."""
    from penalty_env.physics.stepping import runner

    monkeypatch.setattr(runner, "thread_count", lambda: 2)
    monkeypatch.setattr(runner, "SERIAL_MAX_BALLS", 0)
    x, radii, masses, bowl = _pile(LARGE_WORLD_MIN_BALLS + 50, 3, seed=4)
    w = World(x, radii, masses, terrain=bowl, ks=1e4, kd=50.0, dt=1e-3, broadphase="grid", stepping="neighbour_list")
    lists = w.runner.lists
    seen = []
    original = lists.step

    def step(*args, **kwargs):
        seen.append(kwargs.get("serial", False))
        return original(*args, **kwargs)

    monkeypatch.setattr(lists, "step", step)
    saved = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        w.step(2)
        if numba.config.NUMBA_NUM_THREADS >= 2:
            numba.set_num_threads(2)
            w.step(2)
    finally:
        numba.set_num_threads(saved)
    assert seen == [True, False][: len(seen)] and len(seen) == (2 if numba.config.NUMBA_NUM_THREADS >= 2 else 1)


def test_serial_and_parallel_list_steps_agree_bit_for_bit_and_a_batch_equals_each_world_alone(monkeypatch):
    """A large world is stepped parallel over its balls (``run_large``), or serially on one thread
    (``run_large_serial``: a small world alone, a single thread, or a batch, a share of its worlds
    per thread): one algorithm, so the same result bit for bit, through escapes and rebuilds."""
    from penalty_env.physics.stepping import runner

    B, n, d = 3, LARGE_WORLD_MIN_BALLS + 200, 3
    piles = [_pile(n, d, seed=20 + b) for b in range(B)]
    radii, masses, bowl = piles[0][1], piles[0][2], piles[0][3]
    x = np.stack([p[0] for p in piles])
    rng = np.random.default_rng(3)
    v = rng.normal(0.0, 0.3, x.shape)
    kw = dict(ks=1e4, kd=2 * 0.3 * math.sqrt(1e4 * 0.5), dt=0.2 / math.sqrt(2e4), mu=0.3, terrain=bowl)
    kw.update(broadphase="grid", stepping="neighbour_list", start_check=False)  # (piles: packed on purpose)
    forces = rng.normal(0.0, 0.5, x.shape)

    def run(xb, vb, fb, threads, serial_max):
        monkeypatch.setattr(runner, "thread_count", lambda: threads)
        monkeypatch.setattr(runner, "SERIAL_MAX_BALLS", serial_max)
        w = World(xb, radii, masses, vb, **kw)
        for chunk in (40, 1, 39):
            w.step(chunk, forces=fb)
        assert w.neighbour_list_stats()["builds"] > 1
        return w.positions.copy(), w.velocities.copy()

    batch = run(x, v, forces, threads=2, serial_max=0)  # 3 worlds over 2 threads, each serial
    for b in range(B):
        one = slice(b, b + 1)
        serial = run(x[one], v[one], forces[one], threads=2, serial_max=10**9)  # run_large_serial
        # run_large on 2 threads (with Numba on one thread, a single world steps serially)
        parallel = [run(x[one], v[one], forces[one], threads=2, serial_max=0)] if numba.get_num_threads() >= 2 else []
        for got in (*parallel, serial):
            np.testing.assert_array_equal(got[0][0], batch[0][b])
            np.testing.assert_array_equal(got[1][0], batch[1][b])


def test_the_list_pass_block_law_compiles_to_vector_code():
    """The frictionless list pass computes its pairs' forces in one loop per block that LLVM
    vectorises (square roots and divisions of several pairs per instruction): a branch or a gather
    added to ``contact.listed.block_law`` (or to the law it calls) would silently make it scalar
    again. Its source compiled afresh as a kernel of its own, uncached, so its code can be read."""
    import re

    from numba import types

    from penalty_env._jit import njit
    from penalty_env.physics.contact.listed import block_law

    fn = njit(entry=True, cache=False)(block_law.py_func)
    fn.compile((types.int64, types.float64[:, ::1], types.float64, types.float64, types.boolean, types.int64))
    ir = "".join(fn.inspect_llvm().values())
    asm = "".join(fn.inspect_asm().values())
    assert ir.count("<4 x double>") + ir.count("<2 x double>") + ir.count("<8 x double>") > 0
    assert re.findall(r"\bv?sqrtpd\b", asm) and re.findall(r"\bv?divpd\b", asm)
