"""PenaltySandLevel-v1: the level task at a size that matters (2,000 grains of 0.04 m in 3D, random
targets, springs from a softer budget). Registration; the budget the springs are derived from,
held by the settled bed (every overlap within it, the bed at rest); the substep's margin under the
stability limit; the env checker, the picture of the grains, and the native vector env against
single envs; v0 untouched.

Slow but for the registration: the 2,000-grain heap settles once per machine (about 10 s, cached)
and each step costs about 0.1 s."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import penalty_env  # noqa: F401
from penalty_env.envs import sand_level as SL
from penalty_env.envs.level import scene as LS

V1 = LS.LEVEL_VERSIONS[1]


def test_registered_beside_v0():
    spec = gym.spec("PenaltySandLevel-v1")
    assert spec.kwargs == {"dim": 3, "version": 1}
    assert spec.max_episode_steps == 300
    assert spec.vector_entry_point == "penalty_env.envs.sand_level:PenaltySandLevelVectorEnv"
    assert gym.spec("PenaltySandLevel-v0").kwargs == {"dim": 3}  # v0 as it was
    # a version out of range is refused, naming it
    with pytest.raises(ValueError, match="version"):
        SL.SandLevelScene(1, dim=3, version=7)


@pytest.fixture(scope="module")
def scene():
    s = SL.SandLevelScene(1, dim=3, version=1)
    assert s._bed is None  # v1 settles its heap on the first reset (or asked for), not at make
    s.bed  # noqa: B018 (settled here)
    return s


def _overlaps(x: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Every grain pair's overlap and every grain's overlap with the floor, / r (brute force)."""
    gap = np.linalg.norm(x[:, None] - x[None], axis=-1)
    i, j = np.triu_indices(len(x), 1)
    pairs = 2.0 * r - gap[i, j]
    floor = r - x[:, -1]
    return pairs[pairs > 0.0] / r, floor[floor > 0.0] / r


@pytest.mark.slow
def test_a_bed_at_least_two_grains_deep(scene):
    d = 2.0 * V1.grain_radius
    assert scene.n_grains == 2000 and scene.target_kind == "random"
    volume = 4.0 / 3.0 * math.pi * V1.grain_radius**3
    assert scene.flat_level == pytest.approx(2000 * volume / (LS.PACKING[3] * 4.0), rel=1e-12)
    assert scene.flat_level >= 2.0 * d  # flattened, the bed is at least two grains deep


@pytest.mark.slow
def test_the_settled_bed_holds_the_budget_its_springs_come_from(scene):
    """The springs are derived for an overlap of ``overlap`` x r under a column of grains as tall
    as the start (and an impact at the blade's speed); the settled bed must hold it: every pair's
    and every floor contact's overlap within it (the floor's spring is twice the pairs', the same
    omega on its twice heavier m_eff), the bed at rest."""
    assert scene.settle_speed < LS.SETTLE_SPEED
    pairs, floor = _overlaps(np.asarray(scene.bed), V1.grain_radius)
    assert pairs.size > scene.n_grains  # a bed: more contacts than grains
    assert pairs.max() <= V1.overlap and floor.max() <= V1.overlap
    assert scene.ks_terrain == pytest.approx(V1.floor_stiffening * scene.ks, rel=1e-12)
    zeta = scene.kd / (2.0 * math.sqrt(scene.ks * V1.grain_mass / 2.0))
    zeta_floor = scene.kd_terrain / (2.0 * math.sqrt(scene.ks_terrain * V1.grain_mass))
    assert zeta_floor == pytest.approx(zeta, rel=1e-12) and zeta == pytest.approx(scene.config.zeta, rel=1e-12)


@pytest.mark.slow
def test_the_substep_keeps_its_margin_under_the_stability_limit(scene):
    assert scene.dt * scene.substeps == pytest.approx(scene.control_period, rel=1e-12)
    assert scene.dt <= V1.step_margin * scene.world.stability_limit() * (1.0 + 1e-12)
    assert scene.dt <= scene.config.dt * (1.0 + 1e-12)


