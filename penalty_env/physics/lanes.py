"""SIMD across worlds: many small worlds stepped with one world per vector lane.

A world of a few balls has too little work per contact check for a CPU's vector units: the scalar
path tests one pair of one world at a time. Here a block of ``LANES`` worlds is copied into a
world-innermost layout ``(n, D, LANES)`` and every pair check, force and update runs as a loop over
the block's worlds (the laws' twins in :mod:`.contact_lanes`), which LLVM vectorises. Results are
bit-identical to the scalar symplectic / explicit Euler path for every world that stays finite
(tested), only faster. (A world that blows up is reported the same way; the NaN may reach other
balls of that world by a different route.)

Used by :class:`~penalty_env.physics.World` for all-pairs scenes (few balls per world) with
symplectic or explicit Euler, and by the environments' fused step.
"""

from __future__ import annotations

from .._jit import njit
from .contact_lanes import general_terrain_lanes, pair_contact_lanes, terrain_contact_lanes
from .geometry import advance_geometry
from .integrators import STATUS_OK, final_status

__all__ = ["LANES", "LANES_MAX_BALLS", "LANES_MIN_WORLDS", "lanes_step", "load_block", "store_block", "run_lanes"]

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


@njit(inline="always")
def _world(ids, c0, w):
    """The world in lane w: ``c0 + w`` for a contiguous block, ``ids[w]`` for a listed one."""
    return c0 + w if ids is None else ids[w]


@njit(inline="always")
def lanes_step(symplectic, dt, X, V, A, E, F, W, ids, c0, model, friction, g):
    """One symplectic (or explicit) Euler step of the W worlds of a block (lane w holds world
    ``_world(ids, c0, w)``), all pairs; kinematic shapes move on after it."""
    D = len(g)
    n = X.shape[0]
    for i in range(n):
        for k in range(D):
            for w in range(W):
                A[i, k, w] = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            pair_contact_lanes(i, j, X, V, A, F, W, model, friction, g)
        terrain_contact_lanes(i, X, V, A, F, W, model, friction, g)
        general_terrain_lanes(i, X, V, A, W, ids, c0, model, friction, g)
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            gk = g[k]
            for w in range(W):
                if E is not None:
                    ak = (A[i, k, w] + E[i, k, w]) * im + gk
                else:
                    ak = A[i, k, w] * im + gk
                if symplectic:
                    V[i, k, w] += dt * ak
                    X[i, k, w] += dt * V[i, k, w]
                else:
                    X[i, k, w] += dt * V[i, k, w]
                    V[i, k, w] += dt * ak
    for w in range(W):
        advance_geometry(model, _world(ids, c0, w), dt, D)


@njit(inline="always")
def _copy_block(ids, c0, W, x, v, X, V, load):
    """Copy the block's W worlds between (B, n, D) state and the lanes layout (n, D, LANES):
    into the lanes when ``load``, back to the state otherwise."""
    for i in range(x.shape[1]):
        for k in range(x.shape[2]):
            for w in range(W):
                b = _world(ids, c0, w)
                if load:
                    X[i, k, w] = x[b, i, k]
                    V[i, k, w] = v[b, i, k]
                else:
                    x[b, i, k] = X[i, k, w]
                    v[b, i, k] = V[i, k, w]


@njit(inline="always")
def load_block(ids, c0, W, x, v, X, V):
    """Copy the block's W worlds from (B, n, D) state into the lanes layout (n, D, LANES)."""
    _copy_block(ids, c0, W, x, v, X, V, True)


@njit(inline="always")
def store_block(ids, c0, W, x, v, X, V, status, g):
    """Copy the block back to (B, n, D) state and set each world's status; returns how many blew up."""
    _copy_block(ids, c0, W, x, v, X, V, False)
    bad = 0
    for w in range(W):
        b = _world(ids, c0, w)
        status[b] = final_status(b, True, x, v, g)
        bad += status[b] != STATUS_OK
    return bad


@njit(nogil=True)
def run_lanes(symplectic, b0, b1, nsteps, dt, x, v, scratch, ext, model, friction, g, status):
    """Worlds b0..b1-1 of (B, n, D) state, LANES at a time; ``scratch`` is (5, n, D, LANES)."""
    X, V, A, E = scratch[0], scratch[1], scratch[2], scratch[3]
    F = scratch[4, 0]
    for c0 in range(b0, b1, LANES):
        W = min(LANES, b1 - c0)
        load_block(None, c0, W, x, v, X, V)
        if ext is not None:
            load_block(None, c0, W, ext, ext, E, E)
        for _ in range(nsteps):
            if ext is not None:
                lanes_step(symplectic, dt, X, V, A, E, F, W, None, c0, model, friction, g)
            else:
                lanes_step(symplectic, dt, X, V, A, None, F, W, None, c0, model, friction, g)
        store_block(None, c0, W, x, v, X, V, status, g)
