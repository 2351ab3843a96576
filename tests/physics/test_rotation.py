"""Rotation, the tangential models and rolling resistance against closed forms (docs/physics.md,
"Rotation"). Rigid-body results for a solid sphere (I = 2/5 m r^2, c = 2/5) and a disk (c = 1/2):

* sliding without spin on a plane at v0: slides for t = v0 / (mu g (1 + 1/c)) (2 v0 / (7 mu g);
  v0 / (3 mu g) for a disk), then rolls at v0 / (1 + c) (5/7 v0; 2/3 v0);
* on an incline of angle theta, from rest: rolls at a = g sin(theta) / (1 + c) while
  tan(theta) <= mu (1 + 1/c) (7/2 mu); beyond, slides at a = g (sin(theta) - mu cos(theta)) with
  the spin growing at mu g cos(theta) / (c r);
* an oblique impact without spin (Chung and Ooi's rigid-body regimes, 2011): sliding throughout
  while v_t / v_n >= (1 + 1/c) mu (1 + e), leaving with v_t - mu (1 + e) v_n and spin
  mu (1 + e) v_n / (c r); otherwise leaving rolling at v_t / (1 + c);
* rolling resistance M = mu_r r |f_n| decelerates a rolling ball at mu_r g / (1 + c).

Where a contact starts inside a step, the worst case over four phases of the step is checked.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from penalty_env.physics import Bowl, Plane, World, theory

G = 9.81
R_BALL = 0.1
KS = 1e6
C = {3: 0.4, 2: 0.5}  # I / (m r^2)


def _ground(d: int) -> Plane:
    return Plane(np.zeros(d), np.eye(d)[-1])


def _on_plane(d: int, velocity=None, gravity=None, **kw) -> World:
    """One ball of radius 0.1 and mass 1 resting on the plane z = 0 (at its resting overlap)."""
    g = np.zeros(d)
    g[-1] = -G
    if gravity is not None:
        g = np.asarray(gravity, dtype=float)
    x = np.zeros((1, d))
    x[0, -1] = R_BALL + g[-1] / KS  # resting overlap m |g_n| / ks
    v = np.zeros((1, d)) if velocity is None else np.asarray(velocity, dtype=float)[None]
    kw.setdefault("kd", 200.0)
    kw.setdefault("dt", 1e-4)
    return World(x, [R_BALL], [1.0], v, terrain=_ground(d), gravity=g, ks=KS, **kw)


def _slip(w: World) -> float:
    """Speed of the ball's contact point on the plane (lever r less half the resting overlap)."""
    d = w.dim
    v = w.velocities[0]
    om = w.angular_velocities[0]
    lever = R_BALL - 0.5 * G / KS
    if d == 3:
        surface = v + np.cross(om, [0.0, 0.0, -lever])
    else:
        surface = v + om[0] * np.array([lever, 0.0])
    return float(np.hypot(*surface[:-1]) if d == 3 else abs(surface[0]))


# --------------------------------------------------------------------------------------------
# Sliding to rolling
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("d", [pytest.param(3, marks=pytest.mark.slow), 2])
def test_a_sliding_ball_ends_rolling_at_the_closed_form_speed_and_time(d):
    mu, v0 = 0.3, 2.0
    c = C[d]
    v = np.zeros(d)
    v[0] = v0
    w = _on_plane(d, velocity=v, mu=mu, rotation=True)
    t_roll = v0 / (mu * G * (1.0 + 1.0 / c))
    steps = int(1.5 * t_roll / w.dt)
    rolled_at = None
    for k in range(steps):
        w.step()
        if rolled_at is None and _slip(w) < 1e-6 * v0:
            rolled_at = (k + 1) * w.dt
    assert rolled_at is not None
    # the slip decays at the cap until the last step; the regularised tail is one or two steps
    assert rolled_at == pytest.approx(t_roll, rel=0.01)
    assert w.velocities[0, 0] == pytest.approx(v0 / (1.0 + c), rel=0.01)
    # and it goes on rolling: the contact point at rest, r w = v
    spin = w.angular_velocities[0, 1] if d == 3 else -w.angular_velocities[0, 0]
    assert spin * R_BALL == pytest.approx(w.velocities[0, 0], rel=1e-3)


