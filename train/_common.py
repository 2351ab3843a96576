"""Shared pieces of ``train_ppo.py`` and ``evaluate.py``: environments, evaluation, GIFs."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper

# Held-out seeds: training worlds use seed + i (i < n_envs); evaluation during training uses
# EVAL_SEED_OFFSET + seed + i; the final report uses FINAL_SEED_OFFSET + seed + i. The ranges are
# far apart, so no evaluation episode starts from a training seed.
EVAL_SEED_OFFSET = 1_000_000
FINAL_SEED_OFFSET = 2_000_000


def parse_env_kwargs(pairs: list[str]) -> dict[str, Any]:
    """``["n_obstacles=2", "goal_tolerance=0.1"]`` -> dict, values parsed as JSON when possible."""
    out: dict[str, Any] = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise SystemExit(f"--env-kwarg expects key=value, got {pair!r}")
        key, raw = pair.split("=", 1)
        try:
            out[key] = json.loads(raw)
        except json.JSONDecodeError:
            out[key] = raw
    return out


def make_env(
    env_id: str,
    n_envs: int,
    seed: int,
    env_kwargs: dict[str, Any],
    render_mode: str | None = None,
    stagger: bool = False,
    action_repeat: int = 1,
):
    """Our batched SB3 VecEnv (one Numba call steps all worlds), wrapped in VecMonitor;
    ``stagger``: the worlds' first episodes out of phase (``PenaltyBallsVecEnv.stagger``);
    ``action_repeat`` > 1: in :class:`ActionRepeat` (the training's worlds; evaluations step every
    env step, :func:`run_episodes`)."""
    from penalty_env.sb3 import make_vec_env

    kwargs = dict(env_kwargs)
    if render_mode is not None:
        kwargs["render_mode"] = render_mode
    venv = make_vec_env(env_id=env_id, n_envs=n_envs, seed=seed, **kwargs)
    if stagger:
        venv.venv.stagger(seed)
    return ActionRepeat(venv, action_repeat) if action_repeat > 1 else venv


def episodes_per_world(n_episodes: int, n_envs: int) -> list[int]:
    """How many episodes :func:`run_episodes` counts in each world: ``n_episodes`` shared out as
    evenly as can be (as SB3's ``evaluate_policy`` does), the last worlds taking one more when
    ``n_envs`` does not divide it."""
    return [(n_episodes + i) // n_envs for i in range(n_envs)]


def describe_episodes(n_episodes: int, n_envs: int, seed: int) -> str:
    """What :func:`run_episodes` plays on ``n_envs`` worlds made by :func:`make_env` with ``seed``,
    in words: ``"100 episodes: 20 worlds (seeds 3000000..3000019) play 5 each, one after another"``
    (:func:`episodes_per_world`). World i is seeded ``seed + i`` once: its first episode starts from
    that seed, its later ones continue the world's generator (autoreset, no reseed)."""
    if not 1 <= n_envs <= n_episodes:
        raise ValueError(f"n_envs must be between 1 and n_episodes={n_episodes}, got {n_envs}")
    per = episodes_per_world(n_episodes, n_envs)
    text = f"{n_episodes} episode{'s' if n_episodes != 1 else ''}: "
    if n_envs == 1:
        text += f"1 world (seed {seed}) plays {'them one after another' if n_episodes > 1 else 'it'}"
    else:
        text += f"{n_envs} worlds (seeds {seed}..{seed + n_envs - 1}) play {per[0]} each"
        more = n_envs - per.count(per[0])  # the last worlds' one more
        if more == 1:
            text += f", the last (seed {seed + n_envs - 1}) one more"
        elif more:
            text += f", the last {more} (seeds {seed + n_envs - more}..{seed + n_envs - 1}) one more"
        if per[-1] > 1:
            text += ", one after another"
    if per[-1] > 1:
        text += "; a world's first episode starts from its seed, the next ones continue its generator"
    return text


def run_episodes(
    venv, act: Callable[[np.ndarray], np.ndarray], n_episodes: int, action_repeat: int = 1
) -> dict[str, Any]:
    """Run exactly ``n_episodes`` episodes, the same number in each world (as SB3's
    ``evaluate_policy`` does, so short successful episodes are not over-counted;
    :func:`episodes_per_world`, :func:`describe_episodes`). ``action_repeat``: the policy's action is
    taken at an episode's first step and every ``action_repeat`` steps after, each world on its own
    clock, and held in between (as :class:`ActionRepeat` trains it).

    Returns the success rate, mean and std of the episode return, and the per-episode lists (in
    the order the episodes ended); ``keys`` names each episode ``(world, k)``, its world's k-th,
    which is the same episode for any policy (a world draws from its generator only at a reset), so
    two policies' returns pair up key by key (:func:`paired_difference`).
    """
    n_envs = venv.num_envs
    per_env = np.array(episodes_per_world(n_episodes, n_envs))
    done_counts = np.zeros(n_envs, dtype=int)
    returns, successes, keys = [], [], []
    running = np.zeros(n_envs)
    obs = venv.reset()
    clock = np.zeros(n_envs, dtype=int)  # steps since each world's last decision (always 0 without a repeat)
    actions = None
    while (done_counts < per_env).any():
        if actions is None or (clock == 0).any():  # (the policy runs only when some world decides)
            fresh = act(obs)
            decide = (clock == 0).reshape((-1,) + (1,) * (fresh.ndim - 1))
            actions = fresh if actions is None or decide.all() else np.where(decide, fresh, actions)
        obs, rewards, dones, infos = venv.step(actions)
        clock = np.where(dones, 0, (clock + 1) % action_repeat)
        running += rewards
        for i in np.flatnonzero(dones):
            if done_counts[i] < per_env[i]:
                returns.append(float(running[i]))
                successes.append(bool(infos[i].get("is_success", False)))
                keys.append((int(i), int(done_counts[i])))
                done_counts[i] += 1
            running[i] = 0.0
    return {
        "success_rate": float(np.mean(successes)),
        "mean_return": float(np.mean(returns)),
        "std_return": float(np.std(returns)),
        "episodes": len(returns),
        "returns": returns,
        "successes": successes,
        "keys": keys,
    }


def mean_and_se(d: np.ndarray) -> tuple[float, float]:
    """The mean of ``d`` and its standard error (at least 2 values)."""
    d = np.asarray(d, dtype=float)
    if len(d) < 2:
        raise ValueError(f"a standard error needs at least 2 values, got {len(d)}")
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(len(d)))


