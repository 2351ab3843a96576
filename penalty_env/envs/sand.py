"""Sand in the PenaltyBalls scene (``grains > 0``): the grains' start lattice, their bed settled once
per configuration and turned at each reset, and bodies set down on it."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from .._results import cached
from ..physics import World
from .params import ARENA_HALF_WIDTH, SAND_LATTICE, SAND_MAX_DEPTH, SAND_SETTLE_SPEED, SAND_SETTLE_TIME

__all__ = ["SandScene", "settled_bed", "settle", "remembered_bed"]


class SandScene:
    """The scene's sand methods (its ``dim``, ``radii``, ``n_grains``, ``terrain_kind``,
    ``bowl_radius`` and, once settled, ``bed``)."""

    dim: int
    radii: np.ndarray
    n_grains: int
    terrain_kind: str
    bowl_radius: float
    bed: np.ndarray

    def floor(self, h: np.ndarray) -> np.ndarray:
        """Height of the bare floor at horizontal positions ``h`` (..., d - 1): the bowl's, or the
        arena's (0). Only for the sand terrains (``SAND_TERRAINS``), and the bowl where it is
        defined (|h| < R)."""
        h = np.asarray(h, dtype=np.float64)
        if self.terrain_kind == "arena":
            return np.zeros(h.shape[:-1])
        R = self.bowl_radius
        return R - np.sqrt(np.maximum(R * R - np.sum(h * h, axis=-1), 0.0))

    def grain_lattice(self) -> np.ndarray:
        """The grains' start before settling, (n_grains, d): a square lattice of ``SAND_LATTICE``
        radii around the bottom, about four layers (``ceil(sqrt(n) / 2)`` sites wide in 3D,
        ``ceil(n / 4)`` in 2D; more layers where that would pass the walls or the rim of a bed
        ``SAND_MAX_DEPTH`` deep), each
        layer above the floor under it, jittered by up to 10% of a radius (a fixed generator:
        the same bed for every scene of the configuration)."""
        d, n, r = self.dim, self.n_grains, float(self.radii[-1])
        step = SAND_LATTICE * r
        side = max(1, math.ceil(0.5 * n**0.5) if d == 3 else math.ceil(0.25 * n))
        if self.terrain_kind == "arena":  # within the walls
            side = min(side, int((2.0 * ARENA_HALF_WIDTH - 2.0 * r) / step))
        else:  # within the rim of a bed SAND_MAX_DEPTH deep (more layers instead)
            rim = math.sqrt(2.0 * self.bowl_radius * SAND_MAX_DEPTH)
            side = max(1, min(side, int(2.0 * (rim - r) / step)))
        axis = (np.arange(side) - 0.5 * (side - 1)) * step
        layer = np.stack(np.meshgrid(*([axis] * (d - 1)), indexing="ij"), axis=-1).reshape(-1, d - 1)
        layers = math.ceil(n / len(layer))
        h = np.tile(layer, (layers, 1))[:n]
        k = np.repeat(np.arange(layers), len(layer))[:n]
        rng = np.random.default_rng(0)
        h = h + rng.uniform(-0.1 * r, 0.1 * r, h.shape)
        # the floor rises away from the bottom: each site sits on the floor under its rim
        rim = np.sqrt(np.sum(h * h, axis=-1, keepdims=True)) + r
        lift = self.floor(np.concatenate([rim, np.zeros((n, d - 2))], axis=-1)) if d == 3 else self.floor(rim)
        z = lift + 1.05 * r + k * step
        return np.concatenate([h, z[:, None]], axis=-1)

    def _bed_copies(self, draws: list[float]) -> np.ndarray:
        """The settled bed, one copy per uniform draw u: turned by 2 pi u about the vertical
        through the bottom (3D; the bowl and the arena's square are symmetric under it, so the bed
        stays settled: the arena's walls stand beyond the bed), or mirrored if u < 0.5 (2D)."""
        bed = self.bed
        u = np.asarray(draws, dtype=np.float64)
        out = np.repeat(bed[None], len(u), axis=0)
        if self.dim == 3 and self.terrain_kind == "arena":  # quarter turns, exact (the walls are square)
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

    def _on_sand(self, h: np.ndarray, grains: np.ndarray) -> np.ndarray:
        """The lowest centre heights at which bodies at horizontal positions ``h`` (k, bodies, d - 1)
        clear every grain of ``grains`` (k, n_grains, d): just touching the highest grain under
        each (-inf where none lies under it). One body at a time (temporaries of k x grains)."""
        d = self.dim
        rg = float(self.radii[-1])
        out = np.empty(h.shape[:2])
        for i in range(h.shape[1]):
            gap = h[:, i, None, :] - grains[:, :, : d - 1]  # (k, grains, d - 1)
            reach2 = (self.radii[i] + rg) ** 2 - np.sum(gap * gap, axis=-1)
            top = grains[:, :, d - 1] + np.sqrt(np.maximum(reach2, 0.0))
            out[:, i] = np.where(reach2 > 0.0, top, -np.inf).max(axis=-1)
        return out


# ----------------------------------------------------------------------------------------------
# Settled beds: made once per configuration (per process) and reused by every scene and reset
# ----------------------------------------------------------------------------------------------
_BEDS: dict[tuple, tuple[np.ndarray, float, float]] = {}


def settled_bed(scene: Any) -> np.ndarray:
    """The scene's grains settled in its terrain, (n_grains, d): dropped from
    :meth:`SandScene.grain_lattice` and stepped with the scene's own physics (its contact
    model, friction, rotation and substep, the grains alone) for at least ``SAND_SETTLE_TIME[0]``
    and until no grain moves faster than ``SAND_SETTLE_SPEED`` (at most ``SAND_SETTLE_TIME[1]``;
    a bed still moving then warns). Deterministic (one world, a fixed start), and cached per
    configuration for the process: every scene, world and reset of that configuration starts from
    the same bed (turned, see ``reset_worlds``)."""
    p = scene.params
    keys = ("grains", "grain_radius", "grain_mass", "friction", "physics", "rolling_resistance", "terrain")
    key = (
        scene.dim,
        scene.bowl_radius,
        scene.gravity,
        scene.dt,
        scene.ks,
        scene.kd,
        scene.ks_terrain,
        scene.kd_terrain,
        scene.kf,
    ) + tuple(p[k] for k in keys)
    known = remembered_bed(_BEDS, "sand_bed", key, lambda: _settle(scene), f"the sand bed ({p['grains']} grains)")
    bed, scene.settle_time, scene.settle_speed = known
    bed.flags.writeable = False  # (shared by every scene of the configuration)
    return bed


def _settle(scene: Any) -> tuple[np.ndarray, float, float]:
    """(bed, settling time, last grain speed) of :func:`settled_bed`."""
    p = scene.params
    g = scene.n_bodies
    common = dict(scene._common)
    kw: dict[str, Any] = dict(mu=scene.mu)
    if scene.rolling:
        kw.update(rotation=True, mu_r=p["rolling_resistance"])
    else:
        kw.update(kf=scene.kf)
    # (the lattice holds the grains apart: no start check)
    lattice = scene.grain_lattice()
    world = World(lattice, scene.radii[g:], scene.masses[g:], dt=scene.dt, start_check=False, **kw, **common)
    return settle(world, scene.dt, SAND_SETTLE_TIME, SAND_SETTLE_SPEED)


def settle(world: Any, dt: float, times: tuple[float, float], speed: float) -> tuple[np.ndarray, float, float]:
    """Step ``world`` (one world of grains, stepping ``dt``) a quarter second at a time, for at least
    ``times[0]`` and until no ball moves faster than ``speed`` (at most ``times[1]``): (its positions,
    read-only; the time it settled; its fastest ball's last speed)."""
    chunk = max(1, int(round(0.25 / dt)))
    t, fastest = 0.0, math.inf
    while t < times[1]:
        world.step(chunk)
        t += chunk * dt
        fastest = float(np.sqrt(np.max(np.sum(world.velocities**2, axis=-1))))
        if t >= times[0] and fastest < speed:
            break
    bed = np.array(world.positions)
    bed.flags.writeable = False
    return bed, t, fastest


def remembered_bed(
    store: dict, name: str, key: tuple, make: Any, what: str, speed: float = SAND_SETTLE_SPEED
) -> tuple[np.ndarray, float, float]:
    """A settled bed ``make()`` (see :func:`settle`) made once per configuration ``key``: per
    process in ``store``, and on disk for later processes (:func:`penalty_env._results.cached`,
    under ``name``). A bed whose fastest grain still moves at ``speed`` or more warns, naming
    ``what``."""
    known = store.get(key)
    if known is None:
        known = store[key] = cached(name, key, make)
        if not known[2] < speed:
            warnings.warn(
                f"{what} still moves at {known[2]:.3g} m/s after {known[1]:.3g} s of settling (the limit is "
                f"{speed:g} m/s): episodes start from a bed that has not come to rest",
                RuntimeWarning,
                stacklevel=4,
            )
    return known
