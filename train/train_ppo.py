#!/usr/bin/env python
"""Train Stable-Baselines3 PPO on PenaltyBalls (the project's main job).

    python train/train_ppo.py                                # PenaltyBalls-v0, its tuned settings, seed 0
    python train/train_ppo.py --seed 1 --out runs/s1
    python train/train_ppo.py --env-id PenaltyBalls-v1       # rolling balls
    python train/train_ppo.py --env-id PenaltyBallsSand-v1   # sand, from scratch: a curriculum inside
    python train/train_ppo.py --env-id PenaltyBalls2D-v0 --env-kwarg n_obstacles=2
    python train/train_ppo.py --env-id PenaltyBalls2D-v0 --obs-mode rgb   # from pixels (CnnPolicy)
    python train/train_ppo.py --env-id PenaltySandLevel2D-v0 --env-kwarg target='"random"'  # sand shaping

Each id trains with its own tuned settings (``train/_tuned.py``; docs/training.md says how they
were chosen); any flag overrides them. The worlds are stepped by our native SB3 VecEnv (one Numba
call for all of them), their first episodes staggered (``PenaltyBallsVecEnv.stagger``), with
observation and reward normalisation (VecNormalize). Every ``--eval-freq`` steps the policy plays
the same ``--eval-episodes`` held-out episodes, timed apart from the training. On a terminal a
progress bar shows steps/s, the success so far and the time left (``--quiet``: nothing). A sand
id first trains its curriculum's id (``run``); ``--init-from RUN`` starts from a previous run's
policy and normalisation statistics instead (:func:`init_from`). The run folder (``--out``)
receives:

  model.zip           the trained policy
  vecnormalize.pkl    the observation/reward normalisation statistics
  learning_curve.png  success rate and return against environment steps
  policy.gif          the trained policy, two episodes
  evaluations.csv     the curve's data
  summary.json        timesteps, train_time_s (the training without its evaluations), wall_time_s,
                      time_split (env stepping, policy and rollout, update, evaluation),
                      env_steps_per_s, success_rate and mean_return (100 episodes on held-out
                      seeds), random_success_rate and random_mean_return (a random policy on the
                      same seeds; the level task's raster sweep too, scripted_*), the settings,
                      a sand run's ``curriculum`` stage, and with ``--imitate`` the warm start's
                      figures (``imitation``; time_split's imitation_s)
  stage1-<id>/        a sand run's first stage, a run folder of its own

``train(settings, out)`` is the run itself, importable: this CLI and the Ray Tune sweep
(``train/sweep.py``) both call it, so a trial of a sweep is exactly this script's run.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402
import _threads  # noqa: E402
import _tuned  # noqa: E402

# The defaults: PenaltyBalls-v0's tuned settings. Another id's run takes its own (_tuned.TUNED),
# and the command line or train()'s settings override either.
DEFAULTS: dict[str, Any] = dict(
    env_id="PenaltyBalls-v0",
    **{k: v for k, v in _tuned.TUNED["PenaltyBalls-v0"].items() if k != "threads"},
    eval_episodes=100,
    final_episodes=100,
)

# Every setting of one run, train()'s first argument: the defaults above, plus these.
SETTINGS: dict[str, Any] = dict(
    DEFAULTS,
    seed=0,
    env_kwargs={},
    normalize=True,
    threads=_tuned.TUNED["PenaltyBalls-v0"]["threads"],  # torch threads: "auto" or a count (_threads.py)
    numba_threads=None,  # physics threads; None: Numba's own default (every core)
    tensorboard=None,
    init_from=None,  # a run folder whose policy and normalisation this run starts from (init_from())
    progress=True,  # a progress bar when standard output is a terminal
    quiet=False,  # no progress bar and no evaluation lines
    stop_at=None,  # stop at the first evaluation with at least this success rate (None: never)
    gif=True,
    stagger=True,  # the training worlds' first episodes out of phase (PenaltyBallsVecEnv.stagger)
    curriculum=True,  # main(): run the id's curriculum stage first (_tuned.CURRICULUM) when it has one
    obs_mode="state",  # the env's obs_mode: "state", "heightmap", "rgb" or a tuple of them (a Dict)
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
    "log_std_init",
    "sde_sample_freq",
    "action_repeat",
    "imitate",
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
    "sde_sample_freq": -1,
    "action_repeat": 1,
    "imitate": 0,
}
# float settings: (low, high, low included, high included)
_FLOATS = {
    "learning_rate": (0.0, math.inf, False, False),
    "gamma": (0.0, 1.0, False, True),
    "gae_lambda": (0.0, 1.0, True, True),
    "ent_coef": (0.0, math.inf, True, False),
    "clip_range": (0.0, math.inf, False, False),
    "log_std_init": (-math.inf, math.inf, False, False),
}


def _registered(env_id: str) -> bool:
    import gymnasium as gym

    import penalty_env  # noqa: F401  (registers the ids)

    try:
        gym.spec(env_id)
    except gym.error.Error:
        return False
    return True


def check_settings(settings: Mapping[str, Any]) -> dict[str, Any]:
    """``settings`` with the defaults of :data:`SETTINGS` filled in, or a ValueError that names
    the setting, its value and what is allowed (an unknown name lists the known ones)."""
    unknown = [k for k in settings if k not in SETTINGS]
    if unknown:
        raise ValueError(
            f"unknown setting {unknown[0]!r} (value {settings[unknown[0]]!r}); the settings are: {', '.join(SETTINGS)}"
        )
    env_id = settings.get("env_id", SETTINGS["env_id"])
    s = {**SETTINGS, **(_tuned.tuned(env_id) if isinstance(env_id, str) else {}), **settings}
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
    s["threads"] = _threads.parse(s["threads"])
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
    if not isinstance(s["env_id"], str) or not _registered(s["env_id"]):
        raise ValueError(f"setting 'env_id' must be a registered env id (e.g. PenaltyBalls-v0), got {s['env_id']!r}")
    if s["batch_size"] > s["n_envs"] * s["n_steps"]:
        raise ValueError(
            f"setting 'batch_size' ({s['batch_size']}) must be at most n_envs * n_steps "
            f"({s['n_envs']} * {s['n_steps']} = {s['n_envs'] * s['n_steps']}, one rollout)"
        )
    stop = s["stop_at"]
    if stop is not None and (isinstance(stop, bool) or not isinstance(stop, (int, float)) or not 0.0 < stop <= 1.0):
        raise ValueError(f"setting 'stop_at' must be None or a success rate in (0, 1], got {stop!r}")
    for key in ("normalize", "progress", "quiet", "gif", "curriculum", "stagger"):
        if not isinstance(s[key], bool):
            raise ValueError(f"setting {key!r} must be true or false, got {s[key]!r}")
    s["env_kwargs"] = dict(s["env_kwargs"])
    from penalty_env.envs.views import check_obs_mode

    mode = s["obs_mode"]
    if isinstance(mode, str) and "," in mode:  # the command line's "state,rgb"
        mode = tuple(m.strip() for m in mode.split(","))
    try:
        s["obs_mode"] = check_obs_mode(mode)
    except ValueError as e:
        raise ValueError(f"setting 'obs_mode': {e}") from None
    if "obs_mode" in s["env_kwargs"]:
        raise ValueError("set the observation mode with the setting 'obs_mode' (--obs-mode), not in env_kwargs")
    if s["obs_mode"] != "state" and s["init_from"] is not None:
        raise ValueError(f"setting 'init_from' needs obs_mode 'state', got obs_mode {s['obs_mode']!r}")
    if s["imitate"] and (s["obs_mode"] != "state" or not s["env_id"].split(":")[-1].startswith("PenaltySandLevel")):
        raise ValueError(
            f"setting 'imitate' ({s['imitate']}) needs a PenaltySandLevel id observing its state (the raster sweep "
            f"reads it), got env_id {s['env_id']!r} with obs_mode {s['obs_mode']!r}; use 0"
        )
    return s


def policy_for(obs_mode: str | tuple[str, ...]) -> tuple[str, dict[str, Any]]:
    """The SB3 policy for an observation mode and VecNormalize's arguments: vectors (``"state"``,
    ``"heightmap"``) an ``MlpPolicy``, normalised; images (``"rgb"``) SB3's ``CnnPolicy``, not
    normalised (it scales uint8 pixels to [0, 1] itself); a ``Dict`` a ``MultiInputPolicy``, its
    vector entries normalised."""
    if isinstance(obs_mode, str):
        if obs_mode == "rgb":
            return "CnnPolicy", {"norm_obs": False}
        return "MlpPolicy", {"norm_obs": True}
    keys = [m for m in obs_mode if m != "rgb"]
    return "MultiInputPolicy", ({"norm_obs": True, "norm_obs_keys": keys} if keys else {"norm_obs": False})


# the settings with a per-id tuned value: (name, type, help)
_TUNABLE = (
    ("timesteps", int, "environment steps"),
    ("n_envs", int, "parallel worlds"),
    ("n_steps", int, "PPO rollout length per world"),
    ("batch_size", int, "PPO minibatch"),
    ("n_epochs", int, "PPO epochs per update"),
    ("learning_rate", float, "Adam step size, linearly decayed"),
    ("gamma", float, "discount"),
    ("gae_lambda", float, "GAE lambda"),
    ("ent_coef", float, "entropy bonus"),
    ("clip_range", float, "PPO clip"),
    ("log_std_init", float, "initial log standard deviation of the actions (--init-from copies the earlier run's)"),
    (
        "sde_sample_freq",
        int,
        "exploration noise: 0 a new Gaussian draw every step; else generalised state-dependent exploration "
        "(gSDE), its noise drawn anew every this many steps, -1 once per rollout",
    ),
    (
        "action_repeat",
        int,
        "the policy decides every this many env steps and holds its action in between (frame skip; "
        "timesteps, n_steps and eval_freq then count decisions)",
    ),
    (
        "imitate",
        int,
        "a warm start: this many decisions of the task's scripted controller (the level task's raster sweep) on "
        "the training worlds, the policy fitted to its actions and the value to its returns before PPO "
        "(train/_imitate.py); 0: none",
    ),
    ("net_arch", str, "hidden layer sizes, comma separated"),
    ("eval_freq", int, "env steps between held-out evaluations"),
    (
        "threads",
        str,
        "torch threads: auto (2 while nothing else runs on the machine, 1 while something does, looked at "
        "before every update), or a count; a count gives the same result for a seed on any load, auto on an "
        "idle machine equals 2; torch's thread count changes the numbers (docs/training.md)",
    ),
)


def _stop_rate(text: str) -> float | str:
    """``--stop-at``'s value: a success rate, or ``"never"``."""
    if text.strip().lower() == "never":
        return "never"
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a success rate in (0, 1] or 'never', got {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="train_ppo.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--env-id", default=DEFAULTS["env_id"], help="registered env id (default: %(default)s)")
    p.add_argument(
        "--env-kwarg",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="env keyword argument, repeatable; VALUE parsed as JSON (e.g. n_obstacles=2)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the worlds, the policy and torch (default: %(default)s)"
    )
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/ppo-<env>-seed<seed>)")
    # the id's tuned value when not given (train/_tuned.py; PenaltyBalls-v0's is shown)
    for name, kind, text in _TUNABLE:
        p.add_argument(
            "--" + name.replace("_", "-"),
            type=kind,
            default=None,
            help=f"{text} (default: the id's tuned value; PenaltyBalls-v0: {SETTINGS[name]})",
        )
    p.add_argument("--no-normalize", action="store_true", help="disable VecNormalize")
    p.add_argument(
        "--eval-episodes",
        type=int,
        default=DEFAULTS["eval_episodes"],
        help="held-out episodes per evaluation during training, one per world (default: %(default)s)",
    )
    p.add_argument(
        "--final-episodes",
        type=int,
        default=DEFAULTS["final_episodes"],
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
    p.add_argument("--no-progress", action="store_true", help="no progress bar (evaluations are printed instead)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no evaluation lines")
    p.add_argument(
        "--stop-at",
        type=_stop_rate,
        default=None,
        metavar="RATE",
        help="stop at the first evaluation whose success rate is at least RATE (e.g. 0.9), or 'never' (default: "
        "the id's tuned value: 0.95 for the sand ids, else never)",
    )
    p.add_argument("--no-gif", action="store_true", help="skip the GIF of the trained policy")
    p.add_argument(
        "--no-stagger",
        action="store_true",
        help="start the training worlds' episodes together (PenaltyBallsVecEnv.stagger, on by default)",
    )
    p.add_argument(
        "--no-curriculum",
        action="store_true",
        help="a sand id from scratch, without its curriculum's first stage (train/_tuned.py)",
    )
    p.add_argument(
        "--obs-mode",
        default="state",
        help="the env's observation: state (default), heightmap, rgb (an image: PPO's CnnPolicy), or several "
        "comma separated, e.g. state,rgb (a Dict: MultiInputPolicy)",
    )
    p.add_argument(
        "--numba-threads",
        type=int,
        default=None,
        help="threads of the physics (default: Numba's own, every core; a part no thread has started runs on "
        "the main thread, so they cost nothing on a shared machine; the result does not depend on them)",
    )
    return p


def settings_from_args(args: argparse.Namespace) -> dict[str, Any]:
    """The run's settings (:data:`SETTINGS`) from the parsed command line."""
    s = {k: getattr(args, k) for k in DEFAULTS if getattr(args, k, None) is not None}
    if args.threads is not None:
        s["threads"] = args.threads
    s.update(
        seed=args.seed,
        env_kwargs=C.parse_env_kwargs(args.env_kwarg),
        normalize=not args.no_normalize,
        numba_threads=args.numba_threads,
        tensorboard=args.tensorboard,
        init_from=args.init_from,
        progress=not args.no_progress,
        quiet=args.quiet,
        gif=not args.no_gif,
        curriculum=not args.no_curriculum,
        obs_mode=args.obs_mode,
    )
    if args.stop_at is not None:
        s["stop_at"] = None if args.stop_at == "never" else args.stop_at
    if args.no_stagger:
        s["stagger"] = False
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
    return run(settings, args.out or default_out(settings))


def run(
    settings: Mapping[str, Any], out: Path, on_eval: Callable[[dict[str, Any]], None] | None = None
) -> dict[str, Any]:
    """:func:`train`, after the id's curriculum stage when it has one (``_tuned.CURRICULUM``; the
    ``curriculum`` setting on, no ``init_from`` given): that id's tuned run, into
    ``out/stage1-<id>``, until its held-out success reaches ``_tuned.CURRICULUM_STOP_AT`` (or its
    budget ends); then this id's run starts from its policy. The summary's ``curriculum`` entry
    holds the first stage's figures, ``total_train_time_s`` both stages' training time. The first
    stage takes its id's tuned settings, except these of this run: :data:`STAGE_KEEPS`.
    ``on_eval``: as :func:`train`'s, for this id's run."""
    s = check_settings(settings)
    first = _tuned.CURRICULUM.get(s["env_id"].split(":")[-1])
    if first is None or not s["curriculum"] or s["init_from"] is not None:
        return train(s, out, on_eval=on_eval)
    stage_out = Path(out) / f"stage1-{first}"
    keep = STAGE_KEEPS
    stage = train(
        {"env_id": first, **{k: s[k] for k in keep}, "stop_at": _tuned.CURRICULUM_STOP_AT, "gif": False},
        stage_out,
    )
    return train({**s, "init_from": str(stage_out)}, out, on_eval=on_eval, stage=stage)


# the settings a curriculum's first stage takes from the run (init_from needs the same network)
STAGE_KEEPS = (
    "seed",
    "numba_threads",
    "threads",
    "progress",
    "quiet",
    "normalize",
    "net_arch",
    "stagger",
    "eval_episodes",
    "final_episodes",
    "tensorboard",
)


def train(
    settings: Mapping[str, Any],
    out: Path,
    on_eval: Callable[[dict[str, Any]], None] | None = None,
    stage: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """One training run: PPO with ``settings`` (names and defaults in :data:`SETTINGS`), its run
    folder written to ``out`` (the files listed in the module docstring). Returns the summary
    (summary.json). ``on_eval`` is called with each point of the learning curve as it is measured
    (the sweep reports them to Ray Tune). ``stage``: the summary of a curriculum's first stage
    that this run starts from (:func:`run`), recorded in this run's summary."""
    s = check_settings(settings)
    from _callbacks import HeldOutEval, Progress, TimedPPO, TimedVecEnv, TrainClock, show_progress
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecNormalize

    from penalty_env.physics.stepping import runner

    physics_threads = None
    if s["numba_threads"] is not None:
        import numba

        physics_threads = min(s["numba_threads"], numba.config.NUMBA_NUM_THREADS)
        numba.set_num_threads(physics_threads)
    runner.set_thread_count(physics_threads)  # (the env's batches, and the large worlds' parallel regions)
    threads = machine_threads()
    note = _threads.note(s["threads"], threads["cpus"], threads["load_at_start"])
    if note:
        print(note, file=sys.stderr, flush=True)
    torch_threads = _threads.TorchThreads(s["threads"])
    torch_threads.start()
    env_id: str = s["env_id"]
    seed: int = s["seed"]
    env_kwargs: dict[str, Any] = s["env_kwargs"]
    policy, norm = policy_for(s["obs_mode"])
    if s["obs_mode"] != "state":
        env_kwargs = {**env_kwargs, "obs_mode": s["obs_mode"]}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    set_random_seed(seed)

    repeat = s["action_repeat"]
    venv = timed_env = TimedVecEnv(
        C.make_env(env_id, s["n_envs"], seed, env_kwargs, stagger=s["stagger"], action_repeat=repeat)
    )
    if s["normalize"]:
        venv = VecNormalize(venv, norm_reward=True, gamma=s["gamma"], **norm)
    vecnorm = venv if isinstance(venv, VecNormalize) else None

    curve: list[dict] = []
    clock = TrainClock()
    eval_seed = C.EVAL_SEED_OFFSET + seed
    eval_env = C.make_env(env_id, s["eval_episodes"], eval_seed, env_kwargs)

    bar = s["progress"] and show_progress(s["quiet"])
    held_out = HeldOutEval(
        eval_env,
        eval_seed,
        vecnorm,
        every=s["eval_freq"],
        clock=clock,
        curve=curve,
        on_eval=on_eval,
        stop_at=s["stop_at"],
        log=None if (bar or s["quiet"]) else lambda line: print(line, flush=True),
        action_repeat=repeat,
    )
    hidden = [int(h) for h in s["net_arch"].split(",") if h.strip()]
    lr0 = s["learning_rate"]
    with torch_threads.building():  # (the initial weights depend on torch's threads: _threads.py)
        model = TimedPPO(
            policy,
            venv,
            n_steps=s["n_steps"],
            batch_size=s["batch_size"],
            n_epochs=s["n_epochs"],
            learning_rate=lambda frac: lr0 * frac,
            gamma=s["gamma"],
            gae_lambda=s["gae_lambda"],
            ent_coef=s["ent_coef"],
            clip_range=s["clip_range"],
            policy_kwargs=dict(net_arch=dict(pi=hidden, vf=hidden), log_std_init=s["log_std_init"]),
            use_sde=s["sde_sample_freq"] != 0,
            sde_sample_freq=s["sde_sample_freq"],
            tensorboard_log=str(s["tensorboard"]) if s["tensorboard"] else None,
            seed=seed,
            device="cpu",
            verbose=0,
        )
    model.before_update = torch_threads.before_update
    if s["init_from"] is not None:
        init_from(model, vecnorm, Path(s["init_from"]))
    start = f", from {s['init_from']}" if s["init_from"] else ""
    print(
        f"training PPO on {env_id} {env_kwargs or ''}: {s['timesteps']:,} steps, "
        f"{s['n_envs']} worlds, seed {seed}{start} -> {out}",
        flush=True,
    )
    callbacks: list = [held_out]
    if bar:
        callbacks.append(Progress(s["timesteps"], curve, desc=env_id))
    clock.start()
    imitation = None
    if s["imitate"]:
        from _imitate import imitate

        torch_threads.before_update()
        imitation = imitate(model, venv, vecnorm, C.scripted_policy(venv), s["imitate"])
        imitation["train_time_s"] = round(clock.train_time(), 2)
        imitation["env_steps"] = imitation["decisions"] * repeat  # (not in the summary's env_steps: PPO's)
        imitation["env_step_s"] = round(timed_env.time, 2)
        timed_env.time = 0.0  # (the time split below is PPO's)
        if not s["quiet"]:
            print(
                f"[imitate] {imitation['decisions']:,} decisions of the scripted controller (mean return "
                f"{imitation['teacher_mean_return']:.2f} over {imitation['episodes']} episodes), "
                f"action MSE {imitation['action_mse']}, in {imitation['train_time_s']} s",
                flush=True,
            )
        held_out.init_callback(model)  # (PPO's starting point: the curve's point at 0 steps)
        held_out.evaluate()
    if not held_out.reached:  # (a copy already at stop_at needs no PPO)
        model.learn(total_timesteps=s["timesteps"], callback=callbacks)
    wall, train_time = clock.wall_time(), clock.train_time()
    env_time = timed_env.time
    time_split = {
        "env_step_s": round(env_time, 2),
        "policy_and_rollout_s": round(model.rollout_time - env_time - held_out.eval_in_rollout, 2),
        "update_s": round(model.update_time, 2),
        "evaluation_s": round(held_out.eval_time, 2),
        **({"imitation_s": imitation["train_time_s"]} if imitation is not None else {}),
    }

    model.save(out / "model.zip")
    if vecnorm is not None:
        vecnorm.save(str(out / "vecnormalize.pkl"))

    # final evaluation on held-out seeds, and a random policy on the very same seeds
    final_seed = C.FINAL_SEED_OFFSET + seed
    n_eval_envs = min(20, s["final_episodes"])
    trained = C.run_episodes(
        C.make_env(env_id, n_eval_envs, final_seed, env_kwargs),
        C.model_policy(model, vecnorm),
        s["final_episodes"],
        repeat,
    )
    refs = C.baselines(env_id, n_eval_envs, final_seed, env_kwargs, s["final_episodes"])
    rand, scripted = refs["random"], refs.get("scripted")  # (scripted: the level task's raster sweep)

    summary = {
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "obs_mode": s["obs_mode"],
        "seed": seed,
        "timesteps": int(model.num_timesteps),
        "env_steps": int(model.num_timesteps) * repeat,  # (timesteps count decisions)
        "wall_time_s": round(wall, 2),
        "train_time_s": round(train_time, 2),
        "time_split": time_split,
        "env_steps_per_s": round(model.num_timesteps * repeat / train_time, 1),
        "success_rate": trained["success_rate"],
        "mean_return": trained["mean_return"],
        "std_return": trained["std_return"],
        "eval_episodes": trained["episodes"],
        "eval_seeds": f"{final_seed}..{final_seed + n_eval_envs - 1} (held out; training used {seed}..{seed + s['n_envs'] - 1})",
        "random_success_rate": rand["success_rate"],
        "random_mean_return": rand["mean_return"],
        **(
            {"scripted_success_rate": scripted["success_rate"], "scripted_mean_return": scripted["mean_return"]}
            if scripted is not None
            else {}
        ),
        "hyperparameters": {k: s[k] for k in HYPERPARAMETERS},
        "normalize": s["normalize"],
        "stagger": s["stagger"],
        "init_from": s["init_from"],
        **({"imitation": imitation} if imitation is not None else {}),
        "threads": {**torch_threads.record(), **threads},
        "curve": curve,
    }
    if stage is not None:
        summary["curriculum"] = {
            k: stage[k]
            for k in ("env_id", "timesteps", "train_time_s", "wall_time_s", "time_split", "success_rate", "curve")
        }
        summary["total_train_time_s"] = round(stage["train_time_s"] + train_time, 2)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    with open(out / "evaluations.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["timesteps", "success_rate", "mean_return", "train_time_s", "wall_time_s"])
        w.writeheader()
        w.writerows(curve)
    plot_curve(curve, summary, out / "learning_curve.png")
    if s["gif"] and not isinstance(s["obs_mode"], tuple):  # (record_gif feeds one array observation)
        C.record_gif(
            env_id,
            env_kwargs,
            C.model_policy(model, vecnorm),
            out / "policy.gif",
            seed=final_seed,
            action_repeat=repeat,
        )

    print(
        f"done in {train_time:.1f} s of training ({summary['env_steps_per_s']:,.0f} env-steps/s; "
        f"{wall - train_time:.1f} s more for the evaluations): success {trained['success_rate']:.0%} "
        f"(random policy {rand['success_rate']:.0%}) over {trained['episodes']} held-out episodes, "
        f"mean return {trained['mean_return']:.2f} (random {rand['mean_return']:.2f}); results in {out}"
    )
    if scripted is not None:
        print(
            f"the scripted baseline on the same episodes: success {scripted['success_rate']:.0%}, "
            f"mean return {scripted['mean_return']:.2f}"
        )
    return summary


def machine_threads() -> dict[str, Any]:
    """The run's physics threads (``runner.thread_count``) and the machine it started on: the CPUs
    this process may use and the 1-minute load average (summary.json's ``threads``, with torch's)."""
    import os

    from penalty_env.physics.stepping import runner

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
    return {"physics": runner.thread_count(), "cpus": _threads.cpus(), "load_at_start": round(load, 2)}


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
