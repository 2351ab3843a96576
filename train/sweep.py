#!/usr/bin/env python
"""Seeds, hyperparameters and env variants on Ray Tune: the training of ``train_ppo.py``, many times.

    python train/sweep.py --seeds 0,1,2 --grid env_kwargs.restitution_accuracy=0.3,0.1
    python train/sweep.py --config sweep.yaml --out runs/sweep-lr
    python train/sweep.py --resume runs/sweep-lr          # after Ctrl+C, a crash or a lost node
    python train/sweep.py ... --address ray://head:10001  # a cluster (or set RAY_ADDRESS)

Every trial calls ``train_ppo.run`` (the function behind ``train_ppo.py``) with one
configuration and one seed, so its run folder and summary are those of
``python train/train_ppo.py --seed S --threads K --numba-threads K ...`` with the same settings. A
trial holds ``--cpus-per-trial`` K CPUs (``tune.with_resources``) and runs torch and Numba on K
threads, so trials never oversubscribe the cores. A trial whose worker dies is run again, up to
``--max-failures`` times (Tune's ``FailureConfig``), from its start: training is deterministic, so
the retry gives the result the lost run would have.

Configurations: the ``--grid`` product (every combination), or ``--num-samples`` draws of the
``--random`` distributions (crossed with the grid if both are given), each run with every seed of
``--seeds``. A key is a setting of train_ppo.py (``learning_rate``, ``n_epochs``, ``timesteps``,
...) or ``env_kwargs.NAME`` for an env keyword argument. The same in a YAML file (``--config``;
the command line adds to it and wins)::

    name: restitution-accuracy
    seeds: [0, 1, 2]
    cpus_per_trial: 1
    settings: {timesteps: 600000}                 # fixed for every trial
    grid: {env_kwargs.restitution_accuracy: [0.3, 0.1]}
    random: {learning_rate: {loguniform: [1.0e-4, 3.0e-3]}}   # uniform, loguniform, randint, choice
    num_samples: 4
    search_seed: 0

Output, in ``--out`` (default ``runs/sweep-NAME``): ``runs/<trial>/`` (one run folder per trial,
train_ppo.py's format), ``trials.csv`` (one row per trial), ``summary.csv`` and ``summary.md``
(per configuration: mean, spread and range over seeds), ``success_vs_steps.png`` (success rate
against env steps, mean and min-max over seeds, per configuration) and ``sweep.json`` (the
sweep's spec, for ``--resume``). Ray Tune keeps its experiment (state, checkpoints) under
``--storage`` (default ``OUT/tune``; a multi-node cluster needs shared storage there: NFS, s3://).
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import os
import re
import signal
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

TRAIN_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(TRAIN_DIR))

import train_ppo as T  # noqa: E402

ENV_PREFIX = "env_kwargs."
# train_ppo settings a sweep may fix or vary (the seed comes from `seeds`; threads from the CPUs)
SWEEPABLE = tuple(
    k for k in T.SETTINGS if k not in ("seed", "env_kwargs", "threads", "numba_threads", "progress", "tensorboard")
)
SPEC_KEYS = (
    "name",
    "seeds",
    "settings",
    "grid",
    "random",
    "num_samples",
    "search_seed",
    "cpus_per_trial",
    "max_concurrent_trials",
    "max_failures",
)
DISTRIBUTIONS = ("uniform", "loguniform", "randint", "choice")
SPEC_DEFAULTS: dict[str, Any] = dict(
    name="sweep",
    seeds=[0],
    settings={},
    grid={},
    random={},
    num_samples=1,
    search_seed=0,
    cpus_per_trial=1,
    max_concurrent_trials=None,
    max_failures=2,
)
# Fault injection for the tests: "SEED@DIR" kills each trial of that seed once, after its first
# evaluation (SIGKILL of its own worker process), leaving DIR/<trial>.killed; every attempt of a
# trial appends its pid to DIR/<trial>.attempts.
KILL_ONCE_ENV = "PENALTY_ENV_SWEEP_KILL_ONCE"
FINAL_KEYS = (
    "timesteps",
    "success_rate",
    "mean_return",
    "std_return",
    "random_success_rate",
    "random_mean_return",
    "wall_time_s",
    "env_steps_per_s",
)


# ----------------------------------------------------------------------------------------------
# The spec: what to run
# ----------------------------------------------------------------------------------------------


def _int(name: str, value: Any, low: int, allow_none: bool = False) -> int | None:
    if allow_none and value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}{' or null' if allow_none else ''}, got {value!r}")
    return value


def _check_key(where: str, key: Any, value: Any) -> None:
    if not isinstance(key, str):
        raise ValueError(f"{where}: keys must be setting names, got {key!r}")
    if key.startswith(ENV_PREFIX):
        if not key[len(ENV_PREFIX) :]:
            raise ValueError(f"{where}: {key!r} names no env keyword argument (expected env_kwargs.NAME)")
        return
    if key not in SWEEPABLE:
        raise ValueError(
            f"{where}: unknown setting {key!r} (value {value!r}); allowed: {', '.join(SWEEPABLE)}, "
            f"or {ENV_PREFIX}NAME for an env keyword argument"
        )


def check_spec(spec: Mapping[str, Any]) -> dict[str, Any]:
    """The sweep's spec with defaults filled in, or a ValueError naming the bad entry, its value
    and what is allowed (the training settings themselves are checked by :func:`configurations`)."""
    unknown = [k for k in spec if k not in SPEC_KEYS]
    if unknown:
        raise ValueError(
            f"unknown sweep key {unknown[0]!r} (value {spec[unknown[0]]!r}); allowed: {', '.join(SPEC_KEYS)}"
        )
    s = {**SPEC_DEFAULTS, **{k: v for k, v in spec.items() if v is not None or k == "max_concurrent_trials"}}
    if not isinstance(s["name"], str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.=-]*", s["name"]):
        raise ValueError(f"name must be letters, digits and _.=- (a folder name), got {s['name']!r}")
    seeds = s["seeds"]
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        seeds = [seeds]
    if not isinstance(seeds, (list, tuple)) or not seeds:
        raise ValueError(f"seeds must be a non-empty list of integers >= 0, got {seeds!r}")
    for x in seeds:
        _int(f"seeds: each seed (in {list(seeds)!r})", x, 0)
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct, got {list(seeds)!r}")
    s["seeds"] = list(seeds)
    for part in ("settings", "grid", "random"):
        if not isinstance(s[part], Mapping):
            raise ValueError(f"{part} must be a mapping of setting names to values, got {s[part]!r}")
        s[part] = dict(s[part])
        for key, value in s[part].items():
            _check_key(part, key, value)
    for key, values in s["grid"].items():
        if not isinstance(values, (list, tuple)) or not values:
            raise ValueError(f"grid: {key!r} must be a non-empty list of values, got {values!r}")
        s["grid"][key] = list(values)
    for key, dist in s["random"].items():
        s["random"][key] = _check_distribution(key, dist)
    both = sorted(set(s["grid"]) & set(s["random"]))
    if both:
        raise ValueError(f"{both[0]!r} is both in grid and random; give it one of them")
    _int("num_samples", s["num_samples"], 1)
    if s["num_samples"] > 1 and not s["random"]:
        raise ValueError(f"num_samples={s['num_samples']} needs random distributions to draw from (random is empty)")
    _int("search_seed", s["search_seed"], 0)
    _int("cpus_per_trial", s["cpus_per_trial"], 1)
    _int("max_concurrent_trials", s["max_concurrent_trials"], 1, allow_none=True)
    _int("max_failures", s["max_failures"], 0)
    return s


def _check_distribution(key: str, dist: Any) -> dict[str, list]:
    if not (isinstance(dist, Mapping) and len(dist) == 1):
        raise ValueError(
            f"random: {key!r} must be one distribution such as {{loguniform: [1.0e-4, 1.0e-2]}} "
            f"(one of {', '.join(DISTRIBUTIONS)}), got {dist!r}"
        )
    ((kind, args),) = dist.items()
    if kind not in DISTRIBUTIONS:
        raise ValueError(f"random: {key!r}: unknown distribution {kind!r}; allowed: {', '.join(DISTRIBUTIONS)}")
    if not isinstance(args, (list, tuple)) or not args:
        raise ValueError(f"random: {key!r}: {kind} needs a list of arguments, got {args!r}")
    args = list(args)
    if kind != "choice":
        numbers = all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in args)
        if len(args) != 2 or not numbers or not args[0] < args[1]:
            raise ValueError(f"random: {key!r}: {kind} needs [low, high] with low < high, got {args!r}")
        if kind == "loguniform" and args[0] <= 0:
            raise ValueError(f"random: {key!r}: loguniform needs low > 0, got {args!r}")
        if kind == "randint" and not all(isinstance(a, int) for a in args):
            raise ValueError(f"random: {key!r}: randint needs integer [low, high) bounds, got {args!r}")
    return {kind: args}


def _draw(dist: Mapping[str, list], rng) -> Any:
    ((kind, args),) = dist.items()
    if kind == "uniform":
        return float(rng.uniform(args[0], args[1]))
    if kind == "loguniform":
        return float(math.exp(rng.uniform(math.log(args[0]), math.log(args[1]))))
    if kind == "randint":
        return int(rng.integers(args[0], args[1]))
    return args[int(rng.integers(len(args)))]


def _short(key: str) -> str:
    return key[len(ENV_PREFIX) :] if key.startswith(ENV_PREFIX) else key


def _fmt(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def _settings(fixed: Mapping[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
    """train_ppo settings from the spec's keys (env_kwargs.NAME gathered into env_kwargs)."""
    settings: dict[str, Any] = {"env_kwargs": {}}
    for key, value in {**fixed, **values}.items():
        if key.startswith(ENV_PREFIX):
            settings["env_kwargs"][key[len(ENV_PREFIX) :]] = value
        else:
            settings[key] = value
    return settings


