#!/usr/bin/env python
"""RLlib's PPO (new API stack) on PenaltyBalls' native vector env, next to train_ppo.py's SB3 PPO.

    python train/rllib_ppo.py                          # 600,000 steps, 16 worlds, seed 0
    python train/rllib_ppo.py --num-env-runners 1      # sample in a Ray actor instead of the driver
    python train/rllib_ppo.py --address auto           # on a running cluster (or set RAY_ADDRESS)

RLlib's env runners build the env through its vector entry point:
``gym.make_vec("PenaltyBalls-v0", num_envs=N, vectorization_mode="vector_entry_point")``
(``gym_env_vectorize_mode="vector_entry_point"``), so each runner steps its N worlds in one Numba
call, as SB3's adapter does. The settings mirror train_ppo.py's settings before tuning
(``train/_tuned.py``'s LEGACY; its tuned ones are per id): 16 worlds x 256 steps
per update (4,096), minibatches of 1,024, 10 epochs, Adam 1e-3 decayed linearly to 0, gamma 0.98,
GAE lambda 0.95, clip 0.2, separate 128-128 tanh policy and value networks with a state-independent
log std, value loss weight 0.5, no KL term. Differences: observations are normalised by RLlib's
MeanStdFilter (SB3: VecNormalize), rewards are not normalised, the value loss is not clipped, and
gradients are not clipped (RLlib's default; SB3 clips their norm at 0.5, which on these
unnormalised returns slows RLlib's PPO down: ``--grad-clip 0.5``, docs/sweeps.md).

The trained policy (its mean action) is then scored exactly as train_ppo.py scores SB3's: 100
episodes on the same held-out seeds, next to a random policy on those seeds. The run folder
(``--out``) receives summary.json (the same keys as train_ppo.py's where they apply) and
iterations.csv (env steps, RLlib's mean return of the sampled episodes, wall time).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402

ENV_NAME = "penalty_balls_vector"  # the name the env creator is registered under with Ray


def make_vector_env(config: dict[str, Any]):
    """RLlib's env creator: the native vector env through its vector entry point (RLlib passes
    ``num_envs`` in ``config`` when ``gym_env_vectorize_mode`` is ``vector_entry_point``)."""
    import gymnasium as gym

    import penalty_env  # noqa: F401  (registers the ids in this worker)

    kwargs = dict(config)
    env_id = kwargs.pop("env_id", "PenaltyBalls-v0")
    num_envs = kwargs.pop("num_envs", 1)
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)


def build_config(args: argparse.Namespace, env_kwargs: dict[str, Any]):
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.connectors.env_to_module.mean_std_filter import MeanStdFilter
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    hidden = [int(h) for h in args.net_arch.split(",") if h.strip()]
    batch = args.num_envs * args.n_steps
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config={"env_id": args.env_id, **env_kwargs})
        .env_runners(
            num_env_runners=args.num_env_runners,
            num_envs_per_env_runner=args.num_envs // max(1, args.num_env_runners),
            gym_env_vectorize_mode="vector_entry_point",
            env_to_module_connector=(lambda env, spaces, device: MeanStdFilter()) if args.obs_filter else None,
        )
        .training(
            train_batch_size_per_learner=batch,
            minibatch_size=args.batch_size,
            num_epochs=args.n_epochs,
            lr=[[0, args.learning_rate], [args.timesteps, 0.0]],
            gamma=args.gamma,
            lambda_=args.gae_lambda,
            clip_param=args.clip_range,
            entropy_coeff=args.ent_coef,
            vf_loss_coeff=0.5,
            vf_clip_param=float("inf"),
            use_kl_loss=False,
            grad_clip=args.grad_clip if args.grad_clip > 0 else None,
            grad_clip_by="global_norm",
        )
        .rl_module(
            model_config=DefaultModelConfig(
                fcnet_hiddens=hidden,
                fcnet_activation="tanh",
                head_fcnet_hiddens=[],
                vf_share_layers=False,
                free_log_std=True,
            )
        )
        .debugging(seed=args.seed)
    )


def obs_normaliser(algo):
    """The MeanStdFilter of the (synced) local env runner as a function of a batch of
    observations, or the identity without the filter."""
    import numpy as np
    from ray.rllib.utils.filter import MeanStdFilter, RunningStat

    state = algo.env_runner.get_state(components="env_to_module_connector").get("env_to_module_connector", {})
    filt = None
    for piece in state.values():
        if isinstance(piece, dict) and None in piece and "running_stats" in piece[None]:
            s = piece[None]
            filt = MeanStdFilter(
                s["shape"], demean=s["de_mean_to_zero"], destd=s["de_std_to_one"], clip=s["clip_by_value"]
            )
            filt.running_stats = RunningStat.from_state(s["running_stats"][0])
    if filt is None:
        return lambda obs: obs
    return lambda obs: np.asarray(filt(obs, update=False), dtype=np.float32)


def module_policy(algo):
    """The trained policy's mean action (as SB3's ``predict(deterministic=True)``)."""
    import numpy as np
    import torch

    module = algo.get_module()
    normalise = obs_normaliser(algo)

    def act(obs):
        with torch.no_grad():
            out = module.forward_inference({"obs": torch.as_tensor(normalise(obs))})
        inputs = out["action_dist_inputs"].numpy()
        mean = inputs[:, : inputs.shape[1] // 2]
        return np.clip(mean, -1.0, 1.0).astype(np.float32)

    return act


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rllib_ppo.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--env-id", default="PenaltyBalls-v0", help="registered env id (default: %(default)s)")
    p.add_argument("--env-kwarg", action="append", default=[], metavar="KEY=VALUE", help="env keyword argument")
    p.add_argument("--timesteps", type=int, default=600_000, help="environment steps (default: %(default)s)")
    p.add_argument("--num-envs", type=int, default=16, help="worlds, over all env runners (default: %(default)s)")
    p.add_argument(
        "--num-env-runners", type=int, default=0, help="remote env runners; 0 samples in the driver (default: 0)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    p.add_argument("--n-steps", type=int, default=256, help="steps per world per update (default: %(default)s)")
    p.add_argument("--batch-size", type=int, default=1024, help="minibatch (default: %(default)s)")
    p.add_argument("--n-epochs", type=int, default=10, help="epochs per update (default: %(default)s)")
    p.add_argument("--learning-rate", type=float, default=1e-3, help="Adam step, decayed linearly (default: 1e-3)")
    p.add_argument("--gamma", type=float, default=0.98, help="discount (default: %(default)s)")
    p.add_argument("--gae-lambda", type=float, default=0.95, help="GAE lambda (default: %(default)s)")
    p.add_argument("--clip-range", type=float, default=0.2, help="PPO clip (default: %(default)s)")
    p.add_argument("--ent-coef", type=float, default=0.0, help="entropy bonus (default: %(default)s)")
    p.add_argument("--net-arch", default="128,128", help="hidden layer sizes (default: %(default)s)")
    p.add_argument(
        "--grad-clip",
        type=float,
        default=0.0,
        help="global gradient norm clip, 0: none (default: 0, RLlib's; SB3 clips at 0.5, on normalised rewards)",
    )
    p.add_argument("--no-obs-filter", dest="obs_filter", action="store_false", help="no MeanStdFilter")
    p.add_argument("--final-episodes", type=int, default=100, help="held-out episodes (default: %(default)s)")
    p.add_argument("--threads", type=int, default=1, help="torch threads (default: %(default)s)")
    p.add_argument("--address", default=None, help="Ray cluster (default: RAY_ADDRESS, else a local one)")
    p.add_argument("--num-cpus", type=int, default=None, help="CPUs of the local Ray cluster (default: all)")
    p.add_argument("--object-store-mb", type=int, default=None, help="object store of the local cluster, MB")
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/rllib-<env>-seed<seed>)")
    return p


def main(argv=None) -> dict[str, Any]:
    parser = build_parser()
    args = parser.parse_args(argv)
    for name in ("timesteps", "num_envs", "n_steps", "batch_size", "n_epochs", "final_episodes", "threads"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    if args.num_env_runners < 0 or (args.num_env_runners and args.num_envs % args.num_env_runners):
        parser.error(
            f"--num-env-runners must be >= 0 and divide --num-envs ({args.num_envs}), got {args.num_env_runners}"
        )
    env_kwargs = C.parse_env_kwargs(args.env_kwarg)
    out: Path = args.out or Path("runs") / f"rllib-{args.env_id}-seed{args.seed}"
    out.mkdir(parents=True, exist_ok=True)

    import os

    import ray
    import torch
    from ray.tune.registry import register_env

    torch.set_num_threads(args.threads)
    started = not ray.is_initialized()
    if started:
        address = args.address
        kwargs: dict[str, Any] = {"include_dashboard": False}
        if address is None and not os.environ.get("RAY_ADDRESS"):
            address = "local"  # a new local cluster, even where `ray start` left one running
            kwargs["num_cpus"] = args.num_cpus
            if args.object_store_mb:
                kwargs["object_store_memory"] = args.object_store_mb * 1024 * 1024
        ray.init(address=address, **kwargs)
    try:
        register_env(ENV_NAME, make_vector_env)
        t_build = time.perf_counter()
        algo = build_config(args, env_kwargs).build_algo()
        build_s = time.perf_counter() - t_build
        print(
            f"RLlib PPO on {args.env_id} {env_kwargs or ''}: {args.timesteps:,} steps, {args.num_envs} worlds on "
            f"{max(1, args.num_env_runners)} env runner(s), seed {args.seed} -> {out} (built in {build_s:.0f} s)",
            flush=True,
        )
        rows = []
        steps = 0
        t0 = time.perf_counter()
        while steps < args.timesteps:
            r = algo.train()
            runners = r.get("env_runners", {})
            steps = int(runners.get("num_env_steps_sampled_lifetime", steps))
            rows.append(
                {
                    "timesteps": steps,
                    "episode_return_mean": float(runners.get("episode_return_mean", float("nan"))),
                    "wall_time_s": round(time.perf_counter() - t0, 2),
                }
            )
            print(f"[iter {len(rows)}] steps={steps:>9,} return={rows[-1]['episode_return_mean']:.2f}", flush=True)
        wall = time.perf_counter() - t0

        final_seed = C.FINAL_SEED_OFFSET + args.seed
        n_eval_envs = min(20, args.final_episodes)
        trained = C.run_episodes(
            C.make_env(args.env_id, n_eval_envs, final_seed, env_kwargs), module_policy(algo), args.final_episodes
        )
        probe = C.make_env(args.env_id, n_eval_envs, final_seed, env_kwargs)
        rand = C.run_episodes(probe, C.random_policy(probe.action_space, final_seed), args.final_episodes)
        algo.stop()
    finally:
        if started:
            ray.shutdown()

    summary = {
        "algorithm": "RLlib PPO (new API stack)",
        "ray_version": ray.__version__,
        "env_id": args.env_id,
        "env_kwargs": env_kwargs,
        "seed": args.seed,
        "timesteps": steps,
        "wall_time_s": round(wall, 2),
        "build_time_s": round(build_s, 2),
        "env_steps_per_s": round(steps / wall, 1),
        "success_rate": trained["success_rate"],
        "mean_return": trained["mean_return"],
        "std_return": trained["std_return"],
        "eval_episodes": trained["episodes"],
        "eval_seeds": f"{final_seed}..{final_seed + n_eval_envs - 1} (held out, as train_ppo.py's)",
        "random_success_rate": rand["success_rate"],
        "random_mean_return": rand["mean_return"],
        "num_env_runners": args.num_env_runners,
        "num_envs": args.num_envs,
        "obs_filter": args.obs_filter,
        "grad_clip": args.grad_clip,
        "iterations": len(rows),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    with open(out / "iterations.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["timesteps", "episode_return_mean", "wall_time_s"])
        w.writeheader()
        w.writerows(rows)
    print(
        f"done in {wall:.0f} s ({summary['env_steps_per_s']:,.0f} env-steps/s): success {trained['success_rate']:.0%} "
        f"(random policy {rand['success_rate']:.0%}) over {trained['episodes']} held-out episodes, "
        f"mean return {trained['mean_return']:.2f} (random {rand['mean_return']:.2f}); results in {out}"
    )
    return summary


if __name__ == "__main__":
    main()
