"""What a terrain of the PenaltyBalls task answers, and its picture as the kernels read it.

A terrain (one module each: :mod:`.bowl`, :mod:`.arena`, :mod:`.bumpy`, :mod:`.slope`) is an object
built from the scene's ``dim``, ``bowl_radius`` and ``roughness``. It answers

* its **shapes** (``shapes()``: the ``penalty_env.physics`` shapes the World collides with);
* its **draw per reset** (``draw(rngs, roughness)``: new node heights for the worlds reset, or
  None when nothing changes);
* its **floor height** (``floor(h)``: the bare ground's height at horizontal positions, closed
  form; only for the terrains that can hold sand) and where a body **rests** on it
  (``rest(h, rest_radii, worlds, world)``);
* its **picture** (``heights(world)``: a :class:`TerrainHeights`, the height function every view
  kernel, the observation images and ``render()``'s frames read through :func:`terrain_height`).

The starts, the views, the sand and the renderer ask the terrain; none of them switches on its
name.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ..._jit import njit

__all__ = ["Terrain", "TerrainHeights", "terrain_height", "BOWL", "PLANE", "BUMPY"]

# what terrain_height computes (TerrainHeights.kind)
BOWL, PLANE, BUMPY = 0, 1, 2


class TerrainHeights(NamedTuple):
    """A terrain's height z(x[, y]) above the bowl's lowest point, as the kernels read it
    (:func:`terrain_height`), the one definition of a terrain's height that the views, the images
    and the rendered frames share.

    ``kind`` BOWL: the bowl of ``radius`` R, z = R - sqrt(R^2 - rho^2), solid (``cap``) beyond its
    rim. PLANE: a floor z = ``offset`` + ``slope_x`` x + ``slope_y`` y inside walls at
    +-``half_width``, ``cap`` beyond them. BUMPY: a height field's nodes (per world, the World's
    live table ``heights`` from column ``start``; ``nx`` x ``ny`` nodes ``cell`` apart from
    ``origin``), bilinear, held at its edge beyond it, the bowl where that is higher."""

    kind: int
    radius: float
    half_width: float
    cap: float
    offset: float
    slope_x: float
    slope_y: float
    heights: np.ndarray  # (B, m) float64: the World's height-field table ((1, 1) without one)
    start: int
    nx: int
    ny: int
    origin_x: float
    origin_y: float
    cell: float


def plain_heights(kind: int, radius: float, cap: float, half_width: float = 0.0, offset: float = 0.0,
                  slope_x: float = 0.0, slope_y: float = 0.0) -> TerrainHeights:  # fmt: skip
    """A :class:`TerrainHeights` without a height field."""
    return TerrainHeights(
        kind=kind,
        radius=float(radius),
        half_width=float(half_width),
        cap=float(cap),
        offset=float(offset),
        slope_x=float(slope_x),
        slope_y=float(slope_y),
        heights=np.zeros((1, 1)),
        start=0,
        nx=2,
        ny=2,
        origin_x=0.0,
        origin_y=0.0,
        cell=1.0,
    )


@njit(hot=True)
def terrain_height(b, x, y, t):
    """The terrain's height at (x, y) of world b (2D: y = 0, and a height field's ``ny`` is 1)."""
    if t.kind == PLANE:
        if abs(x) > t.half_width or abs(y) > t.half_width:
            return t.cap
        return t.offset + t.slope_x * x + t.slope_y * y
    R = t.radius
    rho2 = x * x + y * y
    if rho2 >= R * R:
        return t.cap
    h = R - math.sqrt(R * R - rho2)
    if t.kind == BUMPY:  # the field, held at its edge beyond the grid; the bowl where higher
        u = min(max((x - t.origin_x) / t.cell, 0.0), t.nx - 1.0)
        i = min(int(u), t.nx - 2)
        fu = u - i
        row = t.heights[b]
        s = t.start
        if t.ny == 1:
            f = row[s + i] * (1.0 - fu) + row[s + i + 1] * fu
        else:
            v = min(max((y - t.origin_y) / t.cell, 0.0), t.ny - 1.0)
            j = min(int(v), t.ny - 2)
            fv = v - j
            k = s + i * t.ny + j
            f = (row[k] * (1.0 - fv) + row[k + 1] * fv) * (1.0 - fu) + (
                row[k + t.ny] * (1.0 - fv) + row[k + t.ny + 1] * fv
            ) * fu
        h = max(h, f)
    return h


class Terrain:
    """A terrain of the PenaltyBalls task (see the module docstring). Subclasses set ``name``,
    ``summary`` (the env docstring's "Terrain" table: its shapes and notes) and override what
    differs.

    Args:
        dim: 3 or 2.
        bowl_radius: the bowl's radius R, m (the scene's scale: the observation's bounds are the
            bowl's box, 2R high).
        roughness: the largest bump height, m (the bumpy terrain's).
    """

    name = ""
    shapes_text = ""  # the env docstring's "Terrain" table: the shapes
    notes = ""  # ... and what sets the terrain apart
    holds_sand = False  # its floor has a closed form (the sand's height map, its bed's lattice)
    quarter_turns = False  # a settled bed turns by quarter turns (square walls), else by any angle
    per_world = False  # drawn again at every reset (each world's own picture)

    def __init__(self, dim: int, bowl_radius: float, roughness: float) -> None:
        self.dim = int(dim)
        self.bowl_radius = float(bowl_radius)
        self.roughness = float(roughness)
        self.cap = 2.0 * self.bowl_radius  # the height of solid columns (the views' upper bound)

    def shapes(self) -> tuple:
        """The World's terrain shapes."""
        raise NotImplementedError

    def draw(self, rngs: list[np.random.Generator], roughness: np.ndarray) -> np.ndarray | None:
        """New node heights for worlds reset with generators ``rngs`` (their ``roughness``), drawn
        after the start's draws; None: the terrain does not change."""
        return None

    def floor(self, h: np.ndarray) -> np.ndarray:
        """The bare floor's height at horizontal positions ``h`` (..., d - 1) (the sand terrains)."""
        raise NotImplementedError(f"terrain {self.name!r} has no closed-form floor")

    def sand_room(self, depth: float) -> float:
        """The volume (2D: area) of a bed ``depth`` deep at the lowest point (the sand's check)."""
        raise NotImplementedError(f"terrain {self.name!r} cannot hold sand")

    def lattice_width(self, r: float, step: float, depth: float) -> int | None:
        """The most lattice sites of ``step`` across a layer of grains of radius ``r`` in a bed at
        most ``depth`` deep (None: no limit)."""
        return None

    def rest(self, h: np.ndarray, rest: np.ndarray, worlds: np.ndarray, world: Any) -> np.ndarray:
        """Heights of centres resting on the terrain at horizontal positions ``h`` (k, m, d - 1) of
        ``worlds`` (``rest``: each resting centre's distance from the surface along its normal,
        (m,) or (k, m)): by the World's own distance (``world.shape_distance``, exact where phi is
        linear in z along the vertical, as for planes and height fields; ``world.shape_distances``:
        every world's in one call)."""
        ground = np.concatenate([h, np.zeros(h.shape[:-1] + (1,))], axis=-1)
        phi0, normal = world.shape_distances(0, ground, worlds)
        return (rest - phi0) / normal[..., -1]

    def heights(self, world: Any) -> TerrainHeights:
        """The terrain's picture (:class:`TerrainHeights`) for ``world`` (its live tables)."""
        raise NotImplementedError
