"""The env's step kernel: act, step the physics on the World's own path, observe and reward.

One call advances the worlds listed in ``worlds`` by one control period. The actions become the
throttles of the pusher's motor (a :class:`~..physics.Motor` of the World), and the physics is the
World's own stepping path with its own buffers and code (:func:`..physics.stepping.runner.advance`:
the SIMD-lanes path for balls that slide, the scalar path for balls that roll and for sand), so
an episode is exactly what ``World.step`` computes, and a world's trajectory does not depend on
which env (single, vector, SB3) steps it or on how many worlds share the batch. The observation,
the reward terms and the penetration diagnostic happen in the same call, so Python touches a batch
once per step, and nothing is allocated.

The data protocol between the scene and this kernel is named: :class:`StepCall` (a thread's
worlds and the World's physics), :class:`SceneArrays` (the scene's arrays: actions, flags, goals,
the observation's layout, :class:`TaskParams` the task's constants and :class:`StepBuffers` what a
step writes, one entry per world) and :class:`HeightMap` (the sand's height map). Ball order in every world: 0 the pusher, 1 the ball, 2.. the
obstacles, then the grains. The last axis is "up"; the others are horizontal.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..._jit import njit
from ...physics.broadphase.grid import build_grid, uses_cells
from ...physics.diagnostics import deepest_contact
from ...physics.per_world import of_world, world_model
from ...physics.stepping.runner import advance
from ..terrains import TerrainHeights, terrain_height

__all__ = [
    "TaskParams",
    "SceneArrays",
    "StepCall",
    "StepBuffers",
    "HeightMap",
    "INFO_KEYS",
    "new_buffers",
    "step_worlds",
    "act_worlds",
    "observe_worlds",
    "first_bad_action",
    "OK",
]

# the info dict's keys, in order (every key a StepBuffers field of that name; is_success <- success)
INFO_KEYS = (
    "reward_goal",
    "reward_reach",
    "reward_success",
    "distance",
    "pusher_distance",
    "max_overlap",
    "is_success",
)
_FLOAT_INFO = INFO_KEYS[:-1]

# return code of ``step_worlds`` when every action was finite (the number of blown-up worlds is
# added: > 0 means some world's state became NaN or inf, flagged in ``status``); a value < 0 is
# -(1 + b) for the first world b whose action is NaN or inf (nothing was stepped)
OK = 0


class TaskParams(NamedTuple):
    """The task's constants (SI units)."""

    w_goal: float  # reward per metre the ball gets closer to the goal
    w_reach: float  # reward per metre the pusher gets closer to the push point
    success_bonus: float
    goal_tolerance: float  # success radius, m
    push_offset: float | np.ndarray  # pusher radius + ball radius: the push point's distance behind the ball (a
    # randomised scene: (B,), each world's)
    substeps: int  # physics steps per env step
    goal_axes: int  # the axes over which the goal is reached: all d, or the d - 1 horizontal (sand)


class HeightMap(NamedTuple):
    """The sand's height map around the ball (scenes with grains; None without): its constants."""

    first: int  # the first grain's index (the bodies come before)
    cells: int  # cells per horizontal axis
    cell: float  # their edge, m
    floor: TerrainHeights  # the bare floor (the terrain's height)
    offset: int  # where the map starts in the observation
    top: float  # the depth's upper bound (2 R)


# rows of StepBuffers.info (in INFO_KEYS order); only this module indexes them, readers use the
# named views (``StepBuffers.distance`` ...)
_R_GOAL, _R_REACH, _R_SUCCESS, _R_DISTANCE, _R_PUSHER, _R_OVERLAP = range(len(_FLOAT_INFO))


class StepBuffers(NamedTuple):
    """What a step writes, per world: the observation, the reward, the info values (its terms and
    diagnostics, as rows of one block), the last distances (the shaping's potentials) and the
    physics status (0 ok). Few arrays on purpose: each one costs Numba an unboxing per call."""

    obs: np.ndarray  # (B, obs_size) float32
    reward: np.ndarray  # (B,) float64
    info: np.ndarray  # (len(INFO_KEYS) - 1, B) float64: the float info values, rows in INFO_KEYS order
    success: np.ndarray  # (B,) bool
    prev: np.ndarray  # (2, B) float64: the last ball-goal and pusher-push point distances
    status: np.ndarray  # (B,) int64: the World's status (0 ok, 1 NaN or inf)

    # the info rows by name
    @property
    def reward_goal(self) -> np.ndarray:
        return self.info[_R_GOAL]

    @property
    def reward_reach(self) -> np.ndarray:
        return self.info[_R_REACH]

    @property
    def reward_success(self) -> np.ndarray:
        return self.info[_R_SUCCESS]

    @property
    def distance(self) -> np.ndarray:  # ball-goal distance, m
        return self.info[_R_DISTANCE]

    @property
    def pusher_distance(self) -> np.ndarray:  # pusher-push point distance, m
        return self.info[_R_PUSHER]

    @property
    def max_overlap(self) -> np.ndarray:  # the largest overlap / the smaller radius
        return self.info[_R_OVERLAP]


