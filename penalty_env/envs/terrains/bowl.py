"""The bowl: the inside of a sphere of radius R whose lowest point is the origin (the course's
terrain, PenaltyBalls-v0's)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...physics import Bowl
from .base import BOWL, Terrain, TerrainHeights, plain_heights

__all__ = ["BowlTerrain"]


class BowlTerrain(Terrain):
    name = "bowl"
    shapes_text = "`Bowl` of radius `bowl_radius`"
    notes = "v0's episodes, bit for bit"
    holds_sand = True

    def shapes(self) -> tuple:
        d, R = self.dim, self.bowl_radius
        return (Bowl((0.0,) * (d - 1) + (R,), R),)

    def floor(self, h: np.ndarray) -> np.ndarray:
        R = self.bowl_radius
        return R - np.sqrt(np.maximum(R * R - np.sum(h * h, axis=-1), 0.0))

    def sand_room(self, depth: float) -> float:
        R, h = self.bowl_radius, depth
        if self.dim == 3:  # the spherical cap
            return math.pi * h * h * (3.0 * R - h) / 3.0
        return R * R * math.acos((R - h) / R) - (R - h) * math.sqrt(2.0 * R * h - h * h)  # the segment

    def lattice_width(self, r: float, step: float, depth: float) -> int | None:
        rim = math.sqrt(2.0 * self.bowl_radius * depth)  # the rim of a bed that deep
        return max(1, int(2.0 * (rim - r) / step))

    def rest(self, h: np.ndarray, rest: np.ndarray, worlds: np.ndarray, world: Any) -> np.ndarray:
        R = self.bowl_radius
        depth = R - rest  # distance of a resting centre from the bowl's centre
        return R - np.sqrt(depth**2 - np.sum(h * h, axis=-1))

    def heights(self, world: Any) -> TerrainHeights:
        return plain_heights(BOWL, self.bowl_radius, self.cap)
