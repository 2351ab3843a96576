"""Spinning balls on the neighbour-list path (``stepping/large_spin.py``): rotation, the tangential
springs with history and rolling resistance, the springs stored per list slot and carried through
every rebuild and re-sort (``broadphase/history.py``). The same physics as the scalar path, which
keeps one spring per ball pair: to round-off, and each spring bit for bit where the state is the
same (the law is one function, antisymmetric to the bit); nothing depends on the thread count.

Tolerances: the two paths sum each ball's forces and torques in different orders (the list's
storage order, the grid's), so they differ by round-off, about 1e-16 relative per step, which a
pile's chaotic dynamics amplifies about tenfold per hundred steps: after 300 steps of the slumping
pile below the paths differ by about 1e-12 in position and 1e-10 in velocity and spin, well inside
the bounds asserted (1e-10 and 1e-8, those of ``test_neighbour_list.py``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from penalty_env.physics import Plane, World
from penalty_env.physics.stepping import neighbour_lists, runner
from penalty_env.physics.world import LARGE_SPIN_MIN_BALLS
from penalty_env.scenarios import packed_bowl, scene_params

SPIN = dict(mu=0.5, mu_r=0.1, rotation=True, tangential="history")


def _slumping_pile(n: int, d: int, seed: int = 1):
    """n balls of radius 0.5 on the core's loose lattice in a bowl (they slump and slosh, so the
    list is rebuilt and re-sorted often), and the top ball near the axis lifted 1.5 above the pile
    and thrown down at it (it escapes its list and meets balls the list does not pair it with:
    those springs go in the escaped balls' tables)."""
    pos, bowl = packed_bowl(n, d, 0.5, seed=seed)
    ks, kd = scene_params(0.5, 1.0)
    v = np.zeros_like(pos)
    top = int(np.argmax(pos[:, -1] - 10.0 * np.abs(pos[:, 0])))
    pos[top, -1] += 1.5
    v[top, 0], v[top, -1] = 2.0, -15.0
    return pos, v, dict(terrain=bowl, ks=ks, kd=kd, dt=2.5e-3)


def _assert_alike(lst: World, ref: World) -> None:
    np.testing.assert_allclose(lst.positions, ref.positions, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lst.velocities, ref.velocities, rtol=0, atol=1e-8)
    np.testing.assert_allclose(lst.angular_velocities, ref.angular_velocities, rtol=0, atol=1e-8)


def _scalar_springs(w: World):
    """The scalar path's live pair springs (i < j, from i's side), as ``live_springs`` lists them
    (without an exactly zero one: the list keeps none, a zero spring being a new contact's)."""
    sp = w.spin
    n = w.n_balls
    live = (sp.stamp[0, :, :n] == sp.clock[0]) & np.any(sp.hist[0, :, :n] != 0.0, axis=-1)
    i, j = np.nonzero(live)
    return np.stack([i, j], axis=1), sp.hist[0, i, j]


@pytest.mark.parametrize("d", [3, pytest.param(2, marks=pytest.mark.slow)])
def test_a_spinning_pile_on_the_list_path_matches_the_scalar_path_through_rebuilds_and_escapes(d):
    """A slumping pile with rotation, the tangential springs with history and rolling resistance:
    its trajectories, spins, energy (the springs' included) and springs themselves agree with the
    scalar path to round-off over 300 steps in which the list is rebuilt and re-sorted many times
    and balls escape it."""
    n = 1000 if d == 3 else 800
    pos, v, kw = _slumping_pile(n, d)
    lst = World(pos, np.full(n, 0.5), np.ones(n), v, broadphase="grid", **SPIN, **kw)
    ref = World(pos, np.full(n, 0.5), np.ones(n), v, broadphase="all_pairs", **SPIN, **kw)
    assert lst.stepping == "neighbour_list" and ref.stepping == "scalar"
    escaped = springs = tabled = 0
    for _ in range(30):
        lst.step(10)
        ref.step(10)
        stats = lst.neighbour_list_stats()
        escaped, springs = max(escaped, stats["escaped"]), max(springs, stats["springs"])
        over = lst.runner.lists.spins[0][1]  # the escaped balls' tables
        tabled = max(tabled, int(np.sum(over.stamp == lst.spin.clock[0])))
        _assert_alike(lst, ref)
        assert lst.energy() == pytest.approx(ref.energy(), rel=1e-12)
    assert stats["builds"] > 10, "the list must have been rebuilt (and the storage re-sorted) many times"
    assert escaped > 0, "some balls must have escaped their list"
    assert tabled > 0, "an escaped ball must have met balls its list did not pair it with"
    assert springs > n, "the pile must hold many springs"
    pairs, xi, _, _ = lst.runner.lists.live_springs()
    ref_pairs, ref_xi = _scalar_springs(ref)
    np.testing.assert_array_equal(pairs, ref_pairs)  # the same contacts live
    np.testing.assert_allclose(xi, ref_xi, rtol=0, atol=1e-12 + 1e-6 * np.abs(ref_xi).max())


def test_a_rebuild_and_re_sort_carry_every_spring_bit_for_bit():
    """Two copies of a pile stepped alike; one has its list thrown away (``invalidate_cache``: the
    storage re-sorted from the balls' own order and the list rebuilt, every spring carried through
    the compact table). One step later both hold the same live springs, bit for bit: each pair's
    spring depends only on the pair's state, which is the same in both."""
    n = 1000
    pos, v, kw = _slumping_pile(n, 3, seed=2)
    one, other = (World(pos, np.full(n, 0.5), np.ones(n), v, broadphase="grid", **SPIN, **kw) for _ in range(2))
    for w in (one, other):
        w.step(150)
    builds = other.neighbour_list_stats()["builds"]
    other.invalidate_cache()
    for w in (one, other):
        w.step(1)
    assert other.neighbour_list_stats()["builds"] == builds + 1
    mine, theirs = one.runner.lists.live_springs(), other.runner.lists.live_springs()
    assert len(mine[0]) > n // 2 and len(mine[2]) > 10  # pairs' springs and the bowl's
    for a, b in zip(mine, theirs, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(one.runner.lists.worlds[0][0].perm, other.runner.lists.worlds[0][0].perm)


def test_stacked_pucks_on_an_incline_hold_at_their_springs_stretch_through_forced_rebuilds():
    """64 stacks of two balls (sliding without spin, mu = 1 > tan 20 degrees) on an incline: the
    lower ball's spring on the plane holds both weights' pull, 2 m g sin(theta) / kt, and the
    upper ball's spring on the lower one its own, m g sin(theta) / kt, where regularised friction
    would creep. The list is thrown away every 200 steps (re-sorted from the balls' own order and
    rebuilt): the springs are carried, so the stacks do not move (a spring restarted at zero would
    let each stack slide by another stretch at every rebuild), and the world steps as the scalar
    path's does."""
    theta, r, ks = math.radians(20.0), 0.1, 1e6
    g = (9.81 * math.sin(theta), 0.0, -9.81 * math.cos(theta))
    base = np.array([[x, y, 0.0] for x in np.arange(8) * 0.5 for y in np.arange(8) * 0.5])
    lower = base + [0.0, 0.0, r - 2.0 * 9.81 * math.cos(theta) / ks]
    upper = lower + [0.0, 0.0, 2.0 * r - 9.81 * math.cos(theta) / ks]
    x = np.concatenate([lower, upper])
    n = len(x)
    assert n >= LARGE_SPIN_MIN_BALLS
    w, ref = (
        World(
            x, np.full(n, r), np.ones(n), terrain=Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), gravity=g, ks=ks, kd=200.0,
            dt=1e-4, mu=1.0, tangential="history", broadphase=bp,
        )
        for bp in ("grid", "all_pairs")
    )  # fmt: skip
    assert w.stepping == "neighbour_list" and ref.stepping == "scalar"
    for world in (w, ref):
        world.step(4000)  # the springs' start-up swing (damped by kd_t = kd / 2) dies down
    held = w.positions.copy()
    builds = w.neighbour_list_stats()["builds"]
    for _ in range(30):
        w.invalidate_cache()
        w.step(200)
        ref.step(200)
    assert w.neighbour_list_stats()["builds"] == builds + 30
    np.testing.assert_allclose(w.positions, ref.positions, rtol=0, atol=1e-14)
    stretch = 9.81 * math.sin(theta) / w.kt
    m = n // 2
    np.testing.assert_allclose(w.positions[:m, 0] - lower[:, 0], 2.0 * stretch, rtol=0.01)
    np.testing.assert_allclose(w.positions[m:, 0] - w.positions[:m, 0], stretch, rtol=0.01)
    assert np.abs(w.positions - held).max() <= 0.05 * stretch  # and they stay put (what moves is the swing's rest)


def test_a_batch_of_spinning_worlds_gives_the_same_bits_on_one_and_two_threads_as_each_world_alone(monkeypatch):
    """A batch of list worlds is stepped a share of its worlds per thread, each world serially: the
    result does not depend on the thread count, and each world is what it is alone."""
    B, n = 3, 400
    piles = [_slumping_pile(n, 3, seed=10 + b) for b in range(B)]
    x, v = np.stack([p[0] for p in piles]), np.stack([p[1] for p in piles])
    kw = dict(piles[0][2], **SPIN)

    def run(xb, vb, threads):
        monkeypatch.setattr(runner, "thread_count", lambda: threads)
        w = World(xb, np.full(n, 0.5), np.ones(n), vb, broadphase="grid", stepping="neighbour_list", **kw)
        for chunk in (60, 1, 59):
            w.step(chunk)
        assert w.neighbour_list_stats()["builds"] > 3
        return w.positions.copy(), w.angular_velocities.copy()

    one, two = run(x, v, 1), run(x, v, 2)
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a, b)
    alone = run(x[1:2], v[1:2], 2)
    np.testing.assert_array_equal(alone[0][0], one[0][1])
    np.testing.assert_array_equal(alone[1][0], one[1][1])


