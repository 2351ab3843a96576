"""The one batched engine every env of the package drives: B worlds of a task, their generators,
episode counters, resets, autoresets and infos.

A *task* (:class:`Task`: the PenaltyBalls scene, the level scene) holds B worlds on one batched
physics ``World`` and knows how to act, advance, observe, reward and reset them. It knows nothing
of episodes or of Gymnasium. :class:`Batch` is everything around it that every env face needs
once, and only once:

* **seeding**: world i draws from its own generator (``seed + i`` for a vector reset's int seed;
  the single env's ``np_random``), so a world's episodes do not depend on the batch it sits in;
* **resets**: of every world or of a mask, with the task's reset options;
* **stepping**: the actions checked (shape, type; NaN or inf refused, naming the world, before
  anything moves), the worlds whose episode ended reset first (``NEXT_STEP``: observed, not
  stepped, reward 0), the rest advanced in one call of the task;
* **autoreset**: Gymnasium's three modes (``NEXT_STEP``, ``SAME_STEP``, ``DISABLED``) as its
  ``SyncVectorEnv`` implements them, and the episode limit (``max_episode_steps``);
* **observations**: through a *view* (:mod:`.views`: the state vector, height maps, images, or the
  goal-conditioned ``Dict`` of :mod:`.goal`), fresh arrays every call;
* **infos**: one dict per world (numpy scalars; ``is_success`` a Python bool) or Gymnasium's
  batched dict with its ``_key`` masks, from the task's info block.

The faces are thin: :class:`.faces.TaskVectorEnv` is Gymnasium's vector API over a Batch,
:class:`.faces.TaskEnv` the single env (a Batch of one world, no autoreset: the ``TimeLimit``
wrapper truncates), :class:`penalty_env.sb3.PenaltyBallsVecEnv` SB3's ``VecEnv``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, cast

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode

from .._jit import readonly_paths, restore_readonly
from .checks import coerce_action

__all__ = ["Task", "View", "Batch"]


class Task(Protocol):
    """B worlds of one task: what :class:`Batch` steps. Every array has a leading world axis and
    is allocated once; the Batch reads them after each call (no copies are made by the task)."""

    # read-only members (properties), so a task may hold any of them as an attribute or a property
    @property
    def n_worlds(self) -> int: ...

    @property
    def dim(self) -> int: ...

    @property
    def control_period(self) -> float: ...

    @property
    def action_space(self) -> spaces.Box:
        """One world's."""

    @property
    def observation_space(self) -> spaces.Box:
        """One world's state vector."""

    @property
    def actions(self) -> np.ndarray:
        """(B, actions) float64: the Batch writes each step's actions here."""

    @property
    def obs(self) -> np.ndarray:
        """(B, size) float32: every world's state vector after the last step or reset."""

    @property
    def reward(self) -> np.ndarray:
        """(B,) float64: the last step's reward (0 for a world just reset)."""

    @property
    def success(self) -> np.ndarray:
        """(B,) bool: the task is done (the episode terminates)."""

    @property
    def stepping(self) -> np.ndarray:
        """(B,) bool: off for a world just reset, which the next step observes only."""

    @property
    def info_keys(self) -> tuple[str, ...]:
        """The info dict's keys before "is_success", in order"""

    @property
    def info_values(self) -> np.ndarray:
        """(len(info_keys), B) float64: their values, rows in that order."""

    @property
    def int_info(self) -> tuple[str, ...]:
        """Those of info_keys reported as integers."""

    @property
    def nested_infos(self) -> dict[str, tuple[tuple[str, ...], np.ndarray]]:
        """Key -> (names, (B, names) values)."""

    @property
    def reset_options(self) -> tuple[str, ...]:
        """The reset options the task takes (besides reset_mask)."""

    @property
    def owner(self) -> str:
        """The env named in a refusal of reset options."""

    def renderer(self) -> Any:
        """A new renderer of the worlds (what draws render_mode's frames)."""

    def first_bad_action(self, skip: np.ndarray) -> int:
        """The first world not ``skip``-ped whose action holds NaN or inf, or -1."""

    def step(self) -> None:
        """Advance every world whose ``stepping`` flag is set by one control period (with
        ``actions``), then observe, reward and set the flags of every world."""

    def reset_worlds(
        self, worlds: np.ndarray, rngs: Sequence[np.random.Generator], observe: bool = True, options: Any = None
    ) -> None:
        """New episodes in ``worlds``, each drawn from its generator; ``observe=False`` leaves the
        world's ``stepping`` flag off (the next ``step`` observes it)."""


