"""The goal-conditioned ids (``PenaltyBallsGoal-v0`` and siblings): Gymnasium's checker, the Dict
observation against the base env's, ``compute_reward`` equal bit for bit to the step's reward
(over rollouts and relabelled batches of any shape), the native vector env against a
``SyncVectorEnv`` of single envs, SB3's ``HerReplayBuffer`` on them, and bad input."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import penalty_env  # noqa: F401 (registers the ids)
from penalty_env.envs.goal import PenaltyBallsGoalEnv, PenaltyBallsGoalVectorEnv, goal_distance
from penalty_env.envs.scripted import ScriptedPusher

GOAL_IDS = {
    "PenaltyBallsGoal-v0": ("PenaltyBalls-v0", 3),
    "PenaltyBallsGoal2D-v0": ("PenaltyBalls2D-v0", 2),
    "PenaltyBallsGoal-v1": ("PenaltyBalls-v1", 3),
    "PenaltyBallsGoal2D-v1": ("PenaltyBalls2D-v1", 2),
}


def rollout(env, seed, steps, rng, scripted_every=2):
    """Steps of alternating episodes: scripted pushes (they succeed) and random ones (they time
    out); yields each step's (obs, reward, terminated, truncated, info)."""
    policy = ScriptedPusher(env.unwrapped.dim, 0.3)
    obs, _ = env.reset(seed=seed)
    episode = 0
    for _ in range(steps):
        if episode % scripted_every == 0:
            action = policy(env.unwrapped.scene.obs[0])  # (the full state: the scripted pusher reads the goal)
        else:
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        out = env.step(action)
        yield out
        obs = out[0]
        if out[2] or out[3]:
            obs, _ = env.reset()
            episode += 1


def test_the_four_ids_are_registered_with_the_base_ids_episode_length():
    for goal_id, (base_id, dim) in GOAL_IDS.items():
        spec, base = gym.spec(goal_id), gym.spec(base_id)
        assert spec.max_episode_steps == base.max_episode_steps == 150
        assert spec.kwargs == base.kwargs and spec.kwargs["dim"] == dim
    assert isinstance(gym.make_vec("PenaltyBallsGoal2D-v0", num_envs=2), PenaltyBallsGoalVectorEnv)


@pytest.mark.parametrize("env_id", ["PenaltyBallsGoal-v0", "PenaltyBallsGoal2D-v1"])
def test_gymnasium_env_checker_passes(env_id):
    check_env(gym.make(env_id).unwrapped, skip_render_check=True)


@pytest.mark.parametrize("goal_id", ["PenaltyBallsGoal-v0", "PenaltyBallsGoal2D-v0", "PenaltyBallsGoal-v1"])
def test_the_observation_is_the_base_envs_regrouped_and_in_its_space(goal_id):
    base_id, dim = GOAL_IDS[goal_id]
    env, base = gym.make(goal_id), gym.make(base_id)
    full = gym.make(goal_id, observe_goal=True)
    layout = env.unwrapped.scene.layout
    ball, goal = layout.slice("ball position"), layout.slice("goal position")
    # observation: the base's without the goal's fields (observe_goal=True: all of it)
    kept = np.ones(layout.size, dtype=bool)
    kept[goal] = False
    kept[layout.slice("goal - ball")] = False
    assert env.observation_space["observation"].shape == (layout.size - 2 * dim,)
    assert np.array_equal(env.observation_space["observation"].low, base.observation_space.low[kept])
    assert full.observation_space["observation"] == base.observation_space
    full_obs, _ = full.reset(seed=4)
    assert env.observation_space["achieved_goal"].shape == (dim,)
    obs, _ = env.reset(seed=4)
    ref, _ = base.reset(seed=4)
    rng = np.random.default_rng(1)
    for _ in range(60):
        assert obs in env.observation_space
        assert np.array_equal(obs["observation"], ref[kept]) and np.array_equal(full_obs["observation"], ref)
        assert np.array_equal(obs["achieved_goal"], ref[ball]) and np.array_equal(obs["desired_goal"], ref[goal])
        action = rng.uniform(-1, 1, dim - 1).astype(np.float32)
        obs, _, _, _, _ = env.step(action)
        full_obs, _, _, _, _ = full.step(action)
        ref, _, _, _, ref_info = base.step(action)
        # the same physics: the base env's float64 distance, up to the goals' float32 rounding
        assert abs(goal_distance(obs["achieved_goal"], obs["desired_goal"], dim) - ref_info["distance"]) < 1e-5


