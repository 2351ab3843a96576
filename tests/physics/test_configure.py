"""Tolerance-driven configuration (penalty_env/physics/configure.py).

``configure`` turns masses, radii, the largest impact speed, a penetration tolerance, a target
restitution and an accuracy tolerance into ks, kd, an integrator, event location and dt, from the
error models fitted to the accuracy benchmark. Checked here on scenarios 1 to 3 of that benchmark:
the configuration meets the tolerances (worst case over 1,024 phases), and costs at most 1.5x the
cheapest configuration of the sweep (integrators x event location x 2..512 steps per contact)
that also meets them.
"""

from __future__ import annotations

import math

import pytest

from penalty_env.physics import configure as CF
from penalty_env.physics import theory
from penalty_env.scenarios import bowl_drop, pair_collision, resting

SPCS = (2, 4, 8, 16, 32, 64, 128, 256, 512)  # steps per contact of the sweep configure is compared with

PHASES = 1024


@pytest.mark.parametrize("zeta", [0.0, 0.1, 0.3, 0.7])
def test_exact_contact_matches_the_closed_forms_without_gravity(zeta):
    r = CF.contact_response(zeta)
    assert r.restitution == pytest.approx(CF.restitution_for_zeta(zeta), rel=1e-12)
    assert r.duration == pytest.approx(math.pi / math.sqrt(1 - zeta * zeta), rel=1e-12)
    ks, m = 1e4, 2.0
    kd = 2 * zeta * math.sqrt(ks * m)
    assert r.restitution == pytest.approx(theory.restitution(ks, kd, m), rel=1e-12)
    if zeta == 0.0:
        assert r.peak_overlap == pytest.approx(1.0, rel=1e-12)  # v / omega0


def test_gravity_lengthens_the_contact_and_no_tension_raises_the_restitution():
    base = CF.contact_response(0.3)
    assert CF.contact_response(0.3, gravity_ratio=0.05).duration > base.duration
    assert CF.contact_response(0.3, "no_tension").restitution > base.restitution
    assert CF.peak_overlap_ratio(0.3, 0.05) == pytest.approx(CF.contact_response(0.3, gravity_ratio=0.05).peak_overlap)
    with pytest.raises(ValueError):
        CF.contact_response(0.7, gravity_ratio=0.5)  # gravity holds the ball in contact


@pytest.mark.parametrize("damping", ["linear", "no_tension"])
@pytest.mark.parametrize("e", [0.2, 0.5, 0.9])
def test_zeta_for_restitution_inverts_the_exact_solution(damping, e):
    z = CF.zeta_for_restitution(e, damping)
    assert CF.restitution_for_zeta(z, damping) == pytest.approx(e, rel=1e-9)


def test_ks_comes_from_the_penetration_tolerance_and_kd_from_the_restitution():
    cfg = CF.configure(
        [1.0, 3.0, 2.0], [0.1, 0.15, 0.12], max_impact_speed=2.0, penetration=0.05, restitution=0.5, accuracy=0.01
    )
    m_heavy_pair = 3.0 * 2.0 / 5.0
    assert cfg.ks == pytest.approx(m_heavy_pair * 2.0**2 / (0.05 * 0.1) ** 2)
    assert cfg.ks_terrain == pytest.approx(3.0 * 2.0**2 / (0.05 * 0.1) ** 2)
    assert theory.restitution(cfg.ks, cfg.kd, m_heavy_pair) == pytest.approx(0.5, rel=1e-9)
    assert theory.restitution(cfg.ks_terrain, cfg.kd_terrain, 3.0) == pytest.approx(0.5, rel=1e-9)
    # lighter contacts are more damped: the reported range brackets the target
    assert cfg.restitution_range[0] < 0.5 <= cfg.restitution_range[1] + 1e-12
    # dt resolves the shortest contact and passes the World's stability guard
    assert cfg.dt <= cfg.contact_time / 2
    kw = cfg.world_kwargs()
    from penalty_env.physics import World

    World([[0, 0, 0.5], [0.5, 0, 0.5], [1.0, 0, 0.5]], [0.1, 0.15, 0.12], [1.0, 3.0, 2.0], **kw)


def test_ks_holds_the_penetration_tolerance_under_gravity_and_numerical_overshoot():
    # undamped: the exact peak is already at the tolerance, gravity and the method's overshoot
    # push it over, so ks must grow
    cfg = CF.configure([1.0, 1.0], [R, R], V, penetration=PEN, restitution=1.0, accuracy=0.05, gravity=9.81)
    ks0 = 0.5 * V**2 / (PEN * R) ** 2
    assert cfg.ks > ks0
    pair = pair_collision(
        cfg.integrator,
        cfg.events,
        "linear",
        None,
        None,
        256,
        masses=(1.0, 1.0),
        radii=(R, R),
        ks=cfg.ks,
        speed=V,
        kd=cfg.kd,
        dt=cfg.dt,
    )
    assert pair.extra["peak_ratio"] <= PEN


def test_a_tolerance_below_every_model_floor_is_refused_clearly():
    with pytest.raises(ValueError, match="loosen"):
        CF.configure([1.0, 1.0], [0.1, 0.1], 1.0, restitution=0.5, accuracy=1e-14)


