"""Stable-Baselines3 ``VecEnv`` over batched PenaltyBalls worlds.

:func:`make_vec_env` is this package's answer to SB3's own ``make_vec_env``: the same worlds as
``gymnasium.make_vec("PenaltyBalls-v0", N)``, stepped in one Numba call, with SB3's same-step
reset semantics. A world whose episode ends is reset inside the ``step`` that ended it; its
``info["terminal_observation"]`` holds the last observation and ``info["TimeLimit.truncated"]``
tells a time-out from a success, exactly as SB3's ``DummyVecEnv`` reports them for
``gymnasium.make`` envs. ``seed(s)`` (or ``make_vec_env(seed=s)``) seeds world i with ``s + i``,
so the episodes equal those of a ``DummyVecEnv`` of single envs seeded the same way.

Importing this module imports stable-baselines3 (and torch); ``import penalty_env`` does not.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecMonitor
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from . import _validate as V
from .envs.balls.params import MAX_EPISODE_STEPS
from .envs.checks import check_options, check_seed, render_fps
from .envs.engine import Batch
from .envs.faces import check_episode_steps
from .envs.penalty_balls import PenaltyBallsVectorEnv

__all__ = ["PenaltyBallsVecEnv", "make_vec_env"]


class PenaltyBallsVecEnv(VecEnv):
    """``n_envs`` worlds of a task as an SB3 ``VecEnv`` (see the module docstring): the engine
    (:class:`~penalty_env.envs.engine.Batch`) with SB3's same-step resets.

    Args:
        n_envs: number of worlds.
        dim: 3 or 2.
        max_episode_steps: episode length (truncation).
        render_mode: None or "rgb_array" (``get_images`` returns one frame per world).
        vector_class: the registered vector env whose worlds these are (its ``parts``): the
            PenaltyBalls ids' (default) or the level task's.
        **kwargs: the scene's keyword arguments (``PenaltyBallsEnv``'s docstring lists them),
            and the observation mode: ``obs_mode`` (``"state"``, ``"heightmap"``, ``"rgb"`` or a
            tuple of them), ``heightmap_cells``, ``heightmap_cell``, ``rgb_size``. An ``"rgb"``
            observation is a channel-last uint8 image (SB3's ``CnnPolicy`` takes it as it is);
            a tuple gives a ``Dict`` observation (``MultiInputPolicy``), whose
            ``terminal_observation`` is a dict too.

    ``set_options`` takes the task's reset options (``randomize``; the level task's ``target``),
    one dict per world, used at the next ``reset()``. ``get_attr``, ``set_attr`` and
    ``env_method`` act on this one object, which all worlds share (there are no per-world env
    objects); they return one result per requested index.
    """

    def __init__(
        self,
        n_envs: int = 1,
        dim: int = 3,
        max_episode_steps: int = MAX_EPISODE_STEPS,
        render_mode: str | None = None,
        vector_class: Any = PenaltyBallsVectorEnv,
        **kwargs: Any,
    ) -> None:
        max_episode_steps = check_episode_steps(max_episode_steps)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.scene, self.views = vector_class.parts(n_envs, dim, "PenaltyBallsVecEnv.__init__", **kwargs)
        self.batch = Batch(self.scene, self.views, max_episode_steps)
        self.render_mode = render_mode
        self.max_episode_steps = int(max_episode_steps)
        super().__init__(self.scene.n_worlds, self.views.space, self.scene.action_space)
        # SB3's VecVideoRecorder records at metadata["render_fps"] (30 when it is missing)
        self.metadata: dict[str, Any] = {**self.metadata, "render_fps": render_fps(self.scene.control_period)}
        self._first_steps = np.zeros(self.num_envs, dtype=np.int64)  # stagger(): step counts after the next reset
        self._actions: np.ndarray | None = None
        self._renderer: Any = None

    # ------------------------------------------------------------------ VecEnv API
    def reset(self) -> VecEnvObs:
        task, batch = self.scene, self.batch
        options = [check_options(o, task.reset_options, task.owner) for o in self._options]
        batch.seed(self._seeds, batch.all)
        # worlds with the same options reset together (each draws from its own generator: the
        # grouping changes nothing of what a world draws)
        groups: dict[str, list[int]] = {}
        for i, o in enumerate(options):
            groups.setdefault(repr(sorted(o.items(), key=lambda kv: kv[0])), []).append(i)
        for members in groups.values():
            idx = np.array(members, dtype=np.int64)
            batch.reset(idx, options[members[0]] or None, self._first_steps)
        self._first_steps[:] = 0
        self.reset_infos = [batch.info(i) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return batch.observe()

    def stagger(self, seed: int | None = None) -> None:
        """Put the worlds' episodes out of phase: after the next ``reset()`` only, world i's first
        episode is truncated after ``n_i`` steps, drawn uniformly from 1 to ``max_episode_steps``
        (``seed`` seeds the draw; None: fresh entropy). Every later episode is whole. Without it
        every world starts together, so a short rollout over many worlds holds one phase of an
        episode only (the trainer's lever: ``train/train_ppo.py``). The worlds' states, and so the
        episodes' seeds, are unchanged; the staggered first episodes end ``TimeLimit.truncated``."""
        n = np.random.default_rng(seed).integers(1, self.max_episode_steps + 1, size=self.num_envs)
        self._first_steps[:] = self.max_episode_steps - n

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("call step_async(actions) (or step) before step_wait()")
        batch = self.batch
        actions, self._actions = self._actions, None
        batch.act(actions, batch.never)  # refused before any world moves (the batch may be split over threads)
        batch.advance()
        rewards, terminated = batch.outcome(None)
        truncated = batch.truncated()
        dones = terminated | truncated
        infos = batch.info_list()
        for info, flag in zip(infos, (truncated & ~terminated).tolist()):
            info["TimeLimit.truncated"] = flag
        if dones.any():
            idx = np.flatnonzero(dones)
            for i, last in zip(idx, batch.final_observations(idx)):
                infos[i]["terminal_observation"] = last
            batch.reset(idx)
            for i in idx:
                self.reset_infos[i] = batch.info(int(i))
        return batch.observe(), rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self._renderer = None

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        if self._renderer is None:
            self._renderer = self.scene.renderer()
        return [self._renderer.frame(b) for b in range(self.num_envs)]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        method = getattr(self, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def _get_indices(self, indices: VecEnvIndices) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, (int, np.integer)):
            return [int(indices)]
        return indices


def make_vec_env(
    env_id: str = "PenaltyBalls-v0",
    n_envs: int = 1,
    seed: int | None = None,
    monitor: bool = True,
    monitor_kwargs: dict[str, Any] | None = None,
    **env_kwargs: Any,
) -> VecEnv:
    """An SB3 ``VecEnv`` of ``n_envs`` worlds of a registered id, like SB3's ``make_vec_env(env_id)``.

    Args:
        env_id: a PenaltyBalls id (the goal-conditioned ids aside: their ``Dict`` observations are
            for SB3's ``HerReplayBuffer`` over ``DummyVecEnv``) or a PenaltySandLevel id (its
            registered ``dim`` and ``max_episode_steps`` are used unless ``env_kwargs`` override
            them).
        n_envs: number of worlds.
        seed: world i's first episode is seeded ``seed + i`` (None: fresh entropy); an int >= 0.
        monitor: wrap in SB3's ``VecMonitor`` (episode return, length and time in
            ``info["episode"]``, plus ``is_success``), as SB3's ``make_vec_env`` wraps each env in
            a ``Monitor``.
        monitor_kwargs: passed to ``VecMonitor`` (e.g. ``filename``).
        **env_kwargs: the env's keyword arguments (and ``max_episode_steps``, ``render_mode``).
    """
    import penalty_env  # noqa: F401  (registers the ids)

    seed = check_seed(seed)
    n_envs = V.integer("n_envs", n_envs, 1)
    vector_class = _vector_class(env_id)
    spec = gym.spec(env_id)
    kwargs = dict(spec.kwargs)
    kwargs["max_episode_steps"] = spec.max_episode_steps
    kwargs.update(env_kwargs)
    venv: VecEnv = PenaltyBallsVecEnv(n_envs, vector_class=vector_class, **kwargs)
    if seed is not None:
        venv.seed(int(seed))
    if monitor:
        mk: dict[str, Any] = {"info_keywords": ("is_success",)}
        mk.update(monitor_kwargs or {})
        metadata = venv.metadata
        venv = VecMonitor(venv, **mk)
        venv.metadata = metadata  # the wrapper's own would drop render_fps
    return venv


def _vector_class(env_id: Any) -> Any:
    """The registered vector class of ``env_id`` when it has ``parts`` (the ids this adapter
    steps), else a ValueError naming the ids it takes."""
    ids = sorted(k for k, s in gym.registry.items() if _has_parts(s.vector_entry_point))
    spec = gym.registry.get(env_id) if isinstance(env_id, str) else None
    if spec is None or not _has_parts(spec.vector_entry_point):
        raise ValueError(f"env_id must be one of {ids}, got {env_id!r}")
    return _load(spec.vector_entry_point)


def _load(entry: Any) -> Any:
    if not isinstance(entry, str):
        return entry
    module, name = entry.split(":")
    return getattr(importlib.import_module(module), name)


def _has_parts(entry: Any) -> bool:
    return isinstance(entry, str) and entry.startswith("penalty_env.") and hasattr(_load(entry), "parts")