@pytest.mark.parametrize("reward", ["sparse", "dense"])
@pytest.mark.parametrize("env_id", ["PenaltyBallsGoal-v0", "PenaltyBallsGoal2D-v0"])
def test_compute_reward_equals_the_step_reward_bit_for_bit(env_id, reward):
    env = gym.make(env_id, reward=reward)
    u = env.unwrapped
    tol = u.goal_tolerance
    successes = ends = 0
    for obs, r, terminated, truncated, info in rollout(env, 0, 500, np.random.default_rng(0)):
        ag, dg = obs["achieved_goal"], obs["desired_goal"]
        assert type(r) is float and r == float(u.compute_reward(ag, dg, info))
        assert type(terminated) is bool and terminated == info["is_success"]
        d = np.sqrt(np.sum((ag.astype(np.float64) - dg.astype(np.float64)) ** 2))
        assert terminated == bool(d < tol)
        if reward == "sparse":
            assert r == (0.0 if terminated else -1.0)
        else:
            assert r == pytest.approx(-d, rel=1e-15, abs=0.0)
        successes += terminated
        ends += terminated or truncated
    assert successes >= 2 and ends > successes  # both kinds of episode end were seen


@pytest.mark.parametrize("reward", ["sparse", "dense"])
def test_compute_reward_over_relabelled_batches_of_any_shape(reward):
    env = gym.make("PenaltyBallsGoal-v0", reward=reward)
    u = env.unwrapped
    steps = list(rollout(env, 3, 300, np.random.default_rng(2)))
    ag = np.array([s[0]["achieved_goal"] for s in steps])
    dg = np.array([s[0]["desired_goal"] for s in steps])
    infos = np.array([s[4] for s in steps])
    rewards = np.array([s[1] for s in steps])
    # the step's own goals, batched: the step's rewards, bit for bit
    assert np.array_equal(u.compute_reward(ag, dg, infos), rewards)
    # relabelled (HER's "future": goals achieved later), some of them reached exactly
    rng = np.random.default_rng(7)
    later = np.minimum(np.arange(len(ag)) + rng.integers(0, 4, len(ag)), len(ag) - 1)
    new_goals = ag[later]
    one_by_one = np.array([u.compute_reward(a, g, None) for a, g in zip(ag, new_goals)])
    assert one_by_one.shape == (len(ag),) and one_by_one.dtype == np.float64
    for shape in [(len(ag),), (20, 15), (5, 6, 10)]:
        k = int(np.prod(shape))
        a, g = ag[:k].reshape(shape + (3,)), new_goals[:k].reshape(shape + (3,))
        batched = u.compute_reward(a, g, [{}] * k)
        assert batched.shape == shape and np.array_equal(batched.ravel(), one_by_one[:k])
    if reward == "sparse":
        assert set(np.unique(one_by_one)) == {-1.0, 0.0}  # both outcomes were relabelled
    # broadcasting: one goal against many achieved ones
    assert np.array_equal(u.compute_reward(ag, dg[0], None), [u.compute_reward(a, dg[0]) for a in ag])


def _sync_twin(env_id, n, mode, **kwargs):
    return SyncVectorEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)], autoreset_mode=mode)


@pytest.mark.parametrize(
    "env_id, mode",
    [
        ("PenaltyBallsGoal-v0", AutoresetMode.NEXT_STEP),
        ("PenaltyBallsGoal-v0", AutoresetMode.SAME_STEP),
        ("PenaltyBallsGoal2D-v0", AutoresetMode.NEXT_STEP),
    ],
)
def test_vector_env_worlds_equal_single_envs_seeded_seed_plus_i(env_id, mode):
    n, dim = 4, GOAL_IDS[env_id][1]
    kwargs = dict(max_episode_steps=100, reward="dense" if mode == AutoresetMode.SAME_STEP else "sparse")
    native = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode, **kwargs)
    twin = _sync_twin(env_id, n, mode, **kwargs)
    policy = ScriptedPusher(dim, 0.3)
    rng = np.random.default_rng(0)
    a, b = native.reset(seed=11), twin.reset(seed=11)
    assert data_equivalence(a, b, exact=True), "reset"
    obs = a[0]
    successes = ends = 0
    for t in range(300):
        acts = rng.uniform(-1, 1, (n, dim - 1)).astype(np.float32)
        for i in range(0, n, 2):  # even worlds push scripted (they succeed), odd ones at random
            acts[i] = policy(native.unwrapped.scene.obs[i])  # (the full state vector)
        a, b = native.step(acts), twin.step(acts)
        for name, x, y in zip(("obs", "reward", "terminated", "truncated", "info"), a, b):
            assert data_equivalence(x, y, exact=True), f"{name} at step {t}"
        obs = a[0]
        assert obs in native.observation_space
        successes += int(a[2].sum())
        ends += int((a[2] | a[3]).sum())
        if mode == AutoresetMode.SAME_STEP and a[2].any():
            i = int(np.flatnonzero(a[2])[0])
            final = a[4]["final_obs"][i]
            assert isinstance(final, dict) and final in native.single_observation_space
    assert successes >= 2 and ends > successes


