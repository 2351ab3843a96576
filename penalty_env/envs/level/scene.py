"""The PenaltySandLevel scene: B worlds of the sand-shaping task over one batched physics ``World``
(the walled arena, the heap of grains settled once per configuration, the kinematic blade, the
height maps and the targets), and the task's constants. The envs in :mod:`.sand_level` drive it.

Units are SI (metres, kilograms, seconds). The last axis is up.
"""

from __future__ import annotations

import math
from dataclasses import astuple
from typing import Any

import numpy as np
from gymnasium import spaces

from ... import _validate as V
from ...physics import Box, Plane, World
from ..beds import remembered_bed, settle
from ..contact import ContactRule, configure_task, derive, substeps_for
from ..randomize import Field, check_override, check_ranges, draw
from ..terrains.arena import walls as arena_walls
from . import kernel as LK
from .versions import GRAIN_MASS, GRAIN_RADIUS, HEAP_SLOPE, LEVEL_VERSIONS, LevelPhysics

__all__ = [
    "SandLevelScene",
    "LevelPhysics",
    "LEVEL_VERSIONS",
    "LEVEL_FIELDS",
    "LEVEL_PARAMETERS",
    "LEVEL_EPISODE_STEPS",
    "settled_heap",
    "GRAIN_RADIUS",
    "GRAIN_MASS",
    "HEAP_SLOPE",
]

# ----------------------------------------------------------------------------------------------
# The task's constants (the env docstring's tables)
# ----------------------------------------------------------------------------------------------
HALF_WIDTH = 1.0  # the arena's walls stand this far from the centre, m
GRAIN_FRICTION = 0.5  # Coulomb mu of every contact (grains, floor, walls, blade)
GRAIN_ROLLING = 0.1  # rolling resistance mu_r (docs/granular.md section 2: a heap stands)
GRAVITY = 9.81
BLADE_HALF = {3: (0.03, 0.25, 0.25), 2: (0.03, 0.25)}  # the blade box's half extents (x, [y,] z), m
WALL_GAP = 0.1  # the blade's faces stay this far from the walls, m
MAP_TOP = 1.0  # the height map's and the target's upper bound, m
PACKING = {3: 0.6, 2: 0.82}  # the height map's nominal solid fraction (a loose random packing)
MAX_LEVEL = 0.4  # the grains' flat level may be at most this deep, m
# the blade's bottom rides a grain radius above the target surface (a bed's grain tops stand about
# a radius above its depth), and never below LevelPhysics.blade_floor
REWARD_SCALE = 100.0  # reward per metre of decrease of the height-map error (1 per cm)
HEAP_LATTICE = 2.1  # ... its sites this many radii apart (jittered by 5% of a radius)
SETTLE_TIME = (15.0, 40.0)  # the heap settles for at least / at most this much simulated time, s
SETTLE_SPEED = 0.005  # ... until no grain moves faster than this, m/s
TARGET_AMPLITUDE = (0.25, 0.5)  # target="random": the relief's half range, x the flat level (uniform)
LEVEL_EPISODE_STEPS = {3: 300, 2: 150}  # the registered ids' episode length (25 s and 15 s)


# keyword arguments: default (3D, 2D), allowed range, meaning
LEVEL_PARAMETERS: dict[str, tuple[Any, Any, Any, str]] = {
    "grains": ((250, 24), 1, 8000, "grains in the heap (v1: 2,000, 80)"),
    "cells": ((10, 20), 2, 64, "height-map cells per horizontal axis"),
    "blade_speed": (0.5, 0.05, 1.0, "the blade's top speed per horizontal axis, m/s"),
    "control_period": (0.1, 0.02, 0.25, "simulated seconds per env step"),
    "success_fraction": (
        (0.5, 0.7),
        0.05,
        1.0,
        "success: the error falls below this fraction of the episode's initial error (v1: 0.75)",
    ),
}
TARGETS = ("flat", "random")

# randomize={name: (low, high)}: the fields a level world may draw at each reset (before the
# turn of its heap and its blade's side), in this order
LEVEL_FIELDS: dict[str, Field] = {
    f.name: f
    for f in (
        Field("friction", (0.0, 1.5), "Coulomb friction mu of every contact (grains, floor, walls, blade)"),
        Field("grain_mass", (0.05, 2.0), "every grain's mass, kg (the heap keeps its settled shape; it re-settles)"),
        Field(
            "blade_speed", LEVEL_PARAMETERS["blade_speed"][1:3], "the blade's top speed per axis, m/s", "blade_speed"
        ),
    )
}


