"""The env's terrains (``terrain="bowl" | "arena" | "bumpy"``): checkers, starts, determinism of the
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
TERRAINS = ("arena", "bumpy")


# every terrain in both dimensions; the default run checks each terrain in one of them (each
# pairing compiles its own kernels), the slow run the rest
_SLOW_PAIRS = {("PenaltyBalls2D-v0", "arena"), ("PenaltyBalls-v0", "bumpy")}


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
        if terrain == "arena":
            assert all(isinstance(s, Plane) for s in scene.terrain) and len(scene.terrain) == 1 + 2 * (d - 1)
        else:
            assert isinstance(scene.terrain[0], HeightField)
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
    bumps = grids[0] - scene._bumpy_floor
    assert bumps.min() >= 0.0 and 0.3 * 0.1 <= bumps.max() <= 0.1 + 1e-12
    flat = gym.make("PenaltyBalls-v0", terrain="bumpy", roughness=0.0).unwrapped.scene
    flat_env = gym.make("PenaltyBalls-v0", terrain="bumpy", roughness=0.0)
    flat_env.reset(seed=0)
    assert np.array_equal(flat_env.unwrapped.scene.world.shape_heights(0), flat._bumpy_floor)


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