# --- scenarios 1 to 3 with a configuration --------------------------------------------------------

R, V, PEN = 0.1, 1.0, 0.05


def _measure(integrator, events, damping, ks, kd, ks_t, kd_t, dt, phases=PHASES):
    """Worst restitution error and peak overlap / r of scenarios 1 and 2, and the resting error."""
    pair = pair_collision(
        integrator, events, damping, None, None, phases, masses=(1.0, 1.0), radii=(R, R), ks=ks, speed=V, kd=kd, dt=dt
    )
    drop = bowl_drop(
        integrator, events, damping, None, None, phases, mass=1.0, radius=R, ks=ks_t, speed=V, kd=kd_t, dt=dt
    )
    rest = resting(integrator, events, damping, None, None, 4, mass=1.0, radius=R, ks=ks_t, kd=kd_t, dt=dt)
    if pair.diverged or drop.diverged or rest.diverged:
        return math.inf, math.inf, math.inf
    e_err = max(pair.errors["restitution"], drop.errors["restitution"])
    peak = max(pair.extra["peak_ratio"], drop.extra["peak_ratio"])
    return e_err, peak, rest.errors["resting_overlap"]


def _meets(e_err, peak, rest_err, accuracy):
    return e_err <= accuracy and peak <= PEN and rest_err <= accuracy


def _check(restitution, accuracy, damping):
    cfg = CF.configure(
        [1.0, 1.0],
        [R, R],
        V,
        penetration=PEN,
        restitution=restitution,
        accuracy=accuracy,
        damping=damping,
        gravity=9.81,
    )
    e_err, peak, rest_err = _measure(
        cfg.integrator, cfg.events, damping, cfg.ks, cfg.kd, cfg.ks_terrain, cfg.kd_terrain, cfg.dt
    )
    assert _meets(e_err, peak, rest_err, accuracy), (
        cfg.integrator,
        cfg.events,
        cfg.steps_per_contact,
        e_err,
        peak,
        rest_err,
    )
    # the sweep: the cheapest configuration that meets the same tolerances (errors fall as the
    # steps per contact grow, so each method stops at its first success)
    cheapest = math.inf
    found = None
    for integ in theory.INTEGRATORS:
        if integ == "implicit_euler" and damping == "no_tension":
            continue  # World refuses it
        for ev in (False, True):
            for spc in SPCS:
                dt = cfg.contact_time / spc
                guard = min(
                    theory.guard_dt(integ, k, c, m)
                    for k, c, m in ((cfg.ks, cfg.kd, 0.5), (cfg.ks_terrain, cfg.kd_terrain, 1.0))
                )
                cost = CF.config_cost(integ, ev, spc)
                if dt > guard or cost >= cheapest:
                    continue
                if _meets(*_measure(integ, ev, damping, cfg.ks, cfg.kd, cfg.ks_terrain, cfg.kd_terrain, dt), accuracy):
                    cheapest, found = cost, (integ, ev, spc)
                    break
    assert found is not None
    assert cfg.cost_per_contact <= 1.5 * cheapest, (
        cfg.integrator,
        cfg.events,
        cfg.steps_per_contact,
        cfg.cost_per_contact,
        found,
        cheapest,
    )
    return cfg, found


@pytest.mark.slow
def test_configuration_for_one_percent_at_zeta_0_3_meets_it_at_near_least_cost():
    _check(CF.restitution_for_zeta(0.3), 1e-2, "linear")


@pytest.mark.slow
def test_configuration_for_a_tight_tolerance_picks_event_located_rk4():
    cfg, found = _check(CF.restitution_for_zeta(0.3), 1e-4, "linear")
    assert cfg.integrator == "rk4" and cfg.events


@pytest.mark.slow
@pytest.mark.parametrize(
    "restitution, accuracy, damping",
    [
        (0.9, 1e-3, "linear"),
        (0.5, 1e-3, "linear"),
        (0.5, 3e-2, "linear"),
        (0.5, 1e-2, "no_tension"),
        (0.3, 1e-3, "no_tension"),
    ],
)
def test_configuration_meets_tolerances_at_near_least_cost(restitution, accuracy, damping):
    _check(restitution, accuracy, damping)


def test_damping_beyond_the_measured_models_is_refused_not_guessed():
    # the error models stop at the largest measured zeta: a contact damped beyond it would be
    # predicted with the last model, which under-predicts (errors grow faster than linearly)
    z_max = max(float(k.split("|")[4]) for k in CF.ERROR_MODELS)
    e_edge = CF.restitution_for_zeta(z_max, "no_tension")
    CF.configure([1.0, 1.0], [0.1, 0.1], 1.0, restitution=e_edge * 1.01, accuracy=0.3, damping="no_tension")
    with pytest.raises(ValueError, match="beyond the measured error models"):
        CF.configure([1.0, 1.0], [0.1, 0.1], 1.0, restitution=e_edge * 0.97, accuracy=0.3, damping="no_tension")
    assert math.isinf(CF.predicted_error("symplectic_euler", False, "linear", z_max * 1.05, 64))
