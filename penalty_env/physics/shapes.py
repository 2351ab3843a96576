"""Static implicit terrain: signed distance functions (phi < 0 inside the solid, > 0 outside).

``grad_phi`` is the outward unit normal of the solid. Where it is undefined (a point exactly at a
shape's centre) we return the last axis ("up"), which keeps every kernel finite.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .. import _validate as V

__all__ = ["Shape", "Sphere", "Bowl", "SPHERE", "BOWL", "pack_terrain"]

SPHERE = 0  # solid ball: phi = |x - c| - R
BOWL = 1  # the inside of a sphere is free space, the solid is outside it: phi = R - |x - c|


def _as_points(points: np.ndarray, d: int) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[-1:] != (d,):
        raise ValueError(f"points must have last dimension {d} (the shape's dimension), got shape {pts.shape}")
    return pts


@dataclass(frozen=True)
class Shape:
    """A sphere surface (centre, radius) and a side that is solid; subclasses fix the side."""

    center: tuple[float, ...]
    radius: float

    kind = -1
    sign = 0.0  # phi = sign * (|x - c| - R)

    def __post_init__(self) -> None:
        c = tuple(float(x) for x in V.real_array("center", self.center, finite=False).reshape(-1))
        if len(c) not in (2, 3):
            raise ValueError(f"center must have 2 or 3 coordinates, got {len(c)}")
        if not all(math.isfinite(x) for x in c):
            raise ValueError(f"center must be finite, got {c}")
        r = V.positive("radius", self.radius)
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "radius", r)

    @property
    def dim(self) -> int:
        return len(self.center)

    def phi(self, points: np.ndarray) -> np.ndarray:
        """Signed distance of each point (shape ``points.shape[:-1]``)."""
        pts = _as_points(points, self.dim)
        dist = np.linalg.norm(pts - np.asarray(self.center), axis=-1)
        return self.sign * (dist - self.radius)

    def grad_phi(self, points: np.ndarray) -> np.ndarray:
        """Outward unit normal of the solid at each point (same shape as ``points``)."""
        pts = _as_points(points, self.dim)
        rel = pts - np.asarray(self.center)
        dist = np.linalg.norm(rel, axis=-1, keepdims=True)
        up = np.zeros(self.dim)
        up[-1] = 1.0
        safe = np.where(dist > 0.0, dist, 1.0)
        return np.where(dist > 0.0, self.sign * rel / safe, up)

    def surface_points(self, n_samples: int) -> np.ndarray:
        """``n_samples`` points spread evenly over the boundary (a circle in 2D, a Fibonacci
        sphere in 3D)."""
        n = int(n_samples)
        if n < 1:
            raise ValueError(f"n_samples must be >= 1, got {n_samples!r}")
        c = np.asarray(self.center)
        if self.dim == 2:
            t = 2.0 * np.pi * (np.arange(n) + 0.5) / n
            dirs = np.stack([np.cos(t), np.sin(t)], axis=-1)
        else:
            k = np.arange(n) + 0.5
            z = 1.0 - 2.0 * k / n
            rho = np.sqrt(np.maximum(0.0, 1.0 - z * z))
            t = np.pi * (1.0 + 5.0**0.5) * k
            dirs = np.stack([rho * np.cos(t), rho * np.sin(t), z], axis=-1)
        return c + self.radius * dirs


@dataclass(frozen=True)
class Sphere(Shape):
    """A solid ball of terrain (a hill, an obstacle): phi = |x - c| - R."""

    kind = SPHERE
    sign = 1.0


@dataclass(frozen=True)
class Bowl(Shape):
    """The inside of a sphere (the course's "spherical terrain"): phi = R - |x - c|."""

    kind = BOWL
    sign = -1.0


def pack_terrain(terrain: Iterable[Shape] | None, d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kernel arrays (kind (S,), center (S, d), radius (S,)) for a sequence of shapes."""
    shapes = tuple(terrain) if terrain is not None else ()
    for k, s in enumerate(shapes):
        if not isinstance(s, Shape) or s.kind < 0:
            raise ValueError(f"terrain[{k}] must be a Sphere or Bowl, got {type(s).__name__}")
        if s.dim != d:
            raise ValueError(f"terrain[{k}] is {s.dim}D but positions are {d}D")
    kind = np.array([s.kind for s in shapes], dtype=np.int64)
    center = np.array([s.center for s in shapes], dtype=np.float64).reshape(len(shapes), d)
    radius = np.array([s.radius for s in shapes], dtype=np.float64)
    return kind, center, radius
