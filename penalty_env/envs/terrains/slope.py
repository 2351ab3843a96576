"""The slope: the arena's walls around a floor tilted along x, rising from the -x wall (where it
stands at the bowl's lowest height, 0) by ``SLOPE_DEGREES``: a ball let go rolls or slides down
towards the -x wall unless friction holds it, so a push uphill must carry it further than the goal
and a push downhill must stop short."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...physics import Plane
from .arena import HALF_WIDTH, walls
from .base import PLANE, Terrain, TerrainHeights, plain_heights

__all__ = ["SlopeTerrain", "SLOPE_DEGREES"]

SLOPE_DEGREES = 5.0  # the floor's tilt along x


class SlopeTerrain(Terrain):
    name = "slope"
    shapes_text = f"a floor `Plane` tilted by {SLOPE_DEGREES:g} degrees along x and the arena's four wall planes"
    notes = "the ground falls towards -x: a resting ball creeps down where friction cannot hold it"
    half_width = HALF_WIDTH

    def __init__(self, dim: int, bowl_radius: float, roughness: float) -> None:
        super().__init__(dim, bowl_radius, roughness)
        self.tilt = math.tan(math.radians(SLOPE_DEGREES))
        self.offset = self.tilt * self.half_width  # the floor's height at x = 0

    def shapes(self) -> tuple:
        d = self.dim
        a = math.radians(SLOPE_DEGREES)
        normal = np.eye(d)[-1] * math.cos(a)
        normal[0] = -math.sin(a)
        corner = np.zeros(d)
        corner[0] = -self.half_width  # the floor meets the -x wall at height 0
        return (Plane(corner, normal), *walls(d, self.half_width))

    def floor(self, h: np.ndarray) -> np.ndarray:
        return self.offset + self.tilt * np.asarray(h)[..., 0]

    def heights(self, world: Any) -> TerrainHeights:
        return plain_heights(
            PLANE, self.bowl_radius, self.cap, half_width=self.half_width, offset=self.offset, slope_x=self.tilt
        )