def test_a_sliding_ball_on_the_bowl_floor_ends_rolling_at_five_sevenths():
    """The bowl's floor (radius 200 m: over the 0.2 m slid, the climb changes v by < 0.1%)."""
    mu, v0, R = 0.3, 2.0, 200.0
    x = np.array([[0.0, 0.0, R_BALL - G / KS]])
    w = World(
        x,
        [R_BALL],
        [1.0],
        [[v0, 0.0, 0.0]],
        terrain=Bowl((0.0, 0.0, R), R),
        ks=KS,
        kd=200.0,
        mu=mu,
        dt=1e-4,
        rotation=True,
    )
    w.step(int(1.2 * 2.0 * v0 / (7.0 * mu * G) / w.dt))
    assert w.velocities[0, 0] == pytest.approx(5.0 / 7.0 * v0, rel=0.01)
    assert w.angular_velocities[0, 1] * R_BALL == pytest.approx(w.velocities[0, 0], rel=1e-3)


# --------------------------------------------------------------------------------------------
# Incline
# --------------------------------------------------------------------------------------------


def _incline_acceleration(d: int, theta: float, mu: float, **kw):
    g = np.zeros(d)
    g[0] = G * math.sin(theta)
    g[-1] = -G * math.cos(theta)
    w = _on_plane(d, gravity=g, mu=mu, rotation=True, **kw)
    w.step(500)  # the normal contact's start-up oscillation dies (zeta ~ 0.1, 100 steps a period)
    v1, w1 = w.velocities[0, 0], w.angular_velocities[0].copy()
    n = 2000
    w.step(n)
    T = n * w.dt
    return (w.velocities[0, 0] - v1) / T, (w.angular_velocities[0] - w1) / T


@pytest.mark.parametrize("d", [3, 2])
def test_on_an_incline_below_the_rolling_limit_the_ball_rolls_at_g_sin_over_one_plus_c(d):
    theta, mu = math.radians(30.0), 0.3  # tan 30 = 0.58 < mu (1 + 1/c): 1.05 (3D), 0.9 (2D)
    a, _ = _incline_acceleration(d, theta, mu)
    assert a == pytest.approx(G * math.sin(theta) / (1.0 + C[d]), rel=0.01)


@pytest.mark.parametrize("d", [3, 2])
def test_on_an_incline_beyond_the_rolling_limit_the_ball_slides_and_spins_up_at_the_friction_rate(d):
    theta, mu = math.radians(30.0), 0.1  # tan 30 > 0.35 (3D), 0.3 (2D)
    a, alpha = _incline_acceleration(d, theta, mu)
    assert a == pytest.approx(G * (math.sin(theta) - mu * math.cos(theta)), rel=0.01)
    spin = alpha[1] if d == 3 else -alpha[0]
    assert spin == pytest.approx(mu * G * math.cos(theta) / (C[d] * R_BALL), rel=0.01)


# --------------------------------------------------------------------------------------------
# Oblique impact (no gravity): the two rigid-body regimes, worst case over the step phase
# --------------------------------------------------------------------------------------------


def _impact(vt: float, vn: float, mu: float, phase: float):
    dt = 1e-5
    gap = vn * dt * (20 + phase)  # the contact starts at this fraction of a step
    w = World(
        [[0.0, 0.0, R_BALL + gap]],
        [R_BALL],
        [1.0],
        [[vt, 0.0, -vn]],
        terrain=_ground(3),
        gravity=(0.0, 0.0, 0.0),
        ks=KS,
        kd=300.0,
        damping="no_tension",
        mu=mu,
        dt=dt,
        rotation=True,
    )
    w.step(int((gap / vn + 3.0 * math.pi * math.sqrt(1.0 / KS)) / dt))
    assert w.max_penetration() == 0.0  # it has left
    e = w.velocities[0, 2] / vn
    return e, w.velocities[0, 0], w.angular_velocities[0, 1]


@pytest.mark.parametrize("phase", [0.0, 0.25, 0.5, 0.75])
def test_an_oblique_impact_slides_throughout_above_the_regime_limit(phase):
    mu, vn, vt = 0.3, 1.0, 3.0
    e, vt_out, spin = _impact(vt, vn, mu, phase)
    assert vt / vn > 3.5 * mu * (1.0 + e)  # the sliding regime
    assert vt_out == pytest.approx(vt - mu * (1.0 + e) * vn, rel=1e-9)  # an impulse, exact while sliding
    # the lever is r less half the overlap (at most 1% of r here): within 1%
    assert spin == pytest.approx(mu * (1.0 + e) * vn / (0.4 * R_BALL), rel=0.01)
    assert spin * R_BALL < vt_out  # still slipping as it leaves


