"""Event-located stepping (``World(events=True)``, penalty_env/physics/events.py).

The contact force switches when a contact begins or ends (the dashpot's kd v_n jumps), so a step
straddling a switch integrates a discontinuous force and every integrator is first order in the
worst case over where the switch falls in the step. Stopping at the switch restores the order.
Errors are worst cases over 1,024 start phases (one batched World): the first-order error lives
in narrow phase windows that a sparse sweep misses (see tests/test_physics_accuracy.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from penalty_env.physics import Bowl, World, events
from penalty_env.scenarios import balls_in_bowl, bowl_drop, pair_collision

PHASES = 1024


def _slope(spcs, errs):
    return float(-np.polyfit(np.log(spcs), np.log(errs), 1)[0])


def test_rk4_with_events_reaches_one_hundredth_of_a_percent_at_16_steps_per_contact():
    # the figure: plain RK4 at 64 steps per contact is no better than 1% at zeta = 0.3;
    # with event location 16 steps give ~0.005% worst case
    plain = pair_collision("rk4", False, "linear", 0.3, 64, PHASES)
    located = pair_collision("rk4", True, "linear", 0.3, 16, PHASES)
    assert plain.errors["restitution"] > 0.009
    assert located.errors["restitution"] < 1e-4, located.errors
    assert located.errors["duration"] < 1e-4
    assert located.errors["peak_overlap"] < 1e-4


def test_rk4_with_events_on_terrain_under_gravity_is_as_accurate():
    located = bowl_drop("rk4", True, "linear", 0.3, 16, PHASES)
    assert located.errors["restitution"] < 1e-4, located.errors
    assert located.errors["peak_overlap"] < 1e-4


def test_verlet_with_events_is_second_order_on_terrain_including_a_touch_at_a_step_end():
    # phase 0 puts the first touch exactly at the end of a step: the state lies within round-off
    # of the switch, where the force kernels' test and the scan's may disagree; it must still be
    # crossed (it is, at once, on the side the ball moves to)
    spcs = [16, 32, 64]
    errs = [bowl_drop("velocity_verlet", True, "linear", 0.3, s, 64).errors["peak_overlap"] for s in spcs]
    assert 1.8 < _slope(spcs, errs) < 2.3, errs


@pytest.mark.parametrize(
    "integrator", ["explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler"]
)
def test_without_events_every_method_is_first_order_in_the_worst_case(integrator):
    spcs = [32, 64, 128]
    errs = [pair_collision(integrator, False, "linear", 0.3, s, PHASES).errors["restitution"] for s in spcs]
    assert 0.8 < _slope(spcs, errs) < 1.3, errs


@pytest.mark.parametrize("integrator, lo, hi", [("velocity_verlet", 1.8, 2.3), ("rk4", 3.5, 4.6)])
def test_with_events_verlet_is_second_order_and_rk4_fourth(integrator, lo, hi):
    spcs = [16, 32, 64]
    errs = [pair_collision(integrator, True, "linear", 0.3, s, PHASES).errors["restitution"] for s in spcs]
    assert lo < _slope(spcs, errs) < hi, errs


def test_rk4_with_events_keeps_its_order_when_the_jerk_points_across_the_switch():
    # zeta = 0.7: at the end of the contact the jerk points out of the contact, so a landing
    # just before the switch would let RK4's fourth stage see the open contact; the margin
    # (dt^3 |jerk| / 4) keeps it inside
    spcs = [16, 32, 64]
    errs = [pair_collision("rk4", True, "linear", 0.7, s, 256).errors["restitution"] for s in spcs]
    assert _slope(spcs, errs) > 3.5, errs


def test_one_collision_locates_two_switches_per_world_and_costs_little():
    res = pair_collision("rk4", True, "linear", 0.3, 32, 64)
    plain = pair_collision("rk4", False, "linear", 0.3, 32, 64)
    switches = res.events_per_sim_s * res.sim_time
    assert switches == pytest.approx(2.0, abs=0.05)
    assert res.fallbacks == 0
    # a located switch costs a few extra integrator calls; the steps without one cost nothing extra
    extra_evals = (res.evals_per_sim_s - plain.evals_per_sim_s) * res.sim_time
    assert 0 < extra_evals < 2 * 4 * 6


def _scatter(n, d, seed, radius=0.1):
    """n balls converging on the origin in free space (the bowl only frames the draw)."""
    x, _, _, _, bowl = balls_in_bowl(n, d, seed=seed, radius=radius, bowl_radius=0.8 + radius, spacing=0.02)
    x = x[0] - np.array(bowl.center)
    v = -1.5 * x + np.random.default_rng(seed).normal(0.0, 0.3, (n, d))
    return x, v


def test_a_scene_without_switches_steps_exactly_as_without_events():
    # balls flying apart under gravity in a big bowl, no contact ever: the trial step is accepted
    x, v = _scatter(6, 3, 0)
    kw = dict(terrain=(Bowl((0.0, 0.0, 30.0), 40.0),), ks=1e4, kd=10.0, dt=1e-3, integrator="rk4")
    a = World(x, np.full(6, 0.1), np.ones(6), -v, **kw)
    b = World(x, np.full(6, 0.1), np.ones(6), -v, events=True, **kw)
    a.step(100)
    b.step(100)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.velocities, b.velocities)
    st = events.stats(b)
    assert st["events"] == 0 and st["integrator_calls"] == 100


@pytest.mark.parametrize("integrator", ["symplectic_euler", "velocity_verlet", "rk4"])
def test_grid_and_all_pairs_locate_the_same_switches(integrator):
    n, d = 60, 3
    x, v = _scatter(n, d, 1, radius=0.06)
    radii, masses = np.full(n, 0.06), np.linspace(0.5, 1.5, n)
    ks = 2e4
    kw = dict(
        gravity=np.zeros(d),
        ks=ks,
        kd=2 * 0.3 * math.sqrt(ks * 0.25),
        integrator=integrator,
        events=True,
        dt=0.1 / math.sqrt(ks / 0.25),
    )
    a = World(x, radii, masses, v, broadphase="all_pairs", **kw)
    b = World(x, radii, masses, v, broadphase="grid", **kw)
    a.step(1500)
    b.step(1500)
    sa, sb = events.stats(a), events.stats(b)
    assert sa["events"] > 20, "the scene must actually collide"
    assert sa["events"] == sb["events"]
    np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=1e-9)


def test_events_conserve_momentum_of_pair_contacts():
    n, d = 12, 3
    x, v = _scatter(n, d, 2)
    masses = np.linspace(0.5, 2.0, n)
    w = World(
        x,
        np.full(n, 0.1),
        masses,
        v,
        gravity=np.zeros(d),
        ks=1e4,
        kd=15.0,
        integrator="velocity_verlet",
        events=True,
        dt=2e-4,
    )
    p0 = w.momentum().copy()
    w.step(4000)  # past the moment they all converge on the origin
    assert events.stats(w)["events"] > 10
    np.testing.assert_allclose(w.momentum(), p0, atol=1e-12 * float(np.sum(masses * np.linalg.norm(v, axis=1))))


def test_events_are_off_by_default():
    w = World(np.zeros((1, 3)), [0.1], [1.0], ks=1e3, dt=1e-3)
    assert w.events is False and w.event_buffers is None
    with pytest.raises(ValueError, match="without event location"):
        events.stats(w)


def test_no_tension_with_events_is_second_order():
    # the clip of the normal force at zero is a kink inside the contact, not a located switch
    spcs = [16, 32, 64]
    errs = [pair_collision("rk4", True, "no_tension", 0.3, s, 256).errors["restitution"] for s in spcs]
    assert 1.7 < _slope(spcs, errs) < 2.4, errs
    assert errs[0] < pair_collision("rk4", False, "no_tension", 0.3, 16, 256).errors["restitution"] / 10