class SceneArrays(NamedTuple):
    """The scene's arrays and constants a step reads and writes."""

    actions: np.ndarray  # (B, d - 1) float64: the throttles asked
    stepping: np.ndarray  # (B,) bool: off for a world just reset (observed, not stepped)
    gravity: tuple  # the World's gravity (its length is the dimension)
    task: TaskParams
    table: np.ndarray  # the observation layout's rows (kind, a, b)
    bounds: np.ndarray  # (2, size): the observation's low and high
    goal: np.ndarray  # (B, d)
    buffers: StepBuffers


class StepCall(NamedTuple):
    """One thread's share of a step: its worlds, a list of ids to fill, the World's physics bundle
    and the thread's SIMD-lanes scratch (None on the scalar path)."""

    worlds: np.ndarray
    ids: np.ndarray
    physics: object
    lane_scratch: object


def new_buffers(n_worlds: int, obs_size: int, status: np.ndarray) -> StepBuffers:
    """Buffers for n_worlds worlds (``status``: the World's own per-world status, which the step
    sets)."""
    return StepBuffers(
        obs=np.zeros((n_worlds, obs_size), dtype=np.float32),
        reward=np.zeros(n_worlds),
        info=np.zeros((len(_FLOAT_INFO), n_worlds)),
        success=np.zeros(n_worlds, dtype=np.bool_),
        prev=np.zeros((2, n_worlds)),
        status=status,
    )


@njit(hot=True)
def _clip(value, lo, hi):
    return min(max(value, lo), hi)


@njit(hot=True)
def _distances(b, x, goal, task, D):
    """(ball-goal distance, pusher-push-point distance) of world b.

    The push point sits behind the ball on the goal line, one contact distance away: a pusher
    there that moves toward the goal pushes the ball straight at it."""
    dg2 = 0.0
    for k in range(D):
        dk = goal[b, k] - x[b, 1, k]
        dg2 += dk * dk
    dg = math.sqrt(dg2)
    inv = 1.0 / dg if dg > 0.0 else 0.0
    offset = of_world(task.push_offset, b)  # (a float; a randomised scene's (B,) per world)
    dp2 = 0.0
    for k in range(D):
        push_k = x[b, 1, k] - (goal[b, k] - x[b, 1, k]) * inv * offset
        dk = push_k - x[b, 0, k]
        dp2 += dk * dk
    return dg, math.sqrt(dp2)


@njit(hot=True)
def observe(b, x, v, goal, obs, table, bounds, D):
    """Write world b's observation, clipped to ``bounds`` ((2, size): low, high).

    The fields are :class:`.observation.ObservationLayout`'s, in its order (pusher position and
    velocity, ball position and velocity, goal, ball - pusher, goal - ball, then each obstacle's
    position and velocity), written field by field: ``table`` (its rows kind, a, b) is what they
    must equal (``tests`` check the kernel against it) but is not read per entry. Reading it per
    entry (a branch on the kind and on "goal or ball" for every coordinate) cost twice the
    instructions of this step's observation: callgrind, make_vec(1024).step, +200 instructions per
    world-step, 7% of the fused kernel."""
    lo = bounds[0]
    hi = bounds[1]
    n = 2 + (table.shape[0] - 7) // 2  # the bodies: pusher, ball, obstacles (grains follow them)
    for k in range(D):
        obs[b, k] = _clip(x[b, 0, k], lo[k], hi[k])
        obs[b, D + k] = _clip(v[b, 0, k], lo[D + k], hi[D + k])
        obs[b, 2 * D + k] = _clip(x[b, 1, k], lo[2 * D + k], hi[2 * D + k])
        obs[b, 3 * D + k] = _clip(v[b, 1, k], lo[3 * D + k], hi[3 * D + k])
        obs[b, 4 * D + k] = _clip(goal[b, k], lo[4 * D + k], hi[4 * D + k])
        obs[b, 5 * D + k] = _clip(x[b, 1, k] - x[b, 0, k], lo[5 * D + k], hi[5 * D + k])
        obs[b, 6 * D + k] = _clip(goal[b, k] - x[b, 1, k], lo[6 * D + k], hi[6 * D + k])
        for j in range(2, n):
            base = 7 * D + 2 * D * (j - 2)
            obs[b, base + k] = _clip(x[b, j, k], lo[base + k], hi[base + k])
            obs[b, base + D + k] = _clip(v[b, j, k], lo[base + D + k], hi[base + D + k])