@pytest.mark.parametrize("phase", [0.0, 0.25, 0.5, 0.75])
def test_an_oblique_impact_below_the_regime_limit_leaves_rolling_at_five_sevenths(phase):
    mu, vn, vt = 0.3, 1.0, 0.5
    e, vt_out, spin = _impact(vt, vn, mu, phase)
    assert vt / vn < 3.5 * mu * (1.0 + e)
    assert vt_out == pytest.approx(5.0 / 7.0 * vt, rel=0.01)
    assert spin * R_BALL == pytest.approx(vt_out, rel=0.01)


# --------------------------------------------------------------------------------------------
# Conservation and dissipation
# --------------------------------------------------------------------------------------------


def _cluster(d: int, seed: int = 0, n: int = 8):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-0.25, 0.25, (n, d))
    x *= 1.0 + 2.2 * R_BALL / np.linalg.norm(x, axis=1, keepdims=True)  # spread out, no overlap
    v = -0.5 * x + rng.normal(0.0, 0.2, (n, d))  # converging
    om = rng.normal(0.0, 5.0, (n, 3 if d == 3 else 1))
    masses = rng.uniform(0.5, 2.0, n)
    return x, v, om, masses


@pytest.mark.parametrize("d", [3, 2])
@pytest.mark.parametrize("tangential", ["coulomb", "history"])
def test_a_pair_only_scene_conserves_total_angular_momentum_to_round_off(d, tangential):
    """Pairs only, no gravity: each contact's forces and torques have zero net moment (lever arms
    to the middle of the overlap), and symplectic Euler keeps sum m x cross v + I w exactly."""
    x, v, om, masses = _cluster(d)
    w = World(
        x,
        np.full(len(x), R_BALL),
        masses,
        v,
        gravity=np.zeros(d),
        ks=1e4,
        kd=5.0,
        mu=0.5,
        mu_r=0.05,
        rotation=True,
        tangential=tangential,
        dt=2e-4,
        start_check=False,  # (a cluster: its balls start in contact, some deep, on purpose)
    )
    w.set_state(angular_velocities=om)
    L0 = w.angular_momentum()
    touched = 0.0
    for _ in range(40):
        w.step(50)
        touched = max(touched, w.max_penetration())
        r, p = w.positions, w.velocities * masses[:, None]
        moment = r[..., 0] * p[..., 1] - r[..., 1] * p[..., 0] if r.shape[-1] == 2 else np.cross(r, p)
        scale = float(np.abs(moment).sum() + np.abs(om).sum())
        assert np.abs(w.angular_momentum() - L0).max() <= 1e-12 * scale
    assert touched > 0.0  # they did collide
    assert np.abs(w.angular_velocities - om).max() > 0.1  # and the contacts turned them


@pytest.mark.parametrize("tangential", ["coulomb", "history"])
def test_a_frictional_rotating_scene_never_gains_energy_between_contacts(tangential):
    """Balls in a closed spherical shell (a Bowl) without gravity: between contacts nothing acts, so
    the total energy (translational, rotational, and the springs') sampled when no contact is
    active must never rise (it may fall: damping, friction, rolling resistance)."""
    x, v, om, masses = _cluster(3, seed=1)
    w = World(
        x,
        np.full(len(x), R_BALL),
        masses,
        4.0 * v,
        terrain=Bowl((0.0, 0.0, 0.0), 0.6),
        gravity=(0.0, 0.0, 0.0),
        ks=1e4,
        kd=5.0,
        mu=0.5,
        mu_r=0.02,
        rotation=True,
        tangential=tangential,
        dt=2e-4,
    )
    w.set_state(angular_velocities=om)
    free = [w.energy()]
    contacts = 0
    for _ in range(3000):
        w.step()
        if w.max_penetration() == 0.0:
            free.append(w.energy())
        else:
            contacts += 1
    assert contacts > 100 and len(free) > 100
    rises = np.diff(free)
    assert rises.max() <= 1e-12 * free[0]
    assert free[-1] < 0.9 * free[0]  # friction took its share


# --------------------------------------------------------------------------------------------
# The history model sticks where regularised friction creeps; rolling resistance
# --------------------------------------------------------------------------------------------


