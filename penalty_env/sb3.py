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

from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from stable_baselines3.common.vec_env import VecEnv, VecMonitor
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from . import _validate as V
from .envs import kernel as KE
from .envs.penalty_balls import MAX_EPISODE_STEPS
from .envs.render import Renderer
from .envs.scene import PenaltyBallsScene, coerce_action, render_fps
from .envs.views import Views, pop_view_kwargs

__all__ = ["PenaltyBallsVecEnv", "make_vec_env"]

_ENV_IDS = (
    "PenaltyBalls-v0",
    "PenaltyBalls2D-v0",
    "PenaltyBalls-v1",
    "PenaltyBalls2D-v1",
    "PenaltyBallsSand-v0",
    "PenaltyBallsSand2D-v0",
    "PenaltyBallsSand-v1",
    "PenaltyBallsSand2D-v1",
)


class PenaltyBallsVecEnv(VecEnv):
    """``n_envs`` PenaltyBalls worlds as an SB3 ``VecEnv`` (see the module docstring).

    Args:
        n_envs: number of worlds.
        dim: 3 or 2.
        max_episode_steps: episode length (truncation).
        render_mode: None or "rgb_array" (``get_images`` returns one frame per world).
        **kwargs: the scene's keyword arguments (``PenaltyBallsEnv``'s docstring lists them),
            and the observation mode: ``obs_mode`` (``"state"``, ``"heightmap"``, ``"rgb"`` or a
            tuple of them), ``heightmap_cells``, ``heightmap_cell``, ``rgb_size``. An ``"rgb"``
            observation is a channel-last uint8 image (SB3's ``CnnPolicy`` takes it as it is);
            a tuple gives a ``Dict`` observation (``MultiInputPolicy``), whose
            ``terminal_observation`` is a dict too.

    ``get_attr``, ``set_attr`` and ``env_method`` act on this one object, which all worlds share
    (there are no per-world env objects); they return one result per requested index.
    """

    def __init__(
        self,
        n_envs: int = 1,
        dim: int = 3,
        max_episode_steps: int = MAX_EPISODE_STEPS,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        if (
            isinstance(max_episode_steps, bool)
            or not isinstance(max_episode_steps, (int, np.integer))
            or max_episode_steps < 1
        ):
            raise ValueError(f"max_episode_steps must be an int >= 1, got {max_episode_steps!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        view_kwargs = pop_view_kwargs(kwargs)
        self.scene = PenaltyBallsScene(
            V.integer("n_envs", n_envs, 1), dim=dim, owner="PenaltyBallsVecEnv.__init__", **kwargs
        )
        self.views = Views(self.scene, **view_kwargs)
        self._view = None if self.views.is_state else self.views  # None: the state vector, as it is
        self._never = np.zeros(n_envs, dtype=np.bool_)
        self.render_mode = render_mode
        self.max_episode_steps = int(max_episode_steps)
        super().__init__(self.scene.n_worlds, self.views.space, self.scene.action_space)
        # SB3's VecVideoRecorder records at metadata["render_fps"] (30 when it is missing)
        self.metadata: dict[str, Any] = {**self.metadata, "render_fps": render_fps(self.scene.control_period)}
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._steps = np.zeros(self.num_envs, dtype=np.int64)
        self._first_steps = np.zeros(self.num_envs, dtype=np.int64)  # stagger(): step counts after the next reset
        self._actions: np.ndarray | None = None
        self._renderer: Renderer | None = None

    # ------------------------------------------------------------------ VecEnv API
    def reset(self) -> VecEnvObs:
        for i, options in enumerate(self._options):
            if options:
                raise ValueError(
                    f"PenaltyBallsVecEnv takes no reset options (the Gymnasium envs take options['randomize']), "
                    f"got {options!r} for env {i}"
                )
        for i, seed in enumerate(self._seeds):
            if seed is not None or self._rngs[i] is None:
                self._rngs[i] = seeding.np_random(seed)[0]
        self.scene.reset_worlds(range(self.num_envs), self._rngs)
        self._steps[:] = self._first_steps
        self._first_steps[:] = 0
        self.reset_infos = [self.scene.info(i) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return self.scene.obs.copy() if self._view is None else self._view.observe()

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
        shape = (self.num_envs, self.scene.action_size)
        if type(actions) is not np.ndarray or actions.shape != shape or actions.dtype.kind != "f":
            actions = coerce_action(actions, shape)
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("call step_async(actions) (or step) before step_wait()")
        scene = self.scene
        scene.actions[:] = self._actions
        self._actions = None
        b = KE.first_bad_action(scene.actions, self._never)
        if b >= 0:  # refuse before any world moves (the batch may be split over threads)
            raise ValueError(f"the action of world {b} contains NaN or inf: {scene.actions[b].tolist()}")
        scene.step()
        self._steps += 1
        terminated = scene.buffers.success.copy()
        truncated = self._steps >= self.max_episode_steps
        dones = terminated | truncated
        rewards = scene.buffers.reward.astype(np.float32)
        infos = self._step_infos(truncated & ~terminated)
        if dones.any():
            idx = np.flatnonzero(dones)
            if self._view is None:
                for i in idx:
                    infos[i]["terminal_observation"] = scene.obs[i].copy()
            else:
                last = self._view.observe(idx)
                for t, i in enumerate(idx):
                    infos[i]["terminal_observation"] = self._view.item(last, t)
            scene.reset_worlds(idx, [self._rngs[i] for i in idx])
            self._steps[idx] = 0
            for i in idx:
                self.reset_infos[i] = scene.info(int(i))
        obs = scene.obs.copy() if self._view is None else self._view.observe()
        return obs, rewards, dones, infos

    def close(self) -> None:
        self._renderer = None

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        if self._renderer is None:
            p = self.scene.params
            self._renderer = Renderer(self.scene, p["render_width"], p["render_height"])
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

    # ------------------------------------------------------------------ helpers
    def _step_infos(self, time_limit: np.ndarray) -> list[dict[str, Any]]:
        """One info dict per world, as a ``gymnasium.make`` env's step returns it, plus SB3's
        ``TimeLimit.truncated``."""
        buf = self.scene.buffers
        keys = KE.INFO_KEYS
        infos = [dict(zip(keys, row)) for row in zip(*buf.info, buf.success.tolist())]
        for info, flag in zip(infos, time_limit.tolist()):
            info["TimeLimit.truncated"] = flag
        if self.scene.randomize:  # each world's draws at its last reset
            for i, info in enumerate(infos):
                info["randomization"] = self.scene.randomization(i)
        return infos

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
    """An SB3 ``VecEnv`` of ``n_envs`` PenaltyBalls worlds, like SB3's ``make_vec_env(env_id)``.

    Args:
        env_id: "PenaltyBalls-v0" or "PenaltyBalls2D-v0" (its registered ``dim`` and
            ``max_episode_steps`` are used unless ``env_kwargs`` override them).
        n_envs: number of worlds.
        seed: world i's first episode is seeded ``seed + i`` (None: fresh entropy).
        monitor: wrap in SB3's ``VecMonitor`` (episode return, length and time in
            ``info["episode"]``, plus ``is_success``), as SB3's ``make_vec_env`` wraps each env in
            a ``Monitor``.
        monitor_kwargs: passed to ``VecMonitor`` (e.g. ``filename``).
        **env_kwargs: the env's keyword arguments (and ``max_episode_steps``, ``render_mode``).
    """
    import penalty_env  # noqa: F401  (registers the ids)

    if env_id not in _ENV_IDS:
        raise ValueError(f"env_id must be one of {_ENV_IDS}, got {env_id!r}")
    spec = gym.spec(env_id)
    kwargs = dict(spec.kwargs)
    kwargs["max_episode_steps"] = spec.max_episode_steps
    kwargs.update(env_kwargs)
    venv: VecEnv = PenaltyBallsVecEnv(n_envs, **kwargs)
    if seed is not None:
        venv.seed(seed)
    if monitor:
        mk: dict[str, Any] = {"info_keywords": ("is_success",)}
        mk.update(monitor_kwargs or {})
        metadata = venv.metadata
        venv = VecMonitor(venv, **mk)
        venv.metadata = metadata  # the wrapper's own would drop render_fps
    return venv
