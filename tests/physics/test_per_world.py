"""Per-world parameters in the core (``World(..., per_world=True)``): each world of a batch steps
exactly as a fixed World made with that world's parameters (bit for bit, on the SIMD-lanes and the
scalar path, with and without rotation), a fixed World is unchanged, and ``set_parameters``
checks its arguments and holds each world to the guard."""

from __future__ import annotations

import numpy as np
import pytest

from penalty_env.physics import Bowl, Motor, World

KW = dict(
    terrain=Bowl((0.0, 0.0, 8.0), 8.0),
    ks=2e4,
    kd=10.0,
    mu=0.3,
    dt=1e-3,
    damping="no_tension",
    motors=[Motor(0, 20.0, 1.0, axes=2)],
    start_check=False,
)


def _start(B: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = np.zeros((B, 2, 3))
    x[:, 0, 0], x[:, 1, 0], x[:, :, 2] = -0.3, 0.3, 0.2
    return x, rng.normal(size=(B, 2, 3))


@pytest.mark.slow
@pytest.mark.parametrize(("stepping", "rotation"), [("lanes", False), ("scalar", False), ("scalar", True)])
def test_each_world_steps_as_a_fixed_world_with_its_parameters(stepping, rotation):
    B = 20
    x, v = _start(B)
    extra = dict(rotation=True, mu_r=0.02) if rotation else {}
    fixed = World(x, [0.15, 0.15], [1.0, 0.5], v, stepping=stepping, **KW, **extra)
    per = World(x, [0.15, 0.15], [1.0, 0.5], v, stepping=stepping, per_world=True, **KW, **extra)
    throttle = np.random.default_rng(1).uniform(-1, 1, (B, 1, 2))
    fixed.step(200, throttle=throttle)
    per.step(200, throttle=throttle)
    assert np.array_equal(fixed.positions, per.positions)  # the same parameters: the same bits
    assert np.array_equal(fixed.energy(), per.energy())
    # world 3 gets its own masses, radii, contact law and motor
    own = dict(ks=3e4, kd=12.0, mu=0.5)
    per.set_parameters(
        [3], masses=[2.0, 0.7], radii=[0.2, 0.1], ks_terrain=3e4, kd_terrain=12.0, max_force=[10.0], **own
    )
    alone = World(
        per.positions[3],
        [0.2, 0.1],
        [2.0, 0.7],
        per.velocities[3],
        stepping="scalar",
        **dict(KW, motors=[Motor(0, 10.0, 1.0, axes=2)], **own),
        **extra,
    )
    if rotation:
        alone.angular_velocities = per.angular_velocities[3]
    before = per.positions.copy()
    alone.step(150, throttle=throttle[3])
    per.step(150, throttle=throttle)
    assert np.array_equal(alone.positions, per.positions[3])
    assert alone.parameters()["kf"] == per.parameters(3)["kf"]  # the default kf follows the masses
    if rotation:
        assert alone.parameters()["kr"] == per.parameters(3)["kr"]
    fixed.step(150, throttle=throttle)
    others = np.arange(B) != 3
    assert np.array_equal(fixed.positions[others], per.positions[others])
    assert not np.array_equal(before[3], per.positions[3])


def test_set_parameters_checks_its_arguments():
    x, v = _start(4)
    per = World(x, [0.15, 0.15], [1.0, 0.5], v, per_world=True, **KW)
    with pytest.raises(ValueError, match="per_world=True"):
        World(x, [0.15, 0.15], [1.0, 0.5], v, **KW).set_parameters(ks=1e4)
    with pytest.raises(ValueError, match=r"masses must have shape \(2,\)"):
        per.set_parameters(masses=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="ks must be > 0"):
        per.set_parameters([1], ks=-1.0)
    with pytest.raises(ValueError, match="kd must be finite"):
        per.set_parameters(kd=np.nan)
    with pytest.raises(ValueError, match="this World has no motors"):
        World(x, [0.15, 0.15], [1.0, 0.5], v, per_world=True, **dict(KW, motors=())).set_parameters(max_force=[1.0])
    # the guard, world by world: a stiffer spring than dt allows is refused, naming the world and the step
    with pytest.raises(ValueError, match=r"world 2: dt=0.001 is above the stability limit.*substeps"):
        per.set_parameters([2], ks=1e7)
    assert per.parameters(2)["ks"] == 2e4  # (refused: nothing changed)
    per.set_parameters([2], ks=1e7, guard=False)  # a caller that checked beforehand
    assert per.parameters(2)["ks"] == 1e7 and per.parameters(1)["ks"] == 2e4
    with pytest.raises(ValueError, match="events=True"):
        World(x, [0.15, 0.15], [1.0, 0.5], v, per_world=True, events=True, **dict(KW, motors=()))


def test_a_per_world_friction_under_the_history_spring_steps_as_a_fixed_world_with_it():
    """The tangential history spring (a heap's static friction) with per-world parameters: a world
    given its own friction coefficient steps exactly as a fixed World made with it, and the others
    as the fixed World of the shared value (bit for bit: the scalar path reads world b's model)."""
    B = 4
    rng = np.random.default_rng(5)
    x = np.zeros((B, 3, 3))
    x[:, :, 0] = [-0.25, 0.0, 0.25]
    x[:, :, 2] = 0.12
    v = rng.normal(scale=0.5, size=(B, 3, 3))
    kw = dict(KW, rotation=True, tangential="history", motors=())
    per = World(x, [0.12] * 3, [0.5] * 3, v, per_world=True, **kw)
    per.set_parameters([2], mu=0.8)
    fixed = World(x, [0.12] * 3, [0.5] * 3, v, **kw)
    alone = World(x[2], [0.12] * 3, [0.5] * 3, v[2], **dict(kw, mu=0.8))
    for w in (per, fixed, alone):
        w.step(300)
    assert np.array_equal(per.positions[[0, 1, 3]], fixed.positions[[0, 1, 3]])
    assert np.array_equal(per.positions[2], alone.positions)
    assert not np.array_equal(per.positions[2], fixed.positions[2])  # (the friction mattered)
