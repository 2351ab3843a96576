"""Bumpy ground: the bowl's floor as a height field with Gaussian bumps, drawn anew for each world
at every reset, and the bowl beyond the field."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...physics import Bowl, HeightField
from .base import BUMPY, Terrain, TerrainHeights

__all__ = ["BumpyTerrain", "HALF_WIDTH", "CELL", "COUNT", "WIDTH", "TAPER"]

HALF_WIDTH = 2.5  # the height field covers the square of this half width, m
CELL = 0.1  # ... with nodes this far apart, m
COUNT = {3: 40, 2: 12}  # Gaussian bumps per draw
WIDTH = (0.15, 0.35)  # their standard deviation, m, uniform
TAPER = 0.5  # bumps fade out over this distance to the field's edge, m (the bowl beyond is smooth)


class BumpyTerrain(Terrain):
    name = "bumpy"
    shapes_text = (
        f"a `HeightField` ({2 * HALF_WIDTH:g} m square, {CELL:g} m cells) of the bowl's floor plus Gaussian bumps, "
        "the `Bowl` beyond it"
    )
    notes = (
        f"bumps ({COUNT[3]} in 3D, {COUNT[2]} in 2D, {WIDTH[0]:g}-{WIDTH[1]:g} m wide, 0.3-1 x `roughness` high, the "
        "field scaled so its top is the tallest bump) redrawn at every reset from the env's `np_random`, after the "
        "start's draws"
    )
    per_world = True

    def __init__(self, dim: int, bowl_radius: float, roughness: float) -> None:
        super().__init__(dim, bowl_radius, roughness)
        n = int(round(2.0 * HALF_WIDTH / CELL)) + 1
        self.axis = np.linspace(-HALF_WIDTH, HALF_WIDTH, n)
        ramp = np.clip((HALF_WIDTH - np.abs(self.axis)) / TAPER, 0.0, 1.0)
        self.taper = ramp * ramp * (3.0 - 2.0 * ramp)  # smoothstep: the bumps fade to the edge
        R = self.bowl_radius
        axes = np.meshgrid(*([self.axis] * (dim - 1)), indexing="ij")
        rho2 = sum(a * a for a in axes)
        self.bowl_floor = R - np.sqrt(R * R - rho2)  # the bowl's floor at the nodes

    def shapes(self) -> tuple:
        d, R = self.dim, self.bowl_radius
        field = HeightField(self.bowl_floor, CELL, origin=(-HALF_WIDTH,) * (d - 1))
        return (field, Bowl((0.0,) * (d - 1) + (R,), R))

    def draw(self, rngs: list[np.random.Generator], roughness: np.ndarray) -> np.ndarray:
        return np.array([self.bump_heights(rng, float(r)) for rng, r in zip(rngs, roughness)])

    def bump_heights(self, rng: np.random.Generator, roughness: float) -> np.ndarray:
        """A new bumpy floor: the bowl's plus COUNT Gaussian bumps of random centre, width and height
        (0.3 to 1 x ``roughness``), faded out towards the field's edge, their sum scaled so that its
        top is the tallest bump's height (so never above ``roughness``). Draws d + 1 uniforms per
        bump from ``rng``."""
        d = self.dim
        u = rng.random((COUNT[d], d + 1))
        centre = (2.0 * u[:, : d - 1] - 1.0) * (HALF_WIDTH - TAPER)
        sigma = WIDTH[0] + (WIDTH[1] - WIDTH[0]) * u[:, d - 1]
        height = roughness * (0.3 + 0.7 * u[:, d])
        ax = self.axis
        g = [
            np.exp(-0.5 * ((ax[None, :] - centre[:, k, None]) / sigma[:, None]) ** 2) * self.taper for k in range(d - 1)
        ]
        bumps = height @ g[0] if d == 2 else np.einsum("k,ki,kj->ij", height, g[0], g[1])
        top = float(bumps.max())
        if top > 0.0:  # overlapping bumps add up: scale the field back to the tallest bump's height
            bumps *= float(height.max()) / top
        return self.bowl_floor + bumps

    def heights(self, world: Any) -> TerrainHeights:
        field = world.terrain[0]
        nx, ny = field.grid_shape
        table, start = world.height_table(0)
        return TerrainHeights(
            kind=BUMPY,
            radius=self.bowl_radius,
            half_width=0.0,
            cap=self.cap,
            offset=0.0,
            slope_x=0.0,
            slope_y=0.0,
            heights=table,
            start=start,
            nx=int(nx),
            ny=int(ny),
            origin_x=float(field.origin[0]),
            origin_y=float(field.origin[1]) if self.dim == 3 else 0.0,
            cell=float(field.cell_size[0]),
        )
