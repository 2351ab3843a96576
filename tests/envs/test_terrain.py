"""The env's terrains (``terrain="bowl" | "arena" | "bumpy" | "slope"``): checkers, starts, determinism of the
redrawn bumps, the vector env's equality with single envs, and the renderer's pictures of them."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import penalty_env  # noqa: F401
from penalty_env.envs.scripted import ScriptedPusher
from penalty_env.physics import HeightField, Plane

IDS = {"PenaltyBalls-v0": 3, "PenaltyBalls2D-v0": 2}
TERRAINS = ("arena", "bumpy", "slope")


# every terrain in both dimensions; the default run checks each terrain in one of them (each
# pairing compiles its own kernels), the slow run the rest
_SLOW_PAIRS = {("PenaltyBalls2D-v0", "arena"), ("PenaltyBalls-v0", "bumpy"), ("PenaltyBalls2D-v0", "slope")}


@pytest.mark.parametrize(
    "env_id,terrain",
    [pytest.param(e, t, marks=pytest.mark.slow) if (e, t) in _SLOW_PAIRS else (e, t) for t in TERRAINS for e in IDS],
)
def test_env_checkers_pass_on_every_terrain(env_id, terrain):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = gym.make(env_id, render_mode="rgb_array", terrain=terrain)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=False)
        sb3_check(env, warn=True)


@pytest.mark.parametrize("env_id", IDS)
def test_terrains_are_built_from_the_documented_shapes_and_start_bodies_at_rest_on_them(env_id):
    d = IDS[env_id]
    for terrain in TERRAINS:
        env = gym.make(env_id, terrain=terrain)
        scene = env.unwrapped.scene
        if terrain in ("arena", "slope"):
            assert all(isinstance(s, Plane) for s in scene.world.terrain) and len(scene.world.terrain) == 1 + 2 * (
                d - 1
            )
        else:
            assert isinstance(scene.world.terrain[0], HeightField)
        for seed in range(5):
            env.reset(seed=seed)
            w = scene.world
            # every body within its penetration tolerance of the terrain, and at rest
            phi, _ = w.terrain_distance(w.positions[0])
            overlap = (scene.radii - phi) / scene.radii
            assert np.all(overlap >= -1e-9) and np.all(overlap <= scene.params["penetration_tolerance"] + 1e-9)
            assert np.all(w.velocities == 0.0)


def test_bumps_are_redrawn_at_every_reset_from_the_seed_and_have_the_chosen_height():
    env = gym.make("PenaltyBalls-v0", terrain="bumpy", roughness=0.1)
    scene = env.unwrapped.scene
    grids = []
    for seed in (0, 0, 1):
        env.reset(seed=seed)
        grids.append(scene.world.shape_heights(0, world=0))
    assert np.array_equal(grids[0], grids[1]) and not np.array_equal(grids[0], grids[2])
    bumps = grids[0] - scene.terrain.bowl_floor
    assert bumps.min() >= 0.0 and 0.3 * 0.1 <= bumps.max() <= 0.1 + 1e-12
    flat = gym.make("PenaltyBalls-v0", terrain="bumpy", roughness=0.0).unwrapped.scene
    flat_env = gym.make("PenaltyBalls-v0", terrain="bumpy", roughness=0.0)
    flat_env.reset(seed=0)
    assert np.array_equal(flat_env.unwrapped.scene.world.shape_heights(0), flat.terrain.bowl_floor)


@pytest.mark.parametrize("dim", [3, 2])
def test_bumps_of_many_worlds_drawn_at_once_are_each_worlds_own_draw_bit_for_bit(dim):
    """A reset draws every reset world's bumps in one call (in chunks; per-world roughness, one of
    them 0: no bumps): bit for bit each world's own draw from its generator, which is left where
    that draw leaves it."""
    from penalty_env.envs.terrains.bumpy import DRAW_CHUNK, BumpyTerrain

    terrain = BumpyTerrain(dim, 4.0, 0.1)  # (a bowl wider than the field's corners)
    k = DRAW_CHUNK + 5
    rough = np.random.default_rng(1).uniform(0.02, 0.2, k)
    rough[3] = 0.0
    mine = [np.random.default_rng(100 + t) for t in range(k)]
    theirs = [np.random.default_rng(100 + t) for t in range(k)]
    together = terrain.draw(mine, rough)
    one_by_one = np.array([terrain.bump_heights(rng, float(r)) for rng, r in zip(theirs, rough)])
    assert together.shape == (k,) + terrain.bowl_floor.shape
    assert np.array_equal(together.view(np.int64), one_by_one.view(np.int64))
    assert np.isfinite(together).all()
    assert np.array_equal(together[3], terrain.bowl_floor) and not np.array_equal(together[4], terrain.bowl_floor)
    assert [a.random() for a in mine] == [b.random() for b in theirs]
    assert terrain.draw([], np.zeros(0)).shape == (0,) + terrain.bowl_floor.shape


@pytest.mark.parametrize("env_id", IDS)
def test_vector_env_on_bumps_equals_single_envs_seeded_seed_plus_i(env_id):
    n, k = 3, IDS[env_id] - 1
    kwargs = dict(max_episode_steps=60, terrain="bumpy")
    native = gym.make_vec(env_id, num_envs=n, **kwargs)
    twin = SyncVectorEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)], autoreset_mode=AutoresetMode.NEXT_STEP)
    policy = ScriptedPusher(IDS[env_id], 0.3)
    rng = np.random.default_rng(0)
    obs_a, _ = native.reset(seed=5)
    obs_b, _ = twin.reset(seed=5)
    assert data_equivalence(obs_a, obs_b, exact=True)
    for t in range(150):
        acts = rng.uniform(-1, 1, (n, k)).astype(np.float32)
        acts[0] = policy(obs_a[0])
        a, b = native.step(acts), twin.step(acts)
        for name, x, y in zip(("obs", "reward", "terminated", "truncated", "info"), a, b):
            assert data_equivalence(x, y, exact=True), f"{name} at step {t}"
        obs_a = a[0]


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("terrain", TERRAINS)
def test_renderer_draws_the_terrain_and_the_bodies_on_it(env_id, terrain):
    env = gym.make(env_id, render_mode="rgb_array", terrain=terrain, render_width=128, render_height=128)
    env.reset(seed=3)
    frame = env.render()
    assert frame.shape == (128, 128, 3) and frame.dtype == np.uint8
    # the terrain is drawn (not a blank frame) and differs between terrains and from the bowl's
    bowl = gym.make(env_id, render_mode="rgb_array", render_width=128, render_height=128)
    bowl.reset(seed=3)
    assert frame.std() > 5.0
    assert np.abs(frame.astype(int) - bowl.render().astype(int)).mean() > 1.0
    if terrain == "bumpy":  # a new draw of bumps is drawn anew
        env.reset(seed=4)
        assert not np.array_equal(env.render(), frame)


@pytest.mark.parametrize("env_id", IDS)
def test_a_frictionless_ball_on_the_slope_slides_down_at_g_sin_theta(env_id):
    """On the slope without friction a ball at rest accelerates down the plane at g sin(theta):
    its velocity after t is g sin(theta) t along the plane (horizontal part g sin cos t towards -x,
    vertical g sin^2 t down), before it meets anything."""
    from penalty_env.envs.terrains.slope import SLOPE_DEGREES

    env = gym.make(env_id, terrain="slope", friction=0.0)
    env.reset(seed=0)
    scene = env.unwrapped.scene
    steps = 5
    for _ in range(steps):
        env.step(np.zeros(env.action_space.shape, np.float32))
    t, a, g = steps * scene.control_period, np.radians(SLOPE_DEGREES), scene.gravity
    v = scene.world.velocities[0, 1]
    assert v[0] == pytest.approx(-g * np.sin(a) * np.cos(a) * t, rel=1e-4)
    assert v[-1] == pytest.approx(-g * np.sin(a) ** 2 * t, rel=1e-3)


@pytest.mark.parametrize("dim,fraction", [(3, 5.0 / 7.0), (2, 2.0 / 3.0)])
def test_a_ball_rolls_down_the_slope_at_the_rolling_fraction_of_g_sin_theta(dim, fraction):
    """With rotation (v1) and no rolling resistance, a ball on the slope (tan theta below 7/2 mu:
    it rolls without slipping) accelerates at 5/7 g sin(theta) (sphere) or 2/3 (disk) once it
    rolls."""
    from penalty_env.envs.terrains.slope import SLOPE_DEGREES

    env = gym.make("PenaltyBalls-v1" if dim == 3 else "PenaltyBalls2D-v1", terrain="slope", rolling_resistance=0.0)
    env.reset(seed=0)
    scene = env.unwrapped.scene
    zero = np.zeros(env.action_space.shape, np.float32)
    for _ in range(3):  # (it starts rolling)
        env.step(zero)
    v0 = scene.world.velocities[0, 1, 0]
    steps = 5
    for _ in range(steps):
        env.step(zero)
    accel = (scene.world.velocities[0, 1, 0] - v0) / (steps * scene.control_period)
    a = np.radians(SLOPE_DEGREES)
    assert accel == pytest.approx(-fraction * scene.gravity * np.sin(a) * np.cos(a), rel=0.02)
