"""Whole scenes: the course's 2D starter scene, and friction (mu > 0)."""

from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest

from penalty_env.demo import starter_scene
from penalty_env.physics import Bowl, World
from penalty_env.physics.world import EnergyDriftWarning

# --------------------------------------------------------------------------------------------
# The course's starter scene (docs/physics.md section 1)
# --------------------------------------------------------------------------------------------


def test_starter_scene_is_the_course_scene():
    w = starter_scene()
    assert (w.dim, w.n_balls, w.integrator, w.dt) == (2, 4, "symplectic_euler", 0.02)
    assert (w.ks, w.kd, w.gravity) == (200.0, 5.0, (0.0, -1.0))
    assert len(w.terrain) == 1 and isinstance(w.terrain[0], Bowl)
    assert (w.terrain[0].center, w.terrain[0].radius) == ((0.0, 8.0), 8.0)
    np.testing.assert_array_equal(w.positions, [[0, 1], [0, 2], [0.2, 2.5], [-0.2, 2.5]])
    np.testing.assert_array_equal(w.radii, [0.4, 0.2, 0.1, 0.3])
    np.testing.assert_array_equal(w.masses, 1.0)


def test_starter_scene_particles_settle_in_the_bowl_and_lose_energy():
    w = starter_scene()
    center = np.array(w.terrain[0].center)
    R = w.terrain[0].radius
    g = -w.gravity[1]
    e0 = w.energy()
    energies = [e0]
    far = 0.0
    n_steps = 3000  # 60 time units: the pendulum period of the bowl is 2 pi sqrt(R / g) = 17.8
    for _ in range(n_steps):
        w.step(1)
        energies.append(w.energy())
        far = max(far, float(np.max(np.linalg.norm(w.positions - center, axis=1))))
    energies = np.array(energies)
    # nobody leaves the bowl: every centre stays inside the bowl's sphere
    assert far < R
    assert np.all(w.positions[:, 1] < 1.0), "the particles should lie on the floor"
    # the energy never rises above its start by more than 1%, and ends well below it
    assert np.max(energies) <= e0 * 1.01
    assert energies[-1] < 0.2 * e0
    # at rest: the kinetic energy left is a vanishing fraction of the energy dissipated. (Without
    # friction a tiny sloshing of the group along the floor is damped only through the normal
    # dashpots; it is ~1e-5 of the energy lost.) The impact speed from the start is ~sqrt(2 g 2.5).
    ke = 0.5 * float(np.sum(w.masses[:, None] * w.velocities**2))
    assert ke < 1e-4 * (e0 - energies[-1])
    assert np.max(np.linalg.norm(w.velocities, axis=1)) < 0.01 * math.sqrt(2 * g * 2.5)
    # frictionless balls cannot stack on a floor this wide: all four lie on it side by side, each
    # pressing it with about its own weight (overlap m g / ks = 0.005; the neighbours' pushes and
    # the slope change that by a few percent)
    floor_overlap = np.linalg.norm(w.positions - center, axis=1) - (R - w.radii)
    np.testing.assert_allclose(floor_overlap, w.masses * g / w.ks, rtol=0.1)


# --------------------------------------------------------------------------------------------
# Friction (regularised Coulomb, |f_t| = min(kf |v_t|, mu |f_n|))
# --------------------------------------------------------------------------------------------

R_BIG, RADIUS, MASS, G, KS = 500.0, 0.2, 1.0, 9.81, 2e4


def _slider(mu, d=3, v0=1.0):
    """A ball resting on the floor of a wide bowl (R = 500), launched sideways at v0."""
    direction = np.array([0.8, 0.6, 0.0])[:d] if d == 3 else np.array([1.0, 0.0])
    x = np.zeros((1, d))
    x[0, -1] = RADIUS - MASS * G / KS
    kd = 2 * 0.5 * math.sqrt(KS * MASS)
    center = np.zeros(d)
    center[-1] = R_BIG
    w = World(
        x,
        [RADIUS],
        [MASS],
        (v0 * direction)[None],
        terrain=Bowl(tuple(center), R_BIG),
        ks=KS,
        kd=kd,
        mu=mu,
        integrator="symplectic_euler",
        dt=0.1 / math.sqrt(KS / MASS),
    )
    return w, direction


def _track(w, seconds):
    n = int(round(seconds / w.dt))
    speed, energy = [float(np.linalg.norm(w.velocities[0]))], [w.energy()]
    vel = [w.velocities[0].copy()]
    for _ in range(n):
        w.step(1)
        speed.append(float(np.linalg.norm(w.velocities[0])))
        energy.append(w.energy())
        vel.append(w.velocities[0].copy())
    return np.arange(n + 1) * w.dt, np.array(speed), np.array(energy), np.array(vel)


