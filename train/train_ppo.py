#!/usr/bin/env python
"""Train Stable-Baselines3 PPO on PenaltyBalls (the project's main job).

    python train/train_ppo.py                       # PenaltyBalls-v0, 16 worlds, seed 0
    python train/train_ppo.py --seed 1 --out runs/s1
    python train/train_ppo.py --env-id PenaltyBalls2D-v0 --env-kwarg n_obstacles=2
    python train/train_ppo.py --env-id PenaltyBalls-v1 --out runs/v1 \
      && python train/train_ppo.py --env-id PenaltyBallsSand-v1 --init-from runs/v1 --gamma 0.99 \
           --learning-rate 3e-4 --timesteps 2000000 --eval-freq 100000

The worlds are stepped by our native SB3 VecEnv (one Numba call for all of them), with
observation and reward normalisation (VecNormalize). An evaluation callback measures the success
rate on held-out seeds as training goes. ``--init-from RUN`` starts from a previous run's policy
and normalisation statistics (a curriculum: the sand envs start from a policy trained without
sand; see :func:`init_from`). The run folder (``--out``) receives:

  model.zip           the trained policy
  vecnormalize.pkl    the observation/reward normalisation statistics
  learning_curve.png  success rate and return against environment steps
  policy.gif          the trained policy, two episodes
  evaluations.csv     the curve's data
  summary.json        timesteps, wall_time_s, env_steps_per_s, success_rate and mean_return
                      (100 episodes on held-out seeds), random_success_rate and
                      random_mean_return (a random policy on the same seeds), and the settings

``train(settings, out)`` is the run itself, importable: this CLI and the Ray Tune sweep
(``train/sweep.py``) both call it, so a trial of a sweep is exactly this script's run.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402

DEFAULTS = dict(
    env_id="PenaltyBalls-v0",
    timesteps=600_000,
    n_envs=16,
    n_steps=256,
    batch_size=1024,
    n_epochs=10,
    learning_rate=1e-3,
    gamma=0.98,
    gae_lambda=0.95,
    ent_coef=0.0,
    clip_range=0.2,
    net_arch="128,128",
    eval_freq=50_000,
    eval_episodes=40,
    final_episodes=100,
)

# Every setting of one run, train()'s first argument: the defaults above, plus these.
SETTINGS: dict[str, Any] = dict(
    DEFAULTS,
    seed=0,
    env_kwargs={},
    normalize=True,
    threads=1,  # torch threads
    numba_threads=None,  # None: Numba's own default (every core)
    tensorboard=None,
    init_from=None,  # a run folder whose policy and normalisation this run starts from (init_from())
    progress=True,
    gif=True,
)
# the settings summary.json records under "hyperparameters"
HYPERPARAMETERS = (
    "n_envs",
    "n_steps",
    "batch_size",
    "n_epochs",
    "learning_rate",
    "gamma",
    "gae_lambda",
    "ent_coef",
    "clip_range",
    "net_arch",
)
# integer settings and their lower bound
_INTS = {
    "timesteps": 1,
    "n_envs": 1,
    "n_steps": 1,
    "batch_size": 2,
    "n_epochs": 1,
    "eval_freq": 1,
    "eval_episodes": 1,
    "final_episodes": 1,
    "seed": 0,
    "threads": 1,
}
# float settings: (low, high, low included, high included)
_FLOATS = {
    "learning_rate": (0.0, math.inf, False, False),
    "gamma": (0.0, 1.0, False, True),
    "gae_lambda": (0.0, 1.0, True, True),
    "ent_coef": (0.0, math.inf, True, False),
    "clip_range": (0.0, math.inf, False, False),
}


def check_settings(settings: Mapping[str, Any]) -> dict[str, Any]:
    """``settings`` with the defaults of :data:`SETTINGS` filled in, or a ValueError that names
    the setting, its value and what is allowed (an unknown name lists the known ones)."""
    unknown = [k for k in settings if k not in SETTINGS]
    if unknown:
        raise ValueError(
            f"unknown setting {unknown[0]!r} (value {settings[unknown[0]]!r}); the settings are: {', '.join(SETTINGS)}"
        )
    s = {**SETTINGS, **settings}
    for key, low in _INTS.items():
        v = s[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise ValueError(f"setting {key!r} must be an integer >= {low}, got {v!r}")
    for key, (lo, hi, lo_in, hi_in) in _FLOATS.items():
        v = s[key]
        ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        ok = ok and (v >= lo if lo_in else v > lo) and (v <= hi if hi_in else v < hi)
        if not ok:
            rng = f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"
            raise ValueError(f"setting {key!r} must be a number in {rng}, got {v!r}")
        s[key] = float(v)
    arch = s["net_arch"]
    if isinstance(arch, (list, tuple)):
        arch = ",".join(str(h) for h in arch)
    parts = [p for p in str(arch).split(",") if p.strip()]
    if not all(p.strip().isdigit() and int(p) >= 1 for p in parts):
        raise ValueError(
            f"setting 'net_arch' must be hidden layer sizes >= 1, comma separated (e.g. '128,128'), got {s['net_arch']!r}"
        )
    s["net_arch"] = str(arch)
    nt = s["numba_threads"]
    if nt is not None and (isinstance(nt, bool) or not isinstance(nt, int) or nt < 1):
        raise ValueError(f"setting 'numba_threads' must be None or an integer >= 1, got {nt!r}")
    if not isinstance(s["env_kwargs"], Mapping):
        raise ValueError(f"setting 'env_kwargs' must be a mapping of env keyword arguments, got {s['env_kwargs']!r}")
    if s["init_from"] is not None:
        src = s["init_from"]
        if not isinstance(src, (str, Path)) or not (Path(src) / "model.zip").is_file():
            raise ValueError(
                f"setting 'init_from' must be None or a run folder of train_ppo.py holding model.zip, got {str(src)!r}"
            )
        s["init_from"] = str(Path(src).resolve())
    if not isinstance(s["env_id"], str):
        raise ValueError(f"setting 'env_id' must be a registered env id, got {s['env_id']!r}")
    for key in ("normalize", "progress", "gif"):
        if not isinstance(s[key], bool):
            raise ValueError(f"setting {key!r} must be true or false, got {s[key]!r}")
    s["env_kwargs"] = dict(s["env_kwargs"])
    return s


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="train_ppo.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    d = DEFAULTS
    p.add_argument("--env-id", default=d["env_id"], help="registered env id (default: %(default)s)")
    p.add_argument(
        "--env-kwarg",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="env keyword argument, repeatable; VALUE parsed as JSON (e.g. n_obstacles=2)",
    )
    p.add_argument("--timesteps", type=int, default=d["timesteps"], help="environment steps (default: %(default)s)")
    p.add_argument("--n-envs", type=int, default=d["n_envs"], help="parallel worlds (default: %(default)s)")
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the worlds, the policy and torch (default: %(default)s)"
    )
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/ppo-<env>-seed<seed>)")
    p.add_argument(
        "--n-steps", type=int, default=d["n_steps"], help="PPO rollout length per world (default: %(default)s)"
    )
    p.add_argument("--batch-size", type=int, default=d["batch_size"], help="PPO minibatch (default: %(default)s)")
    p.add_argument("--n-epochs", type=int, default=d["n_epochs"], help="PPO epochs per update (default: %(default)s)")
    p.add_argument(
        "--learning-rate",
        type=float,
        default=d["learning_rate"],
        help="Adam step size, linearly decayed (default: %(default)s)",
    )
    p.add_argument("--gamma", type=float, default=d["gamma"], help="discount (default: %(default)s)")
    p.add_argument("--gae-lambda", type=float, default=d["gae_lambda"], help="GAE lambda (default: %(default)s)")
    p.add_argument("--ent-coef", type=float, default=d["ent_coef"], help="entropy bonus (default: %(default)s)")
    p.add_argument("--clip-range", type=float, default=d["clip_range"], help="PPO clip (default: %(default)s)")
    p.add_argument(
        "--net-arch", default=d["net_arch"], help="hidden layer sizes, comma separated (default: %(default)s)"
    )
    p.add_argument("--no-normalize", action="store_true", help="disable VecNormalize")
    p.add_argument(
        "--eval-freq", type=int, default=d["eval_freq"], help="env steps between evaluations (default: %(default)s)"
    )
    p.add_argument(
        "--eval-episodes",
        type=int,
        default=d["eval_episodes"],
        help="episodes per evaluation during training (default: %(default)s)",
    )
    p.add_argument(
        "--final-episodes",
        type=int,
        default=d["final_episodes"],
        help="episodes of the final held-out evaluation (default: %(default)s)",
    )
    p.add_argument(
        "--tensorboard",
        type=Path,
        default=None,
        metavar="DIR",
        help="TensorBoard log folder (needs tensorboard installed)",
    )
    p.add_argument(
        "--init-from",
        type=Path,
        default=None,
        metavar="RUN",
        help="start from this run folder's policy and normalisation statistics (a curriculum; see init_from)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-gif", action="store_true", help="skip the GIF of the trained policy")
    p.add_argument(
        "--threads", type=int, default=1, help="torch threads (default: %(default)s: the physics uses the other core)"
    )
    p.add_argument(
        "--numba-threads",
        type=int,
        default=None,
        help="Numba threads of the physics (default: Numba's own, every core)",
    )
    return p


def settings_from_args(args: argparse.Namespace) -> dict[str, Any]:
    """The run's settings (:data:`SETTINGS`) from the parsed command line."""
    s = {k: getattr(args, k) for k in DEFAULTS}
    s.update(
        seed=args.seed,
        env_kwargs=C.parse_env_kwargs(args.env_kwarg),
        normalize=not args.no_normalize,
        threads=args.threads,
        numba_threads=args.numba_threads,
        tensorboard=args.tensorboard,
        init_from=args.init_from,
        progress=not args.no_progress,
        gif=not args.no_gif,
    )
    return s