class View(Protocol):
    """How a Batch observes its worlds (:class:`.views.Views`, :class:`.goal.GoalView`)."""

    @property
    def space(self) -> spaces.Space:
        """One world's observation space."""

    @property
    def is_state(self) -> bool:
        """The task's own state vector, as it is (the Batch's fast path)."""

    def observe(self, worlds: np.ndarray | None = None) -> Any: ...

    def item(self, batch: Any, t: int) -> Any: ...


class Batch:
    """The episodes of a task's B worlds (see the module docstring).

    Args:
        task: the worlds (:class:`Task`).
        view: how they are observed (:class:`View`).
        max_episode_steps: truncation after this many steps (None: never, the single env's).
        autoreset_mode: Gymnasium's ``AutoresetMode`` (the vector faces), or None (the single env:
            a world whose episode ended is stepped on until the caller resets it).
        outcome: None (the task's reward and success) or a callable ``(state rows) -> (rewards,
            success)`` that replaces them (the goal-conditioned envs' ``compute_reward``).
    """

    def __init__(
        self,
        task: Task,
        view: View,
        max_episode_steps: int | None = None,
        autoreset_mode: AutoresetMode | None = None,
        outcome: Any = None,
    ) -> None:
        self.task = task
        self.view = view
        self.state_view = view.is_state
        self.outcome_of = outcome
        self.max_episode_steps = max_episode_steps
        self.autoreset_mode = autoreset_mode
        B = self.n_worlds = task.n_worlds
        self.rngs: list[np.random.Generator | None] = [None] * B
        self.steps = np.zeros(B, dtype=np.int64)
        self.done = np.zeros(B, dtype=np.bool_)  # episode over: the world awaits its reset
        self.all = np.arange(B, dtype=np.int64)
        self.ones = np.ones(B, dtype=np.bool_)
        self.never = np.zeros(B, dtype=np.bool_)
        self._action_shape = (B,) + task.action_space.shape
        self._one_shape = task.action_space.shape
        # the task's arrays, read once (the protocol: allocated once), for the single env's step
        self._arrays = (task.actions, task.obs, task.reward, task.success, task.info_values)
        self._info_keys, self._int_info = task.info_keys, task.int_info

    # ------------------------------------------------------------------ seeding and resets
    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_readonly"] = readonly_paths(self)  # pickling drops numpy's writeable flag
        return state

    def __setstate__(self, state: dict) -> None:
        """After unpickling: the task's read-only arrays read-only again, so its kernels find the
        types they were compiled for (not a new compile of seconds on the first step)."""
        paths = state.pop("_readonly", [])
        self.__dict__.update(state)
        restore_readonly(self, paths)

    def _gens(self, worlds: np.ndarray) -> list[np.random.Generator]:
        """The generators of ``worlds`` (each seeded by its first reset)."""
        return cast("list[np.random.Generator]", [self.rngs[i] for i in worlds])

    def seed(self, seeds: Sequence[int | None], worlds: np.ndarray) -> None:
        """Give each world of ``worlds`` a generator seeded ``seeds[i]`` (its index in the batch),
        or fresh entropy where the seed is None and the world has none yet."""
        for i in worlds:
            if seeds[i] is not None or self.rngs[i] is None:
                self.rngs[i] = seeding.np_random(seeds[i])[0]

    def reset(self, worlds: np.ndarray, options: Any = None, first_steps: np.ndarray | None = None) -> None:
        """New episodes in ``worlds`` from their generators (``options``: the task's reset options;
        ``first_steps``: the step count each starts at, 0 by default)."""
        self.task.reset_worlds(worlds, self._gens(worlds), options=options)
        self.steps[worlds] = 0 if first_steps is None else first_steps[worlds]
        self.done[worlds] = False

    # ------------------------------------------------------------------ stepping
    def act(self, actions: Any, skip: np.ndarray) -> None:
        """Check ``actions`` ((B, ...) of the task's action shape) and write them into the task's
        buffer; refuse NaN or inf in any world not ``skip``-ped, naming it, before anything moves."""
        shape = self._action_shape
        if type(actions) is not np.ndarray or actions.shape != shape or actions.dtype.kind != "f":
            actions = coerce_action(actions, shape)
        task = self.task
        task.actions[:] = actions
        b = task.first_bad_action(skip)
        if b >= 0:
            raise ValueError(f"the action of world {b} contains NaN or inf: {task.actions[b].tolist()}")

    def advance(self) -> np.ndarray | None:
        """Reset the worlds whose episode ended (``NEXT_STEP``: they are observed, not stepped) and
        step the others. Returns the worlds reset here, or None."""
        task = self.task
        reset = None
        if self.autoreset_mode == AutoresetMode.NEXT_STEP and self.done.any():
            reset = np.flatnonzero(self.done)
            task.reset_worlds(reset, self._gens(reset), observe=False)  # stepped as "just reset"
            task.step()
            task.stepping[reset] = True
            self.steps[reset] = -1  # += 1 below
        else:
            task.step()
        self.steps += 1
        return reset

    def outcome(self, reset: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(rewards, terminated) of the last step, fresh arrays (a world just ``reset``: 0 and
        False)."""
        task = self.task
        if self.outcome_of is None:
            return task.reward.copy(), task.success.copy()
        rewards, terminated = self.outcome_of(task.obs)
        if reset is not None:
            rewards[reset] = 0.0
            terminated[reset] = False
        return rewards, terminated

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One step of every world, Gymnasium's vector API (its autoreset mode): (observations,
        rewards, terminated, truncated, infos)."""
        mode = self.autoreset_mode
        if mode == AutoresetMode.DISABLED and self.done.any():
            raise RuntimeError(
                f"world(s) {np.flatnonzero(self.done)[:10].tolist()} ended their episode; with "
                f"autoreset_mode DISABLED, reset them (reset(options={{'reset_mask': mask}})) before stepping"
            )
        self.act(actions, self.done if mode == AutoresetMode.NEXT_STEP else self.never)
        reset = self.advance()
        rewards, terminated = self.outcome(reset)
        truncated = self.truncated()
        done = terminated | truncated
        if mode == AutoresetMode.SAME_STEP and done.any():
            idx = np.flatnonzero(done)
            final_obs = np.full(self.n_worlds, None, dtype=object)
            for i, last in zip(idx, self.final_observations(idx)):
                final_obs[i] = last
            final_info = self.infos(done)
            self.reset(idx)
            infos = self.infos(self.ones)
            infos["final_obs"], infos["_final_obs"] = final_obs, done.copy()
            infos["final_info"], infos["_final_info"] = final_info, done.copy()
            self.done[:] = False
        else:
            infos = self.infos(self.ones)
            self.done[:] = done
        return self.observe(), rewards, terminated, truncated, infos

    def truncated(self) -> np.ndarray:
        """The worlds whose episode reached ``max_episode_steps`` (a fresh array)."""
        if self.max_episode_steps is None:
            return np.zeros(self.n_worlds, dtype=np.bool_)
        return self.steps >= self.max_episode_steps

    def step_one(self, action: Any) -> tuple[Any, float, bool, dict[str, Any]]:
        """The single env's step of world 0: (observation, reward, terminated, info)."""
        task = self.task
        shape = self._one_shape
        actions, obs, reward, success, _ = self._arrays
        # fast path: a float array of the right shape is copied straight into the kernel's buffer
        if type(action) is not np.ndarray or action.shape != shape or action.dtype.kind != "f":
            action = coerce_action(action, shape)
        actions[0] = action
        task.step()  # NaN or inf in the action raises ValueError here, before anything moves
        if self.outcome_of is None:
            done = bool(success[0])
            one = obs[0].copy() if self.state_view else self.observe_one(0)
            return one, float(reward[0]), done, self.info(0, done)
        rewards, success = self.outcome_of(task.obs[:1])
        return self.observe_one(0), float(rewards[0]), bool(success[0]), self.info(0, bool(success[0]))

    # ------------------------------------------------------------------ observations
    def observe(self, worlds: np.ndarray | None = None) -> Any:
        """The observations of ``worlds`` (default every world), fresh arrays."""
        if self.state_view:
            return self.task.obs.copy() if worlds is None else self.task.obs[worlds]
        return self.view.observe(worlds)

    def observe_one(self, b: int) -> Any:
        """World b's observation (no world axis), a fresh array."""
        if self.state_view:
            return self.task.obs[b].copy()
        return self.view.item(self.view.observe(np.array([b], dtype=np.int64)), 0)

    def final_observations(self, idx: np.ndarray) -> list[Any]:
        """The observation of each world in ``idx``, one object per world (an episode's last)."""
        if self.state_view:
            return [self.task.obs[i].copy() for i in idx]
        last = self.view.observe(idx)
        return [self.view.item(last, t) for t in range(idx.size)]

    # ------------------------------------------------------------------ infos
    def success(self) -> np.ndarray:
        """Every world's success (the outcome's, when it replaces the task's), a fresh array."""
        if self.outcome_of is None:
            return self.task.success.copy()
        return self.outcome_of(self.task.obs)[1]

    def info(self, b: int, success: bool | None = None) -> dict[str, Any]:
        """World b's info dict of the last step or reset: numpy scalars, and ``is_success`` a
        Python bool (Gymnasium's own vector envs batch a numpy bool into an object array)."""
        task = self.task
        info = dict(zip(self._info_keys, self._arrays[4][:, b]))  # iterating a float64 array gives its scalars
        for key in self._int_info:
            info[key] = np.int64(info[key])
        if success is None:
            success = bool(task.success[b] if self.outcome_of is None else self.outcome_of(task.obs[b : b + 1])[1][0])
        info["is_success"] = success
        for key, (names, values) in task.nested_infos.items():
            info[key] = dict(zip(names, values[b].tolist()))
        return info

    def info_list(self) -> list[dict[str, Any]]:
        """Every world's info dict (as :meth:`info` gives them), built row by row."""
        task = self.task
        keys = task.info_keys
        infos = [dict(zip(keys, row)) for row in zip(*task.info_values)]
        success = self.success().tolist()
        for info, flag in zip(infos, success):
            for key in task.int_info:
                info[key] = np.int64(info[key])
            info["is_success"] = flag
        for key, (names, values) in task.nested_infos.items():
            for info, row in zip(infos, values.tolist()):
                info[key] = dict(zip(names, row))
        return infos

    def infos(self, mask: np.ndarray) -> dict[str, Any]:
        """Gymnasium's vector info dict for the worlds in ``mask``: one array per key and the
        ``_key`` mask, as ``SyncVectorEnv`` builds it from the single envs' infos (the other
        worlds' entries are zero and masked out). The float arrays are rows of one fresh block: a
        few allocations per step, not one per key and world."""
        task = self.task
        values = task.info_values.copy()  # (keys, N), in info_keys order
        success = self.success()
        n_keys = len(task.info_keys) + 1
        if mask is self.ones:
            masks = np.ones((n_keys, self.n_worlds), dtype=np.bool_)
        else:
            values[:, ~mask] = 0.0
            success &= mask
            masks = np.empty((n_keys, self.n_worlds), dtype=np.bool_)
            masks[:] = mask
        infos: dict[str, Any] = {}
        for j, key in enumerate(task.info_keys):
            infos[key] = values[j] if key not in task.int_info else values[j].astype(np.int64)
            infos["_" + key] = masks[j]
        infos["is_success"] = success
        infos["_is_success"] = masks[-1]
        for key, (names, drawn) in task.nested_infos.items():  # nested as Gymnasium batches a dict-valued info
            block = drawn.T.copy()  # (names, N): one fresh block, its rows the values
            if mask is not self.ones:
                block[:, ~mask] = 0.0
            sub: dict[str, Any] = {}
            for j, name in enumerate(names):
                sub[name], sub["_" + name] = block[j], masks[-1]
            infos[key], infos["_" + key] = sub, masks[-1]
        return infos
