"""``train/evaluate.py``'s report says what is played: how many worlds, their seeds and how many
episodes each plays, as ``run_episodes`` plays them (no training run: a stand-in VecEnv)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "train"))

import _common as C  # noqa: E402


class _Worlds:
    """A VecEnv stand-in: world i ends an episode every ``lengths[i]`` steps; ``ended[i]`` counts them."""

    def __init__(self, lengths):
        self.lengths = np.asarray(lengths)
        self.num_envs = len(lengths)
        self.t = np.zeros(self.num_envs, int)
        self.ended = np.zeros(self.num_envs, int)

    def reset(self):
        return np.zeros((self.num_envs, 1), np.float32)

    def step(self, actions):
        self.t += 1
        dones = self.t % self.lengths == 0
        self.ended += dones
        infos = [{"is_success": True} for _ in range(self.num_envs)]
        return self.reset(), np.ones(self.num_envs), dones, infos


@pytest.mark.parametrize(("n_episodes", "n_envs"), [(100, 20), (101, 20), (119, 20), (10, 1), (20, 20), (7, 3)])
def test_the_report_names_the_worlds_seeds_and_episodes_each_that_run_episodes_plays(n_episodes, n_envs):
    seed = 3_000_000
    venv = _Worlds(lengths=[1 + (i % 4) for i in range(n_envs)])  # short and long episodes side by side
    result = C.run_episodes(venv, lambda obs: np.zeros((len(obs), 1)), n_episodes)
    per = C.episodes_per_world(n_episodes, n_envs)
    assert result["episodes"] == n_episodes == sum(per)
    # every world played at least its share (the run stops when the slowest has its count) ...
    assert (venv.ended >= per).all()
    # ... and the shares are even: at most one apart, the extra ones on the last worlds
    assert max(per) - min(per) <= 1 and per == sorted(per)
    text = C.describe_episodes(n_episodes, n_envs, seed)
    assert text.startswith(f"{n_episodes} episodes: ")
    if n_envs == 1:
        assert f"1 world (seed {seed}) plays them one after another" in text
    else:
        assert f"{n_envs} worlds (seeds {seed}..{seed + n_envs - 1}) play {per[0]} each" in text
        more = per.count(per[0] + 1)
        if more > 1:
            assert f"the last {more} (seeds {seed + n_envs - more}..{seed + n_envs - 1}) one more" in text
        elif more == 1:
            assert f"the last (seed {seed + n_envs - 1}) one more" in text
        else:
            assert "one more" not in text
    assert ("one after another" in text) == (max(per) > 1)


def test_the_default_report_says_20_worlds_play_5_episodes_each():
    """evaluate.py's defaults (100 episodes, 20 worlds, first seed 3,000,000), in the issue's words."""
    assert C.describe_episodes(100, 20, 3_000_000) == (
        "100 episodes: 20 worlds (seeds 3000000..3000019) play 5 each, one after another; "
        "a world's first episode starts from its seed, the next ones continue its generator"
    )


def test_more_worlds_than_episodes_is_refused():
    with pytest.raises(ValueError, match="n_envs must be between 1 and n_episodes=5, got 6"):
        C.describe_episodes(5, 6, 0)


def test_two_policies_play_the_same_episodes_key_by_key_and_their_lead_pairs_up():
    """A world's k-th episode starts from the same state whatever the policy played before it (the
    level task: heap and target drawn at reset), so ``run_episodes``' keys pair two policies'
    returns; ``paired_difference`` is the mean and standard error of the per-episode lead."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class Starts(VecEnvWrapper):
        """Records each episode's first observation under its key (world, k)."""

        def reset(self):
            obs = self.venv.reset()
            self.count = np.zeros(self.num_envs, int)
            self.starts = {(i, 0): obs[i].copy() for i in range(self.num_envs)}
            return obs

        def step_wait(self):
            obs, r, done, infos = self.venv.step_wait()
            for i in np.flatnonzero(done):
                self.count[i] += 1
                self.starts[(int(i), int(self.count[i]))] = obs[i].copy()
            return obs, r, done, infos

    kw = {"target": "random"}
    played = []
    for make_policy in (lambda v: C.scripted_policy(v), lambda v: C.random_policy(v.action_space, 1)):
        venv = Starts(C.make_env("PenaltySandLevel2D-v0", 3, 77, kw))
        played.append((C.run_episodes(venv, make_policy(venv), 7), venv.starts))
    (sweep, s_starts), (rand, r_starts) = played
    assert sorted(sweep["keys"]) == sorted(rand["keys"]) and len(sweep["keys"]) == 7
    for key in sweep["keys"]:
        assert np.array_equal(s_starts[key], r_starts[key]), key
    lead, se, n = C.paired_difference(sweep, rand)
    by_key = dict(zip(rand["keys"], rand["returns"]))
    d = [r - by_key[k] for k, r in zip(sweep["keys"], sweep["returns"])]
    assert n == 7 and lead == pytest.approx(np.mean(d)) and se == pytest.approx(np.std(d, ddof=1) / np.sqrt(7))
    assert lead > 0  # (the sweep levels; a random blade barely does)
    with pytest.raises(ValueError, match="at least 2 episodes played by both, got 0"):
        C.paired_difference(sweep, {"keys": [], "returns": []})


def test_the_sweep_is_offered_only_where_it_can_read_the_state():
    """The raster sweep reads the blade from the level task's state vector: a level env observing
    its height map or pixels gets no scripted baseline (rather than an IndexError later), nor does
    a task without a sweep."""
    assert C.scripted_policy(C.make_env("PenaltySandLevel2D-v0", 2, 0, {})) is not None
    assert C.scripted_policy(C.make_env("PenaltySandLevel2D-v0", 2, 0, {"obs_mode": "heightmap"})) is None
    assert C.scripted_policy(C.make_env("PenaltyBalls2D-v0", 2, 0, {})) is None
