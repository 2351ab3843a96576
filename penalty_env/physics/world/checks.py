"""A :class:`~.world.World`'s arguments checked and shaped: the state, the balls, the terrain,
gravity and the motors (each refusal names the argument, its value and what is allowed)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ... import _validate as V
from ..geometry.shapes import Shape
from ..model import Motors, no_motors

__all__ = ["Motor", "state_arrays", "ball_arrays", "terrain_tuple", "gravity_vector", "motor_arrays", "world_index"]


class Motor(NamedTuple):
    """A motor on ball ``ball``: along its first ``axes`` axes (default: all but the last, the
    horizontal ones) the force of a DC motor's linear force-speed law,
    ``max_force (throttle - v / max_speed)``, throttle in [-1, 1] (``World.step(throttle=...)``)."""

    ball: int
    max_force: float
    max_speed: float
    axes: int | None = None


def state_arrays(positions: Any, velocities: Any) -> tuple[np.ndarray, np.ndarray, bool]:
    """(x, v, batched): ``(B, n, d)`` contiguous copies, and whether ``positions`` had the world axis."""
    x = V.real_array("positions", positions, ndim=(2, 3))
    batched = x.ndim == 3
    if not batched:
        x = x[None]
    B, n, d = x.shape
    if d not in (2, 3):
        raise ValueError(f"positions must have last dimension d = 2 or 3, got {d}")
    if n < 1 or B < 1:
        raise ValueError(f"positions must hold at least one ball and one world, got shape {x.shape}")
    x = np.ascontiguousarray(x)
    if velocities is None:
        return x, np.zeros_like(x), batched
    v = V.real_array("velocities", velocities)
    if v.shape != np.shape(positions):
        raise ValueError(f"velocities must have the shape of positions {np.shape(positions)}, got {v.shape}")
    return x, np.ascontiguousarray(v.reshape(x.shape)), batched


def ball_arrays(radii: Any, masses: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The radii and masses, ``(n,)`` each, > 0, read-only."""
    out = []
    for name, value in (("radii", radii), ("masses", masses)):
        arr = V.real_array(name, value, ndim=(1,))
        if arr.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},) (one per ball), got {arr.shape}")
        if np.any(arr <= 0.0):
            raise ValueError(f"{name} must all be > 0, got min {arr.min()}")
        arr.flags.writeable = False
        out.append(arr)
    return out[0], out[1]


def terrain_tuple(terrain: Sequence[Shape] | Shape, d: int) -> tuple[Shape, ...]:
    """The terrain as a tuple of d-dimensional shapes (a single shape is accepted too)."""
    if isinstance(terrain, Shape):
        terrain = (terrain,)
    if terrain is None or isinstance(terrain, (str, bytes)) or not hasattr(terrain, "__iter__"):
        raise ValueError(
            f"terrain must be a Shape (Sphere, Bowl, Plane, Box, ..., from penalty_env.physics) or a sequence "
            f"of shapes, got {V.describe(terrain)}"
        )
    out = tuple(terrain)
    for k, shape in enumerate(out):
        if not isinstance(shape, Shape):
            raise V.ArgumentTypeError(f"terrain[{k}] must be a Shape, got {V.describe(shape)}")
        if shape.dim != d:
            raise ValueError(f"terrain[{k}] is {shape.dim}D but positions are {d}D")
    return out


def gravity_vector(gravity: Any, d: int) -> tuple[float, ...]:
    """Gravity as a tuple of d floats (the kernels' dimension); default -9.81 along the last axis."""
    if gravity is None:
        gravity = (0.0,) * (d - 1) + (-9.81,)
    g = V.real_array("gravity", gravity, ndim=(1,))
    if g.shape != (d,):
        raise ValueError(f"gravity must have length d = {d}, got {g.shape[0]}")
    return tuple(float(c) for c in g)


def motor_arrays(motors: Sequence[Motor], n: int, d: int) -> Motors:
    """The motors as the kernels' arrays (each checked: its ball, a force > 0, a speed > 0, its axes)."""
    if isinstance(motors, Motor):
        motors = (motors,)
    if not motors:
        return no_motors()
    rows = []
    for q, m in enumerate(motors):
        if not isinstance(m, Motor):
            raise V.ArgumentTypeError(
                f"motors[{q}] must be a Motor(ball, max_force, max_speed, axes), got {V.describe(m)}"
            )
        ball = V.integer(f"motors[{q}].ball", m.ball, 0, n - 1, "a ball index")
        force = V.positive(f"motors[{q}].max_force", m.max_force)
        speed = V.positive(f"motors[{q}].max_speed", m.max_speed)
        axes = d - 1 if m.axes is None else V.integer(f"motors[{q}].axes", m.axes, 1, d, "leading axes driven")
        rows.append((ball, force, 1.0 / speed, axes))
    balls = [r[0] for r in rows]
    if len(set(balls)) != len(balls):
        raise ValueError(f"motors drive balls {balls}: one motor per ball")
    return Motors(
        ball=np.array([r[0] for r in rows], dtype=np.int64),
        max_force=np.array([r[1] for r in rows]),
        inv_max_speed=np.array([r[2] for r in rows]),
        axes=np.array([r[3] for r in rows], dtype=np.int64),
    )


def world_index(worlds: Any, n_worlds: int) -> Any:
    """``worlds`` as an int64 index array (each in 0..n_worlds-1), or ``slice(None)`` for None."""
    if worlds is None:
        return slice(None)
    if np.asarray(worlds).dtype.kind not in "iu":
        raise ValueError(f"worlds must be integer world indices, got dtype {np.asarray(worlds).dtype}")
    chosen = np.atleast_1d(np.asarray(worlds, dtype=np.int64))
    if chosen.size and (chosen.min() < 0 or chosen.max() >= n_worlds):
        raise ValueError(f"worlds must index 0..{n_worlds - 1}, got {worlds!r}")
    return chosen
