#!/usr/bin/env python
"""Record episodes of the scripted pusher, or of a trained policy, into a Minari dataset.

    python train/collect.py                                   # 100 episodes of the scripted pusher
    python train/collect.py --env-id PenaltyBalls2D-v0 --episodes 20 --out datasets
    python train/collect.py --policy runs/ppo-PenaltyBalls-v0-seed0 --episodes 50

Needs the ``minari`` extra (``pip install -e ".[minari]"``: Minari with its ``hdf5`` and
``create`` extras). Episode k is played in a single env, reset with seed ``--seed + k``, and
Minari stores that seed with the episode, so each recorded episode can be replayed exactly:
``env.reset(seed=episode_seed)``, then the stored actions, gives back the stored observations,
rewards, terminations and truncations bit for bit (``tests/train/test_collect.py`` checks it).
The env's spec (id, keyword arguments, episode length) is stored too, so
``minari.load_dataset(dataset_id).recover_environment()`` makes the env again; its entry point
is an import path, so that works without importing ``penalty_env`` first.

The default policy is the task's scripted one (:func:`penalty_env.envs.scripted.scripted_policy`:
the pusher for a PenaltyBalls id, the raster sweep for a PenaltySandLevel id; an env observing
something else than the state vector is refused, naming its id). ``--policy RUN`` loads
a run folder of ``train_ppo.py`` (``model.zip``, and ``vecnormalize.pkl`` when the run has one)
as ``evaluate.py`` does, and plays its deterministic actions; the env id and keyword arguments
then default to the run's own (``summary.json``). The dataset id defaults to
``penalty_env/<env id>/scripted-v0`` (``ppo-v0`` for a trained policy). Datasets are written
under ``--out``, else ``$MINARI_DATASETS_PATH``, else Minari's default (``~/.minari/datasets``).

``collect(...)`` is the run itself, importable; it returns the dataset.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402

Policy = Callable[[np.ndarray], np.ndarray]


def scripted_policy(env) -> Policy:
    """The scripted policy of ``env``'s task (the pusher, or the level task's raster sweep); an env
    it cannot play (a dict or image observation) is refused, naming the id."""
    from penalty_env.envs.scripted import scripted_policy as of_task

    return of_task(env)


def trained_policy(run: Path) -> tuple[Policy, dict[str, Any], tuple[int, ...]]:
    """The deterministic policy of a ``train_ppo.py`` run folder, for single observations; the
    run's summary (``env_id``, ``env_kwargs``); and the observation shape the policy takes. The
    observations are normalised with the run's saved statistics, frozen, as ``evaluate.py`` does."""
    from gymnasium import spaces
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    run = Path(run)
    for name in ("model.zip", "summary.json"):
        if not (run / name).is_file():
            raise ValueError(f"--policy must be a run folder of train_ppo.py with {name}, got {str(run)!r}")
    summary = json.loads((run / "summary.json").read_text())
    model = PPO.load(run / "model.zip", device="cpu")
    if not isinstance(model.observation_space, spaces.Box):
        raise ValueError(
            f"the policy of {str(run)!r} observes a {type(model.observation_space).__name__} "
            f"({model.observation_space}); collect.py records policies of a Box observation (the state vector)"
        )
    vecnorm = None
    if (run / "vecnormalize.pkl").is_file():
        probe = C.make_env(summary["env_id"], 1, 0, summary.get("env_kwargs", {}))
        vecnorm = VecNormalize.load(str(run / "vecnormalize.pkl"), probe)
        vecnorm.training, vecnorm.norm_reward = False, False
    act = C.model_policy(model, vecnorm)

    def policy(obs: np.ndarray) -> np.ndarray:
        return np.asarray(act(obs[None])[0], dtype=np.float32)

    return policy, summary, tuple(model.observation_space.shape)


