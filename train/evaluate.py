#!/usr/bin/env python
"""Evaluate a run folder written by ``train_ppo.py`` on fresh seeds.

    python train/evaluate.py runs/ppo-PenaltyBalls-v0-seed0
    python train/evaluate.py RUN --episodes 200 --seed 3000000 --video runs/eval.gif

Prints the success rate and the mean return of the trained policy and of a random policy on the
same seeds (and, for a task with a scripted controller, the level task's raster sweep, with the
trained policy's mean lead over it per episode, paired, and its standard error), and what was
played: ``--n-envs`` worlds (20) seeded ``--seed`` + i, each playing its
share of ``--episodes`` (100: 5 each) one after another, a world's later episodes continuing its
generator; ``--video`` renders a GIF of the trained policy.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(
        prog="evaluate.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("run", type=Path, help="run folder (model.zip, vecnormalize.pkl, summary.json)")
    p.add_argument("--episodes", type=int, default=100, help="episodes (default: %(default)s)")
    p.add_argument("--seed", type=int, default=3_000_000, help="first seed (default: %(default)s, unused by training)")
    p.add_argument("--n-envs", type=int, default=20, help="worlds evaluated at once (default: %(default)s)")
    p.add_argument("--video", type=Path, default=None, help="write a GIF of the policy here")
    args = p.parse_args(argv)

    summary = json.loads((args.run / "summary.json").read_text())
    env_id, env_kwargs = summary["env_id"], summary.get("env_kwargs", {})
    n_envs = min(args.n_envs, args.episodes)
    venv = C.make_env(env_id, n_envs, args.seed, env_kwargs)
    policy, repeat = C.load_run(args.run, venv)
    trained = C.run_episodes(venv, policy, args.episodes, repeat)
    refs = C.baselines(env_id, n_envs, args.seed, env_kwargs, args.episodes)
    rand, scripted = refs["random"], refs.get("scripted")
    print(
        f"{env_id}: success {trained['success_rate']:.1%}, mean return {trained['mean_return']:.3f} "
        f"± {trained['std_return']:.3f} over {C.describe_episodes(trained['episodes'], n_envs, args.seed)}; "
        f"random policy on the same worlds: success {rand['success_rate']:.1%}, mean return {rand['mean_return']:.3f}"
    )
    if scripted is not None:
        text = (
            f"the scripted baseline on the same episodes: success {scripted['success_rate']:.1%}, mean return "
            f"{scripted['mean_return']:.3f}"
        )
        if args.episodes >= 2:
            lead, se, n = C.paired_difference(trained, scripted)
            text += f"; trained minus scripted, per episode: {lead:+.3f} ± {se:.3f} (one standard error, {n} pairs)"
        print(text)
    if args.video:
        C.record_gif(env_id, env_kwargs, policy, args.video, seed=args.seed, action_repeat=repeat)
        print(f"video: {args.video}")
    return {"trained": trained, **refs}


if __name__ == "__main__":
    main()
