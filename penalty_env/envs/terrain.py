"""The PenaltyBalls terrains (the env docstring's "Terrain" table): the bowl, the walled arena, the
bumpy height field with its bumps drawn per world at each reset, and bodies set down on them."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..physics import HeightField, Plane
from .params import ARENA_HALF_WIDTH, BUMPY_CELL, BUMPY_COUNT, BUMPY_HALF_WIDTH, BUMPY_TAPER, BUMPY_WIDTH

__all__ = ["TerrainScene"]


class TerrainScene:
    """The scene's terrain methods (its ``dim``, ``terrain_kind``, ``bowl``, ``bowl_radius``,
    ``roughness``, ``world`` and ``_rest_radii``)."""

    dim: int
    terrain_kind: str
    bowl: Any
    bowl_radius: float
    roughness: float
    world: Any
    _rest_radii: np.ndarray

    def _make_terrain(self) -> tuple:
        """The terrain shapes (the env docstring's "Terrain" table)."""
        d = self.dim
        up = np.eye(d)[-1]
        if self.terrain_kind == "bowl":
            return (self.bowl,)
        if self.terrain_kind == "arena":
            walls = [Plane(-s * ARENA_HALF_WIDTH * e, s * e) for e in np.eye(d)[:-1] for s in (1.0, -1.0)]
            return (Plane(np.zeros(d), up), *walls)
        # bumpy: the bowl's floor as a height field (bumps drawn at each reset), the bowl beyond it
        n = int(round(2.0 * BUMPY_HALF_WIDTH / BUMPY_CELL)) + 1
        self._bumpy_axis = np.linspace(-BUMPY_HALF_WIDTH, BUMPY_HALF_WIDTH, n)
        ramp = np.clip((BUMPY_HALF_WIDTH - np.abs(self._bumpy_axis)) / BUMPY_TAPER, 0.0, 1.0)
        self._bumpy_taper = ramp * ramp * (3.0 - 2.0 * ramp)  # smoothstep: the bumps fade to the edge
        R = self.bowl_radius
        axes = np.meshgrid(*([self._bumpy_axis] * (d - 1)), indexing="ij")
        rho2 = sum(a * a for a in axes)
        self._bumpy_floor = R - np.sqrt(R * R - rho2)  # the bowl's floor at the nodes
        field = HeightField(self._bumpy_floor, BUMPY_CELL, origin=(-BUMPY_HALF_WIDTH,) * (d - 1))
        return (field, self.bowl)

    def _bump_heights(self, rng: np.random.Generator, roughness: float | None = None) -> np.ndarray:
        """A new bumpy floor: the bowl's plus BUMPY_COUNT Gaussian bumps of random centre, width and
        height (0.3 to 1 x ``roughness``), faded out towards the field's edge, their sum scaled so that
        its top is the tallest bump's height (so never above ``roughness``). Draws d + 1 uniforms per
        bump from ``rng``, after the start's. ``roughness``: a randomised world's (None: the scene's)."""
        d = self.dim
        u = rng.random((BUMPY_COUNT[d], d + 1))
        centre = (2.0 * u[:, : d - 1] - 1.0) * (BUMPY_HALF_WIDTH - BUMPY_TAPER)
        sigma = BUMPY_WIDTH[0] + (BUMPY_WIDTH[1] - BUMPY_WIDTH[0]) * u[:, d - 1]
        height = (self.roughness if roughness is None else roughness) * (0.3 + 0.7 * u[:, d])
        ax = self._bumpy_axis
        g = [
            np.exp(-0.5 * ((ax[None, :] - centre[:, k, None]) / sigma[:, None]) ** 2) * self._bumpy_taper
            for k in range(d - 1)
        ]
        bumps = height @ g[0] if d == 2 else np.einsum("k,ki,kj->ij", height, g[0], g[1])
        top = float(bumps.max())
        if top > 0.0:  # overlapping bumps add up: scale the field back to the tallest bump's height
            bumps *= float(height.max()) / top
        return self._bumpy_floor + bumps

    def _on_terrain(self, h: np.ndarray, worlds: np.ndarray | None = None) -> np.ndarray:
        """Centres resting on the terrain at horizontal positions ``h`` (k, n + 1, d - 1) of
        ``worlds``: each ball sunk by its resting overlap m g / ks (along the terrain's normal);
        the last slot (the goal) as the ball. ``worlds=None``: ``h`` is (n + 1, d - 1), world 0."""
        if worlds is None:
            return self._on_terrain(np.asarray(h)[None], np.zeros(1, dtype=np.int64))[0]
        # resting radii: the scene's (n + 1,), or a randomised scene's rows per world
        rest = self._rest_radii if self._rest_radii.ndim == 1 else self._rest_radii[worlds]
        if self.terrain_kind == "bowl":
            R = self.bowl_radius
            depth = R - rest  # distance of a resting centre from the bowl's centre
            z = R - np.sqrt(depth**2 - np.sum(h * h, axis=-1))
        elif self.terrain_kind == "arena":
            z = np.broadcast_to(rest, h.shape[:-1])
        else:  # the height field's phi is (z - h) n_z: phi = rest radius at z = (rest - phi(z = 0)) / n_z
            z = np.empty(h.shape[:-1])
            for t, b in enumerate(worlds):
                ground = np.concatenate([h[t], np.zeros((h.shape[1], 1))], axis=-1)
                phi0, normal = self.world.shape_distance(0, ground, world=int(b))
                z[t] = ((rest if rest.ndim == 1 else rest[t]) - phi0) / normal[:, -1]
        return np.concatenate([h, z[..., None]], axis=-1)
