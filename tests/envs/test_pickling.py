"""A stepped env and vector env pickle and deep-copy, and the copy's episode goes on bit for bit as
the original's: in this process, and unpickled in a fresh one (the compiled step kernel is not part
of the state; the copy finds it again, cached, on its first step)."""

from __future__ import annotations

import copy
import pickle
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401  (registers the ids)


def _roll(env, actions) -> list:
    out = []
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        out.append((np.asarray(obs).tobytes(), np.asarray(reward).tobytes(), terminated, truncated))
    return out


@pytest.mark.parametrize("env_id", ["PenaltyBalls-v0", "PenaltyBalls-v1"])
@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_stepped_env_copies_and_goes_on_bit_for_bit(env_id, how):
    env = gym.make(env_id)
    env.reset(seed=3)
    env.action_space.seed(3)
    for _ in range(5):
        env.step(env.action_space.sample())
    twin = pickle.loads(pickle.dumps(env)) if how == "pickle" else copy.deepcopy(env)
    actions = [env.action_space.sample() for _ in range(30)]
    assert _roll(env, actions) == _roll(twin, actions)
    # and both reset alike
    assert np.array_equal(env.reset(seed=9)[0], twin.reset(seed=9)[0])


def test_a_stepped_vector_env_unpickled_in_a_fresh_process_goes_on_bit_for_bit():
    envs = gym.make_vec("PenaltyBalls-v0", num_envs=4)
    envs.reset(seed=11)
    envs.action_space.seed(11)
    for _ in range(5):
        envs.step(envs.action_space.sample())
    blob = pickle.dumps(envs)
    actions = np.stack([envs.action_space.sample() for _ in range(20)])
    here = [(o.tobytes(), r.tobytes(), t.tobytes(), u.tobytes()) for o, r, t, u, _ in map(envs.step, actions)]
    copied = copy.deepcopy(pickle.loads(blob))
    assert [(o.tobytes(), r.tobytes(), t.tobytes(), u.tobytes()) for o, r, t, u, _ in map(copied.step, actions)] == here
    code = textwrap.dedent(
        """
        import pickle, sys, numpy as np
        envs, actions = pickle.loads(sys.stdin.buffer.read())
        out = [(o.tobytes(), r.tobytes(), t.tobytes(), u.tobytes()) for o, r, t, u, _ in map(envs.step, actions)]
        sys.stdout.buffer.write(pickle.dumps(out))
        """
    )
    child = subprocess.run(
        [sys.executable, "-c", code], input=pickle.dumps((pickle.loads(blob), actions)), capture_output=True, check=True
    )
    assert pickle.loads(child.stdout) == here
