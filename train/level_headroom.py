#!/usr/bin/env python
"""How much return the sand-shaping task leaves above its raster sweep: per episode, the best of
many open-loop action sequences, chosen in hindsight.

    python train/level_headroom.py --episodes 32 --run runs/ppo-PenaltySandLevel2D-v0-seed0

Each held-out episode (seeds 4,000,000 + k, random targets) is played by ``--sequences`` worlds at
once, every world from the same start, each with its own sequence of actions held for
``--hold`` steps: every "one way, back, the first way again" sequence at full speed (the turns
at any decision; 212 distinct for 15 decisions), then random ones (each decision one of -1,
-0.5, 0, 0.5, 1), all distinct. The best return among them is what some policy could have scored
on that episode, had it known which to play: a lower bound on the best achievable return, and an
upper bound on nothing. The raster sweep and,
with ``--run``, a trained policy play the same episodes. Prints the means and the paired
differences with their standard errors. 2D only: each x action is one number.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402

import penalty_env  # noqa: E402, F401 (registers the ids)

SEED = 4_000_000


def sequences(n: int, decisions: int, seed: int = 0) -> tuple[np.ndarray, int]:
    """``n`` distinct action sequences of ``decisions`` steps (at least the structured ones):
    first every full-speed "a decisions one way, b back, the rest the first way again" in both
    directions (each once: a run of 0 decisions makes some alike), then random ones. Returns them
    and how many are structured."""
    out: list[tuple[float, ...]] = []
    for first in (1.0, -1.0):
        for a in range(decisions + 1):
            for b in range(decisions + 1 - a):
                seq = (first,) * a + (-first,) * b + (first,) * (decisions - a - b)
                if seq not in out:
                    out.append(seq)
    structured = len(out)
    rng = np.random.default_rng(seed)
    seen = set(out)
    while len(out) < n:
        seq = tuple(float(v) for v in rng.choice([-1.0, -0.5, 0.0, 0.5, 1.0], size=decisions))
        if seq not in seen:
            seen.add(seq)
            out.append(seq)
    return np.array(out, dtype=np.float32), structured


def best_of(env_id: str, seqs: np.ndarray, hold: int, seeds: list[int], env_kwargs: dict, length: int) -> np.ndarray:
    """Per seed, every sequence's return (rows: seeds), each world of one vector env playing the
    seed's first episode (at most ``length`` steps) with one sequence, each action held ``hold``
    steps."""
    n = len(seqs)
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **env_kwargs)
    if envs.single_action_space.shape != (1,):
        raise ValueError(
            f"--env-id {env_id!r}: level_headroom plays a 2D level id (one x action), not {envs.single_action_space}"
        )
    out = np.zeros((len(seeds), n))
    for row, seed in enumerate(seeds):
        envs.reset(seed=[seed] * n)
        alive = np.ones(n, dtype=bool)
        t = 0
        while alive.any() and t < length:
            k = min(t // hold, seqs.shape[1] - 1)
            _, r, term, trunc, _ = envs.step(seqs[:, k][:, None])
            out[row] += np.where(alive, r, 0.0)
            alive &= ~(term | trunc)
            t += 1
    envs.close()
    return out


def _per_key(result: dict) -> np.ndarray:
    return np.array([r for _, r in sorted(zip(map(tuple, result["keys"]), result["returns"]))])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(prog="level_headroom.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--env-id", default="PenaltySandLevel2D-v0")
    ap.add_argument("--episodes", type=int, default=32, help="held-out episodes (default: %(default)s)")
    ap.add_argument("--sequences", type=int, default=512, help="sequences per episode (default: %(default)s)")
    ap.add_argument("--hold", type=int, default=10, help="env steps each action is held (default: %(default)s)")
    ap.add_argument("--run", type=Path, default=None, help="a train_ppo.py run folder to play the same episodes")
    args = ap.parse_args(argv)
    for name, low in (("episodes", 2), ("sequences", 1), ("hold", 1)):  # (2 episodes: a standard error)
        if getattr(args, name) < low:
            ap.error(f"--{name} must be at least {low}, got {getattr(args, name)}")
    kw = {"target": "random"}
    length = gym.spec(args.env_id).max_episode_steps or 150
    seqs, structured = sequences(args.sequences, -(-length // args.hold))
    seeds = [SEED + k for k in range(args.episodes)]
    t0 = time.perf_counter()
    table = best_of(args.env_id, seqs, args.hold, seeds, kw, length)
    best, best_structured = table.max(axis=1), table[:, :structured].max(axis=1)
    probe = C.make_env(args.env_id, args.episodes, SEED, kw)
    swept = C.run_episodes(probe, C.scripted_policy(probe), args.episodes)
    sweep = _per_key(swept)  # (world k played seed SEED + k: the table's row k)
    out = {
        "episodes": args.episodes,
        "sequences": len(seqs),
        "best": float(best.mean()),
        "best_structured": float(best_structured.mean()),
        "sweep": float(sweep.mean()),
        "best_minus_sweep": C.mean_and_se(best - sweep),
        "best_sequence": [seqs[i].tolist() for i in table.argmax(axis=1)],
        "seconds": round(time.perf_counter() - t0, 1),
    }
    print(
        f"{args.env_id}, {args.episodes} episodes (seeds {SEED}..{SEED + args.episodes - 1}), random targets: the best "
        f"of {len(seqs)} open-loop sequences {out['best']:.3f} (of the {structured} with two turns: "
        f"{out['best_structured']:.3f}), the raster sweep {out['sweep']:.3f}; best minus sweep "
        f"{out['best_minus_sweep'][0]:+.3f} ± {out['best_minus_sweep'][1]:.3f} (one standard error)"
    )
    if args.run is not None:
        venv = C.make_env(args.env_id, args.episodes, SEED, kw)
        policy, repeat = C.load_run(args.run, venv)
        trained = C.run_episodes(venv, policy, args.episodes, repeat)
        out["trained"] = float(trained["mean_return"])
        out["trained_minus_sweep"] = C.paired_difference(trained, swept)[:2]
        print(
            f"the trained policy {out['trained']:.3f}: minus sweep {out['trained_minus_sweep'][0]:+.3f} "
            f"± {out['trained_minus_sweep'][1]:.3f}"
        )
    print(f"({out['seconds']} s)")
    return out


if __name__ == "__main__":
    main()
