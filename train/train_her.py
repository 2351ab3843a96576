#!/usr/bin/env python
"""Train Stable-Baselines3 SAC with hindsight experience replay (``HerReplayBuffer``) on a
goal-conditioned PenaltyBalls id (sparse reward).

    python train/train_her.py                                  # PenaltyBallsGoal-v0, seed 0
    python train/train_her.py --env-id PenaltyBallsGoal2D-v0 --seed 1
    python train/train_her.py --budget-min 5 --target 0.5 --out runs/her-short

The training worlds are a ``DummyVecEnv`` of ``gymnasium.make`` envs seeded ``seed + i``; HER
relabels the stored transitions with goals the ball reached later in the same episode
(``future``) and rewards them through the env's own ``compute_reward``. Every ``--eval-every``
environment steps the deterministic policy plays ``--eval-episodes`` held-out episodes (one per
world of the native vector env, seeded ``1,000,000 + seed + i``: disjoint from the training
seeds), timed apart from the training. The run stops at the first evaluation whose success rate
reaches ``--target`` (default 0.8), or when the budget (``--budget-min``, default 15, of wall-clock
time; ``--clock cpu``: of the process's CPU time, the fair clock on a machine shared with other
jobs) or ``--max-steps`` runs out; then a second held-out set (seeds ``2,000,000 + seed + i``) measures
the final policy. On a terminal a progress bar shows the budget spent, the steps, steps/s and
the latest held-out success (``--no-progress``: the evaluation lines instead; ``--quiet``:
neither); off a terminal (a log file, a pipe) no bar is drawn. The run folder (``--out``)
receives:

  model.zip           the trained policy (SAC; the replay buffer is not saved)
  summary.json        success_rate (the last held-out evaluation), final_success_rate (the second
                      held-out set), reached (the target met before the budget ran out), timesteps,
                      wall_time_s and cpu_time_s (the whole run, evaluations included),
                      train_wall_time_s (without the evaluations), time_split (setup: making the
                      envs and the model, a first make compiling the env's kernels; env stepping;
                      SAC updates, HER's sampling included; evaluations; the rest: the policy's
                      actions and SB3's bookkeeping), the settings, the curve
  evaluations.csv     the learning curve: steps, success rate, mean return, wall and CPU seconds
  learning_curve.png  success rate against wall-clock and CPU time, and against steps
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402

# The settings of one run (the command line's flags) and their defaults, tuned on
# PenaltyBallsGoal-v0 (docs/training.md, "Goal-conditioned tasks and HER").
SETTINGS: dict[str, Any] = dict(
    env_id="PenaltyBallsGoal-v0",
    seed=0,
    budget_min=15.0,  # the run's budget, minutes (of the clock below)
    clock="wall",  # the budget's clock: "wall" (elapsed time) or "cpu" (the process's CPU time: on a shared machine)
    target=0.8,  # stop at the first held-out evaluation with at least this success rate
    max_steps=10_000_000,  # environment steps (a stop of its own, for short runs)
    n_envs=8,
    net_arch="128,128",
    batch_size=256,
    learning_rate=1e-3,
    gamma=0.98,
    tau=0.05,
    train_freq=1,  # a rollout of train_freq steps in each of the n_envs worlds, then...
    gradient_steps=2,  # ...this many SAC updates
    learning_starts=1_200,
    buffer_size=1_000_000,
    n_sampled_goal=4,
    goal_selection_strategy="future",
    eval_every=25_000,
    eval_episodes=100,
    threads=1,  # torch threads
    reward="sparse",
    policy_obs="goal-free",  # "goal-free": the env's observation without the goal (its default); "full": observe_goal=True
)
POLICY_OBS = ("full", "goal-free")

# What each setting's flag does (the --help text; its default is added there)
HELP: dict[str, str] = dict(
    env_id="the goal-conditioned id to train on (PenaltyBallsGoal-v0, -v1, Goal2D-v0, Goal2D-v1)",
    seed="seed of the training worlds (seed + i), SAC and torch; the held-out seeds are offset from it",
    budget_min="the run's budget in minutes of --clock time: the run stops when it is spent",
    clock="the budget's clock: 'wall' (elapsed time) or 'cpu' (this process's CPU time, fair on a shared machine)",
    target="stop at the first held-out evaluation whose success rate is at least this (0 to 1)",
    max_steps="stop after this many environment steps (summed over the worlds), whatever the budget",
    n_envs="training worlds (a DummyVecEnv of gymnasium.make envs)",
    net_arch="hidden layer widths of the actor and the critics, comma-separated",
    batch_size="minibatch size of each SAC update",
    learning_rate="Adam's learning rate (actor, critics and the entropy coefficient)",
    gamma="discount factor",
    tau="soft update coefficient of the target critics",
    train_freq="environment steps in each world between two rounds of updates",
    gradient_steps="SAC updates in each round",
    learning_starts="environment steps (summed over the worlds) before the first update (at least n_envs x "
    "max_episode_steps: HER samples only from ended episodes)",
    buffer_size="replay buffer capacity, transitions",
    n_sampled_goal="relabelled goals per stored transition (HER's k)",
    goal_selection_strategy="where HER takes the relabelled goals: 'future', 'final' or 'episode'",
    eval_every="environment steps (summed over the worlds) between two held-out evaluations",
    eval_episodes="held-out episodes per evaluation, one per world of the native vector env",
    threads="torch threads",
    reward="the env's reward: 'sparse' (-1 until the goal, 0 at it) or 'dense' (minus the distance)",
    policy_obs="'goal-free': the env's observation without the goal fields (HER relabels the goal); "
    "'full': with them (observe_goal=True)",
)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="train_her.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    for key, default in SETTINGS.items():
        flag = "--" + key.replace("_", "-")
        kind = type(default)
        p.add_argument(flag, type=kind, default=default, help=f"{HELP[key]} (default: %(default)s)")
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/her-<env>-seed<seed>)")
    p.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress bar on a terminal (the evaluation lines are printed instead)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar and no evaluation lines")
    return p


def check_settings(s: dict[str, Any]) -> dict[str, Any]:
    """Refuse settings that cannot run, naming the setting, its value and what is allowed."""
    import gymnasium as gym

    import penalty_env  # noqa: F401 (registers the ids)

    if s["env_id"] not in gym.registry or "Goal" not in s["env_id"]:
        goal_ids = sorted(k for k in gym.registry if k.startswith("PenaltyBallsGoal"))
        raise ValueError(f"env_id must be a goal-conditioned id, one of {goal_ids}, got {s['env_id']!r}")
    for key in ("n_envs", "batch_size", "train_freq", "gradient_steps", "eval_every", "eval_episodes", "threads"):
        if s[key] < 1:
            raise ValueError(f"{key} must be >= 1, got {s[key]}")
    if s["n_sampled_goal"] < 0:
        raise ValueError(f"n_sampled_goal must be >= 0, got {s['n_sampled_goal']}")
    # HER samples only from ended episodes: the first updates wait for every world's first one
    first_episodes = s["n_envs"] * gym.spec(s["env_id"]).max_episode_steps
    if s["learning_starts"] < first_episodes:
        raise ValueError(
            f"learning_starts must be >= n_envs x max_episode_steps = {first_episodes} (HER samples only "
            f"from ended episodes), got {s['learning_starts']}"
        )
    if not s["budget_min"] > 0 or not s["max_steps"] > 0:
        raise ValueError(f"budget_min and max_steps must be > 0, got {s['budget_min']} and {s['max_steps']}")
    if s["policy_obs"] not in POLICY_OBS:
        raise ValueError(f"policy_obs must be one of {POLICY_OBS}, got {s['policy_obs']!r}")
    if s["clock"] not in ("wall", "cpu"):
        raise ValueError(f"clock must be one of ('wall', 'cpu'), got {s['clock']!r}")
    if not 0.0 <= s["target"] <= 1.0:
        raise ValueError(f"target must be in [0, 1], got {s['target']}")
    if s["goal_selection_strategy"] not in ("future", "final", "episode"):
        raise ValueError(
            f"goal_selection_strategy must be one of ('future', 'final', 'episode'), got {s['goal_selection_strategy']!r}"
        )
    if not all(h.strip().isdigit() and int(h) > 0 for h in s["net_arch"].split(",")):
        raise ValueError(f"net_arch must be comma-separated layer widths such as 256,256, got {s['net_arch']!r}")
    return s


def evaluate(model, venv, seed: int) -> dict[str, float]:
    """The deterministic policy's first episode in every world of the native vector env ``venv``
    (world i seeded ``seed + i``): success rate and mean return."""
    n = venv.num_envs
    obs, _ = venv.reset(seed=seed)
    ended = np.zeros(n, dtype=bool)
    success = np.zeros(n, dtype=bool)
    returns = np.zeros(n)
    while not ended.all():
        actions, _ = model.predict(obs, deterministic=True)
        obs, rewards, terminated, truncated, _ = venv.step(actions)
        returns += np.where(ended, 0.0, rewards)
        success |= terminated & ~ended
        ended |= terminated | truncated
    return {"success_rate": float(success.mean()), "mean_return": float(returns.mean())}


def main(argv=None) -> dict[str, Any]:
    parser = build_parser()
    args = parser.parse_args(argv)
    s = {k: getattr(args, k) for k in SETTINGS}
    try:
        check_settings(s)
    except ValueError as e:
        parser.error(str(e))
    out = args.out or Path("runs") / f"her-{s['env_id']}-seed{s['seed']}"
    return train(s, out, quiet=args.quiet, progress=not args.no_progress)


class BudgetBar:
    """A tqdm bar over the run's budget (seconds of its clock, ``clock()``): the share spent, the
    environment steps, steps/s and the latest held-out success (the target is on the line above). Redrawn at
    most every ``every`` seconds of wall time; tqdm's estimate of the time left is the budget's."""

    def __init__(self, budget_s: float, clock, desc: str, every: float = 0.5) -> None:
        import shutil

        from tqdm import tqdm

        self.budget_s, self.clock, self.every = budget_s, clock, every
        self.t0 = time.perf_counter()
        self.last = -every
        # a terminal that reports no size (0 by 0: tqdm would hide the bar) counts as 100 by 24
        size = shutil.get_terminal_size((100, 24))
        self.bar = tqdm(
            total=budget_s,
            desc=desc,
            ncols=size.columns,
            nrows=size.lines,
            file=sys.stdout,
            bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s of budget{postfix} [{remaining} left]",
        )

    def show(self, steps: int, success: float | None, force: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self.last < self.every:
            return
        self.last = now
        rate = steps / max(now - self.t0, 1e-9)
        held_out = "no evaluation yet" if success is None else f"success {success:.0%}"
        self.bar.set_postfix_str(f"{steps:,} steps, {rate:,.0f} steps/s, {held_out}", refresh=False)
        self.bar.update(min(self.clock(), self.budget_s) - self.bar.n)

    def close(self) -> None:
        self.bar.close()


def train(s: dict[str, Any], out: Path, quiet: bool = False, progress: bool = True) -> dict[str, Any]:
    """One run with settings ``s`` (:data:`SETTINGS`' keys), its folder written to ``out``;
    returns the summary (summary.json). ``progress``: a progress bar when standard output is a
    terminal (then no evaluation lines); ``quiet``: no bar and no evaluation lines."""
    import gymnasium as gym
    import torch
    from _callbacks import TimedVecEnv, show_progress
    from stable_baselines3 import SAC, HerReplayBuffer
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import DummyVecEnv

    import penalty_env  # noqa: F401 (registers the ids)

    t_wall, t_cpu = time.perf_counter(), time.process_time()
    torch.set_num_threads(s["threads"])
    set_random_seed(s["seed"])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    # "goal-free": the env's own observation (without the goal: HER's relabelled goals would
    # contradict it); "full": with it (observe_goal=True)
    env_kwargs = {"reward": s["reward"], "observe_goal": s["policy_obs"] == "full"}
    venv = TimedVecEnv(
        make_vec_env(
            s["env_id"],
            n_envs=s["n_envs"],
            seed=s["seed"],
            vec_env_cls=DummyVecEnv,
            env_kwargs=env_kwargs,
        )
    )
    eval_seed, final_seed = C.EVAL_SEED_OFFSET + s["seed"], C.FINAL_SEED_OFFSET + s["seed"]
    eval_env = gym.make_vec(s["env_id"], num_envs=s["eval_episodes"], **env_kwargs)

    class TimedSAC(SAC):
        update_time = 0.0

        def train(self, *args, **kwargs):
            t = time.perf_counter()
            super().train(*args, **kwargs)
            self.update_time += time.perf_counter() - t

    model = TimedSAC(
        "MultiInputPolicy",
        venv,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs=dict(
            n_sampled_goal=s["n_sampled_goal"], goal_selection_strategy=s["goal_selection_strategy"]
        ),
        learning_rate=s["learning_rate"],
        buffer_size=s["buffer_size"],
        learning_starts=s["learning_starts"],
        batch_size=s["batch_size"],
        tau=s["tau"],
        gamma=s["gamma"],
        train_freq=s["train_freq"],
        gradient_steps=s["gradient_steps"],
        policy_kwargs=dict(net_arch=[int(h) for h in s["net_arch"].split(",")]),
        seed=s["seed"],
        device="cpu",
        verbose=0,
    )
    eval_env.reset(seed=eval_seed)  # (a first make compiles the env's kernels: counted in setup_s)
    setup_s = time.perf_counter() - t_wall
    curve: list[dict[str, Any]] = []
    budget_s = 60.0 * s["budget_min"]

    def spent() -> float:
        """Seconds of the budget's clock since the start."""
        return time.process_time() - t_cpu if s["clock"] == "cpu" else time.perf_counter() - t_wall

    class HeldOut(BaseCallback):
        """Evaluate every ``eval_every`` steps; stop at the target or when the budget is spent."""

        def __init__(self) -> None:
            super().__init__()
            self.next_at, self.eval_time, self.reached = s["eval_every"], 0.0, False

        def evaluate(self) -> None:
            t = time.perf_counter()
            res = evaluate(self.model, eval_env, eval_seed)
            self.eval_time += time.perf_counter() - t
            point = {
                "timesteps": int(self.num_timesteps),
                **res,
                "wall_time_s": round(time.perf_counter() - t_wall, 2),
                "cpu_time_s": round(time.process_time() - t_cpu, 2),
            }
            curve.append(point)
            self.reached = res["success_rate"] >= s["target"]
            if bar is not None:
                bar.show(point["timesteps"], res["success_rate"], force=True)
            elif not quiet:
                print(
                    f"[eval] steps={point['timesteps']:>8,} success={res['success_rate']:.2f} "
                    f"return={res['mean_return']:.1f} wall={point['wall_time_s']:.0f}s cpu={point['cpu_time_s']:.0f}s",
                    flush=True,
                )

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_at:
                self.next_at += s["eval_every"]
                self.evaluate()
                if self.reached:
                    return False
            if bar is not None:
                bar.show(int(self.num_timesteps), curve[-1]["success_rate"] if curve else None)
            return spent() < budget_s

        def _on_training_end(self) -> None:
            if not curve or curve[-1]["timesteps"] != self.num_timesteps:
                self.evaluate()
            if bar is not None:
                bar.close()

    print(
        f"training SAC+HER on {s['env_id']}: target {s['target']:.0%} held-out success within "
        f"{s['budget_min']:g} min ({s['clock']} time), {s['n_envs']} worlds, seed {s['seed']} -> {out}",
        flush=True,
    )
    # drawn from here on, below the line above (the callbacks read it when they run)
    bar = BudgetBar(budget_s, spent, s["env_id"]) if progress and show_progress(quiet) else None
    held_out = HeldOut()
    model.learn(total_timesteps=s["max_steps"], callback=held_out)
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    final = evaluate(model, eval_env, final_seed)
    model.save(out / "model.zip")
    summary = {
        "env_id": s["env_id"],
        "seed": s["seed"],
        "success_rate": curve[-1]["success_rate"],
        "final_success_rate": final["success_rate"],
        "reached": bool(held_out.reached),
        "timesteps": int(model.num_timesteps),
        "wall_time_s": round(wall, 2),
        "cpu_time_s": round(cpu, 2),
        "train_wall_time_s": round(wall - held_out.eval_time, 2),
        "time_split": {
            "setup_s": round(setup_s, 2),
            "env_step_s": round(venv.time, 2),
            "sac_update_s": round(model.update_time, 2),
            "evaluation_s": round(held_out.eval_time, 2),
            "policy_and_rest_s": round(wall - setup_s - venv.time - model.update_time - held_out.eval_time, 2),
        },
        "eval_seeds": f"{eval_seed}..{eval_seed + s['eval_episodes'] - 1}",
        "final_seeds": f"{final_seed}..{final_seed + s['eval_episodes'] - 1}",
        "train_seeds": f"{s['seed']}..{s['seed'] + s['n_envs'] - 1}",
        "settings": s,
        "curve": curve,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    with open(out / "evaluations.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["timesteps", "success_rate", "mean_return", "wall_time_s", "cpu_time_s"])
        w.writeheader()
        w.writerows(curve)
    plot_curve(summary, out / "learning_curve.png")
    print(
        f"done in {wall:.0f} s wall, {cpu:.0f} s CPU, {summary['timesteps']:,} steps: held-out success "
        f"{summary['success_rate']:.0%} ({'reached' if summary['reached'] else 'not reached'}: target "
        f"{s['target']:.0%}), {final['success_rate']:.0%} on a second held-out set; results in {out}",
        flush=True,
    )
    return summary


def plot_curve(summary: dict[str, Any], path: Path) -> None:
    """Held-out success against wall-clock and CPU minutes, and against environment steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curve = summary["curve"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
    success = [c["success_rate"] for c in curve]
    ax1.plot([c["wall_time_s"] / 60.0 for c in curve], success, "o-", label="against wall-clock time")
    ax1.plot([c["cpu_time_s"] / 60.0 for c in curve], success, "s--", label="against the process's CPU time")
    ax1.set_xlabel("minutes since the start (evaluations included)")
    ax2.plot([c["timesteps"] for c in curve], success, "o-")
    ax2.set_xlabel("environment steps")
    for ax in (ax1, ax2):
        ax.axhline(summary["settings"]["target"], color="green", ls=":", lw=1, label="target")
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("success rate")
    ax1.legend(loc="lower right", fontsize=8)
    fig.suptitle(
        f"SAC + HER on {summary['env_id']} (seed {summary['seed']}): {summary['success_rate']:.0%} held-out "
        f"success after {summary['wall_time_s'] / 60.0:.1f} min wall, {summary['cpu_time_s'] / 60.0:.1f} min CPU",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
