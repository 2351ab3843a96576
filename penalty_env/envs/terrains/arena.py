"""The walled arena: a flat floor through the origin and four wall planes (2D: two) 2 m from the
centre; one plane per wall gives the full force in a corner."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...physics import Plane
from .base import PLANE, Terrain, TerrainHeights, plain_heights

__all__ = ["ArenaTerrain", "HALF_WIDTH", "walls"]

HALF_WIDTH = 2.0  # the walls stand this far from the centre, m


def walls(dim: int, half_width: float) -> list:
    """The vertical wall planes at +-``half_width`` along each horizontal axis, facing in."""
    return [Plane(-s * half_width * e, s * e) for e in np.eye(dim)[:-1] for s in (1.0, -1.0)]


class ArenaTerrain(Terrain):
    name = "arena"
    shapes_text = f"a floor `Plane` and four wall planes {HALF_WIDTH:g} m from the centre"
    notes = "flat: nothing rolls back to the centre; one plane per wall gives the full force in the corners"
    holds_sand = True
    quarter_turns = True
    half_width = HALF_WIDTH

    def shapes(self) -> tuple:
        d = self.dim
        return (Plane(np.zeros(d), np.eye(d)[-1]), *walls(d, self.half_width))

    def floor(self, h: np.ndarray) -> np.ndarray:
        return np.zeros(np.shape(h)[:-1])

    def sand_room(self, depth: float) -> float:
        return (2.0 * self.half_width) ** (self.dim - 1) * depth

    def lattice_width(self, r: float, step: float, depth: float) -> int | None:
        return int((2.0 * self.half_width - 2.0 * r) / step)  # within the walls

    def rest(self, h: np.ndarray, rest: np.ndarray, worlds: np.ndarray, world: Any) -> np.ndarray:
        return np.broadcast_to(rest, h.shape[:-1])

    def heights(self, world: Any) -> TerrainHeights:
        return plain_heights(PLANE, self.bowl_radius, self.cap, half_width=self.half_width)