def _parameters(dim: Any, params: dict[str, Any], owner: str, phys: LevelPhysics) -> dict[str, Any]:
    """Validated keyword arguments with their defaults (the version's grains and target;
    ValueError naming the argument, its value and its range; TypeError for an unknown one, in
    Python's wording)."""
    dim = V.integer("dim", dim, 2, 3, "2 or 3")
    out: dict[str, Any] = {"dim": dim}
    for name in params:
        if name not in LEVEL_PARAMETERS and name != "target":
            raise TypeError(f"{owner}() got an unexpected keyword argument {name!r}")
    for name, (default, lo, hi, _) in LEVEL_PARAMETERS.items():
        if name == "grains":
            default = phys.grains
        elif name == "success_fraction" and phys.success_fraction is not None:
            default = phys.success_fraction
        value = params.get(name, default[3 - dim] if isinstance(default, tuple) else default)
        if name in ("grains", "cells"):
            out[name] = V.integer(name, value, lo, hi)
        else:
            out[name] = V.in_range(name, value, lo, hi)
    out["target"] = V.choice("target", params.get("target", phys.target), TARGETS)
    return out


class SandLevelScene:
    """B worlds of the sand-shaping task on one batched ``World``.

    Args:
        n_worlds: number of independent worlds B.
        dim: 3 (spheres) or 2 (disks in the arena's vertical slice).
        owner: the caller named in the TypeError for an unknown keyword argument.
        randomize: None, or ranges ``{name: (low, high)}`` of :data:`LEVEL_FIELDS` each world draws
            at each reset (the env docstring's "Domain randomisation").
        version: the task's version (:data:`LEVEL_VERSIONS`: its grains, contact budget and
            default target), or a :class:`LevelPhysics` of one's own (the benches compare a
            version's budget on another's grains this way).
        **params: ``target`` ("flat" or "random") and the keywords of :data:`LEVEL_PARAMETERS`.
    """

    settle_time: float  # (set by settled_heap: how long the heap settled, s, and its last grain speed, m/s)
    settle_speed: float

    def __init__(
        self,
        n_worlds: int,
        dim: int = 3,
        owner: str = "PenaltySandLevelEnv.__init__",
        randomize: Any = None,
        version: int | LevelPhysics = 0,
        **params: Any,
    ):
        self.n_worlds = V.integer("n_worlds", n_worlds, 1)
        if not isinstance(version, LevelPhysics):
            version = LEVEL_VERSIONS[V.integer("version", version, 0, max(LEVEL_VERSIONS))]
        self.phys = phys = version
        p = _parameters(dim, params, owner, phys)
        self.params = p
        self.randomize = check_ranges(randomize, LEVEL_FIELDS)
        self.dim = d = p["dim"]
        self.n_grains = n = p["grains"]
        self.cells = p["cells"]
        self.n_cells = self.cells ** (d - 1)
        self.target_kind = p["target"]
        self.blade_speed = p["blade_speed"]
        self.control_period = p["control_period"]
        self.success_fraction = p["success_fraction"]
        self.half_width = HALF_WIDTH
        self.grain_radius = r = phys.grain_radius
        self.radii = np.full(n, r)
        self.masses = np.full(n, phys.grain_mass)
        self.blade_half = np.array(BLADE_HALF[d])
        # the blade centre's horizontal range: its faces WALL_GAP from the walls
        self.blade_range = HALF_WIDTH - WALL_GAP - self.blade_half[:-1]
        cell = 2.0 * HALF_WIDTH / self.cells
        volume = 4.0 / 3.0 * math.pi * r**3 if d == 3 else math.pi * r**2
        self.depth_unit = volume / (cell ** (d - 1) * PACKING[d])  # one grain's depth over one cell
        self._check_fits()
        self._contact_model()
        self._bed: np.ndarray | None = None
        if phys.version == 0:
            self._bed = settled_heap(self)  # (v0 settles at make, as it always has)
        self._make_world()
        self._spaces()
        self._buffers()

    # ------------------------------------------------------------------ construction
    @property
    def bed(self) -> np.ndarray:
        """The settled heap every reset starts from, (n, d), read-only: settled at make in v0; from
        v1 on the first reset (or this property) settles it, so a make is quick (the 2,000-grain
        heap takes seconds, then lies on disk for later processes)."""
        if self._bed is None:
            self._bed = settled_heap(self)
        return self._bed

    def _check_fits(self) -> None:
        """The grains' flat level (their volume over the arena at the map's packing) at most
        ``MAX_LEVEL``: a deeper bed would bury the blade's lowest setting under grains."""
        most = int(MAX_LEVEL * self.n_cells / self.depth_unit)
        if self.n_grains > most:
            raise ValueError(
                f"grains={self.n_grains} would fill the arena deeper than {MAX_LEVEL} m: at most {most} grains in "
                f"{self.dim}D"
            )

    def _contact_model(self) -> None:
        """ks, kd (pairs and terrain), the substep and kf, by ``physics.configure`` as the
        PenaltyBalls scene derives them, from the version's budget (:class:`LevelPhysics`): a
        grain-grain impact at ``impact`` x the blade's top speed (v0: twice it, a grain thrown by
        the blade meets a resting one; v1: once, a grain struck by the blade) overlaps at most
        ``overlap`` x a radius (v0 10%, v1 20%), also under the weight of a column of grains as
        tall as the heap's start (the steady force), and rebounds with restitution 0.3; the
        substep keeps its worst-case restitution error within 30% and the core's stability limit
        for every contact."""
        d, T, phys = self.dim, self.control_period, self.phys
        self.lattice = lattice = self.heap_lattice(self.n_grains)  # (the start before settling)
        column = math.ceil(lattice[:, -1].max() / (2.0 * phys.grain_radius)) + 1
        # randomised: the springs of the fastest blade and the heaviest grains (the corners that
        # need the stiffest), the substep of the lightest grains with them
        speed = self.randomize.get("blade_speed", (self.blade_speed,) * 2)[1]
        m_lo, m_hi = self.randomize.get("grain_mass", (phys.grain_mass, phys.grain_mass))
        rule = ContactRule(
            speed=phys.impact * speed * math.sqrt(d - 1),
            penetration=phys.overlap,
            restitution=0.3,
            accuracy=0.3,
            force=column * m_hi * GRAVITY,
            gravity=GRAVITY,
            control_period=T,
        )
        pair = np.full(2, m_hi), np.full(2, phys.grain_radius)
        self.config = configure_task(rule, *pair)
        springs = derive(rule, *pair, (0, 1), m_hi, self.config.zeta, self.config.stiffening)
        springs = springs._replace(  # (x 1.0 in v0: the same floats)
            ks_terrain=springs.ks_terrain * phys.floor_stiffening,
            kd_terrain=springs.kd_terrain * math.sqrt(phys.floor_stiffening),
        )
        self.ks, self.kd, self.ks_terrain, self.kd_terrain = springs
        self.gravity = GRAVITY
        self.world_kwargs: dict[str, Any] = dict(
            terrain=self._terrain(),
            gravity=(0.0,) * (d - 1) + (-GRAVITY,),
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            damping="no_tension",
            integrator="symplectic_euler",
            broadphase="grid",
            stepping="scalar" if self.randomize else phys.stepping,
            mu=GRAIN_FRICTION,
            rotation=True,
            mu_r=GRAIN_ROLLING,
            tangential="history",  # a tangential spring: static friction, so a heap stands (granular.md)
            start_check=False,
        )
        probe = World(lattice, self.radii, self.masses, dt=T, allow_unstable=True, **self.world_kwargs)
        limit = probe.stability_limit()
        if m_lo != phys.grain_mass:  # the lightest grains' contacts are the shortest
            limit = min(limit, probe.stability_limit_for(np.full(self.n_grains, m_lo), self.radii, *springs))
        self.substeps = substeps_for(T, min(self.config.dt, phys.step_margin * limit))  # (x 1.0 in v0)
        self.dt = T / self.substeps

    def _terrain(self) -> tuple:
        """The floor, the four (2D: two) walls and the blade (the last shape, kinematic; parked
        above the arena until a reset places it)."""
        d, L = self.dim, HALF_WIDTH
        up = np.eye(d)[-1]
        walls = arena_walls(d, L)
        park = np.zeros(d)
        park[-1] = 10.0
        blade = Box(park, self.blade_half, velocity=(0.0,) * d)
        self.blade_shape = 1 + len(walls)
        return (Plane(np.zeros(d), up), *walls, blade)

    def heap_lattice(self, n: int) -> np.ndarray:
        """The grains' start before settling, (n, d): the n sites of a square lattice of
        ``HEAP_LATTICE`` radii inside the walls that lie lowest under a cone of slope
        ``HEAP_SLOPE`` about the vertical through the centre (sorted by distance from the axis plus
        height / tan(slope)), jittered horizontally by up to 5% of a radius (a fixed generator)."""
        d, r = self.dim, self.grain_radius
        step = HEAP_LATTICE * r
        k_max = int((HALF_WIDTH - 1.1 * r) / step)
        axis = np.arange(-k_max, k_max + 1) * step
        layers = np.arange(max(1, 4 * n // max(1, len(axis) ** (d - 1)) + 4)) * step
        grids = np.meshgrid(*([axis] * (d - 1)), layers, indexing="ij")
        pts = np.stack([g.ravel() for g in grids], axis=-1)
        rho = np.linalg.norm(pts[:, :-1], axis=1)
        score = rho + pts[:, -1] / math.tan(math.radians(self.phys.heap_slope))
        order = np.lexsort((pts[:, -1], rho, score))
        out = pts[order[:n]].copy()
        out[:, -1] += 1.05 * r
        rng = np.random.default_rng(0)
        out[:, :-1] += rng.uniform(-0.05 * r, 0.05 * r, out[:, :-1].shape)
        return out

    def _make_world(self) -> None:
        # (from v1 the World starts from the start lattice: every world is set to the settled heap
        # at its first reset, which ends every contact; no world steps before it)
        first = self._bed if self._bed is not None else self.lattice
        start = np.repeat(first[None], self.n_worlds, axis=0)
        kwargs = dict(self.world_kwargs, per_world=True) if self.randomize else self.world_kwargs
        self.world = World(start, self.radii, self.masses, dt=self.dt, **kwargs)
        # each world's blade speed (a randomised scene's drawn ones; the bound of the observation's
        # blade velocity is the fastest)
        self.blade_speeds = np.full(self.n_worlds, self.blade_speed)
        self.top_speed = self.randomize.get("blade_speed", (self.blade_speed,) * 2)[1]
        self.drawn = np.tile([self._nominal(n) for n in self.randomize], (self.n_worlds, 1))

    def _spaces(self) -> None:
        d, C, L = self.dim, self.n_cells, HALF_WIDTH
        h = d - 1
        self.obs_size = 2 * C + 2 * h
        low = np.concatenate([np.zeros(2 * C), np.full(h, -L), np.full(h, -self.top_speed)])
        high = np.concatenate([np.full(2 * C, MAP_TOP), np.full(h, L), np.full(h, self.top_speed)])
        self.observation_space = spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (h,), dtype=np.float32)
        self.action_size = h
        # the cells' centres (C, d - 1), row-major
        c = (np.arange(self.cells) + 0.5) * (2.0 * L / self.cells) - L
        self.cell_centres = np.stack(np.meshgrid(*([c] * h), indexing="ij"), axis=-1).reshape(C, h)

    def _buffers(self) -> None:
        B, d, C = self.n_worlds, self.dim, self.n_cells
        self.maps = np.zeros((B, C))
        self.targets = np.zeros((B, C))
        self.blade = np.zeros((B, d))  # the blade's centre
        self.blade_velocity = np.zeros((B, d))
        # the info values, rows of one block (the engine's info_values): the error, the episode's
        # initial error, the grains lost (a count)
        self.info_values = np.zeros((len(self.info_keys), B))
        self.error, self.initial_error, self.grains_lost = self.info_values
        self.reward = np.zeros(B)
        self.success = np.zeros(B, dtype=np.bool_)
        self.stepping = np.ones(B, dtype=np.bool_)  # off for a world just reset: observed, not stepped
        self.obs = np.zeros((B, self.obs_size), dtype=np.float32)
        self.actions = np.zeros((B, d - 1))
        self._all = np.arange(B, dtype=np.int64)
        # the bed's flat level: the mean of its height map (the level surface of the same volume)
        self.flat_level = self.n_grains * self.depth_unit / self.n_cells

    # ------------------------------------------------------------------ the height map
    def height_map(self, grains: np.ndarray) -> np.ndarray:
        """Height maps of grain sets ``grains`` (k, n, d): (k, cells^(d-1)) (the kernel's)."""
        g = np.ascontiguousarray(grains, dtype=np.float64)
        out = np.zeros((len(g), self.n_cells))
        LK.height_maps(g, np.arange(len(g), dtype=np.int64), HALF_WIDTH, self.cells, self.depth_unit, MAP_TOP, out)
        return out

    def target_height(self, target: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The target maps ``target`` (k, C) at horizontal points ``h`` (k, d - 1), interpolated
        bilinearly between the cells' centres (constant beyond the outer centres)."""
        n, L = self.cells, HALF_WIDTH
        f = np.clip((h + L) * (n / (2.0 * L)) - 0.5, 0.0, n - 1.0)
        i0 = np.minimum(np.floor(f).astype(np.int64), max(n - 2, 0))
        t = f - i0
        i1 = np.minimum(i0 + 1, n - 1)
        k = np.arange(len(h))
        if self.dim == 2:
            return target[k, i0[:, 0]] * (1.0 - t[:, 0]) + target[k, i1[:, 0]] * t[:, 0]
        grid = target.reshape(len(h), n, n)
        a, b = i0[:, 0], i0[:, 1]
        c, e = i1[:, 0], i1[:, 1]
        u, w = t[:, 0], t[:, 1]
        return (
            grid[k, a, b] * (1 - u) * (1 - w)
            + grid[k, c, b] * u * (1 - w)
            + grid[k, a, e] * (1 - u) * w
            + grid[k, c, e] * u * w
        )

    def _bottom(self, target: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The blade bottom's height over horizontal points ``h``: the target surface there, but
        never below ``blade_floor`` (one grain layer plus 1 cm: lower, it would bulldoze every
        grain on the floor before it)."""
        return np.maximum(self.target_height(target, h) + self.grain_radius, self.phys.blade_floor)

    # ------------------------------------------------------------------ targets
    def check_target(self, target: Any) -> np.ndarray:
        """A user's target height map: ``cells``^(d-1) values (flat, or shaped (cells, cells) in
        3D), finite, within [0, MAP_TOP]. ValueError naming ``options['target']`` otherwise."""
        arr = V.real_array("options['target']", target)
        shapes = [(self.n_cells,)] + ([(self.cells, self.cells)] if self.dim == 3 else [])
        if arr.shape not in shapes:
            raise ValueError(f"options['target'] must have shape {' or '.join(map(str, shapes))}, got {arr.shape}")
        arr = arr.reshape(self.n_cells)
        if arr.min() < 0.0 or arr.max() > MAP_TOP:
            raise ValueError(
                f"options['target'] must lie within [0, {MAP_TOP}] m (the height map's bounds), "
                f"got values in [{arr.min():.3g}, {arr.max():.3g}]"
            )
        return arr

    def random_target(self, rng: np.random.Generator) -> np.ndarray:
        """A target drawn from ``rng`` (5 uniforms u0..u4): the flat level plus a relief of zero
        mean over the cells whose largest |value| is a x the level, a = 0.25 + 0.25 u1
        (``TARGET_AMPLITUDE``). If u0 < 0.5 the relief is a plane sloping along the direction of
        angle 2 pi u2 (2D: +x if u2 < 0.5, else -x); otherwise a Gaussian of standard deviation
        0.4 L centred in the inner half of the arena (3D: at radius 0.5 L sqrt(u2), angle 2 pi u3;
        2D: at (u3 - 0.5) L), a mound, or a pit if u4 < 0.5. The map keeps the flat target's
        volume (its mean is the level)."""
        u = rng.random(5)
        h, L = self.cell_centres, HALF_WIDTH
        amp = (TARGET_AMPLITUDE[0] + (TARGET_AMPLITUDE[1] - TARGET_AMPLITUDE[0]) * u[1]) * self.flat_level
        if u[0] < 0.5:  # a slope
            if self.dim == 3:
                direction = np.array([math.cos(2.0 * math.pi * u[2]), math.sin(2.0 * math.pi * u[2])])
            else:
                direction = np.array([1.0 if u[2] < 0.5 else -1.0])
            f = h @ direction
        else:  # a mound or a pit, centred in the inner half
            if self.dim == 3:
                phi = 2.0 * math.pi * u[3]
                centre = 0.5 * L * math.sqrt(u[2]) * np.array([math.cos(phi), math.sin(phi)])
            else:
                centre = np.array([(u[3] - 0.5) * L])
            f = np.exp(-0.5 * np.sum((h - centre) ** 2, axis=1) / (0.4 * L) ** 2)
            if u[4] < 0.5:
                f = -f
        f = f - f.mean()
        f = f / np.abs(f).max()
        return self.flat_level + amp * f

    # ------------------------------------------------------------------ resets
    def reset_worlds(self, worlds: Any, rngs: Any, observe: bool = True, options: Any = None) -> None:
        """New episodes in ``worlds``, each from its generator in ``rngs``: the settled heap turned
        by a quarter turn (3D) or mirrored (2D), the blade at a wall, the target (``options``:
        ``{"target": map}`` gives every world reset here that map; else the scene's kind). The
        worlds are observed here; ``observe=False`` leaves their ``stepping`` flag off, so the next
        step leaves them as they are (reward 0)."""
        idx = np.asarray(worlds, dtype=np.int64)
        d, k = self.dim, len(idx)
        target = None if options is None else options.get("target")
        targets = None if target is None else [self.check_target(target)] * k
        if self.randomize:  # each world's draws, before its heap and blade
            self._apply_draws(idx, rngs, None if options is None else options.get("randomize"))
        elif options is not None and options.get("randomize") is not None:
            check_override(options["randomize"], self.randomize)  # (refused: nothing randomised at make)
        u = np.array([rng.random(2) for rng in rngs])
        grains = self._bed_copies(u[:, 0])
        for j, b in enumerate(idx):
            given = None if targets is None else targets[j]
            if given is not None:
                self.targets[b] = given
            elif self.target_kind == "random":
                self.targets[b] = self.random_target(rngs[j])
            else:
                self.targets[b] = self.flat_level
        # the blade: at the x wall (side by u[1]); in 3D at a uniform y (one more draw)
        side = np.where(u[:, 1] < 0.5, -1.0, 1.0)
        blade = np.zeros((k, d))
        blade[:, 0] = side * self.blade_range[0]
        if d == 3:
            y = np.array([rng.random() for rng in rngs])
            blade[:, 1] = (2.0 * y - 1.0) * self.blade_range[1]
        bottom = np.maximum(self._bottom(self.targets[idx], blade[:, :-1]), self._clearance(grains, blade))
        blade[:, -1] = bottom + self.blade_half[-1]
        self.blade[idx] = blade
        self.blade_velocity[idx] = 0.0
        zeros = np.zeros((k, self.n_grains, d))
        spin = zeros if d == 3 else zeros[..., :1]
        self.world.set_state(positions=grains, velocities=zeros, angular_velocities=spin, worlds=idx)
        self.world.set_shape_pose(self.blade_shape, position=blade, velocity=np.zeros((k, d)), worlds=idx)
        self._observe(idx)
        self.initial_error[idx] = self.error[idx]
        self.reward[idx] = 0.0
        self.success[idx] = False
        self.stepping[idx] = observe

    def _bed_copies(self, u: np.ndarray) -> np.ndarray:
        """The settled heap, one copy per uniform draw: turned by a quarter turn floor(4u) (3D; the
        square arena is symmetric under it) or mirrored if u < 0.5 (2D)."""
        bed = self.bed
        out = np.repeat(bed[None], len(u), axis=0)
        if self.dim == 3:
            for t, q in enumerate(np.floor(4.0 * u).astype(np.int64) % 4):
                cq, sq = ((1, 0), (0, 1), (-1, 0), (0, -1))[q]
                out[t, :, 0] = cq * bed[:, 0] - sq * bed[:, 1]
                out[t, :, 1] = sq * bed[:, 0] + cq * bed[:, 1]
        else:
            out[:, :, 0] = np.where(u[:, None] < 0.5, -bed[:, 0], bed[:, 0])
        return out

    def _clearance(self, grains: np.ndarray, blade: np.ndarray) -> np.ndarray:
        """The lowest blade bottom clear of ``grains`` (k, n, d) at horizontal positions ``blade``
        (k, d): 5 mm above the highest grain top within a radius of the blade's footprint."""
        r = self.grain_radius
        h = self.blade_half[:-1] + r
        near = np.all(np.abs(grains[:, :, :-1] - blade[:, None, :-1]) < h, axis=-1)
        tops = np.where(near, grains[:, :, -1] + r, 0.0)
        return tops.max(axis=1) + 0.005

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        """Advance the worlds whose ``stepping`` flag is set by one control period with
        ``self.actions``: each component clipped to [-1, 1] and scaled by ``blade_speed``, the move
        cut short at the blade's range; the bottom follows the target surface under the blade
        (vertical speed at most ``blade_speed``). Then observe and reward them."""
        idx = self._all if self.stepping.all() else np.flatnonzero(self.stepping)
        if not idx.size:
            return
        a = self.actions[idx]
        bad = ~np.all(np.isfinite(a), axis=1)
        if bad.any():
            b = int(idx[np.argmax(bad)])
            where = "" if self.n_worlds == 1 else f" of world {b}"
            raise ValueError(f"the action{where} contains NaN or inf: {self.actions[b].tolist()}")
        T = self.control_period
        v = self.blade_speeds[idx] if self.randomize else self.blade_speed
        v_axes = v[:, None] if self.randomize else v
        pos = self.blade[idx]
        new = pos.copy()
        new[:, :-1] = np.clip(pos[:, :-1] + np.clip(a, -1.0, 1.0) * v_axes * T, -self.blade_range, self.blade_range)
        goal = self._bottom(self.targets[idx], new[:, :-1]) + self.blade_half[-1]
        new[:, -1] = pos[:, -1] + np.clip(goal - pos[:, -1], -v * T, v * T)
        vel = (new - pos) / T
        self.world.set_shape_pose(self.blade_shape, position=pos, velocity=vel, worlds=idx)
        try:
            self.world.step(self.substeps, worlds=idx)
        except FloatingPointError as exc:
            raise FloatingPointError(
                f"the physics produced NaN or inf ({exc}); dt={self.dt:g}, substeps={self.substeps}"
            ) from None
        self.blade[idx] = new
        self.blade_velocity[idx] = vel
        previous = self.error[idx].copy()
        self._observe(idx)
        self.reward[idx] = REWARD_SCALE * (previous - self.error[idx])
        self.success[idx] = self.error[idx] < self.success_fraction * self.initial_error[idx]

    def _observe(self, idx: np.ndarray) -> None:
        x = self.world.positions  # (B, n, d): the World is batched
        LK.height_maps(x, idx, HALF_WIDTH, self.cells, self.depth_unit, MAP_TOP, self.maps)
        diff = self.maps[idx] - self.targets[idx]
        self.error[idx] = np.sqrt(np.mean(diff * diff, axis=1))
        g = x[idx]
        L = HALF_WIDTH
        inside = np.all(np.isfinite(g), axis=-1) & np.all(np.abs(g[..., :-1]) <= L, axis=-1) & (g[..., -1] > -L)
        self.grains_lost[idx] = self.n_grains - inside.sum(axis=1)
        C, h = self.n_cells, self.dim - 1
        obs = self.obs
        obs[idx, :C] = self.maps[idx]
        obs[idx, C : 2 * C] = self.targets[idx]
        obs[idx, 2 * C : 2 * C + h] = self.blade[idx, :-1]
        obs[idx, 2 * C + h :] = np.clip(self.blade_velocity[idx, :-1], -self.top_speed, self.top_speed)

    # ------------------------------------------------------------------ the engine's Task protocol
    info_keys = ("error", "initial_error", "grains_lost")
    int_info = ("grains_lost",)
    reset_options = ("target", "randomize")
    owner = "PenaltySandLevel"

    @property
    def nested_infos(self) -> dict[str, tuple[tuple[str, ...], np.ndarray]]:
        return {"randomization": (tuple(self.randomize), self.drawn)} if self.randomize else {}

    def _nominal(self, name: str) -> float:
        return {"friction": GRAIN_FRICTION, "grain_mass": self.phys.grain_mass, "blade_speed": self.blade_speed}[name]

    def _apply_draws(self, idx: np.ndarray, rngs: Any, override: Any) -> None:
        """Draw the fields of the worlds ``idx`` (one uniform per field from each world's generator,
        :func:`..randomize.draw`) and set them: the World's friction and grain masses (its inertia,
        friction and rolling slopes follow, ``World.set_parameters``; every draw is within the
        make-time guard's corners), the blade's speed."""
        ranges = check_override(override, self.randomize)
        drawn = draw(list(rngs), ranges)
        self.drawn[idx] = drawn
        values = dict(zip(ranges, drawn.T))
        kwargs: dict[str, Any] = {}
        if "friction" in values:
            kwargs["mu"] = values["friction"]
        if "grain_mass" in values:
            kwargs["masses"] = np.repeat(values["grain_mass"][:, None], self.n_grains, axis=1)
        if kwargs:
            self.world.set_parameters(idx, guard=False, **kwargs)
        if "blade_speed" in values:
            self.blade_speeds[idx] = values["blade_speed"]

    def view_subject(self) -> Any:
        """What the observation views read (:class:`..views.ViewSubject`): the grains, the arena's
        floor and walls, the height map centred on the blade and bounded by the map's top; no
        goal drawn (the target is the state's map)."""
        from ..terrains import PLANE
        from ..terrains.base import plain_heights
        from ..views import ViewSubject
        from ..views.raster import GRAIN_COLOR

        n = self.n_grains
        return ViewSubject(
            dim=self.dim,
            n_worlds=self.n_worlds,
            state_space=self.observation_space,
            state=self.obs,
            world=self.world,
            radii=np.ascontiguousarray(np.tile(self.radii, (self.n_worlds, 1))),
            colors=255.0 * np.tile(GRAIN_COLOR, (n, 1)),
            order=np.arange(n, dtype=np.int64),
            focus=self.blade,
            goal=np.full((self.n_worlds, self.dim), np.nan),
            goal_radius=0.0,
            terrain=plain_heights(PLANE, 0.0, MAP_TOP, half_width=HALF_WIDTH),
            terrain_per_world=False,
            terrain_version=np.zeros(self.n_worlds, dtype=np.int64),
            height_bound=MAP_TOP,
        )

    def first_bad_action(self, skip: np.ndarray) -> int:
        bad = ~np.all(np.isfinite(self.actions), axis=1) & ~skip
        return int(np.argmax(bad)) if bad.any() else -1

    def renderer(self) -> Any:
        """What draws the worlds (:class:`.picture.LevelPicture`: ``frame(b)``)."""
        from .picture import LevelPicture

        return LevelPicture(self)

    def describe(self) -> str:
        """The derived physics, one line."""
        return (
            f"{self.n_grains} grains, ks={self.ks:.4g} N/m, kd={self.kd:.4g} N s/m, ks_terrain={self.ks_terrain:.4g} "
            f"N/m, dt={self.dt:.4g} s x {self.substeps} substeps per {self.control_period:g} s step; flat level "
            f"{self.flat_level:.3f} m"
        )


# ----------------------------------------------------------------------------------------------
# The settled heap: made once per configuration (per process, and on disk) and reused by every reset
# ----------------------------------------------------------------------------------------------
_HEAPS: dict[tuple, tuple[np.ndarray, float, float]] = {}


def settled_heap(scene: SandLevelScene) -> np.ndarray:
    """The scene's grains settled in the arena, (n, d): dropped from :meth:`SandLevelScene.heap_lattice`
    and stepped with the scene's own physics (the blade parked above) for at least
    ``SETTLE_TIME[0]`` and until no grain moves faster than ``SETTLE_SPEED`` (at most
    ``SETTLE_TIME[1]``; a heap still moving then warns). Deterministic, cached per configuration."""
    # the version's physics, the lattice, the springs and the path that settles it (a randomised
    # scene settles on the scalar path)
    key = (
        "level",
        scene.dim,
        scene.n_grains,
        HEAP_LATTICE,
        scene.dt,
        scene.ks,
        scene.kd,
        scene.ks_terrain,
        scene.kd_terrain,
        scene.world_kwargs["stepping"],
    ) + astuple(scene.phys)
    known = remembered_bed(
        _HEAPS, "sand_level_heap", key, lambda: _settle(scene), f"the heap ({scene.n_grains} grains)", SETTLE_SPEED
    )
    bed, scene.settle_time, scene.settle_speed = known
    bed.flags.writeable = False
    return bed


def _settle(scene: SandLevelScene) -> tuple[np.ndarray, float, float]:
    world = World(scene.lattice, scene.radii, scene.masses, dt=scene.dt, **scene.world_kwargs)
    return settle(world, scene.dt, SETTLE_TIME, SETTLE_SPEED)
