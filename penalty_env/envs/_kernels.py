"""The env's jitted step: action to motor force, physics substeps, observation and reward.

One call advances the worlds listed in ``worlds`` by one control period. The physics is the core's
own symplectic Euler step in its SIMD-across-worlds form (:mod:`..physics.lanes`: a block of worlds
per vector instruction, bit-identical world by world to ``symplectic_euler_step``), so a world's
trajectory does not depend on which env (single, vector, SB3) steps it or on how many worlds share
the batch. Everything else a step needs (the motor force, the observation, the reward terms, the
penetration diagnostic) happens in the same call, so Python touches a batch once per step, and
nothing is allocated.

Ball order in every world: 0 the pusher, 1 the ball, 2.. the obstacles. The last axis is "up";
the others are horizontal.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from ..physics import kernels as K
from ..physics import lanes as L

# ``envp``: the task (float64 array)
(
    E_MAX_FORCE,
    E_MAX_SPEED,
    E_W_GOAL,
    E_W_REACH,
    E_BONUS,
    E_GOAL_TOL,
    E_PUSH_OFFSET,
    E_POS_BOUND,
    E_VEL_BOUND,
) = range(9)
N_ENVP = 9

# ``out``: per-world results of the last step (float64 array, (B, N_OUT)). The info entries come
# first and in the info dict's order, so the vector env copies them out as one slice.
(
    O_REWARD_GOAL,
    O_REWARD_REACH,
    O_REWARD_SUCCESS,
    O_DISTANCE,
    O_PUSHER_DISTANCE,
    O_MAX_OVERLAP,
    O_SUCCESS,
    O_REWARD,
) = range(8)
N_INFO = 7  # out[:, :N_INFO] are the info dict's values (is_success as 0.0 / 1.0)
N_OUT = 8

# return codes of ``step_worlds``
OK = 0
# a value < 0 is -(1 + b) for the first world b whose action is NaN or inf (nothing was stepped);
# a value > 0 is the number of worlds whose state became NaN or inf (flagged in ``status``)


@njit(inline="always")
def _clip(value, lo, hi):
    return min(max(value, lo), hi)


@njit(inline="always")
def _distances(b, x, goal, envp, D):
    """(ball-goal distance, pusher-push-point distance) of world b.

    The push point sits behind the ball on the goal line, one contact distance away: a pusher
    there that moves toward the goal pushes the ball straight at it."""
    dg2 = 0.0
    for k in range(D):
        dk = goal[b, k] - x[b, 1, k]
        dg2 += dk * dk
    dg = np.sqrt(dg2)
    inv = 1.0 / dg if dg > 0.0 else 0.0
    dp2 = 0.0
    for k in range(D):
        push_k = x[b, 1, k] - (goal[b, k] - x[b, 1, k]) * inv * envp[E_PUSH_OFFSET]
        dk = push_k - x[b, 0, k]
        dp2 += dk * dk
    return dg, np.sqrt(dp2)


@njit(inline="always")
def _observe(b, x, v, goal, obs, envp, D):
    """Write world b's observation (layout in the env's docstring), clipped to its bounds."""
    pb = envp[E_POS_BOUND]
    vb = envp[E_VEL_BOUND]
    n = x.shape[1]
    for k in range(D):
        # positions: a centre stays inside the bowl, |x - c| <= R; c = R e_up
        lo = 0.0 if k == D - 1 else -pb
        hi = 2.0 * pb if k == D - 1 else pb
        obs[b, k] = _clip(x[b, 0, k], lo, hi)
        obs[b, D + k] = _clip(v[b, 0, k], -vb, vb)
        obs[b, 2 * D + k] = _clip(x[b, 1, k], lo, hi)
        obs[b, 3 * D + k] = _clip(v[b, 1, k], -vb, vb)
        obs[b, 4 * D + k] = _clip(goal[b, k], lo, hi)
        obs[b, 5 * D + k] = _clip(x[b, 1, k] - x[b, 0, k], -2.0 * pb, 2.0 * pb)
        obs[b, 6 * D + k] = _clip(goal[b, k] - x[b, 1, k], -2.0 * pb, 2.0 * pb)
        for j in range(2, n):
            base = 7 * D + 2 * D * (j - 2)
            obs[b, base + k] = _clip(x[b, j, k], lo, hi)
            obs[b, base + D + k] = _clip(v[b, j, k], -vb, vb)


@njit(inline="always")
def _physics_block(ids, W, act, x, v, S, model, friction, dt, substeps, envp, status, g):
    """Advance the W worlds ``ids[:W]`` by one control period, one world per SIMD lane.

    The lanes step is the core's (:func:`..physics.lanes.lanes_step`), bit-identical to
    ``symplectic_euler_step`` world by world. ``S`` is this thread's (6, n, D, LANES) scratch:
    state, accelerations, external force, the motor throttle and the pair-force buffer. Returns the
    number of blown-up worlds."""
    na = act.shape[1]
    X, V, A, E, T, F = S[0], S[1], S[2], S[3], S[4], S[5, 0]
    fmax = envp[E_MAX_FORCE]
    inv_vmax = 1.0 / envp[E_MAX_SPEED]
    L.load_block(ids, 0, W, x, v, X, V)
    for i in range(E.shape[0]):
        for k in range(E.shape[1]):
            for w in range(W):
                E[i, k, w] = 0.0
    for w in range(W):
        b = ids[w]
        # the throttle a is clipped to [-1, 1] per axis and then to the unit disc, so the
        # self-driven speed |v| = |a| v_max never exceeds v_max
        a2 = 0.0
        for k in range(na):
            ak = _clip(act[b, k], -1.0, 1.0)
            a2 += ak * ak
        scale = 1.0 / np.sqrt(a2) if a2 > 1.0 else 1.0
        for k in range(na):
            T[0, k, w] = _clip(act[b, k], -1.0, 1.0) * scale
    for _ in range(substeps):
        # the pusher's motor: F_max (a - v / v_max) (a DC motor's linear force-speed law),
        # re-evaluated every substep
        for k in range(na):
            for w in range(W):
                E[0, k, w] = fmax * (T[0, k, w] - V[0, k, w] * inv_vmax)
        L.lanes_step(True, dt, X, V, A, E, F, W, model, friction, g)
    return L.store_block(ids, 0, W, x, v, X, V, status, g)


@njit(nogil=True)
def step_worlds(worlds, act, stepping, x, v, scratch, ids, model, friction, g, dt, substeps, envp, goal, prev,
                obs, out, status):
    """Step the worlds listed in ``worlds`` (those whose ``stepping`` flag is off were just reset:
    observe them without stepping). ``x``, ``v``, ``model``, ``friction`` and ``g`` are the
    World's own (``World.kernel_state``); gravity's length D compiles the D-dimensional code."""
    n_lanes = ids.shape[0]
    na = act.shape[1]
    # refuse a non-finite action before anything moves
    for t in range(worlds.shape[0]):
        b = worlds[t]
        if stepping[b]:
            for k in range(na):
                if not np.isfinite(act[b, k]):
                    return -(1 + b)
    D = len(g)
    # physics: the stepping worlds, LANES at a time
    bad = 0
    W = 0
    for t in range(worlds.shape[0]):
        b = worlds[t]
        status[b] = 0
        if stepping[b]:
            ids[W] = b
            W += 1
            if W == n_lanes:
                bad += _physics_block(ids, W, act, x, v, scratch, model, friction, dt, substeps, envp, status, g)
                W = 0
    if W > 0:
        bad += _physics_block(ids, W, act, x, v, scratch, model, friction, dt, substeps, envp, status, g)
    # observation, reward and diagnostics, world by world
    for t in range(worlds.shape[0]):
        b = worlds[t]
        if status[b] != 0:
            continue
        dg, dp = _distances(b, x, goal, envp, D)
        _observe(b, x, v, goal, obs, envp, D)
        out[b, O_MAX_OVERLAP] = K.contacts(K.MAXPEN, b, x, v, x, 0.0, 0.0, None, model, None, g)
        out[b, O_DISTANCE] = dg
        out[b, O_PUSHER_DISTANCE] = dp
        if stepping[b]:
            success = dg < envp[E_GOAL_TOL]
            r_goal = envp[E_W_GOAL] * (prev[b, 0] - dg)
            r_reach = envp[E_W_REACH] * (prev[b, 1] - dp)
            r_success = envp[E_BONUS] if success else 0.0
            out[b, O_REWARD_GOAL] = r_goal
            out[b, O_REWARD_REACH] = r_reach
            out[b, O_REWARD_SUCCESS] = r_success
            out[b, O_REWARD] = r_goal + r_reach + r_success
            out[b, O_SUCCESS] = 1.0 if success else 0.0
        else:  # a world just reset: its observation, no reward
            out[b, O_REWARD_GOAL] = 0.0
            out[b, O_REWARD_REACH] = 0.0
            out[b, O_REWARD_SUCCESS] = 0.0
            out[b, O_REWARD] = 0.0
            out[b, O_SUCCESS] = 0.0
        prev[b, 0] = dg
        prev[b, 1] = dp
    return bad


@njit(nogil=True)
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