def _check_env_kwargs(env_id: str, env_kwargs: Mapping[str, Any], label: str) -> None:
    """The env's own check of its keyword arguments, before any trial starts."""
    import gymnasium as gym

    import penalty_env  # noqa: F401  (registers the ids)
    from penalty_env.envs.balls.params import check_parameters

    try:
        spec = gym.spec(env_id)
    except gym.error.Error as e:
        raise ValueError(f"env_id {env_id!r} ({label}) is not a registered env: {e}") from None
    params = {k: v for k, v in env_kwargs.items() if k != "max_episode_steps"}
    if "max_episode_steps" in env_kwargs:
        _int(f"{ENV_PREFIX}max_episode_steps ({label})", env_kwargs["max_episode_steps"], 1)
    if spec.entry_point != "penalty_env.envs.penalty_balls:PenaltyBallsEnv":
        return
    try:
        check_parameters(spec.kwargs.get("dim", 3), params, owner=env_id)
    except (TypeError, ValueError) as e:
        raise ValueError(f"configuration {label}: env keyword argument: {e}") from None


def configurations(spec: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The configurations of the sweep, each ``{"index", "label", "values", "settings"}``:
    ``values`` the varied keys, ``settings`` train_ppo's settings (seed, threads excepted). Every
    one is checked here (train_ppo.check_settings and the env's own argument checks)."""
    import numpy as np

    grid = spec["grid"]
    points = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())] if grid else [{}]
    if spec["random"]:
        rng = np.random.default_rng(spec["search_seed"])
        draws = [{k: _draw(d, rng) for k, d in spec["random"].items()} for _ in range(spec["num_samples"])]
        points = [{**p, **d} for d in draws for p in points]
    out = []
    for i, values in enumerate(points):
        label = " ".join(f"{_short(k)}={_fmt(v)}" for k, v in values.items()) or "default"
        settings = _settings(spec["settings"], values)
        try:
            checked = T.check_settings(settings)
        except ValueError as e:
            raise ValueError(f"configuration {label}: {e}") from None
        _check_env_kwargs(checked["env_id"], checked["env_kwargs"], label)
        out.append({"index": i, "label": label, "values": values, "settings": settings})
    return out


