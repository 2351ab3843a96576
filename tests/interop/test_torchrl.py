"""TorchRL over the native vector env: a rollout through ``GymWrapper`` holds exactly the
episodes of the vector env stepped by hand with the same seed and actions, in both autoreset
modes TorchRL accepts. ``Disabled``: TorchRL resets the ended worlds through
``options["reset_mask"]``, so the episodes are the env's own. ``SameStep``: the env resets a world
within the step that ends its episode, and when every world ended on the same step, TorchRL
resets them all once more (its ``GymWrapper._reset`` calls ``reset()`` when ``_reset`` is all
True): those worlds start from their generators' next draw (docs/interop.md says so)."""

from __future__ import annotations

import multiprocessing

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401
from penalty_env.envs.scripted import ScriptedPusher

# the v0 ids are made on purpose (penalty_env silences this warning at import; pytest resets the filters)
pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")

N, STEPS = 3, 340  # past two 150-step episodes of every world


@pytest.fixture(scope="module")
def torchrl():
    method = multiprocessing.get_start_method(allow_none=True)
    module = pytest.importorskip("torchrl.envs")
    if multiprocessing.get_start_method(allow_none=True) != method:  # TorchRL's import sets spawn
        multiprocessing.set_start_method(method, force=True)
    return module


PUSHER = ScriptedPusher()  # PenaltyBalls-v0's defaults: the worlds reach the goal at different steps


def _act(obs, t, scripted):
    """``scripted``: the scripted pusher, and every third step a random push, so episodes end at
    different steps, by success or by the time limit; else random pushes only (every world's
    episode then ends at the time limit, all on the same step)."""
    if scripted and t % 3:
        return PUSHER(obs)
    return np.random.default_rng(t).uniform(-1, 1, (N, 2)).astype(np.float32)


def _by_hand(mode, scripted):
    """Observations before each step, observations after it (the final one where an episode
    ended), rewards, terminations and truncations, stepping the vector env directly."""
    venv = gym.make_vec("PenaltyBalls-v0", num_envs=N, autoreset_mode=mode)
    obs, _ = venv.reset(seed=11)
    before, after, rewards, terms, truncs = [], [], [], [], []
    for t in range(STEPS):
        before.append(obs)
        obs, reward, term, trunc, info = venv.step(_act(obs, t, scripted))
        done = term | trunc
        final = obs.copy()
        if mode == "SameStep":
            for i in np.flatnonzero(done):
                final[i] = info["final_obs"][i]
            if done.all():  # TorchRL then resets every world once more (GymWrapper._reset)
                obs = venv.reset()[0]
        elif done.any():
            obs = venv.reset(options={"reset_mask": done})[0]
        after.append(final), rewards.append(reward), terms.append(term), truncs.append(trunc)
    return [np.stack(x, axis=1) for x in (before, after, rewards, terms, truncs)]


@pytest.mark.parametrize("mode, scripted", [("SameStep", True), ("Disabled", True), ("SameStep", False)])
def test_torchrl_rollout_is_the_vector_env_stepped_by_hand(torchrl, mode, scripted):
    import torch

    env = torchrl.GymWrapper(gym.make_vec("PenaltyBalls-v0", num_envs=N, autoreset_mode=mode))
    step = iter(range(STEPS))

    def policy(td):
        td["action"] = torch.from_numpy(_act(td["observation"].numpy(), next(step), scripted))
        return td

    td0 = env.reset(seed=11)
    rollout = env.rollout(STEPS, policy, auto_reset=False, tensordict=td0, break_when_any_done=False)
    before, after, rewards, terms, truncs = _by_hand(mode, scripted)
    ends = terms | truncs
    assert (ends.sum(axis=1) >= 2).all()  # two episodes per world at least
    if scripted:  # successes, and steps where some worlds ended while others went on
        assert terms.any() and (ends.any(axis=0) & ~ends.all(axis=0)).any()
    else:
        assert ends.all(axis=0).any()
    assert rollout["observation"].numpy().tobytes() == before.tobytes()
    assert rollout["next", "observation"].numpy().tobytes() == after.tobytes()
    np.testing.assert_array_equal(rollout["next", "reward"].numpy()[..., 0], rewards.astype(np.float32))
    np.testing.assert_array_equal(rollout["next", "terminated"].numpy()[..., 0], terms)
    np.testing.assert_array_equal(rollout["next", "truncated"].numpy()[..., 0], truncs)
