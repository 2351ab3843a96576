#!/usr/bin/env python
"""Scores of the sand-shaping task's baselines: the raster sweep, a uniformly random policy and a
blade held still, over the same episodes (seeds 10,000 + k), flat and drawn targets.

    python train/level_baselines.py --env-id PenaltySandLevel-v0 --episodes 12
    python train/level_baselines.py --env-id PenaltySandLevel2D-v0 --episodes 32 --csv docs/level_baselines.csv

Prints (and appends to ``--csv``) per policy and target: the mean return (= 100 x the mean error
decrease, m), its standard error, the success rate, the mean episode length and the grains lost.
"""

from __future__ import annotations

import argparse
import csv
import os
import time

import gymnasium as gym
import numpy as np

import penalty_env  # noqa: F401 (registers the ids)
from penalty_env.envs.scripted import RasterSweep

EVAL_SEED = 10_000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env-id", default="PenaltySandLevel-v0")
    ap.add_argument("--episodes", type=int, default=12)
    ap.add_argument("--csv", default=None)
    args = ap.parse_args()
    rows = []
    for target in ("flat", "random"):
        env = gym.make(args.env_id, target=target)
        shape = env.action_space.shape
        raster = RasterSweep(env)
        for name in ("raster", "random", "still"):
            rng = np.random.default_rng(0)
            returns, wins, lengths, lost = [], [], [], 0
            t0 = time.time()
            for k in range(args.episodes):
                obs, info = env.reset(seed=EVAL_SEED + k)
                raster.reset()
                total, done, n = 0.0, False, 0
                while not done:
                    if name == "raster":
                        a = raster(obs)
                    elif name == "random":
                        a = rng.uniform(-1.0, 1.0, shape).astype(np.float32)
                    else:
                        a = np.zeros(shape, dtype=np.float32)
                    obs, r, term, trunc, info = env.step(a)
                    total += r
                    n += 1
                    lost = max(lost, info["grains_lost"])
                    done = term or trunc
                returns.append(total)
                wins.append(info["is_success"])
                lengths.append(n)
            row = {
                "env_id": args.env_id,
                "target": target,
                "policy": name,
                "episodes": args.episodes,
                "mean_return": round(float(np.mean(returns)), 3),
                "stderr": round(float(np.std(returns, ddof=1) / np.sqrt(len(returns))), 3) if len(returns) > 1 else 0.0,
                "success_rate": round(float(np.mean(wins)), 3),
                "mean_length": round(float(np.mean(lengths)), 1),
                "grains_lost": lost,
                "wall_s": round(time.time() - t0, 1),
            }
            print(row, flush=True)
            rows.append(row)
    if args.csv:
        new = not os.path.exists(args.csv)
        with open(args.csv, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            if new:
                w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
