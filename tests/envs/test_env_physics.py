"""The environment's contact model comes from ``physics.configure`` and keeps its tolerances.

The scene declares what it needs (a penetration tolerance at the motor's top speed, a target
restitution, and how accurately that restitution must come out); configure's measured error models
pick the substep. Checked here against the closed-form contact (worst case over where the contact
starts within the substep grid), with the env's own ks, kd and dt.
"""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from penalty_env.envs.balls.scene import PARAMETERS, PenaltyBallsScene
from penalty_env.physics import configure as CF
from penalty_env.physics import theory
from penalty_env.physics.world import EnergyDriftWarning
from penalty_env.scenarios import pair_collision


@pytest.mark.parametrize("accuracy", [0.3, 0.1])
def test_pusher_ball_impact_meets_the_restitution_accuracy_and_penetration(accuracy):
    scene = PenaltyBallsScene(1, 3, restitution_accuracy=accuracy)
    p = {k: v[0] for k, v in PARAMETERS.items()}
    m = (p["pusher_mass"], p["ball_mass"])
    r = (p["pusher_radius"], p["ball_radius"])
    # the dashpot gives the impact exactly the target restitution (no-tension closed form)
    zeta = CF.zeta_for_restitution(p["restitution"], "no_tension")
    m_eff = theory.effective_mass(m[0], m[1])
    assert scene.kd == pytest.approx(2.0 * zeta * (scene.ks * m_eff) ** 0.5, rel=1e-9)
    res = pair_collision(
        "symplectic_euler",
        False,
        "no_tension",
        None,
        None,
        256,
        masses=m,
        radii=r,
        ks=scene.ks,
        speed=p["max_speed"],
        kd=scene.kd,
        dt=scene.dt,
    )
    assert res.errors["restitution"] <= accuracy
    assert res.extra["peak_ratio"] <= p["penetration_tolerance"] * (1.0 + 1e-9)


def test_a_tighter_accuracy_costs_more_substeps():
    loose = PenaltyBallsScene(1, 3, restitution_accuracy=0.5)
    default = PenaltyBallsScene(1, 3)
    tight = PenaltyBallsScene(1, 3, restitution_accuracy=0.05)
    assert loose.substeps <= default.substeps < tight.substeps
    for s in (loose, default, tight):
        assert s.dt * s.substeps == pytest.approx(s.control_period)
        assert s.dt <= s.config.dt * (1 + 1e-12)
        assert s.config.integrator == "symplectic_euler" and not s.config.events


def test_restitution_accuracy_is_range_checked():
    with pytest.raises(ValueError, match="restitution_accuracy"):
        PenaltyBallsScene(1, 3, restitution_accuracy=0.9)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(restitution=PARAMETERS["restitution"][1]),
        dict(restitution=PARAMETERS["restitution"][2]),
        dict(n_obstacles=3, obstacle_mass=PARAMETERS["obstacle_mass"][2], restitution=PARAMETERS["restitution"][1]),
        dict(n_obstacles=3, obstacle_mass=PARAMETERS["obstacle_mass"][1], restitution=PARAMETERS["restitution"][1]),
        dict(
            pusher_mass=PARAMETERS["pusher_mass"][2],
            ball_mass=PARAMETERS["ball_mass"][1],
            restitution_accuracy=PARAMETERS["restitution_accuracy"][1],
        ),
    ],
)
def test_every_documented_parameter_range_builds_a_scene_that_steps(kwargs):
    undamped = kwargs.get("restitution") == 1.0  # (the energy guard warns of it)
    with pytest.warns(EnergyDriftWarning) if undamped else contextlib.nullcontext():
        scene = PenaltyBallsScene(4, 3, **kwargs)
    rngs = [np.random.default_rng(i) for i in range(4)]
    scene.reset_worlds(range(4), rngs)
    scene.actions[:] = 1.0
    for _ in range(5):
        scene.step()
    assert np.isfinite(scene.world.positions).all()
    assert scene.dt <= scene.world.stability_limit()
