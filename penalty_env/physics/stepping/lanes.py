"""SIMD across worlds: many small worlds stepped with one world per vector lane.

A world of a few balls has too little work per contact check for a CPU's vector units: the scalar
path tests one pair of one world at a time. Here a block of ``LANES`` worlds is copied into a
world-innermost layout ``(n, D, LANES)`` and every pair check, force and update runs as a loop over
the block's worlds (the law over lanes, :mod:`..contact.lanes`), which LLVM vectorises. Results are
bit-identical to the scalar symplectic / explicit Euler path for every world that stays finite
(tested), only faster. (A world that blows up is reported the same way; the NaN may reach other
balls of that world by a different route.)

Used by :class:`~penalty_env.physics.World` for all-pairs scenes (few balls per world) with
symplectic or explicit Euler, and so by the environments.

The block scratch (one per thread) is ``(6, n, D, LANES)``: positions, velocities, accelerations,
external forces, the motors' throttles (rows by motor) and the pair-force buffer (row 0).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._jit import njit
from ..contact.lanes import direct_terrain_lanes, pair_lanes, shared_statics, summed_terrain_lanes
from ..contact.terrain import has_summed_shapes
from ..geometry.evaluate import advance_shapes
from ..per_world import lane, lane_buffers, lane_model, lane_rows
from .common import STATUS_OK, final_status, motor_force

__all__ = ["LANES", "LANES_MAX_BALLS", "LANES_MIN_WORLDS", "SCRATCH_ROWS", "lanes_step", "run_lanes"]

# All-pairs worlds of at most this many balls step one world per SIMD lane with symplectic /
# explicit Euler (measured crossover: ``python -m penalty_env.bench core``, section d).
LANES_MAX_BALLS = 24
# ... in batches of at least this many worlds: the vectorised loops take 16 lanes per iteration,
# fewer run their scalar remainder (measured, 6 balls: 0.44x the scalar kernel at 1 world, 0.79x
# at 8, 1.16x at 16, 2.3x at 32)
LANES_MIN_WORLDS = 16
# worlds per block: a block's state (x, v, a, ext of 6 balls in 3D: 37 KB) stays in L1. Measured
# on 1,024 worlds of 6 balls, one thread: 16 lanes 11.6, 32 23.3, 64 36.3, 128 34.0, 256 33.1 M
# particle-substeps/s (each vectorised loop pays a fixed start-up, so short blocks lose)
LANES = 64
SCRATCH_ROWS = 6


@njit(hot=True)
def lanes_step(symplectic, dt, X, V, A, E, has_ext, F, W, block, summed, statics, model, g):
    """One symplectic (or explicit) Euler step of the W worlds of a block (lane w holds world
    ``block[w]``), all pairs; kinematic shapes move on after it. ``summed``: the table holds
    shapes other than static spheres and bowls; ``statics``: the block's
    :func:`..contact.lanes.shared_statics` (both fixed while a block is stepped)."""
    D = len(g)
    n = X.shape[0]
    for i in range(n):
        for k in range(D):
            for w in range(W):
                A[i, k, w] = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            pair_lanes(i, j, X, V, A, F, W, model, g)
        direct_terrain_lanes(i, X, V, A, F, W, block, model, g)
        if summed:
            summed_terrain_lanes(i, X, V, A, F, W, block, statics, model, g)
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            # each combination its own call of the inlined loop, under a branch that fixes the
            # flags: LLVM specialises each loop (no branch in it, which it vectorises best), and
            # Numba compiles the function once (literal flags would make four)
            if has_ext and symplectic:
                _update_lanes(X[i, k], V[i, k], A[i, k], E[i, k], W, im, g[k], dt, has_ext, symplectic)
            elif has_ext:
                _update_lanes(X[i, k], V[i, k], A[i, k], E[i, k], W, im, g[k], dt, has_ext, symplectic)
            elif symplectic:
                _update_lanes(X[i, k], V[i, k], A[i, k], E[i, k], W, im, g[k], dt, has_ext, symplectic)
            else:
                _update_lanes(X[i, k], V[i, k], A[i, k], E[i, k], W, im, g[k], dt, has_ext, symplectic)
    for w in range(W):
        advance_shapes(model.shapes, block[w], dt, D)


@njit(hot=True)
def _update_lanes(x, v, a, e, W, im, gk, dt, has_ext, symplectic):
    """Symplectic (or explicit) Euler on one coordinate of one ball in every lane: a = (f [+ e]) / m
    + g. Called with constant flags (each call inlined and specialised by LLVM). ``im``: the ball's
    1 / m, a float (a fixed scene) or a lane row (per-world)."""
    for w in range(W):
        if has_ext:
            ak = (a[w] + e[w]) * lane(im, w) + gk
        else:
            ak = a[w] * lane(im, w) + gk
        if symplectic:
            v[w] += dt * ak
            x[w] += dt * v[w]
        else:
            x[w] += dt * v[w]
            v[w] += dt * ak


@njit
def _load_block(block, W, x, v, X, V):
    """Copy the block's W worlds from (B, n, D) state into the lanes layout (n, D, LANES)."""
    for i in range(x.shape[1]):
        for k in range(x.shape[2]):
            for w in range(W):
                b = block[w]
                X[i, k, w] = x[b, i, k]
                V[i, k, w] = v[b, i, k]


