"""The native vector env: the same episodes as single envs seeded seed + i (checked against
Gymnasium's own SyncVectorEnv of them, infos included), in every autoreset mode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import penalty_env  # noqa: F401
from penalty_env.envs import PenaltyBallsVectorEnv
from penalty_env.envs.scripted import ScriptedPusher
from penalty_env.physics.stepping.runner import split, thread_count

DIM = {"PenaltyBalls-v0": 3, "PenaltyBalls2D-v0": 2}


def mixed_actions(obs, policy, rng, k):
    """Even worlds push scripted (they succeed), odd ones act at random (they time out)."""
    acts = rng.uniform(-1.2, 1.2, (obs.shape[0], k)).astype(np.float32)
    for i in range(0, obs.shape[0], 2):
        acts[i] = policy(obs[i])
    return acts


def sync_twin(env_id, n, mode, **kwargs):
    return SyncVectorEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)], autoreset_mode=mode)


def assert_same(a, b, what):
    assert data_equivalence(a, b, exact=True), what


def test_make_vec_uses_the_native_vector_env():
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=3)
    assert isinstance(envs, PenaltyBallsVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.max_episode_steps == 150
    assert envs.observation_space.shape == (3, 21) and envs.action_space.shape == (3, 2)
    envs = gym.make_vec("PenaltyBalls2D-v0", num_envs=2, n_obstacles=1)
    assert envs.single_observation_space.shape == (18,)


@pytest.mark.parametrize("env_id", DIM)
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_episodes_equal_a_sync_vector_env_of_single_envs(env_id, mode):
    n, k = 4, DIM[env_id] - 1
    kwargs = dict(max_episode_steps=100, n_obstacles=1)
    native = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode, **kwargs)
    twin = sync_twin(env_id, n, mode, **kwargs)
    policy = ScriptedPusher(DIM[env_id], 0.3)
    rng = np.random.default_rng(0)
    obs_a, info_a = native.reset(seed=11)
    obs_b, info_b = twin.reset(seed=11)
    assert_same(obs_a, obs_b, "reset obs")
    assert_same(info_a, info_b, "reset info")
    ends = successes = 0
    for t in range(300):
        acts = mixed_actions(obs_a, policy, rng, k)
        a = native.step(acts)
        b = twin.step(acts)
        for name, x, y in zip(("obs", "reward", "terminated", "truncated", "info"), a, b):
            assert_same(x, y, f"{name} at step {t}")
        obs_a = a[0]
        ends += int(np.sum(a[2] | a[3]))
        successes += int(np.sum(a[2]))
    assert successes >= 2 and ends > successes  # both kinds of episode end were exercised


def test_disabled_autoreset_with_a_reset_mask_equals_sync_vector_env():
    mode = AutoresetMode.DISABLED
    native = gym.make_vec("PenaltyBalls-v0", num_envs=3, autoreset_mode=mode, max_episode_steps=20)
    twin = sync_twin("PenaltyBalls-v0", 3, mode, max_episode_steps=20)
    assert_same(native.reset(seed=3), twin.reset(seed=3), "reset")
    acts = np.full((3, 2), 0.3, np.float32)
    for t in range(20):
        assert_same(native.step(acts), twin.step(acts), f"step {t}")
    with pytest.raises(RuntimeError, match="reset_mask"):
        native.step(acts)
    mask = np.array([True, False, True])
    assert_same(native.reset(options={"reset_mask": mask}), twin.reset(options={"reset_mask": mask.copy()}), "mask")


def test_next_step_autoreset_ignores_the_action_and_returns_the_reset_observation():
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=2, max_episode_steps=5)
    envs.reset(seed=0)
    for _ in range(5):
        obs, rewards, terminated, truncated, _ = envs.step(np.zeros((2, 2), np.float32))
    assert truncated.all() and not terminated.any()
    single = gym.make("PenaltyBalls-v0")
    single.reset(seed=0)
    for _ in range(5):
        single.step(np.zeros(2, np.float32))
    second_start, _ = single.reset()  # the generator carries on, as in a single env
    nan = np.full((2, 2), np.nan, np.float32)  # ignored: both worlds are resetting
    obs, rewards, terminated, truncated, info = envs.step(nan)
    assert np.array_equal(obs[0], second_start)
    assert not rewards.any() and not terminated.any() and not truncated.any()
    assert not info["is_success"].any() and (info["reward_goal"] == 0).all()


def test_a_large_threaded_batch_gives_each_world_its_single_env_episode():
    n = 300  # enough work to be spread over threads
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=n)
    scene = envs.unwrapped.scene
    assert len(split(np.arange(n), scene.n_balls * scene.substeps)) == thread_count()  # one chunk per thread
    obs, _ = envs.reset(seed=100)
    acts = np.random.default_rng(5).uniform(-1, 1, (40, n, 2)).astype(np.float32)
    trace = [obs]
    for t in range(40):
        trace.append(envs.step(acts[t])[0])
    for i in (0, 151, 299):
        single = gym.make("PenaltyBalls-v0")
        o, _ = single.reset(seed=100 + i)
        assert np.array_equal(o, trace[0][i])
        for t in range(40):
            o = single.step(acts[t, i])[0]
            assert np.array_equal(o, trace[t + 1][i]), (i, t)


def test_reset_takes_a_list_of_seeds():
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=2)
    a, _ = envs.reset(seed=[5, 9])
    b, _ = envs.reset(seed=5)
    assert np.array_equal(a[0], b[0]) and not np.array_equal(a[1], b[1])
    with pytest.raises(ValueError, match="2 seeds"):
        envs.reset(seed=[1, 2, 3])


def test_bad_input_is_refused_before_any_world_moves():
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=4)
    with pytest.raises(ResetNeeded, match="before reset"):
        envs.step(np.zeros((4, 2), np.float32))
    envs.reset(seed=0)
    before = envs.unwrapped.scene.world.positions.copy()
    acts = np.zeros((4, 2), np.float32)
    acts[2, 1] = np.inf
    with pytest.raises(ValueError, match="world 2 contains NaN or inf"):
        envs.step(acts)
    with pytest.raises(ValueError, match=r"shape \(4, 2\)"):
        envs.step(np.zeros((3, 2), np.float32))
    assert np.array_equal(envs.unwrapped.scene.world.positions, before)
    with pytest.raises(ValueError, match="autoreset_mode"):
        PenaltyBallsVectorEnv(2, autoreset_mode="sometimes")
    with pytest.raises(ValueError, match="max_episode_steps"):
        PenaltyBallsVectorEnv(2, max_episode_steps=0)


def test_render_returns_one_frame_per_world():
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=3, render_mode="rgb_array", render_width=64, render_height=48)
    envs.reset(seed=0)
    frames = envs.render()
    assert len(frames) == 3 and all(f.shape == (48, 64, 3) and f.dtype == np.uint8 for f in frames)
    assert not np.array_equal(frames[0], frames[1])  # different worlds, different pictures
