"""A warm start by imitation: PPO's policy first copies the task's scripted controller.

:func:`imitate` plays the scripted policy (``_common.scripted_policy``: the level task's raster
sweep) on the training worlds for a number of decisions, then fits the policy's mean action to the
controller's actions and its value to the discounted returns of those episodes that terminated
(least squares, the rewards and observations as the run's ``VecNormalize`` sees them). PPO then
starts from a policy that already does what the controller does, and has to find what does
better. The demonstration's steps go through the training env: ``VecNormalize``'s statistics and
the env's clock count them, and the run's summary records them apart from PPO's.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _rollout(venv, vecnorm, teacher, decisions: int) -> tuple[np.ndarray, ...]:
    """``decisions`` of ``teacher`` on ``venv`` from a reset (whole steps of every world, at least
    ``decisions`` in all): the raw observations, the actions, the raw rewards, the dones and which
    of those were a time limit's truncation."""
    obs = venv.reset()
    observations, actions, rewards, dones, cut = [], [], [], [], []
    for _ in range(-(-decisions // venv.num_envs)):
        raw = vecnorm.get_original_obs() if vecnorm is not None else obs
        act = np.asarray(teacher(raw), dtype=np.float32)
        obs, reward, done, infos = venv.step(act)
        observations.append(np.array(raw, dtype=np.float32))
        actions.append(act)
        rewards.append(np.asarray(vecnorm.get_original_reward() if vecnorm is not None else reward, dtype=np.float64))
        dones.append(np.asarray(done, dtype=bool))
        cut.append(np.array([bool(d and info.get("TimeLimit.truncated", False)) for d, info in zip(done, infos)]))
    return tuple(np.stack(a) for a in (observations, actions, rewards, dones, cut))


def _returns(
    rewards: np.ndarray, dones: np.ndarray, truncated: np.ndarray, gamma: float
) -> tuple[np.ndarray, np.ndarray]:
    """Discounted returns of each (step, world) within its episode, and which of them are the
    whole return: those of episodes that terminated. An episode cut off by the time limit (PPO
    bootstraps it from the value of its last state) or by the end of the demonstration is left out
    of the value's fit."""
    ret = np.zeros_like(rewards)
    whole = np.zeros_like(dones)
    acc = np.zeros(rewards.shape[1])
    valid = np.zeros(rewards.shape[1], dtype=bool)
    for t in range(len(rewards) - 1, -1, -1):
        acc = np.where(dones[t], 0.0, acc)
        valid = np.where(dones[t], ~truncated[t], valid)
        acc = rewards[t] + gamma * acc
        ret[t], whole[t] = acc, valid
    return ret, whole


def imitate(model, venv, vecnorm, teacher, decisions: int, epochs: int = 40, batch: int = 256) -> dict[str, Any]:
    """Fit ``model``'s policy (an SB3 ``ActorCriticPolicy``) to ``teacher`` over ``decisions``
    decisions on ``venv`` (see the module docstring). Returns the fit's figures: the decisions
    played, the demonstration's episodes and mean episode return, and the fit's mean squared
    errors over the whole demonstration (the value's over the terminated episodes)."""
    import torch as th

    obs, act, rew, done, cut = _rollout(venv, vecnorm, teacher, decisions)
    episode_returns = []
    acc = np.zeros(rew.shape[1])
    for t in range(len(rew)):
        acc += rew[t]
        episode_returns += acc[done[t]].tolist()
        acc[done[t]] = 0.0
    norm_obs = vecnorm.normalize_obs(obs) if vecnorm is not None else obs
    norm_rew = vecnorm.normalize_reward(rew) if vecnorm is not None else rew
    ret, ended = _returns(norm_rew, done, cut, model.gamma)
    x = th.as_tensor(norm_obs.reshape(-1, obs.shape[-1]), dtype=th.float32)
    y = th.as_tensor(act.reshape(len(x), -1), dtype=th.float32)
    g = th.as_tensor(ret.reshape(-1), dtype=th.float32)
    keep = th.as_tensor(ended.reshape(-1))
    policy = model.policy

    def heads(obs):  # the policy's mean action and value (SB3's forward, without the noise)
        features = policy.extract_features(obs)
        pi_f, vf_f = features if isinstance(features, tuple) else (features, features)
        mean = policy.action_net(policy.mlp_extractor.forward_actor(pi_f))
        return mean, policy.value_net(policy.mlp_extractor.forward_critic(vf_f)).squeeze(-1)

    opt = th.optim.Adam(policy.parameters(), lr=1e-3)
    gen = th.Generator().manual_seed(int(model.seed or 0))
    for _ in range(epochs):
        order = th.randperm(len(x), generator=gen)
        for k in range(0, len(x), batch):
            idx = order[k : k + batch]
            mean, value = heads(x[idx])
            pi_loss = ((mean - y[idx]) ** 2).mean()
            m = keep[idx]
            vf_loss = ((value - g[idx])[m] ** 2).mean() if bool(m.any()) else th.zeros(())
            opt.zero_grad()
            (pi_loss + 0.5 * vf_loss).backward()
            opt.step()
    with th.no_grad():  # the fit's errors over the whole demonstration
        mean, value = heads(x)
        pi_err = float(((mean - y) ** 2).mean())
        vf_err = float(((value - g)[keep] ** 2).mean()) if bool(keep.any()) else float("nan")
    return {
        "decisions": int(obs.shape[0] * obs.shape[1]),
        "episodes": len(episode_returns),
        "teacher_mean_return": float(np.mean(episode_returns)) if episode_returns else float("nan"),
        "action_mse": round(pi_err, 5),
        "value_mse": round(vf_err, 5),
    }
