"""``PenaltyBallsVectorEnv``: N PenaltyBalls worlds stepped together, the native vector twin of
:class:`~.penalty_balls.PenaltyBallsEnv` (one Numba call per step; threads for large N)."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import error, logger
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .. import _validate as V
from . import kernel as KE
from .params import PARAMETERS, check_options, check_seed, coerce_action, render_fps
from .render import Renderer
from .scene import PenaltyBallsScene
from .views import Views, pop_view_kwargs

__all__ = ["PenaltyBallsVectorEnv"]

MAX_EPISODE_STEPS = 150  # the registered ids' default: 6 s of simulated time at the default 0.04 s


class PenaltyBallsVectorEnv(VectorEnv):
    """N PenaltyBalls worlds stepped together: one Numba call per step (threads for large N).

    The same task, spaces and keyword arguments as :class:`PenaltyBallsEnv`, plus
    ``num_envs``, ``max_episode_steps`` (the vector env truncates episodes itself) and
    ``autoreset_mode`` (default ``NEXT_STEP``, Gymnasium's default; ``SAME_STEP`` and
    ``DISABLED`` are supported as Gymnasium's ``SyncVectorEnv`` implements them). World i draws
    its starts from its own generator, seeded ``seed + i`` by ``reset(seed=seed)``, so the
    episodes are exactly those of N single envs seeded ``seed + i`` (and of a ``SyncVectorEnv``
    of them, infos included). ``render()`` returns one frame per world.

    ``obs_mode`` (``"state"``, ``"heightmap"``, ``"rgb"`` or a tuple of them, with
    ``heightmap_cells``, ``heightmap_cell``, ``rgb_size``: :class:`PenaltyBallsEnv`'s "Observation
    Space") is observed for the whole batch in one Numba call per mode after each step
    (:class:`~.views.Views`); a ``Dict`` mode's batch is a dict of arrays with a leading world
    axis, and ``SAME_STEP``'s ``final_obs`` holds each ended world's last observation in the
    same mode.
    """

    metadata = {
        "render_modes": ["rgb_array"],
        "render_fps": render_fps(PARAMETERS["control_period"][0]),
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        dim: int = 3,
        max_episode_steps: int = MAX_EPISODE_STEPS,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        if (
            isinstance(max_episode_steps, bool)
            or not isinstance(max_episode_steps, (int, np.integer))
            or max_episode_steps < 1
        ):
            raise ValueError(f"max_episode_steps must be an int >= 1, got {max_episode_steps!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        try:
            autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ValueError(
                f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, got {autoreset_mode!r}"
            ) from None
        view_kwargs = pop_view_kwargs(kwargs)
        self.scene = PenaltyBallsScene(
            V.integer("num_envs", num_envs, 1), dim=dim, owner="PenaltyBallsVectorEnv.__init__", **kwargs
        )
        self.views = Views(self.scene, **view_kwargs)
        self._view = None if self.views.is_state else self.views  # None: the state vector, as it is
        self.num_envs = self.scene.n_worlds
        self.dim = self.scene.dim
        self.max_episode_steps = int(max_episode_steps)
        self.render_mode = render_mode
        self.autoreset_mode = autoreset_mode
        self.metadata = dict(
            self.metadata, render_fps=render_fps(self.scene.control_period), autoreset_mode=autoreset_mode
        )
        self.single_action_space = self.scene.action_space
        self.single_observation_space = self.views.space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        N = self.num_envs
        self._rngs: list[np.random.Generator | None] = [None] * N
        self._steps = np.zeros(N, dtype=np.int64)
        self._done = np.zeros(N, dtype=np.bool_)  # episode over: the world awaits its reset
        self._started = False
        self._renderer: Renderer | None = None
        self._ones = np.ones(N, dtype=np.bool_)
        self._never = np.zeros(N, dtype=np.bool_)

    # ------------------------------------------------------------------ Gymnasium API
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        N = self.num_envs
        options = check_options(options, ("reset_mask", "randomize"))
        if seed is None or isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
            seed = check_seed(seed)
            seeds: list[int | None] = [None] * N if seed is None else [seed + i for i in range(N)]
        elif isinstance(seed, (list, tuple, np.ndarray)):
            seeds = [check_seed(s) for s in seed]
            if len(seeds) != N:
                raise ValueError(f"seed must be None, an int or a list of {N} seeds (one per world), got {len(seeds)}")
        else:
            raise V.ArgumentTypeError(
                f"seed must be None, an int >= 0 or a list of {N} of them, got {V.describe(seed)}"
            )
        mask = options.pop("reset_mask", None)
        if seed is None or isinstance(seed, int):
            super().reset(seed=seed)
        if mask is None:
            mask = self._ones
        elif not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (N,) and mask.any()):
            raise ValueError(
                f"options['reset_mask'] must be a bool array of shape ({N},) with a True value, got {mask!r}"
            )
        idx = np.flatnonzero(mask)
        for i in idx:
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        self.scene.reset_worlds(idx, [self._rngs[i] for i in idx], randomize=options.get("randomize"))
        self._steps[idx] = 0
        self._done[idx] = False
        self._started = True
        return self._observe(), self._infos(mask)

    def step(self, actions: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            raise error.ResetNeeded(f"Cannot call {type(self).__name__}.step() before reset()")
        scene = self.scene
        mode = self.autoreset_mode
        reset = self._advance(actions)
        rewards, terminated = self._outcome(reset)
        truncated = self._steps >= self.max_episode_steps
        done = terminated | truncated
        if mode == AutoresetMode.SAME_STEP and done.any():
            idx = np.flatnonzero(done)
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i, last in zip(idx, self._final_obs(idx)):
                final_obs[i] = last
            final_info = self._infos(done)
            scene.reset_worlds(idx, [self._rngs[i] for i in idx])
            self._steps[idx] = 0
            infos = self._infos(self._ones)
            infos["final_obs"], infos["_final_obs"] = final_obs, done.copy()
            infos["final_info"], infos["_final_info"] = final_info, done.copy()
            self._done[:] = False
        else:
            infos = self._infos(self._ones)
            self._done[:] = done
        return self._observe(), rewards, terminated, truncated, infos

    def render(self) -> tuple[np.ndarray, ...] | None:
        if self.render_mode is None:
            logger.warn('You are calling render without a render mode; pass render_mode="rgb_array" to make_vec.')
            return None
        if self._renderer is None:
            p = self.scene.params
            self._renderer = Renderer(self.scene, p["render_width"], p["render_height"])
        return tuple(self._renderer.frame(b) for b in range(self.num_envs))

    # ------------------------------------------------------------------ the step's parts
    # (the goal-conditioned twin, :class:`.goal.PenaltyBallsGoalVectorEnv`, replaces the outcome,
    # the observation and the infos' success; the stepping and the autoresets are these)
    def _advance(self, actions: np.ndarray) -> np.ndarray | None:
        """Check the actions, reset the worlds whose episode ended (``NEXT_STEP``: they are
        observed, not stepped) and step the others. Returns the worlds reset here, or None."""
        scene = self.scene
        shape = (self.num_envs, scene.action_size)
        if type(actions) is not np.ndarray or actions.shape != shape or actions.dtype.kind != "f":
            actions = coerce_action(actions, shape)
        mode = self.autoreset_mode
        resetting = self._done if mode == AutoresetMode.NEXT_STEP else None
        if mode == AutoresetMode.DISABLED and self._done.any():
            raise RuntimeError(
                f"world(s) {np.flatnonzero(self._done)[:10].tolist()} ended their episode; with "
                f"autoreset_mode DISABLED, reset them (reset(options={{'reset_mask': mask}})) before stepping"
            )
        scene.actions[:] = actions
        b = KE.first_bad_action(scene.actions, self._done if resetting is not None else self._never)
        if b >= 0:  # refuse before any world moves or resets
            raise ValueError(f"the action of world {b} contains NaN or inf: {scene.actions[b].tolist()}")
        reset = None
        if resetting is not None and resetting.any():
            reset = np.flatnonzero(resetting)
            scene.reset_worlds(reset, [self._rngs[i] for i in reset], observe=False)  # stepped as "just reset"
            scene.step()
            scene.stepping[reset] = True
            self._steps[reset] = -1  # += 1 below
        else:
            scene.step()
        self._steps += 1
        return reset

    def _outcome(self, reset: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(rewards, terminated) of the step (a world just ``reset``: 0 and False, the scene's)."""
        buf = self.scene.buffers
        return buf.reward.copy(), buf.success.copy()

    def _observe(self) -> Any:
        """Every world's observation, fresh arrays."""
        return self.scene.obs.copy() if self._view is None else self._view.observe()

    def _final_obs(self, idx: np.ndarray) -> list[Any]:
        """The last observation of each world in ``idx``, one object per world."""
        if self._view is None:
            return [self.scene.obs[i].copy() for i in idx]
        last = self._view.observe(idx)
        return [self._view.item(last, t) for t in range(idx.size)]

    # ------------------------------------------------------------------ helpers
    def _infos(self, mask: np.ndarray) -> dict[str, Any]:
        """Gymnasium's vector info dict for the worlds in ``mask``: one array per key and the
        ``_key`` mask, as ``SyncVectorEnv`` builds it from the single envs' infos. The float
        arrays are rows of one fresh block: a few allocations per step, not one per key and world."""
        buf = self.scene.buffers
        values = buf.info.copy()  # (keys - 1, N), in INFO_KEYS order
        success = buf.success.copy()
        n_keys = len(KE.INFO_KEYS)
        if mask is self._ones:
            masks = np.ones((n_keys, self.num_envs), dtype=np.bool_)
        else:
            values[:, ~mask] = 0.0
            success[~mask] = False
            masks = np.empty((n_keys, self.num_envs), dtype=np.bool_)
            masks[:] = mask
        infos: dict[str, Any] = {}
        for j, key in enumerate(KE.INFO_KEYS[:-1]):
            infos[key] = values[j]
            infos["_" + key] = masks[j]
        infos["is_success"] = success
        infos["_is_success"] = masks[-1]
        if self.scene.randomize:  # each world's draws, nested as Gymnasium batches a dict-valued info
            drawn = self.scene.drawn.T.copy()  # (names, N): one fresh block, its rows the values
            if mask is not self._ones:
                drawn[:, ~mask] = 0.0
            sub: dict[str, Any] = {}
            for j, name in enumerate(self.scene.randomize):
                sub[name], sub["_" + name] = drawn[j], masks[-1]
            infos["randomization"], infos["_randomization"] = sub, masks[-1]
        return infos

    def __repr__(self) -> str:
        return f"PenaltyBallsVectorEnv({self.spec.id if self.spec else f'{self.dim}D'}, num_envs={self.num_envs})"
