"""The SB3 adapter: DummyVecEnv's same-step reset semantics over the batched worlds."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.monitor import Monitor  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor  # noqa: E402

import penalty_env  # noqa: F401, E402
from penalty_env.envs.scripted import ScriptedPusher  # noqa: E402
from penalty_env.sb3 import PenaltyBallsVecEnv, make_vec_env  # noqa: E402

DIM = {"PenaltyBalls-v0": 3, "PenaltyBalls2D-v0": 2}


def dummy_twin(env_id, n, seed, monitor=False, **kwargs):
    def make():
        env = gym.make(env_id, **kwargs)
        return Monitor(env) if monitor else env

    venv = DummyVecEnv([make for _ in range(n)])
    venv.seed(seed)
    return venv


def mixed_actions(obs, policy, rng, k):
    acts = rng.uniform(-1.0, 1.0, (obs.shape[0], k)).astype(np.float32)
    for i in range(0, obs.shape[0], 2):
        acts[i] = policy(obs[i])
    return acts


@pytest.mark.parametrize("env_id", DIM)
def test_adapter_episodes_equal_a_dummy_vec_env_of_single_envs(env_id):
    n, k = 4, DIM[env_id] - 1
    ours = make_vec_env(env_id, n_envs=n, seed=21, monitor=False, max_episode_steps=100)
    assert isinstance(ours, PenaltyBallsVecEnv)
    twin = dummy_twin(env_id, n, 21, max_episode_steps=100)
    obs_a, obs_b = ours.reset(), twin.reset()
    assert np.array_equal(obs_a, obs_b)
    assert ours.reset_infos == twin.reset_infos
    policy = ScriptedPusher(DIM[env_id], 0.3)
    rng = np.random.default_rng(1)
    kinds = set()
    for t in range(300):
        acts = mixed_actions(obs_a, policy, rng, k)
        obs_a, rew_a, done_a, infos_a = ours.step(acts)
        obs_b, rew_b, done_b, infos_b = twin.step(acts)
        assert np.array_equal(obs_a, obs_b), t
        assert rew_a.dtype == rew_b.dtype and np.array_equal(rew_a, rew_b), t
        assert np.array_equal(done_a, done_b), t
        for i, (a, b) in enumerate(zip(infos_a, infos_b)):
            assert a.keys() == b.keys(), (t, i)
            for key in a:
                if key == "terminal_observation":
                    assert np.array_equal(a[key], b[key]) and a[key].dtype == b[key].dtype
                    kinds.add("success" if a["is_success"] else "time-out")
                else:
                    assert a[key] == b[key] and type(a[key]) is type(b[key]), (t, i, key)
        assert ours.reset_infos == twin.reset_infos
    assert kinds == {"success", "time-out"}


def test_terminal_observation_is_the_last_observation_before_the_reset():
    venv = make_vec_env("PenaltyBalls-v0", n_envs=2, seed=0, monitor=False, max_episode_steps=3)
    single = gym.make("PenaltyBalls-v0", max_episode_steps=3)
    venv.reset()
    single.reset(seed=0)
    acts = np.array([[0.5, -0.5], [0.1, 0.2]], np.float32)
    for _ in range(3):
        obs, rewards, dones, infos = venv.step(acts)
        last = single.step(acts[0])[0]
    assert dones.all() and rewards.dtype == np.float32
    assert np.array_equal(infos[0]["terminal_observation"], last)
    assert infos[0]["TimeLimit.truncated"] is True
    assert np.array_equal(obs[0], single.reset()[0])  # already reset, same step


def test_vec_monitor_episode_statistics_match_monitor():
    ours = make_vec_env("PenaltyBalls-v0", n_envs=2, seed=4, max_episode_steps=40)
    assert isinstance(ours, VecMonitor)
    twin = dummy_twin("PenaltyBalls-v0", 2, 4, monitor=True, max_episode_steps=40)
    ours.reset()
    obs = twin.reset()
    policy = ScriptedPusher(3, 0.3)
    episodes = 0
    for _ in range(120):
        acts = np.stack([policy(o) for o in obs])
        _, _, done_a, infos_a = ours.step(acts)
        obs, _, done_b, infos_b = twin.step(acts)
        for i in np.flatnonzero(done_b):
            a, b = infos_a[i]["episode"], infos_b[i]["episode"]
            assert a["l"] == b["l"] and a["r"] == pytest.approx(b["r"], abs=1e-4)
            assert infos_a[i]["episode"]["is_success"] == infos_b[i]["is_success"]
            episodes += 1
    assert episodes >= 2


def test_vecenv_interface():
    venv = make_vec_env(
        "PenaltyBalls-v0", n_envs=3, monitor=False, render_mode="rgb_array", render_width=32, render_height=32
    )
    assert isinstance(venv, VecEnv)
    assert venv.get_attr("render_mode") == ["rgb_array"] * 3
    assert venv.get_attr("max_episode_steps", indices=[0]) == [150]
    assert venv.env_is_wrapped(Monitor) == [False] * 3
    venv.seed(3)
    venv.reset()
    images = venv.get_images()
    assert len(images) == 3 and images[0].shape == (32, 32, 3)
    assert venv.render().ndim == 3  # SB3 tiles them
    with pytest.raises(ValueError, match="env_id"):
        make_vec_env("CartPole-v1")
    with pytest.raises(ValueError, match=r"shape \(3, 2\)"):
        venv.step(np.zeros((3, 3), np.float32))


def test_ppo_learns_on_the_adapter():
    from stable_baselines3 import PPO

    venv = make_vec_env("PenaltyBalls-v0", n_envs=2, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = PPO("MlpPolicy", venv, n_steps=1024, seed=0, device="cpu")
        model.learn(2048)
    assert model.num_timesteps >= 2048
    assert len(model.ep_info_buffer) > 0  # VecMonitor's episode statistics reached the logger


def test_stagger_cuts_only_the_first_episodes_and_leaves_the_worlds_alone():
    """``stagger(seed)``: after the next reset, world i's first episode is truncated after a
    drawn number of steps in 1..max_episode_steps (the same draws for the same seed); the
    worlds' states are those of an unstaggered env until then, and later episodes are whole."""
    n, T = 6, 10
    plain = PenaltyBallsVecEnv(n, max_episode_steps=T)
    cut = PenaltyBallsVecEnv(n, max_episode_steps=T)
    plain.seed(5)
    cut.seed(5)
    cut.stagger(11)
    drawn = np.random.default_rng(11).integers(1, T + 1, size=n)
    assert len(set(drawn.tolist())) > 1  # out of phase
    np.testing.assert_array_equal(plain.reset(), cut.reset())
    zero = np.zeros((n, plain.action_space.shape[0]), np.float32)
    first_end = np.zeros(n, dtype=int)
    for t in range(1, T + 1):
        obs_p, _, done_p, _ = plain.step(zero)
        obs_c, _, done_c, info_c = cut.step(zero)
        assert done_p.any() == (t == T)  # no push, no success: the plain worlds run to T
        live = first_end == 0
        np.testing.assert_array_equal(obs_p[live & ~done_c], obs_c[live & ~done_c])  # the same worlds
        for i in np.flatnonzero(done_c & live):
            first_end[i] = t
            assert info_c[i]["TimeLimit.truncated"]
            np.testing.assert_array_equal(info_c[i]["terminal_observation"], obs_p[i])
    np.testing.assert_array_equal(first_end, drawn)
    # the next reset is whole again: every episode lasts T steps
    cut.seed(5)
    cut.reset()
    for t in range(1, T + 1):
        _, _, done_c, _ = cut.step(zero)
        assert done_c.all() == done_c.any() == (t == T)