def trial_name(config: Mapping[str, Any], seed: int) -> str:
    """The folder of one trial: c<index>_<label>_seed<seed>, filesystem-safe."""
    label = re.sub(r"[^A-Za-z0-9_.=-]+", "_", config["label"])[:80]
    return f"c{config['index']}_{label}_seed{seed}"


# ----------------------------------------------------------------------------------------------
# The trial
# ----------------------------------------------------------------------------------------------


def _fault_injection(name: str) -> Any:
    """The test hook (:data:`KILL_ONCE_ENV`): a function to call after each evaluation."""
    value = os.environ.get(KILL_ONCE_ENV)
    if not value:
        return lambda: None
    seed, _, folder = value.partition("@")
    if not name.endswith(f"_seed{seed}"):
        return lambda: None
    marker = Path(folder) / f"{name}.killed"
    with open(Path(folder) / f"{name}.attempts", "a") as f:
        f.write(f"{os.getpid()}\n")

    def maybe_kill() -> None:
        if not marker.exists():
            marker.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)

    return maybe_kill


def trainable(config: dict[str, Any]) -> None:
    """Ray Tune's trainable: ``train_ppo.run`` for one configuration and seed, on the trial's
    CPUs. Reports each evaluation, then the summary with the run folder as its checkpoint (Tune
    stores it under the experiment, wherever the trial ran)."""
    from ray import tune

    cfg, seed, cpus = config["config"], config["seed"], config["cpus"]
    name = trial_name(cfg, seed)
    settings = {**cfg["settings"], "seed": seed, "threads": cpus, "numba_threads": cpus, "progress": False}
    maybe_kill = _fault_injection(name)

    def on_eval(point: dict[str, Any]) -> None:
        tune.report({**point, "final": False})
        maybe_kill()

    with tempfile.TemporaryDirectory(prefix="penalty_env-trial-") as tmp:
        run = Path(tmp) / name
        summary = T.run(settings, run, on_eval=on_eval)
        metrics = {k: summary[k] for k in FINAL_KEYS}
        tune.report({**metrics, "final": True}, checkpoint=tune.Checkpoint.from_directory(str(run)))