@pytest.mark.slow
def test_a_large_spinning_world_steps_the_same_bits_parallel_over_its_balls_and_serially(monkeypatch):
    """A single world of 3,000 spinning balls on two threads runs its slabs in parallel
    (``run_large_spin``); alone on one it runs serially (``run_large_spin_serial``): one algorithm,
    the same bits, through rebuilds and escapes."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two threads")
    n = 3000
    pos, v, kw = _slumping_pile(n, 3, seed=3)
    out = []
    for serial_max in (10**9, 0):
        monkeypatch.setattr(runner, "thread_count", lambda: 2)
        monkeypatch.setattr(runner, "SERIAL_MAX_BALLS", serial_max)
        monkeypatch.setattr(runner, "SERIAL_MAX_SPIN_BALLS", serial_max)
        w = World(pos, np.full(n, 0.5), np.ones(n), v, broadphase="grid", **SPIN, **kw)
        for chunk in (100, 1, 99):
            w.step(chunk)
        assert w.neighbour_list_stats()["builds"] > 5
        out.append((w.positions.copy(), w.angular_velocities.copy(), w.runner.lists.live_springs()[1]))
    for a, b in zip(*out, strict=True):
        np.testing.assert_array_equal(a, b)


def test_short_tables_grow_and_change_nothing(monkeypatch):
    """The escaped balls' tables and the rebuild's compact table start small and grow when short (the
    step returns before writing anything, the caller grows the table and goes on): with both empty
    entry the world steps bit for bit as with the usual sizes."""
    n = 1000
    pos, v, kw = _slumping_pile(n, 3, seed=4)
    usual = World(pos, np.full(n, 0.5), np.ones(n), v, broadphase="grid", **SPIN, **kw)
    monkeypatch.setattr(neighbour_lists.NeighbourLists, "PER_ESCAPE", 0)
    monkeypatch.setattr(neighbour_lists.NeighbourLists, "CARRY_PER_BALL", {2: 0, 3: 0})
    short = World(pos, np.full(n, 0.5), np.ones(n), v, broadphase="grid", **SPIN, **kw)
    first = short.runner.lists.spins[0]
    for w in (usual, short):
        w.step(200)
    grown = short.runner.lists.spins[0]
    assert grown[1].hist.shape[2] > first[1].hist.shape[2] and grown[2].carry_partner.size > first[2].carry_partner.size
    np.testing.assert_array_equal(short.positions, usual.positions)
    np.testing.assert_array_equal(short.angular_velocities, usual.angular_velocities)


def test_the_list_path_takes_spinning_balls_and_auto_picks_it_for_large_worlds():
    """The refusal is gone: ``stepping="neighbour_list"`` takes rotation and the history model, and
    ``auto`` steps a large spinning world (grid, Euler) on it; a small one, another integrator, or
    the lanes stay as they were."""
    n = LARGE_SPIN_MIN_BALLS
    pos, v, kw = _slumping_pile(n + 20, 3)
    big = World(pos, np.full(n + 20, 0.5), np.ones(n + 20), v, broadphase="grid", **SPIN, **kw)
    assert big.stepping == "neighbour_list"
    small = World(pos[: n - 1], np.full(n - 1, 0.5), np.ones(n - 1), broadphase="grid", **SPIN, **kw)
    assert small.stepping == "scalar"
    verlet = World(pos, np.full(n + 20, 0.5), np.ones(n + 20), broadphase="grid", rotation=True, mu=0.5,
                   integrator="velocity_verlet", **kw)  # fmt: skip
    assert verlet.stepping == "scalar"
    with pytest.raises(ValueError, match="stepping='lanes' does not support rotation"):
        World(pos[:4], np.full(4, 0.5), np.ones(4), stepping="lanes", broadphase="all_pairs", **SPIN, **kw)
    with pytest.raises(ValueError, match="stepping='neighbour_list' needs the grid"):
        World(
            pos, np.full(n + 20, 0.5), np.ones(n + 20), stepping="neighbour_list", broadphase="all_pairs", **SPIN, **kw
        )


@pytest.mark.parametrize("stepping", ["neighbour_list", "scalar"])
def test_new_positions_end_every_spring_as_a_new_world_would(stepping):
    """``set_state(positions=...)`` ends every contact's tangential history (World's docstring):
    after it a world steps exactly as a new World made from that state, on the list path too (its
    listed springs carry no stamp: they are zeroed, not left for the rebuild to carry). New
    velocities alone keep the springs."""
    n = 400
    pos, v, kw = _slumping_pile(n, 3, seed=5)
    kw = dict(kw, **SPIN, broadphase="grid", stepping=stepping)
    w = World(pos, np.full(n, 0.5), np.ones(n), v, **kw)
    w.step(120)
    x1, v1, w1 = w.positions.copy(), w.velocities.copy(), w.angular_velocities.copy()
    w.set_state(positions=x1, velocities=v1, angular_velocities=w1)
    w.step(60)
    fresh = World(x1, np.full(n, 0.5), np.ones(n), v1, **kw)
    fresh.angular_velocities = w1
    fresh.step(60)
    np.testing.assert_array_equal(w.positions, fresh.positions)
    np.testing.assert_array_equal(w.angular_velocities, fresh.angular_velocities)
    # velocities alone: the springs continue, as in a world never touched (bit for bit on the
    # scalar path; the list's storage returns to ball order and is re-sorted, so to round-off
    # there, the module's tolerance); new positions end them: far more than round-off
    a, b, c = (World(pos, np.full(n, 0.5), np.ones(n), v, **kw) for _ in range(3))
    for world in (a, b, c):
        world.step(120)
    b.set_state(velocities=b.velocities.copy())
    c.set_state(positions=c.positions.copy())
    for world in (a, b, c):
        world.step(30)
    if stepping == "scalar":
        np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=1e-10)
    assert np.abs(a.positions - c.positions).max() > 1e-6
