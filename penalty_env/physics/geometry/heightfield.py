"""Height fields: terrain z = h(x, y) from a grid of node heights (its phi is :func:`.sdf.sdf_height`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ... import _validate as V
from .sdf import HEIGHTS
from .shapes import Shape

__all__ = ["HeightField"]


class HeightField(Shape):
    """The solid below a terrain z = h(x, y) (3D) or y = h(x) (2D), interpolated bilinearly
    (linearly) between grid nodes and held at its edge values beyond the grid.

    Args:
        heights: ``(nx, ny)`` (3D) or ``(nx,)`` (2D) node heights, at least 2 nodes per axis:
            ``heights[i, j]`` is h at ``origin + (i, j) * cell_size``.
        cell_size: node spacing (one number, or one per horizontal axis), > 0.
        origin: the horizontal position of node 0 (default the origin).

    phi = (z - h) / sqrt(1 + |grad h|^2): the distance to the surface's tangent plane at the foot
    of the point, exact for a tilted plane; for a surface of curvature at most K it is within
    K delta^2 / 2 of the true distance, delta = z - h (docs/physics.md section 1). The heights may
    be changed per world between steps (``World.set_heights``).
    """

    kind = HEIGHTS

    def __init__(
        self,
        heights: Any,
        cell_size: Any,
        origin: Any = None,
        *,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        h = V.real_array("heights", heights, ndim=(1, 2))
        d = h.ndim + 1
        if any(m < 2 for m in h.shape):
            raise ValueError(f"heights must have at least 2 nodes along each axis, got shape {h.shape}")
        cs = V.real_array("cell_size", cell_size, ndim=(0, 1)).reshape(-1)
        if cs.size == 1:
            cs = np.repeat(cs, d - 1)
        if cs.shape != (d - 1,) or not np.all(cs > 0.0):
            raise ValueError(
                f"cell_size must be one number > 0 or {d - 1} of them, got {np.asarray(cell_size).tolist()}"
            )
        o = np.zeros(d - 1) if origin is None else V.real_array("origin", origin, ndim=(0, 1)).reshape(-1)
        if o.shape != (d - 1,):
            raise ValueError(f"origin must have {d - 1} coordinate(s) (the horizontal axes), got {o.tolist()}")
        self.heights = h.reshape(h.shape[0], -1)
        self.heights.flags.writeable = False
        self.cell_size = tuple(float(c) for c in cs)
        self.origin = tuple(float(c) for c in o)
        self._init_pose((0.0,) * d, None, velocity, angular_velocity)

    @property
    def grid_shape(self) -> tuple[int, int]:
        return (self.heights.shape[0], self.heights.shape[1])

    def _par6(self) -> list[float]:
        nx, ny = self.grid_shape
        cy = self.cell_size[1] if self.dim == 3 else 1.0
        oy = self.origin[1] if self.dim == 3 else 0.0
        return [float(nx), float(ny), self.cell_size[0], cy, self.origin[0], oy]

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        d = self.dim
        lo = np.asarray(self.origin)
        hi = lo + (np.array(self.grid_shape[: d - 1]) - 1) * np.asarray(self.cell_size)
        if window is not None:
            c, radius = self._window_local(window)
            lo = np.maximum(lo, c[: d - 1] - radius)
            hi = np.minimum(hi, c[: d - 1] + radius)
            if np.any(hi < lo):
                return np.zeros((0, d))
        if d == 2:
            xs = lo[0] + (hi[0] - lo[0]) * (np.arange(n) + 0.5) / n
            flat = xs[:, None]
        else:
            m = max(1, int(round(math.sqrt(n))))
            g0 = lo[0] + (hi[0] - lo[0]) * (np.arange(m) + 0.5) / m
            g1 = lo[1] + (hi[1] - lo[1]) * (np.arange(m) + 0.5) / m
            X, Y = np.meshgrid(g0, g1, indexing="ij")
            flat = np.stack([X.ravel(), Y.ravel()], -1)
        # the surface point above each: phi at z = 0 is -h n_z, so h = -phi / n_z (exact)
        pts = np.concatenate([flat, np.zeros((len(flat), 1))], axis=1)
        ev = self._evaluate_local(pts)
        pts[:, -1] = -ev[:, 0] / ev[:, d]
        return pts

    def _evaluate_local(self, pts: np.ndarray) -> np.ndarray:
        world = pts @ self.rotation.T + np.asarray(self.center)
        return self._evaluate(world)

    def __repr__(self) -> str:
        return f"HeightField(grid={self.grid_shape}, cell_size={self.cell_size}, origin={self.origin})"
