#!/usr/bin/env python
"""Train Stable-Baselines3 PPO on the sand-shaping task, against a random policy and the raster
sweep on the same held-out episodes.

    python train/train_level.py                          # PenaltySandLevel-v0, 28 minutes of wall time
    python train/train_level.py --env-id PenaltySandLevel2D-v0 --minutes 5 --out runs/level2d

The worlds are a ``DummyVecEnv`` of ``--n-envs`` single envs (seeds ``seed + i``) with
observation normalisation (``VecNormalize``, rewards left as they are). Every ``--eval-freq``
steps the deterministic policy plays ``--eval-episodes`` held-out episodes (seeds from 10,000),
which the random policy and the raster sweep (``penalty_env.envs.scripted.RasterSweep``) play once
at the start. The run stops at ``--minutes`` of wall time or ``--timesteps``. The folder ``--out``
receives ``evaluations.csv`` (steps, wall and CPU seconds, the held-out mean return, mean error
decrease in metres, success rate and the baselines' numbers) and ``learning_curve.png``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import time

import gymnasium as gym
import numpy as np

import penalty_env  # noqa: F401 (registers the ids)
from penalty_env.envs.scripted import RasterSweep

EVAL_SEED = 10_000


def cpu_seconds() -> float:
    """This process's user + system CPU time, s (its threads included)."""
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def play(env: gym.Env, policy, episodes: int, reset=None) -> dict[str, float]:
    """Mean return, mean error decrease (m) and success rate of ``policy`` over ``episodes``
    episodes of ``env`` seeded ``EVAL_SEED + k``."""
    returns, drops, wins = [], [], []
    for k in range(episodes):
        obs, info = env.reset(seed=EVAL_SEED + k)
        if reset is not None:
            reset()
        e0, total, done = info["error"], 0.0, False
        while not done:
            obs, r, term, trunc, info = env.step(policy(obs))
            total += r
            done = term or trunc
        returns.append(total)
        drops.append(e0 - info["error"])
        wins.append(bool(info["is_success"]))
    return {"return": float(np.mean(returns)), "error_drop": float(np.mean(drops)), "success": float(np.mean(wins))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env-id", default="PenaltySandLevel-v0")
    ap.add_argument("--minutes", type=float, default=28.0)
    ap.add_argument("--timesteps", type=int, default=2_000_000)
    ap.add_argument("--n-envs", type=int, default=8)
    ap.add_argument("--eval-freq", type=int, default=20_000)
    ap.add_argument("--eval-episodes", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="runs/level")
    args = ap.parse_args()

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(1)
    os.makedirs(args.out, exist_ok=True)
    t0, c0 = time.time(), cpu_seconds()
    eval_env = gym.make(args.env_id)
    rng = np.random.default_rng(0)
    space = eval_env.action_space
    random_score = play(eval_env, lambda o: rng.uniform(space.low, space.high).astype(np.float32), args.eval_episodes)
    raster = RasterSweep(eval_env)
    raster_score = play(eval_env, raster, args.eval_episodes, raster.reset)
    print("random", random_score, "raster", raster_score, flush=True)
    venv = VecNormalize(make_vec_env(args.env_id, n_envs=args.n_envs, seed=args.seed), norm_reward=False)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=256,
        batch_size=256,
        n_epochs=10,
        learning_rate=3e-4,
        gamma=0.99,
        gae_lambda=0.95,
        ent_coef=0.0,
        seed=args.seed,
        verbose=0,
        policy_kwargs=dict(net_arch=[128, 128]),
    )
    rows: list[dict] = []
    path = os.path.join(args.out, "evaluations.csv")

    def evaluate(steps: int) -> None:
        norm = venv.normalize_obs
        score = play(eval_env, lambda o: model.predict(norm(o[None]), deterministic=True)[0][0], args.eval_episodes)
        row = {"timesteps": steps, "wall_s": round(time.time() - t0, 1), "cpu_s": round(cpu_seconds() - c0, 1)}
        row.update({f"ppo_{k}": round(v, 5) for k, v in score.items()})
        row.update({f"random_{k}": round(v, 5) for k, v in random_score.items()})
        row.update({f"raster_{k}": round(v, 5) for k, v in raster_score.items()})
        rows.append(row)
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        print(row, flush=True)

    deadline = t0 + 60.0 * args.minutes

    class Clock(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next_eval = args.eval_freq

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_eval:
                self.next_eval += args.eval_freq
                evaluate(self.num_timesteps)
            return time.time() < deadline

    evaluate(0)
    model.learn(args.timesteps, callback=Clock())
    evaluate(model.num_timesteps)
    model.save(os.path.join(args.out, "model.zip"))
    venv.save(os.path.join(args.out, "vecnormalize.pkl"))
    summary = {
        "env_id": args.env_id,
        "timesteps": model.num_timesteps,
        "wall_s": time.time() - t0,
        "cpu_s": cpu_seconds() - c0,
        "final": rows[-1],
    }
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    plot(rows, os.path.join(args.out, "learning_curve.png"), args.env_id)


def plot(rows: list[dict], path: str, title: str) -> None:
    """The held-out mean error decrease against training steps, with the baselines as lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [r["timesteps"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(steps, [100 * r["ppo_error_drop"] for r in rows], "o-", label="PPO")
    ax.axhline(100 * rows[0]["raster_error_drop"], color="g", ls="--", label="raster sweep")
    ax.axhline(100 * rows[0]["random_error_drop"], color="r", ls=":", label="random")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("held-out mean error decrease, cm (= return)")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