def default_out(settings: Mapping[str, Any]) -> Path:
    return Path("runs") / f"ppo-{settings['env_id'].split(':')[-1]}-seed{settings['seed']}"


def main(argv=None) -> dict:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        settings = check_settings(settings_from_args(args))
    except ValueError as e:
        parser.error(str(e))
    return train(settings, args.out or default_out(settings))


def train(
    settings: Mapping[str, Any], out: Path, on_eval: Callable[[dict[str, Any]], None] | None = None
) -> dict[str, Any]:
    """One training run: PPO with ``settings`` (names and defaults in :data:`SETTINGS`), its run
    folder written to ``out`` (the files listed in the module docstring). Returns the summary
    (summary.json). ``on_eval`` is called with each point of the learning curve as it is measured
    (the sweep reports them to Ray Tune)."""
    s = check_settings(settings)
    import numpy as np
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import EvalCallback
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(max(1, s["threads"]))
    if s["numba_threads"] is not None:
        import numba

        numba.set_num_threads(min(s["numba_threads"], numba.config.NUMBA_NUM_THREADS))
    env_id: str = s["env_id"]
    seed: int = s["seed"]
    env_kwargs: dict[str, Any] = s["env_kwargs"]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    set_random_seed(seed)

    venv = C.make_env(env_id, s["n_envs"], seed, env_kwargs)
    eval_env = C.make_env(env_id, min(s["n_envs"], s["eval_episodes"]), C.EVAL_SEED_OFFSET + seed, env_kwargs)
    if s["normalize"]:
        venv = VecNormalize(venv, norm_obs=True, norm_reward=True, gamma=s["gamma"])
        eval_env = VecNormalize(eval_env, norm_obs=True, norm_reward=False, training=False)

    curve: list[dict] = []

    class CurveCallback(EvalCallback):
        """EvalCallback that also keeps (steps, success rate, mean return) for the curve."""

        def _on_step(self) -> bool:
            cont = super()._on_step()
            if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:  # an evaluation just ran
                curve.append(
                    {
                        "timesteps": int(self.num_timesteps),
                        "success_rate": float(np.mean(self._is_success_buffer)) if self._is_success_buffer else 0.0,
                        "mean_return": float(self.last_mean_reward),
                        "wall_time_s": time.perf_counter() - t0,
                    }
                )
                if not s["progress"]:
                    c = curve[-1]
                    print(
                        f"[eval] steps={c['timesteps']:>9,} success={c['success_rate']:.2f} return={c['mean_return']:.2f}",
                        flush=True,
                    )
                if on_eval is not None:
                    on_eval(dict(curve[-1]))
            return cont

    eval_cb = CurveCallback(
        eval_env,
        n_eval_episodes=s["eval_episodes"],
        eval_freq=max(1, s["eval_freq"] // s["n_envs"]),
        deterministic=True,
        verbose=0,
    )
    hidden = [int(h) for h in s["net_arch"].split(",") if h.strip()]
    lr0 = s["learning_rate"]
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=s["n_steps"],
        batch_size=s["batch_size"],
        n_epochs=s["n_epochs"],
        learning_rate=lambda frac: lr0 * frac,
        gamma=s["gamma"],
        gae_lambda=s["gae_lambda"],
        ent_coef=s["ent_coef"],
        clip_range=s["clip_range"],
        policy_kwargs=dict(net_arch=dict(pi=hidden, vf=hidden)),
        tensorboard_log=str(s["tensorboard"]) if s["tensorboard"] else None,
        seed=seed,
        device="cpu",
        verbose=0,
    )
    if s["init_from"] is not None:
        init_from(model, venv if isinstance(venv, VecNormalize) else None, Path(s["init_from"]))
    start = f", from {s['init_from']}" if s["init_from"] else ""
    print(
        f"training PPO on {env_id} {env_kwargs or ''}: {s['timesteps']:,} steps, "
        f"{s['n_envs']} worlds, seed {seed}{start} -> {out}",
        flush=True,
    )
    t0 = time.perf_counter()
    model.learn(total_timesteps=s["timesteps"], callback=eval_cb, progress_bar=s["progress"])
    wall = time.perf_counter() - t0

    model.save(out / "model.zip")
    vecnorm = venv if isinstance(venv, VecNormalize) else None
    if vecnorm is not None:
        vecnorm.save(str(out / "vecnormalize.pkl"))

    # final evaluation on held-out seeds, and a random policy on the very same seeds
    final_seed = C.FINAL_SEED_OFFSET + seed
    n_eval_envs = min(20, s["final_episodes"])
    trained = C.run_episodes(
        C.make_env(env_id, n_eval_envs, final_seed, env_kwargs),
        C.model_policy(model, vecnorm),
        s["final_episodes"],
    )
    probe = C.make_env(env_id, n_eval_envs, final_seed, env_kwargs)
    rand = C.run_episodes(probe, C.random_policy(probe.action_space, final_seed), s["final_episodes"])

    summary = {
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "seed": seed,
        "timesteps": int(model.num_timesteps),
        "wall_time_s": round(wall, 2),
        "env_steps_per_s": round(model.num_timesteps / wall, 1),
        "success_rate": trained["success_rate"],
        "mean_return": trained["mean_return"],
        "std_return": trained["std_return"],
        "eval_episodes": trained["episodes"],
        "eval_seeds": f"{final_seed}..{final_seed + n_eval_envs - 1} (held out; training used {seed}..{seed + s['n_envs'] - 1})",
        "random_success_rate": rand["success_rate"],
        "random_mean_return": rand["mean_return"],
        "hyperparameters": {k: s[k] for k in HYPERPARAMETERS},
        "normalize": s["normalize"],
        "init_from": s["init_from"],
        "curve": curve,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    with open(out / "evaluations.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["timesteps", "success_rate", "mean_return", "wall_time_s"])
        w.writeheader()
        w.writerows(curve)
    plot_curve(curve, summary, out / "learning_curve.png")
    if s["gif"]:
        C.record_gif(env_id, env_kwargs, C.model_policy(model, vecnorm), out / "policy.gif", seed=final_seed)

    print(
        f"done in {wall:.0f} s ({summary['env_steps_per_s']:,.0f} env-steps/s): success {trained['success_rate']:.0%} "
        f"(random policy {rand['success_rate']:.0%}) over {trained['episodes']} held-out episodes, "
        f"mean return {trained['mean_return']:.2f} (random {rand['mean_return']:.2f}); results in {out}"
    )
    return summary


INIT_STATS_COUNT = 10_000  # init_from: the earlier run's normalisation statistics weigh as this many samples


def init_from(model, vecnorm, src: Path) -> None:
    """Start ``model`` (and its ``VecNormalize`` ``vecnorm``, or None) from the run folder ``src``.

    The policy's weights are copied. The new env's observation may extend the earlier one's (the
    sand envs append a height map to v1's 21 entries, which mean the same): the first layers'
    weights for the extra inputs start at zero, so the policy first acts as the earlier one did,
    and learns to read the extra entries. The normalisation statistics of the shared entries
    (and of the return) are copied with a weight of ``INIT_STATS_COUNT`` samples, so the new env's
    own statistics take over within a few rollouts; the extra entries start at mean 0, variance 1
    under the same weight, so their statistics converge slowly (the height map's std of about
    0.05 is overestimated for most of a 2 M-step run; statistics measured on sand instead learned
    far worse, docs/granular.md section 5, so this stays). The
    return statistics carry the earlier run's discount until they adapt. Only the observation's
    length is checked, not its layout: the earlier entries must mean the same (v1 into the sand
    envs, without obstacles). Refused (ValueError naming the folder) when the action space or the
    hidden layers differ, the earlier observation is longer, or one run normalises and the other
    does not."""
    import pickle

    import torch
    from stable_baselines3 import PPO

    old = PPO.load(src / "model.zip", device="cpu")
    if old.action_space.shape != model.action_space.shape:
        raise ValueError(
            f"init_from={str(src)!r}: its action space {old.action_space.shape} is not this env's {model.action_space.shape}"
        )
    k_old, k_new = old.observation_space.shape[0], model.observation_space.shape[0]
    if k_old > k_new:
        raise ValueError(f"init_from={str(src)!r}: its observation has {k_old} entries, this env's only {k_new}")
    old_sd, new_sd = old.policy.state_dict(), model.policy.state_dict()
    if set(old_sd) != set(new_sd):
        raise ValueError(f"init_from={str(src)!r}: its policy's layers differ from this run's (net_arch)")
    for key, w in new_sd.items():
        w_old = old_sd[key]
        if w_old.shape == w.shape:
            new_sd[key] = w_old.clone()
        elif w.ndim == 2 and w_old.shape == (w.shape[0], k_old) and w.shape[1] == k_new:  # a first layer
            grown = torch.zeros_like(w)
            grown[:, :k_old] = w_old
            new_sd[key] = grown
        else:
            raise ValueError(
                f"init_from={str(src)!r}: layer {key} has shape {tuple(w_old.shape)} there, {tuple(w.shape)} here (net_arch)"
            )
    model.policy.load_state_dict(new_sd)
    stats = src / "vecnormalize.pkl"
    if stats.is_file() != (vecnorm is not None):
        raise ValueError(
            f"init_from={str(src)!r}: that run was trained {'with' if stats.is_file() else 'without'} "
            f"VecNormalize, this one {'with' if vecnorm is not None else 'without'} (--no-normalize)"
        )
    if vecnorm is not None:
        with open(stats, "rb") as f:
            old_norm = pickle.load(f)
        vecnorm.obs_rms.mean[:k_old] = old_norm.obs_rms.mean
        vecnorm.obs_rms.var[:k_old] = old_norm.obs_rms.var
        vecnorm.obs_rms.count = float(INIT_STATS_COUNT)
        vecnorm.ret_rms = old_norm.ret_rms
        vecnorm.ret_rms.count = float(INIT_STATS_COUNT)


def plot_curve(curve: list[dict], summary: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
    steps = [c["timesteps"] for c in curve]
    ax1.plot(steps, [c["success_rate"] for c in curve], "o-", label="PPO (held-out seeds)")
    ax1.axhline(summary["random_success_rate"], color="gray", ls="--", label="random policy")
    ax1.axhline(0.8, color="green", ls=":", lw=1, label="80% target")
    ax1.set_ylim(-0.02, 1.02)
    ax1.set_xlabel("environment steps")
    ax1.set_ylabel("success rate")
    ax1.legend(loc="lower right", fontsize=8)
    ax2.plot(steps, [c["mean_return"] for c in curve], "o-")
    ax2.axhline(summary["random_mean_return"], color="gray", ls="--")
    ax2.set_xlabel("environment steps")
    ax2.set_ylabel("mean episode return")
    fig.suptitle(
        f"PPO on {summary['env_id']} (seed {summary['seed']}): final success "
        f"{summary['success_rate']:.0%}, random {summary['random_success_rate']:.0%}",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