@njit(hot=True)
def _throttle_scale(act, b, na):
    """The throttle a is clipped to [-1, 1] per axis and then to the unit disc (this factor), so
    the self-driven speed |v| = |a| v_max never exceeds v_max."""
    a2 = 0.0
    for k in range(na):
        ak = _clip(act[b, k], -1.0, 1.0)
        a2 += ak * ak
    return 1.0 / math.sqrt(a2) if a2 > 1.0 else 1.0


@njit(hot=True)
def _refuse_bad_action(worlds, act, stepping):
    """-(1 + b) for the first stepping world b of ``worlds`` whose action is NaN or inf, else 0."""
    for t in range(worlds.shape[0]):
        b = worlds[t]
        if stepping[b]:
            for k in range(act.shape[1]):
                if not np.isfinite(act[b, k]):
                    return -(1 + b)
    return 0


@njit(hot=True)
def _reward(b, stepped, dg, dp, task, buf):
    """World b's reward terms, success and shaping potentials from its distances ``dg`` (ball to
    goal) and ``dp`` (pusher to push point); a world just reset (not ``stepped``) gets no reward."""
    info = buf.info
    prev = buf.prev
    if stepped:
        success = dg < task.goal_tolerance
        r_goal = task.w_goal * (prev[0, b] - dg)
        r_reach = task.w_reach * (prev[1, b] - dp)
        r_success = task.success_bonus if success else 0.0
        info[_R_GOAL, b] = r_goal
        info[_R_REACH, b] = r_reach
        info[_R_SUCCESS, b] = r_success
        buf.reward[b] = r_goal + r_reach + r_success
        buf.success[b] = success
    else:  # a world just reset: its observation, no reward
        info[_R_GOAL, b] = 0.0
        info[_R_REACH, b] = 0.0
        info[_R_SUCCESS, b] = 0.0
        buf.reward[b] = 0.0
        buf.success[b] = False
    prev[0, b] = dg
    prev[1, b] = dp


@njit(entry=True, nogil=True)
def first_bad_action(act, skip):
    """Index of the first world whose action holds NaN or inf (worlds with ``skip`` set are
    ignored: their action is not used), or -1."""
    for b in range(act.shape[0]):
        if skip[b]:
            continue
        for k in range(act.shape[1]):
            if not np.isfinite(act[b, k]):
                return b
    return -1


@njit
def observe_sand(b, x, model, obs, hm, D):
    """World b's sand height map into its observation: in each of the ``hm.cells``^(D-1) cells of
    edge ``hm.cell`` centred on the ball (row-major: x, then y), the depth of the sand there, the
    highest grain top (z + r) above the bare floor under that grain (the terrain's height, 0 where
    there is none),
    clipped to ``hm.top``. One pass over the grains (a non-finite position is skipped)."""
    H = hm.cells
    size = H ** (D - 1)
    for c in range(size):
        obs[b, hm.offset + c] = 0.0
    width = H * hm.cell
    inv = 1.0 / hm.cell
    for i in range(hm.first, x.shape[1]):
        u = x[b, i, 0] - x[b, 1, 0] + 0.5 * width
        w = x[b, i, 1] - x[b, 1, 1] + 0.5 * width if D == 3 else 0.0
        if not (u >= 0.0 and u < width and w >= 0.0 and w < width):
            continue
        c = min(int(u * inv), H - 1)
        if D == 3:
            c = c * H + min(int(w * inv), H - 1)
        floor = terrain_height(b, x[b, i, 0], x[b, i, 1] if D == 3 else 0.0, hm.floor)
        depth = min(x[b, i, D - 1] + model.radii[i] - floor, hm.top)
        if depth > obs[b, hm.offset + c]:
            obs[b, hm.offset + c] = depth


@njit(hot=True)
def _max_overlap(b, x, grid, buf, model, D):
    """World b's largest overlap / the smaller radius, over every contact (through the World's
    grid, built for x, where it has one; ``grid`` None on the lanes path: every pair, and no grid
    code compiled)."""
    if grid is not None:
        if uses_cells(grid):
            build_grid(b, x, grid, model.cell_size, D)
    return deepest_contact(b, x, grid, buf, model, D)


