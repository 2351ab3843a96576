"""Stability where the methods fail (docs/physics.md section 4).

The probe is a ball on the floor of a bowl under gravity, displaced from its resting overlap
m g / ks by 5% and released: while it stays in contact it is a linear oscillator of frequency
omega = sqrt(ks / m), and its oscillation energy (World energy minus the resting energy) is exactly
1/2 m v^2 + 1/2 ks (delta - m g / ks)^2. In units where omega = 1 and the energy is x^2 + v^2, the
closed forms used below are (h = omega dt, starting from rest at displacement x0, E0 = x0^2):

* symplectic Euler conserves x^2 - h x v + v^2, so E stays <= E0 / (1 - h/2) (= 20 E0 at h = 1.9);
* velocity Verlet conserves (1 - h^2/4) x^2 + v^2, so E stays <= E0;
* RK4's step is R(i h) = 1 - h^2/2 + h^4/24 + i (h - h^3/6) times a normal matrix: each step
  multiplies E by |R(i h)|^2 exactly;
* explicit Euler multiplies E by exactly 1 + h^2 per step (undamped);
* linearised backward Euler multiplies E by exactly 1 / (1 + h^2) per step (undamped).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from penalty_env.physics import theory

N_STEPS = 20_000


def _run(osc, n_steps=N_STEPS):
    """Oscillation energy after every step (relative to the start), and whether it blew up."""
    e0 = osc.oscillation_energy()
    energies = np.empty(n_steps)
    with np.errstate(over="ignore", invalid="ignore"):  # a diverging run overflows before it raises
        for k in range(n_steps):
            try:
                osc.world.step(1)
            except FloatingPointError:
                return energies[:k] / e0, True
            energies[k] = osc.oscillation_energy()
        return energies / e0, False


# the largest E / E0 a stable undamped run can reach from rest, by integrator (closed forms above)
def _stable_energy_bound(integrator, h):
    if integrator == "symplectic_euler":
        return 1.0 / (1.0 - h / 2.0)
    return 1.0


UNDAMPED_LIMITS = [
    ("symplectic_euler", 2.0),
    ("velocity_verlet", 2.0),
    ("rk4", 2.0 * math.sqrt(2.0)),
]


@pytest.mark.parametrize("integrator,limit", UNDAMPED_LIMITS)
def test_undamped_contact_oscillation_stays_bounded_at_095_of_the_stability_limit(oscillator, integrator, limit):
    assert theory.critical_omega_dt(integrator, 0.0) == pytest.approx(limit, rel=1e-12)
    h = 0.95 * limit
    osc = oscillator(integrator, h)
    E, diverged = _run(osc)
    assert not diverged
    bound = _stable_energy_bound(integrator, h)
    assert np.max(E) <= bound * (1 + 1e-6), f"max E/E0 = {np.max(E):.6g} > closed-form bound {bound:.6g}"
    # the ball never left the floor: the amplitude stayed below the resting overlap
    assert 0.0 < osc.overlap() < 2 * osc.rest_overlap
    if integrator == "rk4":
        rk = complex(1 - h**2 / 2 + h**4 / 24, h - h**3 / 6)
        ratios = E[1:8] / E[:7]
        np.testing.assert_allclose(ratios, abs(rk) ** 2, rtol=1e-6)  # energy "slowly lost": 49% a step here
        assert np.all(np.diff(E[E > 1e-8]) <= 0.0)
    else:
        # symplectic: the oscillation neither grows nor decays over 20,000 steps
        tenth = N_STEPS // 10
        assert np.max(E[-tenth:]) >= 0.9 * bound, f"late max E/E0 {np.max(E[-tenth:]):.4g}, bound {bound:.4g}"


@pytest.mark.parametrize("integrator,limit", UNDAMPED_LIMITS)
def test_undamped_contact_oscillation_blows_up_at_105_of_the_stability_limit(oscillator, integrator, limit):
    h = 1.05 * limit
    osc = oscillator(integrator, h)
    E, diverged = _run(osc)
    # an order of magnitude above anything a stable run (h < limit) can reach: 20 E0 for
    # symplectic Euler (its bound tends to 1/(1 - limit/2) -> inf only at the limit itself; we use
    # the bound at 0.95 x), E0 for Verlet and RK4
    stable_max = _stable_energy_bound(integrator, 0.95 * limit)
    assert diverged or np.max(E) >= 10 * stable_max, f"max E/E0 = {np.max(E):.4g}, no divergence"


def test_explicit_euler_gains_energy_at_any_dt_when_undamped(oscillator):
    """Even at omega dt = 0.01, the undamped contact's energy grows by exactly 1 + h^2 a step."""
    h = 0.01
    osc = oscillator("explicit_euler", h)
    E, diverged = _run(osc)
    assert not diverged
    n = np.arange(1, N_STEPS + 1)
    np.testing.assert_allclose(E, (1 + h * h) ** n, rtol=1e-6)
    assert E[-1] > 7.0  # (1.0001)^20000 = e^2