def test_disabled_autoreset_with_a_reset_mask_equals_sync_vector_env():
    mode = AutoresetMode.DISABLED
    native = gym.make_vec("PenaltyBallsGoal-v0", num_envs=3, autoreset_mode=mode, max_episode_steps=20)
    twin = _sync_twin("PenaltyBallsGoal-v0", 3, mode, max_episode_steps=20)
    assert data_equivalence(native.reset(seed=3), twin.reset(seed=3), exact=True)
    acts = np.full((3, 2), 0.3, np.float32)
    for t in range(20):
        assert data_equivalence(native.step(acts), twin.step(acts), exact=True), f"step {t}"
    with pytest.raises(RuntimeError, match="reset_mask"):
        native.step(acts)
    mask = np.array([True, False, True])
    a = native.reset(options={"reset_mask": mask})
    b = twin.reset(options={"reset_mask": mask.copy()})
    assert data_equivalence(a, b, exact=True)


def test_sb3_her_replay_buffer_trains_sac_through_compute_reward():
    sb3 = pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = make_vec_env("PenaltyBallsGoal2D-v0", n_envs=2, seed=0, vec_env_cls=DummyVecEnv)
    calls = []
    compute = PenaltyBallsGoalEnv.compute_reward

    def spy(self, achieved_goal, desired_goal, info):
        calls.append(achieved_goal.shape)
        return compute(self, achieved_goal, desired_goal, info)

    model = sb3.SAC(
        "MultiInputPolicy",
        venv,
        replay_buffer_class=sb3.HerReplayBuffer,
        replay_buffer_kwargs=dict(n_sampled_goal=4, goal_selection_strategy="future"),
        learning_starts=300,
        batch_size=32,
        policy_kwargs=dict(net_arch=[16]),
        seed=0,
        device="cpu",
    )
    PenaltyBallsGoalEnv.compute_reward = spy  # type: ignore[method-assign]
    try:
        model.learn(400)
    finally:
        PenaltyBallsGoalEnv.compute_reward = compute  # type: ignore[method-assign]
    assert model.num_timesteps == 400
    # the relabelled samples' rewards came from the env's compute_reward, batched
    assert any(len(shape) == 2 and shape[1] == 2 for shape in calls)
    buf = model.replay_buffer
    assert buf.n_envs == 2 and buf.size() > 0


def test_bad_input_is_refused_with_a_clear_error():
    with pytest.raises(ValueError, match=r"reward must be one of \('sparse', 'dense'\), got 'shaped'"):
        gym.make("PenaltyBallsGoal-v0", reward="shaped")
    with pytest.raises(TypeError, match="reward must be one of"):
        gym.make_vec("PenaltyBallsGoal-v0", num_envs=2, reward=1)
    with pytest.raises(ValueError, match=r"obs_mode must be 'state' for the goal-conditioned envs.*'rgb'"):
        gym.make("PenaltyBallsGoal-v0", obs_mode="rgb")
    with pytest.raises(ValueError, match="observe_goal"):
        gym.make("PenaltyBallsGoal-v0", observe_goal="yes")
    with pytest.raises(ValueError, match="grains must be 0"):
        PenaltyBallsGoalEnv(dim=2, grains=10, physics="rolling")
    with pytest.raises(ValueError, match="grains must be 0"):
        PenaltyBallsGoalVectorEnv(2, grains=300)
    env = gym.make("PenaltyBallsGoal-v0").unwrapped
    with pytest.raises(ValueError, match=r"achieved_goal must have shape \(\.\.\., 3\).*\(4, 2\)"):
        env.compute_reward(np.zeros((4, 2)), np.zeros((4, 3)), None)
    with pytest.raises(ValueError, match="broadcast"):
        env.compute_reward(np.zeros((4, 3)), np.zeros((5, 3)), None)
    with pytest.raises(ValueError, match="desired_goal must be finite"):
        env.compute_reward(np.zeros(3), np.array([0.0, np.nan, 0.0]), None)
    with pytest.raises(TypeError, match="achieved_goal must be an array of real numbers"):
        env.compute_reward("ball", np.zeros(3), None)
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(2, np.float32))
