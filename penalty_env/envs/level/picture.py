"""The level task's pictures: a world's height map and target side by side, and from v1 the grains
themselves, drawn by the observations' raster."""

from __future__ import annotations

from typing import Any

import numpy as np

from .scene import HALF_WIDTH

__all__ = ["LevelPicture"]


class LevelPicture:
    """The pictures of a :class:`.scene.SandLevelScene`'s worlds (its renderer): read from the
    scene's live state at every call."""

    def __init__(self, scene: Any) -> None:
        self.scene = scene

    def frame(self, b: int, scale: int = 16) -> np.ndarray:
        """World b as a uint8 RGB image: from v1 a picture of the grains (:meth:`grains_picture`;
        in 3D turned to the maps' orientation, x down the rows and y across) on the left; then
        :meth:`maps_picture`."""
        maps = self.maps_picture(b, scale)
        if self.scene.phys.version == 0:
            return maps
        side = maps.shape[0]
        gap = np.full((side, scale // 4, 3), 255, dtype=np.uint8)
        grains = self.grains_picture(b, side)
        if self.scene.dim == 3:  # turned to the maps' orientation: x down the rows, y across the columns
            grains = np.ascontiguousarray(grains[::-1].transpose(1, 0, 2))
        return np.concatenate([grains, gap, maps], axis=1)

    def grains_picture(self, b: int, size: int) -> np.ndarray:
        """World b's grains as a uint8 RGB image ``size`` pixels square: in 3D from above (x right,
        y up, the arena filling the image), each grain a disc shaded by its height (dark at the
        floor, light at twice the flat level), the highest drawn last; in 2D from the side (z up,
        the floor at 0.8 of the image's height). The blade is a red outline (its footprint in
        3D, its section in 2D), the walls dark lines. The observations' raster draws the discs."""
        from ..views.raster import rgb_worlds

        sc = self.scene
        d, L = sc.dim, HALF_WIDTH
        x = np.ascontiguousarray(sc.world.positions[b : b + 1])
        up = x[0, :, -1]
        shade = np.clip(up / (2.0 * max(sc.flat_level, sc.grain_radius)), 0.0, 1.0)[:, None]
        low, high = np.array([120.0, 84.0, 40.0]), np.array([246.0, 222.0, 160.0])
        colors = np.ascontiguousarray(low + shade * (high - low))
        order = np.argsort(up, kind="stable").astype(np.int64) if d == 3 else np.arange(sc.n_grains, dtype=np.int64)
        scale = size / (2.0 * L)
        ground = 0.8 * size
        background = np.full((1, size, size, 3), 250, dtype=np.uint8)
        if d == 2:
            background[0, int(ground) :] = 200  # below the floor
        out = np.empty((1, size, size, 3), dtype=np.uint8)
        worlds = np.zeros(1, dtype=np.int64)
        no_goal = np.full((1, d), np.nan)
        rgb_worlds(worlds, out, x, sc.radii[None], colors, order, no_goal, 0.0, background, worlds, scale, ground)
        img = out[0]
        # the blade: an outline of its footprint (3D) or section (2D)
        lo = sc.blade[b] - sc.blade_half
        hi = sc.blade[b] + sc.blade_half
        origin = 0.5 * size if d == 3 else ground
        c0, c1 = (np.clip(0.5 * size + v[0] * scale, 0, size - 1) for v in (lo, hi))
        # (the image's vertical axis is index 1: y in 3D, z in 2D)
        r0, r1 = (np.clip(origin - v[1] * scale, 0, size - 1) for v in (hi, lo))
        i0, i1, j0, j1 = int(r0), int(r1), int(c0), int(c1)
        red = np.array([220, 30, 30], dtype=np.uint8)
        for t in range(2):  # two pixels wide
            img[i0 : i1 + 1, min(j0 + t, size - 1)] = red
            img[i0 : i1 + 1, max(j1 - t, 0)] = red
            img[min(i0 + t, size - 1), j0 : j1 + 1] = red
            img[max(i1 - t, 0), j0 : j1 + 1] = red
        img[:, :2] = img[:, -2:] = 60  # the walls
        if d == 3:
            img[:2] = img[-2:] = 60
        return img

    def maps_picture(self, b: int, scale: int = 16) -> np.ndarray:
        """World b's height map (left) and target (right), each cell a ``scale``-pixel square (2D: a
        column of bars), grey by height (white at 0.5 m), the blade's cell red on the map."""
        sc = self.scene
        n = sc.cells
        maps = np.stack([sc.maps[b], sc.targets[b]])
        if sc.dim == 2:
            rows = np.arange(n)[::-1, None] * (0.5 / n)  # a bar chart: row k lit below the height
            img = (maps[:, None, :] > rows[None]).astype(float) * 0.9
        else:
            img = np.clip(maps.reshape(2, n, n) / 0.5, 0.0, 1.0)
        rgb = np.repeat(img[..., None], 3, axis=-1)
        cell = np.clip(((sc.blade[b, :-1] + HALF_WIDTH) * n / (2.0 * HALF_WIDTH)).astype(int), 0, n - 1)
        if sc.dim == 3:
            rgb[0, cell[0], cell[1]] = (1.0, 0.0, 0.0)
        else:
            rgb[0, :, cell[0]] = rgb[0, :, cell[0]] * 0.5 + np.array([0.5, 0.0, 0.0])
        gap = np.ones((n, 1, 3))
        out = np.concatenate([rgb[0], gap, rgb[1]], axis=1)
        return (np.kron(out, np.ones((scale, scale, 1))) * 255).astype(np.uint8)