def test_friction_decelerates_a_sliding_ball_at_mu_g_and_stops_it():
    mu, v0 = 0.4, 1.0
    w, direction = _slider(mu)
    t_stop = v0 / (mu * G)  # Coulomb: the speed falls linearly at mu g
    t, speed, energy, vel = _track(w, 1.3 * t_stop)
    sliding = t < 0.9 * t_stop
    # Coulomb friction mu g plus the floor's slope g s / R (a pendulum of omega_p^2 = g / R):
    # s'' = -omega_p^2 s - mu g  =>  v(t) = v0 cos(omega_p t) - (mu g / omega_p) sin(omega_p t).
    # Neglected: the curvature's v^2 / R in the normal force; it shifts v by < v0^3 / (3 g R) = 7e-5 v0.
    wp = math.sqrt(G / R_BIG)
    expected = v0 * np.cos(wp * t) - (mu * G / wp) * np.sin(wp * t)
    np.testing.assert_allclose(speed[sliding], expected[sliding], rtol=0.005, atol=1e-4 * v0)
    # the tangential force opposes the sliding: the velocity keeps its direction while it slows
    moving = speed > 0.05 * v0
    horizontal = vel[moving, :-1]
    cos = horizontal @ direction[:-1] / np.linalg.norm(horizontal, axis=1)
    assert np.min(cos) > 1 - 1e-12
    # then it rests: what is left is the creep of regularised friction on the floor's slope
    # (v = m g sin(theta) / kf, ~1e-4 here), orders of magnitude below v0
    assert speed[-1] < 1e-3 * v0
    # friction never adds energy: the energy falls at every step while the ball slides
    assert np.all(np.diff(energy) <= 1e-12 * abs(energy[0]))


def test_a_frictionless_ball_keeps_sliding_where_friction_stops_it():
    v0 = 1.0
    t_stop = v0 / (0.4 * G)
    w0, _ = _slider(0.0, v0=v0)
    _, speed0, energy0, _ = _track(w0, 1.3 * t_stop)
    w1, _ = _slider(0.4, v0=v0)
    _, speed1, energy1, _ = _track(w1, 1.3 * t_stop)
    # without friction only the bowl's gentle slope slows it (a pendulum of period 45 s)
    assert speed0[-1] > 0.95 * v0
    assert speed1[-1] < 1e-3 * v0
    # friction only removes energy: at every sample the rubbing ball has no more energy than the
    # frictionless one (up to symplectic Euler's own energy ripple, bounded by the latter's spread)
    ripple = np.max(energy0) - np.min(energy0)
    assert np.all(energy1 <= energy0 + ripple)
    assert energy0[-1] - energy1[-1] == pytest.approx(0.5 * MASS * v0**2, rel=0.02)


def test_pair_friction_stops_relative_sliding_at_mu_f_over_m_eff_and_conserves_momentum():
    """Two balls pressed together by equal and opposite forces F while sliding past each other:
    the relative tangential speed falls at mu F / m_eff."""
    m = np.array([1.0, 2.0])
    r = np.array([0.3, 0.25])
    m_eff = m[0] * m[1] / m.sum()
    ks, F, mu, u = 1e4, 10.0, 0.3, 0.2
    kd = 2 * 0.7 * math.sqrt(ks * m_eff)
    n = np.array([0.6, 0.8])
    t_hat = np.array([-0.8, 0.6])
    x = np.array([[0.0, 0.0], (r.sum() - F / ks) * n])  # at the pressed equilibrium overlap
    v = np.array([-(m[1] / m.sum()) * u * t_hat, (m[0] / m.sum()) * u * t_hat])
    w = World(
        x,
        r,
        m,
        v,
        gravity=(0.0, 0.0),
        ks=ks,
        kd=kd,
        mu=mu,
        integrator="symplectic_euler",
        dt=0.05 / math.sqrt(ks / m_eff),
    )
    a = mu * F / m_eff
    t_stop = u / a
    n_steps = int(1.5 * t_stop / w.dt)
    rel = []
    for _ in range(n_steps):
        # press along the current line of centres (it turns slowly as the balls slide past)
        x = w.positions
        n_now = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
        w.step(1, forces=np.array([F * n_now, -F * n_now]))
        v_rel = w.velocities[1] - w.velocities[0]
        rel.append(np.linalg.norm(v_rel - (v_rel @ n_now) * n_now))
        np.testing.assert_allclose(w.momentum(), 0.0, atol=1e-14)
    rel = np.array(rel)
    t = np.arange(1, n_steps + 1) * w.dt
    sliding = t < 0.9 * t_stop
    # The pair turns as it slides, so the spring also supplies the centripetal m_eff u^2 / L and
    # the normal force is F - m_eff u^2 / L: du/dt = -a + k u^2 with k = mu / L, solved by
    # u(t) = c tanh(artanh(u0 / c) - c k t), c = sqrt(a / k). (Without the correction: u0 - a t.)
    L = r.sum() - F / ks
    k = mu / L
    c = math.sqrt(a / k)
    expected = c * np.tanh(math.atanh(u / c) - c * k * t)
    np.testing.assert_allclose(rel[sliding], expected[sliding], rtol=0.005, atol=1e-4 * u)
    assert abs(rel[-1]) < 1e-3 * u