def collect(
    env_id: str | None = None,
    episodes: int = 100,
    seed: int = 0,
    out: str | os.PathLike | None = None,
    dataset_id: str | None = None,
    policy_run: str | os.PathLike | None = None,
    env_kwargs: dict[str, Any] | None = None,
    ref_episodes: int = 100,
    record_infos: bool = False,
):
    """Play ``episodes`` episodes (seeds ``seed``, ``seed + 1``, ...) and write them to a Minari
    dataset; returns the ``minari.MinariDataset``.

    ``env_id`` and ``env_kwargs`` default to the run's own with ``policy_run``, else to
    ``PenaltyBalls-v0`` and its defaults. ``out`` sets ``MINARI_DATASETS_PATH`` for this process (Minari reads it when it writes and
    loads). ``ref_episodes``: episodes of a random policy (and of the recorded policy) that Minari
    plays to store ``ref_min_score`` and ``ref_max_score`` (0: neither is stored).
    ``record_infos``: also store the env's info dicts.
    """
    import gymnasium as gym
    import minari

    import penalty_env  # noqa: F401  (registers the ids)

    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"episodes must be an int >= 1, got {episodes!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an int >= 0, got {seed!r}")
    if isinstance(ref_episodes, bool) or not isinstance(ref_episodes, int) or ref_episodes < 0:
        raise ValueError(f"ref_episodes must be an int >= 0, got {ref_episodes!r}")
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        os.environ["MINARI_DATASETS_PATH"] = str(Path(out).resolve())

    if policy_run is not None:
        policy, summary, obs_shape = trained_policy(Path(policy_run))
        env_id = summary["env_id"] if env_id is None else env_id
        env_kwargs = summary.get("env_kwargs", {}) if env_kwargs is None else env_kwargs
        name, algorithm = "ppo", "PPO (stable-baselines3), deterministic"
    else:
        policy, name, algorithm = None, "scripted", ""
    env_id = env_id or "PenaltyBalls-v0"
    env = minari.DataCollector(gym.make(env_id, **(env_kwargs or {})), record_infos=record_infos)
    if policy is not None and env.observation_space.shape != obs_shape:
        raise ValueError(
            f"the policy of {str(policy_run)!r} takes observations of shape {obs_shape}, but {env_id} "
            f"with {env_kwargs or {}} has {env.observation_space.shape}"
        )
    if policy is None:
        policy = scripted_policy(env)
        algorithm = f"{type(policy).__name__} (penalty_env.envs.scripted)"
    dataset_id = dataset_id or f"penalty_env/{env_id}/{name}-v0"

    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        done = False
        while not done:
            obs, _, terminated, truncated, _ = env.step(policy(obs))
            done = terminated or truncated

    # Minari plays the reference episodes only when given a policy (or a maximum score) to rate.
    score: dict[str, Any] = {}
    if ref_episodes > 0:
        score = dict(expert_policy=policy, num_episodes_average_score=ref_episodes)

    with warnings.catch_warnings():  # Minari asks for a contact address; the project has none to give
        warnings.filterwarnings("ignore", message="`author_email` is set to None")
        dataset = env.create_dataset(
            dataset_id=dataset_id,
            eval_env=env.env.spec,  # the collecting env's own spec, said outright (else Minari warns)
            algorithm_name=algorithm,
            code_permalink="train/collect.py",
            author="penalty_env",
            description=(
                f"{episodes} episodes of {env_id} ({env_kwargs or 'default arguments'}) played by {algorithm}; "
                f"episode k reset with seed {seed} + k (stored with the episode)."
            ),
            requirements=[f"penalty-env=={penalty_env.__version__}"],
            **score,
        )
    env.close()
    return dataset


def main(argv: list[str] | None = None):
    p = argparse.ArgumentParser(
        prog="collect.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--env-id", default=None, help="registered id (default: the run's id, else PenaltyBalls-v0)")
    p.add_argument("--env-kwarg", action="append", default=None, help="env keyword argument key=value (repeatable)")
    p.add_argument("--episodes", type=int, default=100, help="episodes to record (default: %(default)s)")
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the first episode; episode k: seed + k (default: %(default)s)"
    )
    p.add_argument("--policy", type=Path, default=None, help="a train_ppo.py run folder (default: the scripted pusher)")
    p.add_argument(
        "--dataset-id", default=None, help="Minari dataset id (default: penalty_env/<env id>/<scripted|ppo>-v0)"
    )
    p.add_argument(
        "--out", type=Path, default=None, help="datasets folder (default: $MINARI_DATASETS_PATH or ~/.minari/datasets)"
    )
    p.add_argument(
        "--ref-episodes",
        type=int,
        default=100,
        help="episodes Minari plays for the reference scores, random and this policy (0: none; default: %(default)s)",
    )
    p.add_argument("--record-infos", action="store_true", help="also store the info dicts")
    args = p.parse_args(argv)
    env_kwargs = C.parse_env_kwargs(args.env_kwarg) if args.env_kwarg else None
    try:
        dataset = collect(
            env_id=args.env_id,
            episodes=args.episodes,
            seed=args.seed,
            out=args.out,
            dataset_id=args.dataset_id,
            policy_run=args.policy,
            env_kwargs=env_kwargs,
            ref_episodes=args.ref_episodes,
            record_infos=args.record_infos,
        )
    except ValueError as exc:
        p.error(str(exc))
    meta = dataset.storage.metadata
    reached = sum(bool(episode.terminations[-1]) for episode in dataset.iterate_episodes())  # success ends an episode
    print(
        f"{meta['dataset_id']}: {dataset.total_episodes} episodes ({reached} reached the goal), "
        f"{dataset.total_steps} steps -> "
        f"{os.environ.get('MINARI_DATASETS_PATH', '~/.minari/datasets')}"
        + (
            f"; reference scores {meta['ref_min_score']:.3f} (random) to {meta['ref_max_score']:.3f}"
            if "ref_max_score" in meta
            else ""
        )
    )
    return dataset


if __name__ == "__main__":
    main()