def paired_difference(a: dict[str, Any], b: dict[str, Any]) -> tuple[float, float, int]:
    """The mean of ``a``'s return minus ``b``'s over the episodes both played (two
    :func:`run_episodes` results on the same worlds and seeds, paired by ``keys``), its standard
    error, and the number of pairs."""
    rb = dict(zip(map(tuple, b["keys"]), b["returns"]))
    d = np.array([r - rb[tuple(k)] for k, r in zip(a["keys"], a["returns"]) if tuple(k) in rb])
    if len(d) < 2:
        raise ValueError(f"paired_difference needs at least 2 episodes played by both, got {len(d)}")
    return (*mean_and_se(d), len(d))


class ActionRepeat(VecEnvWrapper):
    """The agent decides every ``repeat`` env steps (frame skip): each action is held for
    ``repeat`` steps of the VecEnv below and their rewards add up. A world whose episode ends
    within a hold is reset there (SB3's VecEnv resets it) and steps its new episode with the held
    action for the rest of the hold; those steps' rewards are added to its next decision's, so
    each episode's rewards are counted once, in its own return. (A new episode shorter than the
    rest of the hold would end unseen: the level task's cannot.)"""

    def __init__(self, venv, repeat: int) -> None:
        super().__init__(venv)
        self.repeat = int(repeat)
        self._carry = np.zeros(venv.num_envs)
        self._actions: np.ndarray | None = None

    def reset(self):
        self._carry[:] = 0.0
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        n = self.num_envs
        reward, self._carry = self._carry, np.zeros(n)
        done = np.zeros(n, dtype=bool)
        infos: list[dict] = [{} for _ in range(n)]
        obs = None
        for _ in range(self.repeat):
            self.venv.step_async(self._actions)
            obs, r, d, info = self.venv.step_wait()
            reward = reward + np.where(done, 0.0, r)
            self._carry += np.where(done, r, 0.0)
            for i in np.flatnonzero(~done):
                infos[i] = info[i]
            done |= d
        return obs, reward, done, infos


