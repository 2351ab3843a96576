"""train/collect.py: episodes recorded into a Minari dataset replay exactly in a fresh env.

Each stored episode is replayed from its stored seed with its stored actions, in an env made
from the id and in the env Minari recovers from the dataset's stored spec: observations (float32,
bit for bit), rewards, terminations and truncations must equal the stored ones exactly.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

minari = pytest.importorskip("minari")
pytest.importorskip("h5py")
pytest.importorskip("jax")  # minari[create]: its DataCollector's episode buffers

import gymnasium as gym  # noqa: E402

import penalty_env  # noqa: E402, F401

# the v0 ids are made on purpose (penalty_env silences this warning at import; pytest resets the filters)
pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "train"))

import collect  # noqa: E402


def _replay(env, episode, seed):
    """Replay ``episode``'s actions from ``seed`` in ``env``; returns the same fields as stored."""
    obs, _ = env.reset(seed=seed)
    observations, rewards, terminations, truncations = [obs], [], [], []
    for action in episode.actions:
        obs, reward, terminated, truncated, _ = env.step(action)
        observations.append(obs)
        rewards.append(reward)
        terminations.append(terminated)
        truncations.append(truncated)
    return np.stack(observations), np.array(rewards), np.array(terminations), np.array(truncations)


def _check_replays(dataset, env_id, seeds):
    episodes = list(dataset.iterate_episodes())
    stored_seeds = [m["seed"] for m in dataset.storage.get_episode_metadata(range(dataset.total_episodes))]
    assert stored_seeds == seeds
    fresh = gym.make(env_id)
    recovered = dataset.recover_environment()
    assert recovered.spec.id == env_id and recovered.spec.max_episode_steps == fresh.spec.max_episode_steps
    for episode, seed in zip(episodes, stored_seeds):
        assert episode.observations.dtype == np.float32 and episode.actions.dtype == np.float32
        assert episode.terminations[-1] or episode.truncations[-1]  # whole episodes only
        assert not (episode.terminations[:-1] | episode.truncations[:-1]).any()
        for env in (fresh, recovered):
            obs, rewards, terminations, truncations = _replay(env, episode, seed)
            assert obs.tobytes() == episode.observations.tobytes()
            assert rewards.tobytes() == episode.rewards.astype(np.float64).tobytes()
            assert episode.rewards.dtype == np.float64  # the env's float rewards, stored whole
            np.testing.assert_array_equal(terminations, episode.terminations)
            np.testing.assert_array_equal(truncations, episode.truncations)
    return episodes


def test_scripted_episodes_replay_exactly_from_their_stored_seeds(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))  # collect(out=...) sets it too
    collect.collect(env_id="PenaltyBalls2D-v0", episodes=3, seed=7, out=tmp_path, ref_episodes=0)
    dataset = minari.load_dataset("penalty_env/PenaltyBalls2D-v0/scripted-v0")
    assert dataset.total_episodes == 3
    episodes = _check_replays(dataset, "PenaltyBalls2D-v0", [7, 8, 9])
    # the scripted pusher reaches the goal: an episode ends by termination before the time limit
    assert any(ep.terminations[-1] and len(ep.actions) < 150 for ep in episodes)
    assert dataset.storage.metadata["algorithm_name"].startswith("ScriptedPusher")


def test_a_trained_run_is_recorded_with_its_normalisation(tmp_path, monkeypatch):
    """A run folder as train_ppo.py writes it (an untrained policy: the loading is under test);
    the recorded actions are the model's deterministic actions on the normalised observations."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from penalty_env.sb3 import make_vec_env

    run = tmp_path / "run"
    run.mkdir()
    venv = VecNormalize(make_vec_env("PenaltyBalls-v0", n_envs=2, seed=0))
    venv.reset()
    for _ in range(20):  # statistics that are not the identity
        venv.step(np.random.default_rng(0).uniform(-1, 1, (2, 2)).astype(np.float32))
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=32, device="cpu", seed=0)
    model.save(run / "model.zip")
    venv.save(str(run / "vecnormalize.pkl"))
    (run / "summary.json").write_text(json.dumps({"env_id": "PenaltyBalls-v0", "env_kwargs": {}}))

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "data"))
    dataset = collect.collect(episodes=2, seed=100, out=tmp_path / "data", policy_run=run, ref_episodes=0)
    assert dataset.spec.dataset_id == "penalty_env/PenaltyBalls-v0/ppo-v0"
    episodes = _check_replays(minari.load_dataset("penalty_env/PenaltyBalls-v0/ppo-v0"), "PenaltyBalls-v0", [100, 101])
    stats = VecNormalize.load(str(run / "vecnormalize.pkl"), make_vec_env("PenaltyBalls-v0", n_envs=1, seed=0))
    first = episodes[0]
    for obs, action in zip(first.observations[:5], first.actions[:5]):  # one observation at a time, as played
        expected, _ = model.predict(stats.normalize_obs(obs[None]), deterministic=True)
        assert action.tobytes() == expected[0].tobytes()
    with pytest.raises(ValueError, match=r"takes observations of shape \(21,\), but PenaltyBalls2D-v0"):
        collect.collect(env_id="PenaltyBalls2D-v0", episodes=1, out=tmp_path / "data", policy_run=run)


def test_bad_arguments_are_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))  # restored after the test, as collect() sets it
    with pytest.raises(ValueError, match="episodes must be an int >= 1, got 0"):
        collect.collect(episodes=0, out=tmp_path)
    with pytest.raises(ValueError, match="--policy must be a run folder"):
        collect.collect(episodes=1, out=tmp_path, policy_run=tmp_path)
    collect.collect(episodes=1, out=tmp_path, ref_episodes=0)
    with pytest.raises(ValueError, match="already exists"):  # Minari never overwrites a dataset
        collect.collect(episodes=1, out=tmp_path, ref_episodes=0)
