"""Bumpy ground: the bowl's floor as a height field with Gaussian bumps, drawn anew for each world
at every reset, and the bowl beyond the field."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._jit import compile_notice, entry_point, njit
from ...physics import Bowl, HeightField
from .base import BUMPY, Terrain, TerrainHeights

__all__ = ["BumpyTerrain", "HALF_WIDTH", "CELL", "COUNT", "WIDTH", "TAPER", "bump_fields"]

HALF_WIDTH = 2.5  # the height field covers the square of this half width, m
CELL = 0.1  # ... with nodes this far apart, m
COUNT = {3: 40, 2: 12}  # Gaussian bumps per draw
WIDTH = (0.15, 0.35)  # their standard deviation, m, uniform
TAPER = 0.5  # bumps fade out over this distance to the field's edge, m (the bowl beyond is smooth)
DRAW_CHUNK = 32  # worlds whose bumps a reset draws at once (their numpy temporaries, ~0.5 MB each in 3D, stay cached)


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
        self._kernel: Any = None  # bump_fields, compiled at the first draw

    def shapes(self) -> tuple:
        d, R = self.dim, self.bowl_radius
        field = HeightField(self.bowl_floor, CELL, origin=(-HALF_WIDTH,) * (d - 1))
        return (field, Bowl((0.0,) * (d - 1) + (R,), R))

    def draw(self, rngs: list[np.random.Generator], roughness: np.ndarray) -> np.ndarray:
        """New floors for the worlds reset with generators ``rngs`` (one per world, their
        ``roughness``): (k, n, n) in 3D, (k, n) in 2D. Bit for bit :meth:`bump_heights` of each
        world in turn: each world's uniforms from its own generator, the elementwise steps (the
        bumps' centres, widths, heights and profiles) as numpy arrays over all the worlds at once,
        and the sum of the bumps, its scaling and the floor in one compiled call (:func:`bump_fields`;
        in 2D the sum is numpy's matrix product, batched: BLAS's order, which a loop would not
        reproduce)."""
        d, k = self.dim, len(rngs)
        n = self.axis.size
        out = np.empty((k,) + (n,) * (d - 1))
        if k == 0:
            return out
        u = np.array([rng.random((COUNT[d], d + 1)) for rng in rngs])  # (k, COUNT, d + 1)
        rough = np.asarray(roughness, dtype=np.float64)[:, None]
        scratch = np.empty(n ** (d - 1))
        for a in range(0, k, DRAW_CHUNK):  # (the temporaries of a chunk stay in the cache)
            b = min(k, a + DRAW_CHUNK)
            centre, sigma, height = self._bump_parameters(u[a:b], rough[a:b])
            g = [self._profile(centre[..., j], sigma) for j in range(d - 1)]  # (chunk, COUNT, n) each
            if d == 2:  # each world's ``height @ g``, (chunk, 1, n)
                bumps = np.matmul(height[:, None, :], g[0])
                args = (height, bumps, bumps, True, self.bowl_floor, scratch, out[a:b])
            else:
                args = (height, g[0], g[1], False, self.bowl_floor, scratch, out[a:b])
            if self._kernel is None:
                with compile_notice("bumpy terrain"):
                    self._kernel = entry_point(bump_fields, args)
            self._kernel(*args)
        return out

    def _bump_parameters(self, u: np.ndarray, roughness: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The bumps' centres (..., COUNT, d - 1), widths and heights (..., COUNT) from their
        uniforms ``u`` (..., COUNT, d + 1)."""
        d = self.dim
        centre = (2.0 * u[..., : d - 1] - 1.0) * (HALF_WIDTH - TAPER)
        sigma = WIDTH[0] + (WIDTH[1] - WIDTH[0]) * u[..., d - 1]
        height = roughness * (0.3 + 0.7 * u[..., d])
        return centre, sigma, height

    def _profile(self, centre: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """Each bump's Gaussian along one axis at the nodes, tapered: (..., COUNT, n)."""
        ax = self.axis
        return np.exp(-0.5 * ((ax - centre[..., None]) / sigma[..., None]) ** 2) * self.taper

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_kernel"] = None  # compiled code: found again (cached) on the first draw after
        return state

    def bump_heights(self, rng: np.random.Generator, roughness: float) -> np.ndarray:
        """A new bumpy floor: the bowl's plus COUNT Gaussian bumps of random centre, width and height
        (0.3 to 1 x ``roughness``), faded out towards the field's edge, their sum scaled so that its
        top is the tallest bump's height (so never above ``roughness``). Draws d + 1 uniforms per
        bump from ``rng``."""
        d = self.dim
        u = rng.random((COUNT[d], d + 1))
        centre, sigma, height = self._bump_parameters(u, roughness)
        g = [self._profile(centre[:, k], sigma) for k in range(d - 1)]
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


@njit(entry=True, nogil=True)
def bump_fields(height, g0, g1, summed, floor, acc, out):
    """Each world's floor ``out[t]`` = ``floor`` + its bumps, scaled so that their top is the
    tallest bump's height ``max(height[t])`` (:meth:`BumpyTerrain.bump_heights`, bit for bit).
    The bumps: ``summed``, ``g0[t, 0]`` (2D: numpy's product); else (3D)
    ``sum_c height[t, c] g0[t, c, i] g1[t, c, j]`` in numpy's ``einsum("k,ki,kj->ij")`` order (c
    ascending, each term ``(height g0) g1`` added to the running sum) into ``acc``, a scratch of
    the floor's size."""
    k = out.shape[0]
    flat = out.reshape(k, -1)
    base = floor.reshape(-1)
    m = base.shape[0]
    for t in range(k):
        if summed:
            bumps = g0[t, 0]
        else:
            bumps = acc
            n = g1.shape[2]
            for q in range(m):
                bumps[q] = 0.0
            for c in range(g0.shape[1]):
                for i in range(g0.shape[2]):
                    a = height[t, c] * g0[t, c, i]
                    row = i * n
                    for j in range(n):
                        bumps[row + j] = a * g1[t, c, j] + bumps[row + j]
        top = bumps[0]
        for q in range(1, m):
            top = max(top, bumps[q])
        tallest = height[t, 0]
        for c in range(1, height.shape[1]):
            tallest = max(tallest, height[t, c])
        if top > 0.0:
            scale = tallest / top
            for q in range(m):
                flat[t, q] = base[q] + bumps[q] * scale
        else:
            for q in range(m):
                flat[t, q] = base[q] + bumps[q]