def test_the_level_task_on_the_adapter_equals_a_dummy_vec_env_of_single_envs():
    """The level task gains SB3's VecEnv through the one engine: its episodes (with autoreset
    after short truncated episodes) equal DummyVecEnv's of single envs, randomised too."""
    kw = dict(max_episode_steps=6, randomize={"friction": (0.3, 0.7), "blade_speed": (0.3, 0.6)})
    ours = make_vec_env("PenaltySandLevel2D-v0", n_envs=2, seed=5, monitor=False, **kw)
    assert isinstance(ours, PenaltyBallsVecEnv)
    twin = dummy_twin("PenaltySandLevel2D-v0", 2, 5, **kw)
    obs_a, obs_b = ours.reset(), twin.reset()
    np.testing.assert_array_equal(obs_a, obs_b)
    rng = np.random.default_rng(2)
    ended = 0
    for t in range(14):
        acts = rng.uniform(-1, 1, (2, 1)).astype(np.float32)
        obs_a, rew_a, done_a, infos_a = ours.step(acts)
        obs_b, rew_b, done_b, infos_b = twin.step(acts)
        np.testing.assert_array_equal(obs_a, obs_b)
        np.testing.assert_array_equal(rew_a, rew_b)
        np.testing.assert_array_equal(done_a, done_b)
        for a, b in zip(infos_a, infos_b):
            assert a["randomization"] == b["randomization"] and a["error"] == b["error"], t
        ended += int(done_a.sum())
    assert ended >= 4  # episodes ended and reset automatically