@pytest.mark.slow
def test_check_env_and_the_picture_of_the_grains():
    env = gym.make("PenaltySandLevel-v1")
    check_env(env.unwrapped, skip_render_check=True)
    env = gym.make("PenaltySandLevel-v1", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.array([1.0, 0.0], dtype=np.float32))
    img = env.render()
    scene = env.unwrapped.scene
    maps = scene.renderer().maps_picture(0)
    side = maps.shape[0]
    assert img.dtype == np.uint8 and img.shape[0] == side and img.shape[1] > side + maps.shape[1]
    np.testing.assert_array_equal(img[:, -maps.shape[1] :], maps)  # the maps on the right, as v0's
    grains = img[:, :side].astype(int)
    # sand-coloured discs (red > green > blue) cover much of the arena's picture; the blade's red
    # outline is there
    sand = (grains[..., 0] > grains[..., 1]) & (grains[..., 1] > grains[..., 2]) & (grains[..., 2] < 200)
    assert sand.mean() > 0.3
    red = (grains[..., 0] == 220) & (grains[..., 1] == 30) & (grains[..., 2] == 30)
    assert red.sum() >= 4 * 10
    # v0's frame is the maps alone, as before
    v0 = gym.make("PenaltySandLevel-v0", render_mode="rgb_array")
    v0.reset(seed=0)
    assert v0.unwrapped.scene.phys is LS.LEVEL_VERSIONS[0]
    np.testing.assert_array_equal(v0.render(), v0.unwrapped.scene.renderer().maps_picture(0))


@pytest.mark.slow
def test_vector_env_equals_single_envs():
    steps, n_worlds = 3, 2
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1.0, 1.0, (steps, n_worlds, 2)).astype(np.float32)
    venv = gym.make_vec("PenaltySandLevel-v1", num_envs=n_worlds, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=5)
    rows = [(obs, None)]
    for a in actions:
        o, r, *_ = venv.step(a)
        rows.append((o, r))
    for w in range(n_worlds):
        env = gym.make("PenaltySandLevel-v1")
        o, _ = env.reset(seed=5 + w)
        np.testing.assert_array_equal(o, rows[0][0][w])
        for k in range(steps):
            o, r, *_ = env.step(actions[k, w])
            np.testing.assert_array_equal(o, rows[k + 1][0][w])
            assert r == rows[k + 1][1][w]


@pytest.mark.slow
def test_the_settled_mound_is_no_steeper_than_the_repose_angle(scene):
    """v1's grains have v0's friction and rolling resistance (mu 0.5, mu_r 0.1): the settled mound's
    flank, fitted by the pile benchmark's ``profile_angle`` (bins of one diameter), is no steeper
    than the repose angle docs/granular.md reports for them (26.1 degrees) plus 1.5."""
    from penalty_env.bench.granular.pile import profile_angle

    assert (scene.world_kwargs["mu"], scene.world_kwargs["mu_r"]) == (LS.GRAIN_FRICTION, LS.GRAIN_ROLLING) == (0.5, 0.1)
    x = np.asarray(scene.bed) / (2.0 * V1.grain_radius)
    angle, (rho, h), _ = profile_angle(x, np.full(len(x), 0.5), np.zeros(2), 3, 1.0)
    assert angle <= 26.1 + 1.5
    assert h.max() >= 3.0  # a mound: at least three layers of grains at its crest


def test_v1_defaults_and_v0_unchanged():
    """The version's defaults (grains, target, success threshold) without settling anything."""
    p1 = LS._parameters(3, {}, "test", V1)
    p0 = LS._parameters(3, {}, "test", LS.LEVEL_VERSIONS[0])
    assert (p1["grains"], p1["target"], p1["success_fraction"]) == (2000, "random", 0.75)
    assert (p0["grains"], p0["target"], p0["success_fraction"]) == (250, "flat", 0.5)
    assert LS._parameters(3, {"success_fraction": 0.6, "target": "flat"}, "test", V1)["success_fraction"] == 0.6