def random_policy(action_space, seed: int) -> Callable[[np.ndarray], np.ndarray]:
    rng = np.random.default_rng(seed)
    low, high = action_space.low, action_space.high

    def act(obs: np.ndarray) -> np.ndarray:
        return rng.uniform(low, high, size=(len(obs),) + low.shape).astype(np.float32)

    return act


def scripted_policy(venv) -> Callable[[np.ndarray], np.ndarray] | None:
    """The task's scripted baseline for ``venv`` (:func:`make_env`'s): the sand-shaping task's
    raster sweep (:func:`penalty_env.envs.scripted.scripted_policy`); None for a task without one,
    and for a level env that does not observe its state vector (the sweep reads the blade from
    it, and that function refuses such an env)."""
    if not hasattr(getattr(venv.unwrapped, "scene", None), "blade_range"):
        return None
    from penalty_env.envs.scripted import scripted_policy as task_policy

    try:
        return task_policy(venv)
    except ValueError:
        return None


def baselines(env_id: str, n_envs: int, seed: int, env_kwargs: dict[str, Any], n_episodes: int) -> dict[str, Any]:
    """The reference policies on the episodes :func:`run_episodes` plays on ``n_envs`` worlds
    seeded ``seed``: ``"random"`` (:func:`random_policy`), and for the level task ``"scripted"``
    (:func:`scripted_policy`), both on one vector env, reseeded in between."""
    probe = make_env(env_id, n_envs, seed, env_kwargs)
    out = {"random": run_episodes(probe, random_policy(probe.action_space, seed), n_episodes)}
    sweep = scripted_policy(probe)
    if sweep is not None:
        probe.seed(seed)  # (the same episodes again, on the same worlds)
        out["scripted"] = run_episodes(probe, sweep, n_episodes)
    return out


def load_run(run: Path, venv) -> tuple[Callable[[np.ndarray], np.ndarray], int]:
    """The deterministic policy of a ``train_ppo.py`` run folder for ``venv`` (its normalisation
    statistics loaded, frozen), and the action repeat it was trained with."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    summary = json.loads((run / "summary.json").read_text())
    model = PPO.load(run / "model.zip", device="cpu")
    vecnorm = None
    if (run / "vecnormalize.pkl").exists():
        vecnorm = VecNormalize.load(str(run / "vecnormalize.pkl"), venv)
        vecnorm.training, vecnorm.norm_reward = False, False
    return model_policy(model, vecnorm), int(summary.get("hyperparameters", {}).get("action_repeat", 1))


def model_policy(model, vecnorm=None) -> Callable[[np.ndarray], np.ndarray]:
    def act(obs: np.ndarray) -> np.ndarray:
        if vecnorm is not None:
            obs = vecnorm.normalize_obs(obs)
        actions, _ = model.predict(obs, deterministic=True)
        return actions

    return act


def record_gif(
    env_id: str,
    env_kwargs: dict[str, Any],
    act,
    path: Path,
    seed: int,
    episodes: int = 2,
    fps: int = 20,
    max_frames: int = 400,
    action_repeat: int = 1,
) -> int:
    """Roll out ``act`` in a single rendered env and save the frames as a GIF (Pillow); the policy
    decides every ``action_repeat`` steps (:func:`run_episodes`)."""
    import gymnasium as gym
    from PIL import Image

    import penalty_env  # noqa: F401  (registers the ids)

    env = gym.make(env_id, render_mode="rgb_array", **env_kwargs)
    frames = []
    for ep in range(episodes):
        obs, _ = env.reset(seed=seed + ep)
        frames.append(env.render())
        done, step = False, 0
        while not done and len(frames) < max_frames:
            if step % action_repeat == 0:
                action = act(obs[None])[0]
            obs, _, terminated, truncated, _ = env.step(action)
            step += 1
            frames.append(env.render())
            done = terminated or truncated
    env.close()
    # each frame to its own 256 colours with the fast octree (Pillow's default, median cut, took
    # 70% of a sand GIF's 12 s; this is about 4x faster and looks the same)
    images = [
        Image.fromarray(f).quantize(256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        for f in frames[:: max(1, math.ceil(len(frames) / max_frames))]
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0, optimize=True)
    return len(images)
