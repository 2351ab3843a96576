"""penalty_env.physics.theory against the closed forms of docs/physics.md sections 3 and 4, and its
stability analysis against the integrators as the World actually runs them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from penalty_env.physics import Bowl, World, theory


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.1, 0.3, 0.7, 1.0, 2.0])
def test_critical_omega_dt_matches_the_closed_forms(zeta):
    sqrt = math.sqrt
    if zeta <= 1.0:
        assert theory.critical_omega_dt("explicit_euler", zeta) == pytest.approx(2 * zeta, rel=1e-12, abs=0)
    assert theory.critical_omega_dt("symplectic_euler", zeta) == pytest.approx(
        2 * (sqrt(1 + zeta**2) - zeta), rel=1e-12
    )
    assert theory.critical_omega_dt("implicit_euler", zeta) == math.inf
    if zeta == 0.0:
        assert theory.critical_omega_dt("velocity_verlet", 0.0) == pytest.approx(2.0, rel=1e-12)
        assert theory.critical_omega_dt("rk4", 0.0) == pytest.approx(2 * sqrt(2), rel=1e-12)
        assert theory.critical_omega_dt("explicit_euler", 0.0) == 0.0


def _spectral_radius(m):
    return float(np.max(np.abs(np.linalg.eigvals(m))))


def _rk4_growth(h, zeta):
    """|largest root| of RK4's stability polynomial at the oscillator's eigenvalues, a closed form
    independent of theory.amplification_matrix."""
    lam = complex(-zeta, math.sqrt(max(0.0, 1 - zeta**2))) if zeta < 1 else complex(-zeta + math.sqrt(zeta**2 - 1), 0)
    lams = [lam, lam.conjugate()] if zeta < 1 else [lam, complex(-zeta - math.sqrt(zeta**2 - 1), 0)]
    return max(abs(sum((h * lm) ** k / math.factorial(k) for k in range(5))) for lm in lams)


@pytest.mark.parametrize("zeta", [0.1, 0.3, 0.6, 1.0])
def test_damped_rk4_and_verlet_limits_sit_on_the_boundary_of_stability(zeta):
    """RK4: "about 2.6 to 2.95 for zeta 0.1 to 1"; the limit is where the stability polynomial's
    root crosses the unit circle (checked with the polynomial, not the library's matrix)."""
    h = theory.critical_omega_dt("rk4", zeta)
    assert 2.6 <= h <= 2.96
    assert _rk4_growth(0.999 * h, zeta) <= 1.0 + 1e-9
    assert _rk4_growth(1.001 * h, zeta) > 1.0
    # Verlet with its damping at the predicted velocity: below the undamped 2, falling with zeta.
    # (it is often called "similar to symplectic Euler": true for small zeta only, e.g. 0.72 vs
    # 1.13 at zeta = 0.6; test_physics_stability checks this computed limit on the World.)
    hv = theory.critical_omega_dt("velocity_verlet", zeta)
    assert hv < 2.0
    assert theory.critical_omega_dt("velocity_verlet", zeta + 0.05) < hv
    m = theory.amplification_matrix("velocity_verlet", 0.999 * hv, zeta)
    assert _spectral_radius(m) <= 1.0 + 1e-9
    assert _spectral_radius(theory.amplification_matrix("velocity_verlet", 1.001 * hv, zeta)) > 1.0


def test_explicit_euler_undamped_growth_per_step_is_one_plus_omega_dt_squared():
    for h in (0.01, 0.1, 1.0):
        m = theory.amplification_matrix("explicit_euler", h, 0.0)
        assert _spectral_radius(m) ** 2 == pytest.approx(1 + h * h, rel=1e-12)
        m = theory.amplification_matrix("implicit_euler", h, 0.0)
        assert _spectral_radius(m) == pytest.approx(1 / math.sqrt(1 + h * h), rel=1e-12)


@pytest.mark.parametrize("e", [0.01, 0.1, 0.3, 0.5, 0.8, 0.95, 0.999, 1.0])
def test_restitution_and_damping_for_restitution_round_trip(e):
    ks, m = 3.7e4, 0.35
    kd = theory.damping_for_restitution(e, ks, m)
    assert theory.restitution(ks, kd, m) == pytest.approx(e, rel=1e-12)
    # LIGGGHTS' form: gamma_n = sqrt(4 m k / (1 + (pi / ln e)^2))
    if e < 1.0:
        assert kd == pytest.approx(math.sqrt(4 * m * ks / (1 + (math.pi / math.log(e)) ** 2)), rel=1e-12)
    else:
        assert kd == 0.0
    zeta = kd / (2 * math.sqrt(ks * m))
    assert theory.damping_ratio(ks, kd, m) == pytest.approx(zeta, rel=1e-12)
    assert theory.contact_time(ks, kd, m) == pytest.approx(
        math.pi / (math.sqrt(ks / m) * math.sqrt(1 - zeta**2)), rel=1e-12
    )


def test_closed_forms_of_the_contact():
    ks, m = 1e4, 0.5
    assert theory.natural_frequency(ks, m) == pytest.approx(math.sqrt(2e4))
    assert theory.contact_time(ks, 0.0, m) == pytest.approx(math.pi * math.sqrt(m / ks))
    assert theory.restitution(ks, 0.0, m) == 1.0
    crit = 2 * math.sqrt(ks * m)  # critical damping: the contact never ends
    assert theory.restitution(ks, crit, m) == 0.0 and theory.contact_time(ks, crit, m) == math.inf
    assert theory.peak_overlap(ks, m, -3.0) == pytest.approx(3.0 / math.sqrt(ks / m))
    assert theory.resting_overlap(2.0, -9.81, ks) == pytest.approx(2.0 * 9.81 / ks)
    # stiffness for a penetration tolerance: peak overlap at that stiffness is the tolerance
    k = theory.stiffness_for_penetration(m, 2.0, 0.01)
    assert theory.peak_overlap(k, m, 2.0) == pytest.approx(0.01)
    assert theory.critical_dt("symplectic_euler", ks, 0.0, m) == pytest.approx(2.0 / math.sqrt(ks / m))
    with pytest.raises(ValueError, match="restitution"):
        theory.damping_for_restitution(0.0, ks, m)
    with pytest.raises(ValueError, match="restitution"):
        theory.damping_for_restitution(1.2, ks, m)
    with pytest.raises(ValueError, match="integrator"):
        theory.critical_omega_dt("leapfrog", 0.0)


@pytest.mark.parametrize(
    "integrator", ["explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler"]
)
@pytest.mark.parametrize("zeta", [0.0, 0.4])
def test_amplification_matrix_is_the_worlds_one_step_map_on_a_contact(integrator, zeta):
    """The stability limits come from theory.amplification_matrix; it must be the map the World
    applies. Probe: a ball on a bowl floor under gravity (linear while in contact), stepped once
    from two (three for Verlet, whose state carries the cached acceleration) independent states
    about the resting overlap, in units where omega = 1."""
    R, r, m, g, ks = 4.0, 0.25, 2.0, 9.81, 2e4
    omega = math.sqrt(ks / m)
    kd = 2 * zeta * math.sqrt(ks * m)
    h = 0.3
    rest = m * g / ks
    amp = 0.05 * rest

    def world():
        return World(
            np.array([[0.0, 0.0, r - rest]]),
            [r],
            [m],
            terrain=Bowl((0, 0, R), R),
            ks=ks,
            kd=kd,
            integrator=integrator,
            dt=h / omega,
            allow_unstable=True,
        )

    def deviation(w):
        # x = deviation of the overlap from rest (overlap = r - z), v = d(overlap)/dt / omega
        z, vz = w.positions[0, 2], w.velocities[0, 2]
        return np.array([(r - z) - rest, -vz / omega]) / amp

    def set_dev(w, x, v):
        w.set_state(
            positions=np.array([[0.0, 0.0, r - rest - x * amp]]), velocities=np.array([[0.0, 0.0, -v * omega * amp]])
        )

    expected = theory.amplification_matrix(integrator, h, zeta)
    if integrator != "velocity_verlet":
        cols = []
        for x0, v0 in ((1.0, 0.0), (0.0, 1.0)):
            w = world()
            set_dev(w, x0, v0)
            w.step(1)
            cols.append(deviation(w))
        measured = np.array(cols).T
        np.testing.assert_allclose(measured, expected, atol=1e-7)
    else:
        # state (x, v, a) with a = -x - 2 zeta v at the cached (predicted-velocity) evaluation:
        # a freshly set state has a consistent a0 = -x0 - 2 zeta v0, so compare the 3x3 map on
        # that subspace: (x1, v1, a1) = M (x0, v0, -x0 - 2 zeta v0)
        for x0, v0 in ((1.0, 0.0), (0.0, 1.0)):
            w = world()
            set_dev(w, x0, v0)
            w.step(1)
            s0 = np.array([x0, v0, -x0 - 2 * zeta * v0])
            np.testing.assert_allclose(deviation(w), (expected @ s0)[:2], atol=1e-7)