@njit(hot=True)
def _act(ids, act, throttle):
    """The actions of the worlds ``ids`` as the pusher motor's throttles: each component clipped
    to [-1, 1], then the vector to the unit disc (so the self-driven speed |v| = |a| v_max never
    exceeds v_max)."""
    na = act.shape[1]
    for w in range(ids.shape[0]):
        b = ids[w]
        scale = _throttle_scale(act, b, na)
        for k in range(na):
            throttle[b, 0, k] = _clip(act[b, k], -1.0, 1.0) * scale


@njit(hot=True)
def _act_on(worlds, act, stepping, status, throttle, ids):
    """The actions of ``worlds`` as the motor's ``throttle``, their World ``status`` cleared, the
    stepping ones listed in ``ids``: returns how
    many (``ids[:W]``), or -(1 + b) for the first world b whose action is NaN or inf (then
    nothing is touched)."""
    refused = _refuse_bad_action(worlds, act, stepping)  # before anything moves
    if refused < 0:
        return refused
    W = 0
    for t in range(worlds.shape[0]):
        b = worlds[t]
        status[b] = 0
        if stepping[b]:
            ids[W] = b
            W += 1
    _act(ids[:W], act, throttle)
    return W


@njit(hot=True)
def _observe_worlds(worlds, stepping, phys, g, task, table, bounds, goal, buf, hm):
    """Observation, reward and diagnostics of every world of ``worlds`` whose physics did not
    blow up (world by world). (The scene's arrays arrive unpacked from :class:`SceneArrays`: a
    callee that is not inlined takes a tuple argument field by field, and the nested tuple cost
    this function's compile 1.6 s more.)"""
    x, v, status = phys.x, phys.v, phys.status
    D = len(g)
    model = phys.model
    for t in range(worlds.shape[0]):
        b = worlds[t]
        if status[b] != 0:
            continue
        mb = world_model(model, b)  # (the model itself for a fixed scene)
        dg, dp = _distances(b, x, goal, task, task.goal_axes)
        observe(b, x, v, goal, buf.obs, table, bounds, D)
        if hm is not None:  # (compiled away without sand)
            observe_sand(b, x, mb, buf.obs, hm, D)
        info = buf.info
        info[_R_OVERLAP, b] = _max_overlap(b, x, phys.grid, phys.scratch.partners[b], mb, D)
        info[_R_DISTANCE, b] = dg
        info[_R_PUSHER, b] = dp
        _reward(b, stepping[b], dg, dp, task, buf)


@njit(entry=True, nogil=True)
def step_worlds(worlds, ids, phys, lane_scratch, s, hm):
    """Step the worlds listed in ``worlds`` (those whose ``stepping`` flag is off were just reset:
    observe them without stepping), in one call: act, the physics on the World's runner (its
    ``advance``), observe and reward (a :class:`StepCall`, then the scene's :class:`SceneArrays`
    and the sand's :class:`HeightMap`, None without sand). ``phys`` is the World's runner's
    bundle (its state, model and buffers), ``lane_scratch`` this thread's SIMD-lanes scratch (None
    on the scalar path), ``ids`` a per-thread list of worlds. Returns OK plus the number of worlds
    that blew up, or -(1 + b) for the first world b whose action is NaN or inf (nothing was stepped
    then)."""
    W = _act_on(worlds, s.actions, s.stepping, phys.status, phys.control.throttle, ids)
    if W < 0:
        return W
    bad = advance(phys, ids[:W], s.task.substeps, lane_scratch)  # sets status[b] (the World's)
    _observe_worlds(worlds, s.stepping, phys, s.gravity, s.task, s.table, s.bounds, s.goal, s.buffers, hm)
    return bad


@njit(entry=True, nogil=True)
def act_worlds(worlds, ids, phys, s):
    """:func:`step_worlds`' first part alone (the actions as throttles, the stepping worlds listed
    in ``ids``; returns how many, or the refusal): for a scene whose physics steps through
    ``World.step``'s own kernel (the sand scenes), which then compiles once for the scene and for
    everything else that steps a World of its kind (its bed's settling)."""
    return _act_on(worlds, s.actions, s.stepping, phys.status, phys.control.throttle, ids)


@njit(entry=True, nogil=True)
def observe_worlds(worlds, phys, s, hm):
    """:func:`step_worlds`' last part alone (after :func:`act_worlds` and ``World.step``)."""
    _observe_worlds(worlds, s.stepping, phys, s.gravity, s.task, s.table, s.bounds, s.goal, s.buffers, hm)
