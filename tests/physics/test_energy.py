"""Energy per collision: elastic scenes must not heat up at a step the World accepts silently.

Symplectic Euler and velocity Verlet keep an undamped contact's energy bounded, but each contact
switch leaves an error whose mean over where the contact starts within the step is positive, so
many elastic collisions heat a scene at steps the stability limit allows (docs/physics.md
section 6). ``theory.energy_gain_per_collision`` computes that mean from each method's own step;
the World warns above ``theory.ENERGY_BUDGET`` (1% per 1,000 collisions) and ``configure`` stays
within it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from penalty_env.physics import World, theory
from penalty_env.physics.configure import configure
from penalty_env.physics.world import EnergyDriftWarning
from penalty_env.scenarios import elastic_gas, wall_collision_gains

PHASES = 256


@pytest.mark.parametrize(
    "integrator, omega_dt, zeta",
    [
        ("symplectic_euler", 0.3, 0.0),
        ("symplectic_euler", 0.7, 0.0),
        ("velocity_verlet", 0.55, 0.0),
        ("rk4", 0.9, 0.0),
        ("symplectic_euler", 0.4, 0.05),
        ("implicit_euler", 2.0, 0.0),
    ],
)
def test_the_energy_model_is_the_worlds_own_collision(integrator, omega_dt, zeta):
    """The model is the implementation: the World's mean gain over the same phases agrees with it."""
    world = wall_collision_gains(integrator, omega_dt, zeta, PHASES)
    mean, spread = theory.energy_gain_per_collision(integrator, omega_dt, zeta, phases=PHASES)
    assert world.mean() == pytest.approx(mean, abs=1e-9 + 1e-6 * abs(mean))
    assert world.std() == pytest.approx(spread, rel=1e-5, abs=1e-9)


def test_symplectic_methods_gain_energy_per_elastic_collision_as_the_step_grows():
    """The heating is real and grows about as (omega0 dt)^4 under its resonance dips: +0.5% per
    collision at omega0 dt = 0.7, +1.5% at 0.9 (the figures the reliability review measured on a
    gas), against +2e-6 at 0.1. RK4 loses energy instead."""
    gain = {h: theory.energy_gain_per_collision("symplectic_euler", h)[0] for h in (0.1, 0.7, 0.9)}
    assert gain[0.7] == pytest.approx(5.2e-3, rel=0.05)
    assert gain[0.9] == pytest.approx(1.48e-2, rel=0.05)
    assert 0 < gain[0.1] < 3e-6
    assert theory.energy_gain_per_collision("rk4", 0.9)[0] < 0.0
    assert theory.energy_gain_per_collision("implicit_euler", 5.0)[0] < -0.5


def test_the_energy_limit_sits_where_the_mean_gain_reaches_the_budget():
    h = theory.energy_omega_dt("symplectic_euler", 0.0)
    assert 0.1 < h < 0.2
    for below in np.linspace(0.05, h, 40):  # no dip is relied on below the limit
        assert theory.energy_gain_per_collision("symplectic_euler", below)[0] <= theory.ENERGY_BUDGET * 1.2
    assert (
        max(theory.energy_gain_per_collision("symplectic_euler", h * f)[0] for f in (1.0, 1.03, 1.06, 1.1))
        > theory.ENERGY_BUDGET
    )
    # damping outweighs the heating: then the stability guard is the only limit
    assert theory.energy_omega_dt("symplectic_euler", 0.05) == theory.guard_omega_dt("symplectic_euler", 0.05)
    assert theory.energy_omega_dt("implicit_euler", 0.0) == math.inf


def test_the_world_warns_with_the_figures_where_an_elastic_scene_would_heat():
    x, v, r, kw = elastic_gas(2, 4)
    probe = World(x, np.full(4, r), np.ones(4), v, dt=1.0, allow_unstable=True, **kw)
    with pytest.warns(EnergyDriftWarning, match=r"can gain up to .* of its energy per collision .*budget.*substeps"):
        World(x, np.full(4, r), np.ones(4), v, dt=probe.stability_limit(), **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        World(x, np.full(4, r), np.ones(4), v, dt=probe.energy_limit(), **kw)
        damped = dict(kw, kd=20.0)  # zeta = 0.14: the dashpot outweighs the heating at every stable step
        limit = World(x, np.full(4, r), np.ones(4), v, dt=1.0, allow_unstable=True, **damped).stability_limit()
        World(x, np.full(4, r), np.ones(4), v, dt=limit, **damped)


def test_a_dense_elastic_gas_at_the_largest_step_accepted_keeps_its_energy_within_the_budget():
    """192 worlds of 8 elastic balls in a spherical cage, no gravity, 20,000 steps at the largest dt
    the World accepts without a warning. Before the energy budget the guard allowed omega dt = 1 for
    the pairs: median energy 2.3x the start, 7% of the worlds above 10x. Now the mean relative drift
    over the worlds (the systematic part: each collision also adds a random error of either sign,
    which averages out) stays within the budget for the collisions counted."""
    x, v, r, kw = elastic_gas()
    B, n = x.shape[:2]
    probe = World(x, np.full(n, r), np.ones(n), v, dt=1.0, allow_unstable=True, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyDriftWarning)
        w = World(x, np.full(n, r), np.ones(n), v, dt=probe.energy_limit(), **kw)
    e0 = w.energy()
    iu, ju = np.triu_indices(n, 1)
    touching = np.zeros((B, iu.size + n), dtype=bool)
    collisions = np.zeros(B)
    every = 4  # a contact lasts about pi / (omega dt) = 20 steps or more here: none is missed between samples
    for _ in range(20_000 // every):
        w.step(every)
        p = w.positions
        now = np.concatenate(
            [
                np.linalg.norm(p[:, iu] - p[:, ju], axis=-1) < 2 * r,  # pairs
                np.linalg.norm(p, axis=-1) > 1.0 - r,
            ],
            axis=1,
        )  # the cage's wall
        collisions += np.sum(now & ~touching, axis=1)
        touching = now
    drift = w.energy() / e0 - 1.0
    assert collisions.mean() > 100, "the gas must collide"
    budget = theory.ENERGY_BUDGET * collisions.mean()
    stderr = drift.std() / math.sqrt(B)
    assert drift.mean() <= budget + 3.0 * stderr, (drift.mean(), budget, stderr)
    assert np.median(drift) < 0.05 and drift.max() < 1.0  # no world runs away


def test_configure_keeps_a_nearly_elastic_contact_within_the_budget():
    cfg = configure(
        [1.0, 1.0], [0.1, 0.1], 1.0, penetration=0.05, restitution=1.0, accuracy=0.1, integrators=("symplectic_euler",)
    )
    omega_dt = math.sqrt(cfg.ks / 0.5) * cfg.dt
    assert omega_dt <= theory.energy_omega_dt("symplectic_euler", 0.0) * (1 + 1e-9)
    loose = configure(
        [1.0, 1.0],
        [0.1, 0.1],
        1.0,
        penetration=0.05,
        restitution=1.0,
        accuracy=0.1,
        integrators=("symplectic_euler",),
        energy_budget=None,
    )
    assert loose.dt > cfg.dt  # the budget is what set the step