# ----------------------------------------------------------------------------------------------
# The sweep
# ----------------------------------------------------------------------------------------------


def _ray_init(address: str | None, num_cpus: int | None, object_store_mb: int | None) -> bool:
    """Connect to the cluster at ``address`` (or RAY_ADDRESS), else start a local one. The train/
    scripts travel as the job's working_dir; the package itself must be installed on every node.
    Returns whether this call started Ray."""
    import ray

    if ray.is_initialized():
        return False
    env_vars = {KILL_ONCE_ENV: os.environ[KILL_ONCE_ENV]} if os.environ.get(KILL_ONCE_ENV) else {}
    runtime_env = {"working_dir": str(TRAIN_DIR), "excludes": ["__pycache__"], "env_vars": env_vars}
    kwargs: dict[str, Any] = {"runtime_env": runtime_env, "include_dashboard": False}
    if address is None and not os.environ.get("RAY_ADDRESS"):
        # "local": a new local cluster, even where `ray start` left one running on this machine
        address = "local"
        kwargs["num_cpus"] = num_cpus
        if object_store_mb:
            kwargs["object_store_memory"] = object_store_mb * 1024 * 1024
    ray.init(address=address, **kwargs)
    return True


def run_sweep(
    spec: Mapping[str, Any],
    out: Path,
    storage: str | None = None,
    address: str | None = None,
    num_cpus: int | None = None,
    object_store_mb: int | None = None,
    resume: bool = False,
) -> int:
    """Run (or resume) the sweep; write the run folders, tables and plot into ``out``. Returns the
    number of trials that did not finish (0: all did)."""
    out = Path(out).resolve()
    state_file = out / "sweep.json"
    if resume:
        state = json.loads(state_file.read_text())
    else:
        spec = check_spec(spec)
        configs = configurations(spec)
        if state_file.exists():
            raise ValueError(
                f"--out {out} already holds a sweep: resume it with --resume {out}, or choose another --out"
            )
        if storage is None:
            storage = str(out / "tune")
        elif "://" not in storage:
            storage = str(Path(storage).resolve())
        state = {"spec": spec, "configurations": configs, "storage": storage}
        out.mkdir(parents=True, exist_ok=True)
        state_file.write_text(json.dumps(state, indent=2))
    spec, configs, storage = state["spec"], state["configurations"], state["storage"]
    experiment = f"{storage.rstrip('/')}/{spec['name']}"

    import ray
    from ray import tune

    started = _ray_init(address, num_cpus, object_store_mb)
    try:
        cpus = spec["cpus_per_trial"]
        runnable = tune.with_resources(trainable, {"cpu": cpus})
        if resume and tune.Tuner.can_restore(experiment):
            tuner = tune.Tuner.restore(experiment, trainable=runnable, resume_unfinished=True, restart_errored=True)
        else:
            tuner = tune.Tuner(
                runnable,
                param_space={
                    "config": tune.grid_search(configs),
                    "seed": tune.grid_search(spec["seeds"]),
                    "cpus": cpus,
                },
                tune_config=tune.TuneConfig(
                    max_concurrent_trials=spec["max_concurrent_trials"],
                    trial_dirname_creator=lambda trial: trial_name(trial.config["config"], trial.config["seed"]),
                ),
                run_config=tune.RunConfig(
                    name=spec["name"],
                    storage_path=storage,
                    failure_config=tune.FailureConfig(max_failures=spec["max_failures"]),
                    verbose=1,
                ),
            )
        n = len(configs) * len(spec["seeds"])
        print(
            f"sweep {spec['name']}: {len(configs)} configuration(s) x {len(spec['seeds'])} seed(s) = {n} trials "
            f"of {cpus} CPU(s) each on {ray.cluster_resources().get('CPU', 0):g} CPUs; experiment {experiment}",
            flush=True,
        )
        results = tuner.fit()
        missing = 0
        for result in results:
            name = result.path.rstrip("/").rsplit("/", 1)[-1]  # the trial's folder: trial_name()
            if result.checkpoint is None or not (result.metrics or {}).get("final"):
                missing += 1
                print(f"trial {name}: not finished ({result.error or 'stopped'})", flush=True)
                continue
            result.checkpoint.to_directory(str(out / "runs" / name))
    finally:
        if started:
            ray.shutdown()
    report(out)
    if missing:
        print(f"{missing} of {n} trials did not finish: resume with  python train/sweep.py --resume {out}")
    return missing