@njit
def _store_block(block, W, x, v, X, V):
    """Copy the block's W worlds back from the lanes layout to the (B, n, D) state."""
    for i in range(x.shape[1]):
        for k in range(x.shape[2]):
            for w in range(W):
                b = block[w]
                x[b, i, k] = X[i, k, w]
                v[b, i, k] = V[i, k, w]


@njit
def _load_inputs(block, W, control, motors, E, T):
    """The block's given forces into E (zeros without) and its motors' throttles into T."""
    given = control.flags[0] != 0
    for i in range(E.shape[0]):
        for k in range(E.shape[1]):
            for w in range(W):
                E[i, k, w] = control.forces[block[w], i, k] if given else 0.0
    for q in range(motors.ball.shape[0]):
        for k in range(motors.axes[q]):
            for w in range(W):
                T[q, k, w] = control.throttle[block[w], q, k]


@njit
def _motors_lanes(block, W, V, E, T, control, motors):
    """Each motor's force at its ball's velocity now, into E (plus the given force)."""
    given = control.flags[0] != 0
    for q in range(motors.ball.shape[0]):
        i = motors.ball[q]
        fmax = motors.max_force[q]
        inv = motors.inv_max_speed[q]
        for k in range(motors.axes[q]):
            for w in range(W):
                f = motor_force(lane(fmax, w), inv, T[q, k, w], V[i, k, w])
                E[i, k, w] = control.forces[block[w], i, k] + f if given else f


@njit(nogil=True)
def run_lanes(symplectic, worlds, nsteps, dt, x, v, scratch, control, model, g, status):
    """The listed worlds of (B, n, D) state, LANES at a time, ``nsteps`` steps each (``scratch`` is
    (SCRATCH_ROWS, n, D, LANES), this thread's; with per-world parameters the pair of it and the
    thread's parameter scratch, :func:`new_lane_scratch`); sets their ``status``. Returns how many
    blew up."""
    D = len(g)
    sc, P = lane_buffers(scratch)
    X, V, A, E, T = sc[0], sc[1], sc[2], sc[3], sc[4]
    F = sc[5, 0]
    has_ext = control.flags[0] != 0 or model.motors.ball.shape[0] > 0
    bad = 0
    for c in range(0, worlds.shape[0], LANES):
        W = min(LANES, worlds.shape[0] - c)
        block = worlds[c : c + W]
        lm = lane_model(model, block, W, P)  # (the model itself for a fixed scene)
        motors = lm.motors
        _load_block(block, W, x, v, X, V)
        summed = has_summed_shapes(model.shapes)
        statics = shared_statics(model.shapes, block, W, D)
        if has_ext:
            _load_inputs(block, W, control, motors, E, T)
        for _ in range(nsteps):
            if motors.ball.shape[0] > 0:
                _motors_lanes(block, W, V, E, T, control, motors)
            lanes_step(symplectic, dt, X, V, A, E, has_ext, F, W, block, summed, statics, lm, g)
        _store_block(block, W, x, v, X, V)
        for w in range(W):
            b = block[w]
            status[b] = final_status(b, True, x, v, D)
            bad += status[b] != STATUS_OK
    return bad


def new_lane_scratch(threads: int, n: int, d: int, per_world_motors: int | None = None) -> Any:
    """One block scratch per thread: an array ``(threads, SCRATCH_ROWS, n, d, LANES)``; for a scene
    with per-world parameters (``per_world_motors``: its motor count) a list of one pair per thread,
    the block scratch and a ``(lane_rows, LANES)`` parameter scratch (:mod:`..per_world`).)"""
    blocks = np.zeros((threads, SCRATCH_ROWS, n, d, LANES))
    if per_world_motors is None:
        return blocks
    return [(blocks[t], np.zeros((lane_rows(n, per_world_motors), LANES))) for t in range(threads)]