@pytest.mark.parametrize(
    "integrator,zeta",
    [
        ("explicit_euler", 0.3),
        ("explicit_euler", 0.6),
        ("symplectic_euler", 0.3),
        ("symplectic_euler", 1.0),
        ("velocity_verlet", 0.6),
        ("rk4", 0.3),
    ],
)
def test_damped_contact_is_stable_just_below_and_unstable_just_above_the_limit(oscillator, integrator, zeta):
    """Explicit Euler: omega dt <= 2 zeta; symplectic Euler: omega dt < 2 (sqrt(1 + zeta^2) - zeta).
    Damped Verlet and RK4 have no simple closed form: their limit is theory's (the spectral radius
    of the step map, which test_physics_theory checks against the World's step)."""
    if integrator == "explicit_euler":
        closed = 2 * zeta
    elif integrator == "symplectic_euler":
        closed = 2 * (math.sqrt(1 + zeta**2) - zeta)
    else:
        closed = theory.critical_omega_dt(integrator, zeta)
    assert theory.critical_omega_dt(integrator, zeta) == pytest.approx(closed, rel=1e-12)
    below, below_div = _run(oscillator(integrator, 0.95 * closed, zeta=zeta))
    above, above_div = _run(oscillator(integrator, 1.05 * closed, zeta=zeta))
    assert not below_div
    assert np.max(below[-N_STEPS // 10 :]) < 1e-6, "below the limit the damped oscillation must die out"
    assert np.max(below) < 10.0
    assert above_div or np.max(above) >= 10.0, f"max E/E0 above the limit: {np.max(above):.4g}"


def test_implicit_euler_stays_bounded_at_omega_dt_100(oscillator):
    h = 100.0
    osc = oscillator("implicit_euler", h, allow_unstable=False)  # no guard for an implicit method
    assert osc.world.stability_limit() == math.inf
    E, diverged = _run(osc)
    assert not diverged
    assert E[0] == pytest.approx(1.0 / (1.0 + h * h), rel=1e-4)
    assert np.max(E) <= 1.0 / (1.0 + h * h) * (1 + 1e-4)
    assert osc.overlap() == pytest.approx(osc.rest_overlap, rel=1e-6)


def _caged_ball(dt_factor, zeta=0.215, steps=600):
    """One ball (m = 1) pressed by 12 face-centred cubic neighbours 1e8 times heavier (they stay put):
    sum_j ks n_j n_j^T = 4 ks, so the ball is a linear oscillator at 2 omega with twice the damping
    ratio, the fastest mode of a dense pile. Returns its displacement amplitude over the last 100
    steps relative to the initial 1e-5 (inf if it blew up)."""
    from penalty_env.physics import World

    ks, r = 1e4, 0.5
    m_eff = 1e8 / (1.0 + 1e8)
    kd = 2 * zeta * math.sqrt(ks * m_eff)
    d = 0.999 * 2 * r  # every contact pressed by 0.1% (stays in contact throughout)
    dirs = np.array([p for p in __import__("itertools").product((-1, 0, 1), repeat=3) if sum(map(abs, p)) == 2], float)
    x = np.vstack([np.zeros(3), d * dirs / math.sqrt(2)])
    x[0] = 1e-5 * np.array([0.8, 0.5, 0.33]) / np.linalg.norm([0.8, 0.5, 0.33])
    limit = theory.guard_dt("symplectic_euler", ks, kd, m_eff)
    w = World(
        x,
        np.full(13, r),
        np.r_[1.0, np.full(12, 1e8)],
        gravity=(0.0, 0.0, 0.0),
        ks=ks,
        kd=kd,
        dt=dt_factor(limit, theory.critical_dt("symplectic_euler", ks, kd, m_eff)),
        allow_unstable=True,
    )
    amp = []
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(steps):
            try:
                w.step(1)
            except FloatingPointError:
                return math.inf
            if k >= steps - 100:
                amp.append(np.linalg.norm(w.positions[0]))
    return max(amp) / 1e-5


def test_the_guard_keeps_a_dense_pile_mode_stable_where_half_the_critical_dt_did_not():
    """The guard's dense-pile bound, exactly: the caged ball's mode (2 omega, 2 zeta) decays at 0.95x
    the guard's dt, grows at 1.05x, and grows at the old limit of half the critical dt."""
    assert _caged_ball(lambda guard, crit: 0.95 * guard) < 0.5
    assert _caged_ball(lambda guard, crit: 1.05 * guard) > 10.0
    assert theory.guard_dt("symplectic_euler", 1e4, 43.0, 1.0) < 0.45 * theory.critical_dt(
        "symplectic_euler", 1e4, 43.0, 1.0
    )
    assert _caged_ball(lambda guard, crit: 0.5 * crit) > 10.0