def test_below_the_friction_angle_the_history_spring_holds_where_regularised_friction_creeps():
    """A sliding (non-spinning) ball on an incline of 20 degrees, mu = 1 > tan 20 (and above the
    start-up swing's peak, about 1.8 x the load, so it never slips): the spring stretches to
    m g sin / kt and holds; regularised friction is a dashpot below the cap, so the ball creeps at
    m g sin / kf."""
    theta, mu = math.radians(20.0), 1.0
    g = (G * math.sin(theta), 0.0, -G * math.cos(theta))
    held = _on_plane(3, gravity=g, mu=mu, tangential="history")
    held.step(2000)  # the spring's start-up swing (damped by kd_t = kd / 2) dies
    x1 = held.positions[0, 0]
    held.step(10000)
    elastic = G * math.sin(theta) / held.kt
    assert held.positions[0, 0] == pytest.approx(elastic, rel=0.01)  # the spring's stretch, no more
    assert abs(held.positions[0, 0] - x1) <= 1e-3 * elastic  # and it stays put
    creeping = _on_plane(3, gravity=g, mu=mu)
    creeping.step(2000)
    assert creeping.velocities[0, 0] == pytest.approx(G * math.sin(theta) / creeping.kf, rel=0.01)


@pytest.mark.parametrize("d", [3, 2])
def test_rolling_resistance_decelerates_a_rolling_ball_at_mu_r_g_over_one_plus_c(d):
    mu_r, v0 = 0.05, 1.0
    v = np.zeros(d)
    v[0] = v0
    w = _on_plane(d, velocity=v, mu=0.5, rotation=True, mu_r=mu_r)
    spin = np.array([0.0, v0 / R_BALL, 0.0]) if d == 3 else np.array([-v0 / R_BALL])
    w.set_state(angular_velocities=spin[None])
    w.step(500)
    v1 = w.velocities[0, 0]
    w.step(5000)
    a = (w.velocities[0, 0] - v1) / (5000 * w.dt)
    assert a == pytest.approx(-mu_r * G / (1.0 + C[d]), rel=0.01)


# --------------------------------------------------------------------------------------------
# Off costs nothing; batching; every path and integrator
# --------------------------------------------------------------------------------------------


def _pile(d: int, B: int = 1, n: int = 10):
    rng = np.random.default_rng(3)
    side = 4
    g = np.stack(np.meshgrid(*[np.arange(side)] * d, indexing="ij"), -1).reshape(-1, d)[:n] * 0.21
    g = g - g.mean(0)
    g[:, -1] += 0.5
    x = g[None] + rng.uniform(-0.01, 0.01, (B, n, d))
    return x, Bowl((0.0,) * (d - 1) + (2.0,), 2.0)


@pytest.mark.parametrize(
    "integrator,d",
    [
        ("symplectic_euler", 3),
        # each integrator compiles its own step (10 to 35 s cold); the rolling test below runs
        # velocity Verlet and RK4 with friction in the default run
        pytest.param("velocity_verlet", 3, marks=pytest.mark.slow),
        pytest.param("rk4", 3, marks=pytest.mark.slow),
        pytest.param("implicit_euler", 3, marks=pytest.mark.slow),
        ("symplectic_euler", 2),
    ],
)
def test_rotation_without_friction_is_the_sliding_step_bit_for_bit(integrator, d):
    """mu = 0: no tangential force, no torque: the rotating law's normal part is the reference
    law's arithmetic, so the trajectories are identical (this pins the twin)."""
    x, bowl = _pile(d)
    kw = dict(terrain=bowl, ks=2e4, kd=20.0, dt=5e-4, integrator=integrator)
    a = World(x[0], np.full(10, R_BALL), np.ones(10), **kw)
    b = World(x[0], np.full(10, R_BALL), np.ones(10), rotation=True, **kw)
    a.step(400)
    b.step(400)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)
    assert not b.angular_velocities.any()


@pytest.mark.parametrize(
    "broadphase", ["all_pairs", pytest.param("grid", marks=pytest.mark.slow)]
)  # grid: 45 s to compile
def test_rotating_worlds_batched_equal_alone_with_history(broadphase):
    x, bowl = _pile(3, B=3)
    kw = dict(terrain=bowl, ks=2e4, kd=20.0, dt=5e-4, mu=0.4, mu_r=0.02, rotation=True, tangential="history")
    batch = World(x, np.full(10, R_BALL), np.ones(10), broadphase=broadphase, **kw)
    batch.step(600)
    for b in range(3):
        alone = World(x[b], np.full(10, R_BALL), np.ones(10), broadphase=broadphase, **kw)
        alone.step(600)
        assert np.array_equal(alone.positions, batch.positions[b])
        assert np.array_equal(alone.angular_velocities, batch.angular_velocities[b])


