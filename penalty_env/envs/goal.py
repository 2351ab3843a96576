"""Goal-conditioned PenaltyBalls: the same worlds, observed and rewarded as Gymnasium-Robotics'
goal-conditioned tasks (a ``Dict`` observation with ``observation``, ``achieved_goal`` and
``desired_goal``; a sparse reward; ``compute_reward`` for hindsight relabelling).

:class:`PenaltyBallsGoalEnv` is the single env (``PenaltyBallsGoal-v0`` and its siblings) and
:class:`PenaltyBallsGoalVectorEnv` its native vector twin (all worlds in one Numba call). Both are
the engine (:class:`.engine.Batch`) over the base task's scene, unchanged, with two parts of its
own: :class:`GoalView` regroups the state vector into the ``Dict``, and :class:`GoalReward`
recomputes the reward, success and termination from it. So the physics, the starts and the random
draws are the base ids' own.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from .. import _validate as V
from .balls.params import MAX_EPISODE_STEPS
from .balls.scene import PenaltyBallsScene
from .faces import TaskEnv, TaskVectorEnv, check_autoreset_mode, check_episode_steps, check_render_mode
from .penalty_balls import PenaltyBallsEnv, PenaltyBallsVectorEnv
from .views import pop_view_kwargs

__all__ = [
    "PenaltyBallsGoalEnv",
    "PenaltyBallsGoalVectorEnv",
    "GoalView",
    "GoalReward",
    "REWARD_TYPES",
    "goal_distance",
]

REWARD_TYPES = ("sparse", "dense")


GOAL_FIELDS = ("goal position", "goal - ball")  # the base observation's fields that hold the goal


def goal_distance(achieved_goal: Any, desired_goal: Any, dim: int) -> np.ndarray:
    """The Euclidean distance between ``achieved_goal`` and ``desired_goal`` over their last axis
    (length ``dim``), in float64, for any batch shape ``(..., dim)`` (the two broadcast).

    The sum of squares runs axis by axis, element-wise, so every batch shape gives each distance
    by the same arithmetic, bit for bit (a reduction such as ``np.linalg.norm`` may change its
    summation order with the array's shape and memory layout)."""
    a = V.real_array("achieved_goal", achieved_goal)
    b = V.real_array("desired_goal", desired_goal)
    for name, arr in (("achieved_goal", a), ("desired_goal", b)):
        if arr.ndim == 0 or arr.shape[-1] != dim:
            raise ValueError(f"{name} must have shape (..., {dim}) (a goal is {dim} coordinates), got {arr.shape}")
    try:
        diff = a - b
    except ValueError:
        raise ValueError(
            f"achieved_goal and desired_goal must broadcast together, got shapes {a.shape} and {b.shape}"
        ) from None
    sq = diff[..., 0] * diff[..., 0]
    for k in range(1, dim):
        sq = sq + diff[..., k] * diff[..., k]
    return np.sqrt(sq)


def _check_reward(reward: Any) -> str:
    return V.choice("reward", reward, REWARD_TYPES)


def _refuse_sand(kwargs: dict[str, Any]) -> None:
    """Refuse ``grains`` other than 0 before any scene is built (a bed of sand settles then)."""
    grains = kwargs.get("grains", 0)
    if isinstance(grains, (bool, np.bool_)) or grains != 0:
        raise ValueError(
            f"grains must be 0 for the goal-conditioned envs (with sand the goal is reached horizontally, "
            f"which a goal of the ball's centre does not express), got {grains!r}"
        )


class GoalView:
    """The engine's view of a goal-conditioned env (:class:`.engine.View`): each world's state
    vector as the ``Dict`` of ``observation`` (the base observation's entries, all but the goal's
    fields "goal position" and "goal - ball" unless ``observe_goal``), ``achieved_goal`` (the
    ball's position) and ``desired_goal`` (the goal's), fresh arrays at every call."""

    is_state = False

    def __init__(self, scene: PenaltyBallsScene, observe_goal: bool) -> None:
        layout = scene.layout
        self.scene = scene
        self.ball, self.goal = layout.slice("ball position"), layout.slice("goal position")
        entries = np.arange(layout.size)
        if not observe_goal:
            drop = np.concatenate([entries[layout.slice(name)] for name in GOAL_FIELDS])
            entries = np.setdiff1d(entries, drop)
        self.entries = entries
        low, high = layout.low.astype(np.float32), layout.high.astype(np.float32)
        self.space = spaces.Dict(
            {
                "observation": spaces.Box(low[entries], high[entries], dtype=np.float32),
                "achieved_goal": spaces.Box(low[self.ball], high[self.ball], dtype=np.float32),
                "desired_goal": spaces.Box(low[self.goal], high[self.goal], dtype=np.float32),
            }
        )

    def of(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """The Dict of state vectors ``rows`` ((k, size) or (size,)), fresh arrays."""
        return {
            "observation": rows[..., self.entries],
            "achieved_goal": rows[..., self.ball].copy(),
            "desired_goal": rows[..., self.goal].copy(),
        }

    def observe(self, worlds: np.ndarray | None = None) -> dict[str, np.ndarray]:
        obs = self.scene.obs
        return self.of(obs if worlds is None else obs[worlds])

    def item(self, batch: dict[str, np.ndarray], t: int) -> dict[str, np.ndarray]:
        return {key: value[t].copy() for key, value in batch.items()}


def _check_obs_mode(kwargs: dict[str, Any]) -> None:
    """The goal envs observe the state vector only (the goals are fields of it)."""
    mode = kwargs.get("obs_mode", "state")
    if mode != "state":
        raise ValueError(
            f"obs_mode must be 'state' for the goal-conditioned envs (achieved_goal and desired_goal are "
            f"fields of the state vector), got {mode!r}"
        )


class GoalReward:
    """The reward and success of a goal-conditioned env, from the goals alone (``dim`` coordinates
    each; success within ``goal_tolerance``; ``reward_type`` "sparse" or "dense")."""

    def __init__(self, dim: int, goal_tolerance: float, reward_type: str, view: GoalView) -> None:
        self.dim = dim
        self.goal_tolerance = goal_tolerance
        self.reward_type = reward_type
        self.view = view

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any = None) -> np.ndarray:
        """The reward of reaching ``achieved_goal`` when ``desired_goal`` was asked, for any batch
        shape ``(..., d)`` (the two broadcast), as float64 of shape ``(...)`` (a numpy scalar for
        a single pair): sparse, ``-1.0`` while the distance is at least ``goal_tolerance`` and
        ``0.0`` within it; dense, ``-distance``. The distance is computed in float64 from the
        (float32) goals. ``info`` is not read (it may be
        a dict, a list or array of dicts, or None). The step's reward is this function of the
        very arrays the step returns, so the two are equal bit for bit."""
        distance = goal_distance(achieved_goal, desired_goal, self.dim)
        if self.reward_type == "sparse":
            return -(distance >= self.goal_tolerance).astype(np.float64)
        return -distance

    def is_success(self, achieved_goal: Any, desired_goal: Any) -> np.ndarray:
        """``distance < goal_tolerance``, by ``compute_reward``'s arithmetic (bool, shape ``(...)``)."""
        return goal_distance(achieved_goal, desired_goal, self.dim) < self.goal_tolerance

    def __call__(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rewards, success) of the state vectors ``rows`` (the engine's outcome)."""
        achieved, desired = rows[..., self.view.ball], rows[..., self.view.goal]
        return self.compute_reward(achieved, desired, None), self.is_success(achieved, desired)


def _goal_parts(scene: PenaltyBallsScene, reward: str, observe_goal: bool) -> tuple[GoalView, GoalReward]:
    view = GoalView(scene, observe_goal)
    return view, GoalReward(scene.dim, float(scene.goal_tolerance), reward, view)


class PenaltyBallsGoalEnv(TaskEnv):
    """
    ## Description

    The goal-conditioned form of `PenaltyBalls-v0` and `-v1` (`PenaltyBallsGoal-v0`,
    `PenaltyBallsGoal2D-v0`, `PenaltyBallsGoal-v1`, `PenaltyBallsGoal2D-v1`), in the convention
    of Gymnasium-Robotics' goal-conditioned tasks, for hindsight experience replay (HER). The
    task, its physics and its starts are those of the base env (`PenaltyBallsEnv`, whose
    docstring documents them): a motor-driven pusher must push a ball onto a goal in a bowl.
    Only the observation is regrouped into a `Dict`, and the reward, success and termination are
    recomputed from that observation by `compute_reward`.

    ## Action Space

    The base env's: `Box(-1, 1, (d - 1,), float32)`, one motor throttle per horizontal axis.

    ## Observation Space

    `Dict` of three float32 `Box`es:

    | Key | Shape | Value | Bounds |
    |---|---|---|---|
    | `observation` | `(5 d + 2 d n_obstacles,)` | the base env's observation without its two goal fields, "goal position" and "goal - ball" (all of it, `(7 d + 2 d n_obstacles,)`, with `observe_goal=True`) | the base env's, for the fields kept |
    | `achieved_goal` | `(d,)` | the ball's centre (the base observation's "ball position") | the base layout's for that field |
    | `desired_goal` | `(d,)` | the goal (the base observation's "goal position": a resting ball's centre there) | the base layout's for that field |

    Both goals are positions relative to the bowl's lowest point, the last axis up.

    `observation` leaves the goal out, as in Gymnasium-Robotics' tasks: HER relabels a stored
    transition's `desired_goal` but keeps its `observation`, whose goal fields would then describe
    the episode's own goal and contradict the relabelled one (docs/training.md, "Goal-conditioned
    tasks and HER", has the runs with and without it).

    ## Rewards

    `compute_reward(achieved_goal, desired_goal, info)` on the step's own `achieved_goal` and
    `desired_goal`, so the step's reward and a relabelled one are computed alike, bit for bit.
    `distance` is the Euclidean distance of the two goals, computed in float64 from their float32
    values.

    | `reward` | Value per step |
    |---|---|
    | `"sparse"` (default) | `-1.0` while `distance >= goal_tolerance`, `0.0` once within it |
    | `"dense"` | `-distance` |

    `compute_reward` takes goals of any batch shape `(..., d)` and returns a float64 array of
    shape `(...)`; it does not read `info`. `info` holds the base env's keys (its `distance`,
    in float64 from the physics state, and its reward terms), with `is_success` replaced by this
    env's success: `distance < goal_tolerance` by `compute_reward`'s arithmetic.

    ## Starting State

    The base env's, draw for draw: the same seed gives the same start.

    ## Episode End

    1. Termination: `info["is_success"]`, the ball's centre within `goal_tolerance` (0.1 m) of
       the goal. The goals are the float32 values the observation holds, where the base env
       tests its own success on the float64 state: the two agree except when the distance is
       within float32 rounding (about 1e-7 m) of the tolerance, where this env's answer is the
       one that holds (the reward, the success and the termination always agree with each other).
    2. Truncation: 150 steps, as the base ids (the registered `max_episode_steps`).

    ## Arguments

    `gymnasium.make("PenaltyBallsGoal-v0", render_mode=None, reward="sparse", **kwargs)`:
    `reward` is `"sparse"` or `"dense"` (anything else raises `ValueError`); `observe_goal`
    (default False) keeps the goal's fields in `observation`; `obs_mode` must stay `"state"`;
    every other keyword
    is the base env's (its docstring's table), except the sand's: `grains` must stay 0 (with
    sand the base task's goal is reached horizontally, which a goal of the ball's centre does not
    express).

    ## Vectorized environment

    `gymnasium.make_vec("PenaltyBallsGoal-v0", num_envs=N)` returns
    :class:`PenaltyBallsGoalVectorEnv`: all N worlds stepped in one Numba call, with the same
    episodes as N single envs seeded `seed + i`.

    ## Version History

    * v0: the goal-conditioned form of `PenaltyBalls-v0` (3D) and `PenaltyBalls2D-v0`.
    * v1: the goal-conditioned form of `PenaltyBalls-v1` and `PenaltyBalls2D-v1` (the balls roll).
    """

    OBS_MODES = ("state",)
    metadata = PenaltyBallsEnv.metadata

    def __init__(
        self,
        dim: int = 3,
        render_mode: str | None = None,
        reward: str = "sparse",
        observe_goal: bool = False,
        **kwargs: Any,
    ) -> None:
        self.reward_type = _check_reward(reward)
        self.observe_goal = V.flag("observe_goal", observe_goal)
        _refuse_sand(kwargs)
        _check_obs_mode(kwargs)
        pop_view_kwargs(kwargs)  # (checked; the goal envs observe the state vector)
        check_render_mode(render_mode, self.metadata["render_modes"])
        scene = PenaltyBallsScene(1, dim=dim, **kwargs)
        self.view, self.goal_reward = _goal_parts(scene, self.reward_type, self.observe_goal)
        self._attach(scene, self.view, render_mode, outcome=self.goal_reward)
        self.goal_tolerance = self.goal_reward.goal_tolerance

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any = None) -> np.ndarray:
        """:meth:`GoalReward.compute_reward`: HER's relabelling calls it on batches of goals."""
        return self.goal_reward.compute_reward(achieved_goal, desired_goal, info)

    def is_success(self, achieved_goal: Any, desired_goal: Any) -> np.ndarray:
        """:meth:`GoalReward.is_success`."""
        return self.goal_reward.is_success(achieved_goal, desired_goal)


class PenaltyBallsGoalVectorEnv(TaskVectorEnv):
    """N goal-conditioned PenaltyBalls worlds stepped together (one Numba call per step): the
    native vector twin of :class:`PenaltyBallsGoalEnv`, as :class:`PenaltyBallsVectorEnv` is the
    base env's.

    The same keywords as :class:`PenaltyBallsVectorEnv` plus ``reward`` and ``observe_goal``. Observations are a
    ``Dict`` of ``(N, ...)`` arrays; rewards, ``terminated`` and ``info["is_success"]`` are the
    goal env's, computed for all worlds at once by ``compute_reward``. World i's episodes are
    those of the single env seeded ``seed + i`` (and of Gymnasium's ``SyncVectorEnv`` of them, in
    each autoreset mode; with ``SAME_STEP``, ``info["final_obs"]`` holds each ended world's last
    observation as a ``Dict``).
    """

    OBS_MODES = ("state",)
    metadata = PenaltyBallsVectorEnv.metadata

    def __init__(
        self,
        num_envs: int = 1,
        dim: int = 3,
        max_episode_steps: int = MAX_EPISODE_STEPS,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        reward: str = "sparse",
        observe_goal: bool = False,
        **kwargs: Any,
    ) -> None:
        self.reward_type = _check_reward(reward)
        self.observe_goal = V.flag("observe_goal", observe_goal)
        _refuse_sand(kwargs)
        _check_obs_mode(kwargs)
        pop_view_kwargs(kwargs)  # (checked; the goal envs observe the state vector)
        max_episode_steps = check_episode_steps(max_episode_steps)
        check_render_mode(render_mode, self.metadata["render_modes"])
        mode = check_autoreset_mode(autoreset_mode)
        num_envs = V.integer("num_envs", num_envs, 1)
        scene = PenaltyBallsScene(num_envs, dim=dim, owner="PenaltyBallsGoalVectorEnv.__init__", **kwargs)
        self.view, self.goal_reward = _goal_parts(scene, self.reward_type, self.observe_goal)
        self._attach(scene, self.view, max_episode_steps, render_mode, mode, outcome=self.goal_reward)
        self.goal_tolerance = self.goal_reward.goal_tolerance

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any = None) -> np.ndarray:
        """:meth:`GoalReward.compute_reward`."""
        return self.goal_reward.compute_reward(achieved_goal, desired_goal, info)

    def is_success(self, achieved_goal: Any, desired_goal: Any) -> np.ndarray:
        """:meth:`GoalReward.is_success`."""
        return self.goal_reward.is_success(achieved_goal, desired_goal)
