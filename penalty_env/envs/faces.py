"""Gymnasium's two faces over the one engine (:class:`.engine.Batch`): the single env and the native
vector env of any task.

:class:`TaskEnv` is a Batch of one world without autoreset (the registered ``TimeLimit`` wraps
it), :class:`TaskVectorEnv` a Batch of N worlds with Gymnasium's vector API. The registered
classes of each task (:mod:`.penalty_balls`, :mod:`.goal`, :mod:`.sand_level`) build their task and
view and hand them here; these classes hold the API, nothing of a task.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import error, logger
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .. import _validate as V
from .checks import check_options, check_reset_mask, check_seed, check_seeds, render_fps
from .engine import Batch, Task, View

__all__ = ["TaskEnv", "TaskVectorEnv", "check_render_mode", "check_autoreset_mode", "check_episode_steps"]


def check_render_mode(render_mode: Any, modes: list[str]) -> str | None:
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode must be one of {modes} or None, got {render_mode!r}")
    return render_mode


def check_autoreset_mode(mode: Any) -> AutoresetMode:
    try:
        return AutoresetMode(mode)
    except ValueError:
        raise ValueError(f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, got {mode!r}") from None


def check_episode_steps(max_episode_steps: Any) -> int:
    return V.integer("max_episode_steps", max_episode_steps, 1, None, "the episode length")


class TaskEnv(gym.Env):
    """One world of a task as a Gymnasium env: a :class:`~.engine.Batch` of one world.

    A subclass (the registered class) builds ``task`` (one world) and ``view`` and calls
    :meth:`_attach`; ``metadata["render_modes"]`` says which render modes it draws.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def _attach(self, task: Task, view: View, render_mode: str | None, outcome: Any = None) -> None:
        self.render_mode = check_render_mode(render_mode, self.metadata["render_modes"])
        self.scene = task
        self.batch = Batch(task, view, outcome=outcome)
        self.dim = task.dim
        self.metadata = dict(self.metadata, render_fps=render_fps(task.control_period))
        self.action_space = task.action_space
        self.observation_space = view.space
        self._needs_reset = True
        self._renderer: Any = None
        self._window: Any = None

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self._needs_reset:
            raise error.ResetNeeded(f"Cannot call {type(self).__name__}.step() before reset()")
        obs, reward, terminated, info = self.batch.step_one(action)
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        seed = check_seed(seed)
        task = self.scene
        options = check_options(options, task.reset_options, task.owner)
        super().reset(seed=seed)
        batch = self.batch
        batch.rngs[0] = self.np_random
        batch.reset(batch.all, options)
        self._needs_reset = False
        if self.render_mode == "human":
            self.render()
        return batch.observe_one(0), batch.info(0)

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            logger.warn(
                "You are calling render method without specifying any render mode. "
                'Pass render_mode="rgb_array" or "human" when making the env.'
            )
            return None
        if self._renderer is None:
            self._renderer = self.scene.renderer()
        frame = self._renderer.frame(0)
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            from .views.render import HumanWindow

            title = f"{type(self).__name__.removesuffix('Env')} ({self.dim}D)"
            self._window = HumanWindow(frame.shape[1], frame.shape[0], self.metadata["render_fps"], title=title)
        self._window.show(frame)
        return None

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None


class TaskVectorEnv(VectorEnv):
    """N worlds of a task as Gymnasium's native vector env: a :class:`~.engine.Batch` of N worlds
    stepped in one call, Gymnasium's three autoreset modes, world i seeded ``seed + i``.

    A subclass (the registered vector class) builds ``task`` and ``view`` and calls
    :meth:`_attach`."""

    metadata: dict[str, Any] = {
        "render_modes": ["rgb_array"],
        "render_fps": 10,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def _attach(
        self,
        task: Task,
        view: View,
        max_episode_steps: int,
        render_mode: str | None,
        autoreset_mode: AutoresetMode,
        outcome: Any = None,
    ) -> None:
        self.render_mode = check_render_mode(render_mode, self.metadata["render_modes"])
        self.scene = task
        self.max_episode_steps = max_episode_steps
        self.autoreset_mode = autoreset_mode
        self.batch = Batch(task, view, max_episode_steps, autoreset_mode, outcome)
        self.num_envs = task.n_worlds
        self.dim = task.dim
        self.metadata = dict(self.metadata, render_fps=render_fps(task.control_period), autoreset_mode=autoreset_mode)
        self.single_action_space = task.action_space
        self.single_observation_space = view.space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._started = False
        self._renderer: Any = None

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        batch, task = self.batch, self.scene
        options = check_options(options, ("reset_mask",) + task.reset_options, task.owner)
        seeds, int_seed = check_seeds(seed, self.num_envs)
        if not isinstance(seed, (list, tuple, np.ndarray)):
            super().reset(seed=int_seed)
        mask = options.pop("reset_mask", None)
        mask = batch.ones if mask is None else check_reset_mask(mask, self.num_envs)
        idx = np.flatnonzero(mask)
        batch.seed(seeds, idx)
        batch.reset(idx, options)
        self._started = True
        return batch.observe(), batch.infos(mask)

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            raise error.ResetNeeded(f"Cannot call {type(self).__name__}.step() before reset()")
        return self.batch.step(actions)

    def render(self) -> tuple[np.ndarray, ...] | None:
        if self.render_mode is None:
            logger.warn('You are calling render without a render mode; pass render_mode="rgb_array" to make_vec.')
            return None
        if self._renderer is None:
            self._renderer = self.scene.renderer()
        return tuple(self._renderer.frame(b) for b in range(self.num_envs))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.spec.id if self.spec else f'{self.dim}D'}, num_envs={self.num_envs})"