@pytest.mark.parametrize(
    "integrator",
    ["explicit_euler", "velocity_verlet", "rk4", pytest.param("implicit_euler", marks=pytest.mark.slow)],
)
def test_every_integrator_rolls_a_sliding_ball_at_five_sevenths(integrator):
    mu, v0 = 0.3, 2.0
    kw = {"dt": 2e-5} if integrator == "explicit_euler" else {}
    w = _on_plane(3, velocity=[v0, 0.0, 0.0], mu=mu, rotation=True, integrator=integrator, **kw)
    w.step(int(1.3 * 2.0 * v0 / (7.0 * mu * G) / w.dt))
    assert w.velocities[0, 0] == pytest.approx(5.0 / 7.0 * v0, rel=0.01)
    assert w.angular_velocities[0, 1] * R_BALL == pytest.approx(w.velocities[0, 0], rel=2e-3)


# --------------------------------------------------------------------------------------------
# Refusals
# --------------------------------------------------------------------------------------------


def test_rotation_refuses_what_it_does_not_support_with_the_argument_named():
    x = [[0.0, 0.0, 0.1]]
    base = dict(terrain=_ground(3), ks=1e4, kd=10.0, dt=1e-4)
    with pytest.raises(ValueError, match="stepping='lanes'.*rotation"):
        World(x, [0.1], [1.0], rotation=True, stepping="lanes", **base)
    with pytest.raises(ValueError, match="events=True.*rotation"):
        World(x, [0.1], [1.0], rotation=True, events=True, **base)
    with pytest.raises(ValueError, match="tangential='history'.*symplectic_euler or explicit_euler.*rk4"):
        World(x, [0.1], [1.0], rotation=True, tangential="history", mu=0.5, integrator="rk4", **base)
    with pytest.raises(ValueError, match="mu_r=0.1 needs rotation=True"):
        World(x, [0.1], [1.0], mu_r=0.1, **base)
    with pytest.raises(ValueError, match="tangential must be one of"):
        World(x, [0.1], [1.0], rotation=True, tangential="spring", **base)
    with pytest.raises(ValueError, match="kr=.*above the explicit rolling-resistance limit"):
        World(x, [0.1], [1.0], rotation=True, mu=0.5, mu_r=0.1, kr=1e3, **base)  # I / dt = 40
    with pytest.raises(ValueError, match="kf=.*tangential m_eff"):
        World(x, [0.1], [1.0], rotation=True, mu=0.5, kf=1e4, **base)  # m/dt is above 2/7 m/dt
    w = World(x, [0.1], [1.0], **base)
    with pytest.raises(ValueError, match="angular_velocities.*rotation=False"):
        w.set_state(angular_velocities=[[1.0, 0.0, 0.0]])
    r = World(x, [0.1], [1.0], rotation=True, **base)
    with pytest.raises(ValueError, match=r"angular_velocities must have shape \(1, 3\)"):
        r.set_state(angular_velocities=[[1.0, 0.0]])


def test_the_guard_holds_the_tangential_spring_to_the_normal_springs_limit():
    """kt acts on the tangential effective mass (2/7 m with rotation): a kt that makes the
    tangential mode the stiffest sets the stability limit, and a dt above it is refused."""
    base = dict(terrain=_ground(3), ks=1e4, kd=10.0, mu=0.5, rotation=True, tangential="history")
    w = World([[0.0, 0.0, 0.1]], [0.1], [1.0], kt=1e4, dt=1e-4, **base)
    stiff = World([[0.0, 0.0, 0.1]], [0.1], [1.0], kt=1e5, dt=1e-5, **base)
    assert stiff.stability_limit() < w.stability_limit()
    # the tangential mode (kt, kd_t = kd / 2 on the tangential effective mass 2/7 m) sets it
    assert stiff.stability_limit() == theory.guard_dt("symplectic_euler", 1e5, 5.0, 2.0 / 7.0)
    with pytest.raises(ValueError, match=r"tangential spring contact \(kt=100000, kd_t=5"):
        World([[0.0, 0.0, 0.1]], [0.1], [1.0], kt=1e5, dt=2.0 * stiff.stability_limit(), **base)