@pytest.mark.parametrize(
    "integrator,zeta,omega_dt",
    [
        ("symplectic_euler", 0.0, None),
        ("velocity_verlet", 0.0, None),
        ("rk4", 0.0, None),
        ("explicit_euler", 0.5, None),
        ("symplectic_euler", 0.5, None),
        ("implicit_euler", 0.0, 3.0),
        ("implicit_euler", 0.5, 10.0),
    ],
)
def test_friction_never_adds_energy_at_any_time_step_the_world_accepts(integrator, zeta, omega_dt):
    """A ball resting on the floor of a wide bowl, nudged sideways at 1 mm/s, with mu = 0.5 and the
    default kf, at the largest dt the stability guard accepts (implicit Euler: it accepts any dt;
    we take omega dt = 3 and 10). Friction may only take energy out: the energy never rises above
    its start by more than the same run's ripple without friction (the integrator's own error),
    the sliding speed never grows, and the ball comes to rest."""
    m = MASS
    kd = 2 * zeta * math.sqrt(KS * m)
    omega = math.sqrt(KS / m)
    x = np.array([[0.0, 0.0, RADIUS - m * G / KS]])
    v = np.array([[1e-3, 0.0, 0.0]])
    runs = {}
    for mu in (0.0, 0.5):
        kw = dict(terrain=Bowl((0.0, 0.0, R_BIG), R_BIG), ks=KS, kd=kd, mu=mu, integrator=integrator)
        dt = omega_dt / omega if omega_dt else World(x, [RADIUS], [m], v, dt=1e-9, **kw).stability_limit()
        # no allow_unstable: a dt the World accepts; undamped at the stability limit, the energy
        # guard warns that collisions would gain energy (none happen here: the ball rests)
        drifts = zeta == 0.0 and integrator in ("symplectic_euler", "velocity_verlet") and not omega_dt
        with pytest.warns(EnergyDriftWarning) if drifts else contextlib.nullcontext():
            w = World(x, [RADIUS], [m], v, dt=dt, **kw)
        e0 = w.energy()
        rise, speed = [], []
        for _ in range(3000):
            w.step(1)
            rise.append(w.energy() - e0)
            speed.append(float(np.linalg.norm(w.velocities[0, :2])))
        runs[mu] = (np.array(rise), np.array(speed))
    ripple = max(0.0, float(np.max(runs[0.0][0])))
    rise, speed = runs[0.5]
    assert np.max(rise) <= ripple + 1e-12 * abs(e0), (
        f"friction added {np.max(rise):.3g} J (frictionless ripple {ripple:.3g} J); sliding speed went "
        f"from 1e-3 to max {np.max(speed):.3g} m/s"
    )
    assert np.max(speed) <= 1e-3 * (1 + 1e-6), f"friction accelerated the sliding ball to {np.max(speed):.3g} m/s"
    assert speed[-1] < 1e-5, f"the nudged ball still slides at {speed[-1]:.3g} m/s after 3000 steps"


@pytest.mark.parametrize("integrator", ["symplectic_euler", "velocity_verlet", "rk4"])
def test_pair_friction_never_accelerates_relative_sliding_at_the_largest_accepted_time_step(integrator):
    """Two unit balls pressed together (F = 10) and sliding past each other at 1 mm/s, zeta = 0.3,
    mu = 0.3, default kf, at the largest dt the stability guard accepts: the relative tangential
    speed may only fall, and the pair stops sliding."""
    m, r, ks, F, u = np.ones(2), np.array([0.3, 0.3]), 1e4, 10.0, 1e-3
    n, t_hat = np.array([0.6, 0.8]), np.array([-0.8, 0.6])
    x = np.array([[0.0, 0.0], (r.sum() - F / ks) * n])
    v = np.array([-0.5 * u * t_hat, 0.5 * u * t_hat])
    kw = dict(gravity=(0.0, 0.0), ks=ks, kd=2 * 0.3 * math.sqrt(ks * 0.5), mu=0.3, integrator=integrator)
    w = World(x, r, m, v, dt=World(x, r, m, v, dt=1e-9, **kw).stability_limit(), **kw)
    speeds = []
    for _ in range(2000):
        pos = w.positions
        n_now = (pos[1] - pos[0]) / np.linalg.norm(pos[1] - pos[0])
        w.step(1, forces=np.array([F * n_now, -F * n_now]))
        v_rel = w.velocities[1] - w.velocities[0]
        speeds.append(float(np.linalg.norm(v_rel - (v_rel @ n_now) * n_now)))
    assert max(speeds) <= u * (1 + 1e-6), f"friction drove the relative sliding up to {max(speeds):.3g} m/s"
    assert speeds[-1] < 1e-2 * u