# ----------------------------------------------------------------------------------------------
# Tables and plot
# ----------------------------------------------------------------------------------------------


def _mean_std(xs: Sequence[float]) -> tuple[float, float]:
    m = sum(xs) / len(xs)
    return m, math.sqrt(sum((x - m) ** 2 for x in xs) / len(xs))


def collect(out: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The sweep's state and, per finished trial, its configuration, seed and summary."""
    state = json.loads((Path(out) / "sweep.json").read_text())
    trials = []
    for cfg in state["configurations"]:
        for seed in state["spec"]["seeds"]:
            path = Path(out) / "runs" / trial_name(cfg, seed) / "summary.json"
            if path.exists():
                trials.append(
                    {"config": cfg, "seed": seed, "run": path.parent, "summary": json.loads(path.read_text())}
                )
    return state, trials


def report(out: Path) -> list[dict[str, Any]]:
    """trials.csv, summary.csv, summary.md and success_vs_steps.png from the run folders in ``out``.
    Returns the summary rows (one per configuration)."""
    out = Path(out)
    state, trials = collect(out)
    varied = list(dict.fromkeys(k for cfg in state["configurations"] for k in cfg["values"]))
    with open(out / "trials.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["configuration", *map(_short, varied), "seed", *FINAL_KEYS, "run"])
        for t in trials:
            s = t["summary"]
            values = [t["config"]["values"].get(k, "") for k in varied]
            w.writerow(
                [t["config"]["label"], *values, t["seed"], *(s[k] for k in FINAL_KEYS), t["run"].relative_to(out)]
            )
    rows = []
    for cfg in state["configurations"]:
        mine = [t["summary"] for t in trials if t["config"]["index"] == cfg["index"]]
        if not mine:
            continue
        succ = [s["success_rate"] for s in mine]
        ret = [s["mean_return"] for s in mine]
        rows.append(
            {
                "configuration": cfg["label"],
                **{_short(k): cfg["values"].get(k, "") for k in varied},
                "seeds": len(mine),
                "timesteps": mine[0]["timesteps"],
                "success_mean": _mean_std(succ)[0],
                "success_std": _mean_std(succ)[1],
                "success_min": min(succ),
                "success_max": max(succ),
                "return_mean": _mean_std(ret)[0],
                "return_std": _mean_std(ret)[1],
                "random_success_mean": _mean_std([s["random_success_rate"] for s in mine])[0],
                "wall_time_s_mean": _mean_std([s["wall_time_s"] for s in mine])[0],
                "env_steps_per_s_mean": _mean_std([s["env_steps_per_s"] for s in mine])[0],
            }
        )
    if rows:
        with open(out / "summary.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
        (out / "summary.md").write_text(markdown_table(rows, state["spec"]["name"]))
        plot(trials, state, out / "success_vs_steps.png")
    return rows


def markdown_table(rows: list[dict[str, Any]], name: str) -> str:
    lines = [
        "| configuration | seeds | env steps | success (held-out, mean ± std) | min .. max | return (mean ± std) "
        "| random policy | wall time per run | env-steps/s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['configuration']} | {r['seeds']} | {r['timesteps']:,} | {100 * r['success_mean']:.1f}% ± "
            f"{100 * r['success_std']:.1f} | {100 * r['success_min']:.0f}% .. {100 * r['success_max']:.0f}% | "
            f"{r['return_mean']:.2f} ± {r['return_std']:.2f} | {100 * r['random_success_mean']:.0f}% | "
            f"{r['wall_time_s_mean']:.0f} s | {r['env_steps_per_s_mean']:,.0f} |"
        )
    return f"Sweep `{name}`: final success rate over 100 held-out episodes per run.\n\n" + "\n".join(lines) + "\n"


def plot(trials: list[dict[str, Any]], state: Mapping[str, Any], path: Path) -> None:
    """Success rate (evaluations during training) against env steps: per configuration, the mean
    over seeds and their min-max band; the legend gives the final held-out success."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(7, 4))
    for cfg in state["configurations"]:
        mine = [t["summary"] for t in trials if t["config"]["index"] == cfg["index"]]
        curves = [s["curve"] for s in mine if s["curve"]]
        if not curves:
            continue
        n = min(len(c) for c in curves)
        steps = np.array([c["timesteps"] for c in curves[0][:n]])
        succ = np.array([[p["success_rate"] for p in c[:n]] for c in curves])
        final = [s["success_rate"] for s in mine]
        (line,) = ax.plot(
            steps,
            succ.mean(axis=0),
            "o-",
            ms=3,
            label=f"{cfg['label']}: final {100 * np.mean(final):.0f}% ± {100 * np.std(final):.0f} ({len(mine)} seeds)",
        )
        ax.fill_between(steps, succ.min(axis=0), succ.max(axis=0), color=line.get_color(), alpha=0.2, lw=0)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("success rate (evaluation episodes)")
    ax.set_title(f"sweep {state['spec']['name']}: mean over seeds, band min..max", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ----------------------------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------------------------


def _value(raw: str) -> Any:
    try:
        return json.loads(raw)
    except json.JSONDecodeError:
        return raw


def _pair(option: str, text: str) -> tuple[str, str]:
    key, sep, raw = text.partition("=")
    if not sep or not key or not raw:
        raise ValueError(f"{option} expects KEY=VALUE, got {text!r}")
    return key, raw


def _grid_values(option: str, text: str) -> tuple[str, list]:
    key, raw = _pair(option, text)
    if raw.lstrip().startswith("["):
        try:
            values = json.loads(raw)
        except json.JSONDecodeError as e:
            raise ValueError(f"{option} {text!r}: the value list is not valid JSON ({e})") from None
    else:
        values = [_value(v) for v in raw.split(",")]
    if not values or any(v == "" for v in values):
        raise ValueError(f"{option} {text!r}: expected KEY=V1,V2,... (or KEY=[JSON list]), with no empty value")
    return key, values


def _random_dist(option: str, text: str) -> tuple[str, dict]:
    key, raw = _pair(option, text)
    kind, sep, args = raw.partition(":")
    if not sep or not args:
        raise ValueError(f"{option} {text!r}: expected KEY=DISTRIBUTION:A,B (one of {', '.join(DISTRIBUTIONS)})")
    return key, {kind: [_value(a) for a in args.split(",")]}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="sweep.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--config", type=Path, help="YAML file of the sweep (the command line adds to it and wins)")
    p.add_argument("--name", help="the sweep's name (default: the file's, else 'sweep')")
    p.add_argument("--seeds", help="comma-separated seeds, every configuration runs each (default: 0)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a fixed setting, repeatable")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2", help="a grid dimension, repeatable")
    p.add_argument(
        "--random",
        action="append",
        default=[],
        metavar="KEY=DIST:A,B",
        help=f"a random dimension ({', '.join(DISTRIBUTIONS)}), repeatable",
    )
    p.add_argument("--num-samples", type=int, help="random configurations to draw (default: 1)")
    p.add_argument("--search-seed", type=int, help="seed of the random draws (default: 0)")
    p.add_argument(
        "--cpus-per-trial", type=int, help="CPUs of each trial, and its torch and Numba threads (default: 1)"
    )
    p.add_argument("--max-concurrent", type=int, help="trials at once (default: as many as the CPUs allow)")
    p.add_argument("--max-failures", type=int, help="retries of a trial whose worker dies (default: 2)")
    p.add_argument("--no-gif", action="store_true", help="no policy.gif in the run folders")
    p.add_argument("--out", type=Path, help="results folder (default: runs/sweep-NAME)")
    p.add_argument("--storage", help="Ray Tune's storage path (default: OUT/tune; multi-node: shared, e.g. s3://...)")
    p.add_argument("--address", help="Ray cluster address (default: RAY_ADDRESS, else a local cluster)")
    p.add_argument("--num-cpus", type=int, help="CPUs of the local cluster (default: all)")
    p.add_argument("--object-store-mb", type=int, help="object store of the local cluster, MB (default: Ray's)")
    p.add_argument("--resume", type=Path, metavar="OUT", help="resume the sweep in OUT (stopped, crashed or lost)")
    p.add_argument("--report", type=Path, metavar="OUT", help="only write the tables and plot of OUT again")
    p.add_argument("--dry-run", action="store_true", help="print the configurations and exit")
    return p


def spec_from_args(args: argparse.Namespace) -> dict[str, Any]:
    spec: dict[str, Any] = {}
    if args.config is not None:
        import yaml

        try:
            loaded = yaml.safe_load(args.config.read_text())
        except (OSError, yaml.YAMLError) as e:
            raise ValueError(f"--config {str(args.config)!r}: {e}") from None
        if not isinstance(loaded, dict):
            raise ValueError(f"--config {str(args.config)!r}: expected a mapping of sweep keys, got {loaded!r}")
        spec = dict(loaded)
        spec.setdefault("name", args.config.stem)
    for part in ("settings", "grid", "random"):
        spec[part] = dict(spec.get(part) or {})
    for text in args.set:
        key, raw = _pair("--set", text)
        spec["settings"][key] = _value(raw)
    for text in args.grid:
        key, values = _grid_values("--grid", text)
        spec["grid"][key] = values
    for text in args.random:
        key, dist = _random_dist("--random", text)
        spec["random"][key] = dist
    if args.seeds is not None:
        try:
            spec["seeds"] = [int(x) for x in args.seeds.split(",")]
        except ValueError:
            raise ValueError(f"--seeds expects comma-separated integers, got {args.seeds!r}") from None
    for opt, key in (
        ("name", "name"),
        ("num_samples", "num_samples"),
        ("search_seed", "search_seed"),
        ("cpus_per_trial", "cpus_per_trial"),
        ("max_concurrent", "max_concurrent_trials"),
        ("max_failures", "max_failures"),
    ):
        if getattr(args, opt) is not None:
            spec[key] = getattr(args, opt)
    if args.no_gif:
        spec["settings"]["gif"] = False
    return spec


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.report is not None:
        for row in report(args.report):
            print(row)
        return 0
    try:
        if args.resume is not None:
            if not (args.resume / "sweep.json").exists():
                raise ValueError(f"--resume {str(args.resume)!r}: no sweep.json there (not a sweep's --out folder)")
            missing = run_sweep({}, args.resume, None, args.address, args.num_cpus, args.object_store_mb, resume=True)
            return 1 if missing else 0
        spec = check_spec(spec_from_args(args))
        configs = configurations(spec)
        if args.dry_run:
            for c in configs:
                print(f"{c['label']}: {c['settings']}")
            print(f"{len(configs)} configuration(s) x {len(spec['seeds'])} seed(s)")
            return 0
        out = args.out or Path("runs") / f"sweep-{spec['name']}"
        missing = run_sweep(spec, out, args.storage, args.address, args.num_cpus, args.object_store_mb)
    except ValueError as e:
        parser.error(str(e))
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
