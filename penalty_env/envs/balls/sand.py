"""Sand in the PenaltyBalls scene (``grains > 0``): the grains' start lattice, their bed settled once
per configuration and turned at each reset, and bodies set down on it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...physics import World
from ..beds import remembered_bed, settle
from ..terrains import Terrain
from .params import SAND_LATTICE, SAND_MAX_DEPTH, SAND_SETTLE_SPEED, SAND_SETTLE_TIME

__all__ = ["SandBed", "grain_lattice"]

_BEDS: dict[tuple, tuple[np.ndarray, float, float]] = {}


class SandBed:
    """The grains of a PenaltyBalls scene.

    Args:
        dim: 3 or 2.
        terrain: the scene's terrain (a sand terrain: its floor has a closed form).
        n_grains, grain_radius: the grains.
        key: what else the settled bed depends on (the contact model, the friction...): the cache key.
        world_kwargs: the World's keyword arguments the grains settle with (the scene's physics).
        masses: the grains' masses.

    ``bed`` is the settled bed (n_grains, d), read-only; ``settle_time`` and ``settle_speed`` how long
    it settled and how fast its fastest grain still moved.
    """

    def __init__(
        self,
        dim: int,
        terrain: Terrain,
        n_grains: int,
        grain_radius: float,
        grain_mass: float,
        dt: float,
        key: tuple,
        world_kwargs: dict[str, Any],
    ) -> None:
        self.dim = dim
        self.terrain = terrain
        self.n_grains = n_grains
        self.grain_radius = grain_radius
        self.grain_mass = grain_mass
        self.dt = dt
        known = remembered_bed(
            _BEDS,
            "sand_bed",
            (dim, terrain.name, terrain.bowl_radius, n_grains, grain_radius, grain_mass, dt) + key,
            lambda: self._settle(world_kwargs),
            f"the sand bed ({n_grains} grains)",
            SAND_SETTLE_SPEED,
        )
        self.bed, self.settle_time, self.settle_speed = known
        self.bed.flags.writeable = False  # (shared by every scene of the configuration)

    def lattice(self) -> np.ndarray:
        """The grains' start before settling (:func:`grain_lattice`)."""
        return grain_lattice(self.dim, self.terrain, self.n_grains, self.grain_radius)

    def _settle(self, world_kwargs: dict[str, Any]) -> tuple[np.ndarray, float, float]:
        """(bed, settling time, last grain speed): the lattice stepped with the scene's physics, the
        grains alone (the lattice holds them apart: no start check)."""
        n = self.n_grains
        radii, masses = np.full(n, self.grain_radius), np.full(n, self.grain_mass)
        world = World(self.lattice(), radii, masses, dt=self.dt, start_check=False, **world_kwargs)
        return settle(world, self.dt, SAND_SETTLE_TIME, SAND_SETTLE_SPEED)

    def copies(self, draws: list[float]) -> np.ndarray:
        """The settled bed, one copy per uniform draw u: turned by 2 pi u about the vertical through
        the bottom (3D; quarter turns floor(4u) on square walls, exact), or mirrored if u < 0.5 (2D):
        the terrain is symmetric under it, so the bed stays settled."""
        bed = self.bed
        u = np.asarray(draws, dtype=np.float64)
        out = np.repeat(bed[None], len(u), axis=0)
        if self.dim == 3 and self.terrain.quarter_turns:
            quarter = np.floor(4.0 * u).astype(np.int64) % 4
            for t, q in enumerate(quarter):
                cq, sq = ((1, 0), (0, 1), (-1, 0), (0, -1))[q]
                out[t, :, 0] = cq * bed[:, 0] - sq * bed[:, 1]
                out[t, :, 1] = sq * bed[:, 0] + cq * bed[:, 1]
        elif self.dim == 3:
            c, s = np.cos(2.0 * np.pi * u)[:, None], np.sin(2.0 * np.pi * u)[:, None]
            out[:, :, 0] = c * bed[:, 0] - s * bed[:, 1]
            out[:, :, 1] = s * bed[:, 0] + c * bed[:, 1]
        else:
            out[:, :, 0] = np.where(u[:, None] < 0.5, -bed[:, 0], bed[:, 0])
        return out

    def on_sand(self, h: np.ndarray, grains: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """The lowest centre heights at which bodies of ``radii`` at horizontal positions ``h`` (k,
        bodies, d - 1) clear every grain of ``grains`` (k, n_grains, d): just touching the highest
        grain under each (-inf where none lies under it). One body at a time (temporaries of k x
        grains)."""
        d = self.dim
        rg = self.grain_radius
        out = np.empty(h.shape[:2])
        for i in range(h.shape[1]):
            gap = h[:, i, None, :] - grains[:, :, : d - 1]  # (k, grains, d - 1)
            reach2 = (radii[i] + rg) ** 2 - np.sum(gap * gap, axis=-1)
            top = grains[:, :, d - 1] + np.sqrt(np.maximum(reach2, 0.0))
            out[:, i] = np.where(reach2 > 0.0, top, -np.inf).max(axis=-1)
        return out


def grain_lattice(dim: int, terrain: Terrain, n: int, r: float) -> np.ndarray:
    """The ``n`` grains' start before settling on ``terrain``, (n, d): a square lattice of ``SAND_LATTICE``
    radii around the bottom, about four layers (``ceil(sqrt(n) / 2)`` sites wide in 3D,
    ``ceil(n / 4)`` in 2D; more layers where that would pass the walls or the rim of a bed
    ``SAND_MAX_DEPTH`` deep), each layer above the floor under it, jittered by up to 10% of a
    radius (a fixed generator: the same bed for every scene of the configuration)."""
    d = dim
    step = SAND_LATTICE * r
    side = max(1, math.ceil(0.5 * n**0.5) if d == 3 else math.ceil(0.25 * n))
    most = terrain.lattice_width(r, step, SAND_MAX_DEPTH)
    if most is not None:  # within the walls, or the rim of a bed SAND_MAX_DEPTH deep (more layers instead)
        side = min(side, most)
    axis = (np.arange(side) - 0.5 * (side - 1)) * step
    layer = np.stack(np.meshgrid(*([axis] * (d - 1)), indexing="ij"), axis=-1).reshape(-1, d - 1)
    layers = math.ceil(n / len(layer))
    h = np.tile(layer, (layers, 1))[:n]
    k = np.repeat(np.arange(layers), len(layer))[:n]
    rng = np.random.default_rng(0)
    h = h + rng.uniform(-0.1 * r, 0.1 * r, h.shape)
    # the floor rises away from the bottom: each site sits on the floor under its rim
    rim = np.sqrt(np.sum(h * h, axis=-1, keepdims=True)) + r
    floor = terrain.floor
    lift = floor(np.concatenate([rim, np.zeros((n, d - 2))], axis=-1)) if d == 3 else floor(rim)
    z = lift + 1.05 * r + k * step
    return np.concatenate([h, z[:, None]], axis=-1)
