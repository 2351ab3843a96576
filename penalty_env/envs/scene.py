"""The PenaltyBalls scene: B worlds of the pushing task over one batched physics ``World``.

The single env (B = 1), the native vector env and the SB3 ``VecEnv`` all drive this one class, so
they share the scene, its physics and its per-world random draws, and produce the same episodes.

The scene is a *model* (sizes, masses, contact stiffness, the task's constants: fixed at
construction) plus per-world *state* (the ``World``'s positions and velocities, the goal, the
last distances). ``step`` advances every world by one control period in one Numba call (spread
over threads for large batches); ``reset_worlds`` draws new starts for some worlds, each from its
own random generator.

Units are SI (metres, kilograms, seconds, newtons). The last axis is up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from .. import _validate as V
from .._jit import compile_notice
from ..physics import Bowl, Motor, World, theory
from ..physics.configure import configure
from ..physics.stepping import runner as _runner
from . import kernel as KE
from .observation import ObservationLayout
from .params import *  # noqa: F403 - the task's parameters and constants, read here and by users as scene.X
from .params import (
    HEIGHTMAP_CELL,
    HEIGHTMAP_CELLS,
    PARAMETERS,
    SUCCESS_BONUS,
    W_GOAL,
    W_REACH,
    check_parameters,
    check_randomize,
    check_randomize_override,
    coerce_action,
    render_fps,
)
from .randomize import RandomizedScene
from .sand import SandScene, settled_bed
from .start import StartScene
from .terrain import TerrainScene

__all__ = ["PenaltyBallsScene", "PARAMETERS", "check_parameters", "coerce_action", "render_fps", "settled_bed"]


class PenaltyBallsScene(RandomizedScene, SandScene, TerrainScene, StartScene):
    """B worlds of the PenaltyBalls task on one batched ``World``.

    Args:
        n_worlds: number of independent worlds B.
        dim: 3 (spheres in a bowl) or 2 (the vertical slice: circles in a circular bowl).
        owner: the caller named in the TypeError for an unknown keyword argument.
        randomize: None (the fixed scene) or per-world ranges, ``{name: (low, high)}`` with names
            of :data:`.params.RANDOMIZE` (:mod:`.randomize`; the env docstring's "Domain
            randomisation" section).
        **params: keyword arguments of :data:`PARAMETERS`.
    """

    def __init__(
        self,
        n_worlds: int,
        dim: int = 3,
        owner: str = "PenaltyBallsEnv.__init__",
        randomize: Any = None,
        **params: Any,
    ) -> None:
        n_worlds = V.integer("n_worlds", n_worlds, 1)
        p = check_parameters(dim, params, owner)
        self.params = p
        self.randomize = check_randomize(randomize, p, dim)
        self.dim = int(dim)
        self.n_worlds = int(n_worlds)
        self._bodies(p)
        self._contact_model(p)
        self._make_world(p)
        self._spaces(p)
        self._task(p)
        self._buffers()

    # ------------------------------------------------------------------ construction
    def _bodies(self, p: dict[str, Any]) -> None:
        """The balls (pusher, ball, obstacles, then the grains), the terrain and the task's scales."""
        d, B = self.dim, self.n_worlds
        self.n_obstacles = p["n_obstacles"]
        # the bodies (pusher, ball, obstacles), then the grains
        self.n_bodies = 2 + self.n_obstacles
        self.n_grains = n_grains = p["grains"]
        self.n_balls = self.n_bodies + n_grains
        self.radii = np.array(
            [p["pusher_radius"], p["ball_radius"]]
            + [p["obstacle_radius"]] * self.n_obstacles
            + [p["grain_radius"]] * n_grains
        )
        self.masses = np.array(
            [p["pusher_mass"], p["ball_mass"]] + [p["obstacle_mass"]] * self.n_obstacles + [p["grain_mass"]] * n_grains
        )
        self.bowl_radius = R = p["bowl_radius"]
        self.bowl = Bowl((0.0,) * (d - 1) + (R,), R)  # the floor's lowest point is the origin
        self.terrain_kind = p["terrain"]
        self.roughness = p["roughness"]
        self.terrain = self._make_terrain()
        # bumped at every reset of a world whose terrain changes (the renderer redraws it then)
        self.terrain_version = np.zeros(B, dtype=np.int64)
        self.gravity = p["gravity"]
        self.control_period = p["control_period"]
        self.goal_tolerance = p["goal_tolerance"]

    def _contact_model(self, p: dict[str, Any]) -> None:
        """ks, kd (pairs and terrain), the substep and kf from the task's tolerances."""
        d = self.dim
        # --- contact model and substep from the task's contact, the pusher-ball impact, by
        # physics.configure: ks keeps a head-on impact at the motor's top speed (ks >= m_eff v^2 /
        # delta^2) and the motor pressing the pusher into a blocked ball at full force (ks >= F /
        # delta) under delta; kd gives the impact the target restitution exactly (no-tension closed
        # form); dt is the cheapest symplectic-Euler step whose worst-case restitution error, by the
        # measured error models, stays within restitution_accuracy. Obstacles share the spring and
        # dashpot (one ks, kd per scene): a heavier pair rebounds more, a lighter one less, and the
        # stability limit below covers every pair.
        self.config = configure(
            self.masses[:2],
            self.radii[:2],
            max_impact_speed=p["max_speed"],
            penetration=p["penetration_tolerance"],
            restitution=p["restitution"],
            accuracy=p["restitution_accuracy"],
            damping="no_tension",
            terrain=False,
            integrators=("symplectic_euler",),
            events=False,
            max_dt=self.control_period,
            max_force=p["max_force"],
            energy_budget=None,  # v0's substep rule (its episodes stay as they were)
        )
        self.ks = self.config.ks
        self.kd = self.config.kd
        # terrain: the same spring, stiffened where a body would otherwise rest deeper than the
        # penetration tolerance (resting overlap m g / ks <= tol r for every body: ks_t >= m g /
        # (tol r)); its dashpot gives the ball's bounce off the terrain the same restitution. A body
        # on the terrain is heavier than any pair's m_eff, so its contacts are longer than the pair
        # contact configure resolved: at least as many steps per contact (the stability limit below
        # covers a stiffened terrain).
        self.ks_rest = float(np.max(self.masses * self.gravity / (p["penetration_tolerance"] * self.radii)))
        self.ks_terrain = max(self.ks, self.ks_rest)
        self.kd_terrain = 2.0 * self.config.zeta * math.sqrt(self.ks_terrain * p["ball_mass"])
        gravity = (0.0,) * (d - 1) + (-self.gravity,)
        common: dict[str, Any] = dict(
            terrain=self.terrain,
            gravity=gravity,
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            damping="no_tension",
            integrator="symplectic_euler",
            broadphase="grid" if self.n_grains else "all_pairs",
        )
        if self.n_grains:
            common["stepping"] = "scalar"  # one world per thread, through the grid (the fused kernel's step)
        self._common = common
        start = self._placeholder_positions()
        self._start = start
        probe = World(start[0], self.radii, self.masses, dt=self.control_period, allow_unstable=True, **common)
        dt_max = min(self.config.dt, probe.stability_limit())
        self.substeps = max(1, math.ceil(self.control_period / dt_max))
        if self.control_period / self.substeps > dt_max:  # rounding
            self.substeps += 1
        self.dt = self.control_period / self.substeps
        if self.randomize:  # a substep every draw is stable at (more substeps, with a warning, if needed)
            self._randomized_substeps(probe, dt_max)
        # regularised Coulomb friction: the viscous slope kf is the largest that still brings the
        # lightest contact's sliding to rest within one substep without overshoot (kf dt / m = 1)
        m_sorted = np.sort(self.masses)
        m_eff_min = theory.effective_mass(m_sorted[0], m_sorted[1])
        self.kf = m_eff_min / self.dt
        # the motor's speed feedback F_max / v_max acts like a dashpot on the pusher, explicit in
        # each substep: keep it from overshooting (c dt / m <= 1)
        feedback = p["max_force"] / p["max_speed"] * self.dt / p["pusher_mass"]
        if feedback > 1.0:
            raise ValueError(
                f"max_force / max_speed * dt / pusher_mass = {feedback:.3g} must be <= 1 (dt = {self.dt:.3g} s, "
                f"the physics substep): the motor's speed feedback would overshoot. Lower max_force, or "
                f"raise max_speed or pusher_mass."
            )

    def _make_world(self, p: dict[str, Any]) -> None:
        """The batched World the scene steps: its motor, its stepping path, its grid."""
        d, common, n_grains = self.dim, self._common, self.n_grains
        start = self.__dict__.pop("_start")  # (the World keeps its own copy)
        self.mu = p["friction"]
        # physics="rolling": the balls spin (the World's rotation, regularised Coulomb friction at
        # the contact point, rolling resistance); the pusher's motor still pushes at its centre (so
        # an action means what it means in v0), and friction at the ground makes it roll
        self.rolling = p["physics"] == "rolling"
        motor = Motor(0, p["max_force"], p["max_speed"], axes=d - 1)
        stepping = "scalar" if (self.rolling or n_grains) else "lanes"
        # with grains the bodies (few, large) meet every ball directly; the grains meet each other
        # through a grid of the grains' own size (its lead balls): cells of the pusher's size would
        # hold ~(r_pusher / r_grain)^3 grains each
        # (no start check: the resets place every ball clear of the others and on the terrain)
        lead = self.n_bodies if n_grains else 0
        own = dict(common, stepping=stepping, motors=[motor], grid_lead=lead, start_check=False)
        if self.randomize:  # each world's physics its own, set at its reset
            own["per_world"] = True
        if self.rolling:
            self.world = World(
                start,
                self.radii,
                self.masses,
                dt=self.dt,
                mu=self.mu,
                rotation=True,
                mu_r=p["rolling_resistance"],
                **own,
            )
            self.kf = self.world.kf  # the largest the tangential effective mass allows (2/7 of v0's in 3D)
        else:
            self.world = World(start, self.radii, self.masses, dt=self.dt, mu=self.mu, kf=self.kf, **own)

    def _spaces(self, p: dict[str, Any]) -> None:
        """The action and observation spaces and the observation's layout."""
        d, R, n_grains = self.dim, self.bowl_radius, self.n_grains
        # --- spaces and the observation's layout (one definition: the kernel, the bounds, the docs)
        self.action_size = d - 1
        pos_bound = R
        self.vel_bound = max(10.0 * p["max_speed"], math.sqrt(4.0 * self.gravity * R))
        self.layout = ObservationLayout(
            d,
            self.n_obstacles,
            pos_bound,
            self.vel_bound,
            heightmap=(HEIGHTMAP_CELLS, HEIGHTMAP_CELL) if n_grains else None,
        )
        self.obs_size = self.layout.size
        self.observation_space = spaces.Box(
            self.layout.low.astype(np.float32), self.layout.high.astype(np.float32), dtype=np.float32
        )
        self.action_space = spaces.Box(-1.0, 1.0, (self.action_size,), dtype=np.float32)

    def _task(self, p: dict[str, Any]) -> None:
        """The task's constants the kernel reads, and where bodies rest."""
        d, n_grains = self.dim, self.n_grains
        if self.randomize:  # per world (set at each reset; the fixed values until then)
            self._push_offset = np.full(self.n_worlds, p["pusher_radius"] + p["ball_radius"])
        # --- the task's constants the kernel reads (the contact model is the World's own)
        self.task = KE.TaskParams(
            w_goal=W_GOAL,
            w_reach=W_REACH,
            success_bonus=SUCCESS_BONUS,
            goal_tolerance=self.goal_tolerance,
            push_offset=self._push_offset if self.randomize else p["pusher_radius"] + p["ball_radius"],
            substeps=self.substeps,
            goal_axes=d - 1 if n_grains else d,  # with sand, the goal is reached horizontally
        )
        # resting overlap m g / ks puts each ball at rest on the terrain at the start
        rest_depth = self.masses * self.gravity / self.ks_terrain
        # a resting centre sits at radius - m g / ks above the terrain (per body; the goal as the ball)
        nb = self.n_bodies
        self._rest_radii = np.append(self.radii[:nb] - rest_depth[:nb], self.radii[1] - rest_depth[1])
        self._radii_list = self.radii.tolist()
        self._contact = float(self.radii[0] + self.radii[1])
        if self.randomize:
            B = self.n_worlds
            self._rest_radii = np.tile(self._rest_radii, (B, 1))
            self._radii_rows = self.world.model.radii  # (B, n): each world's (the World's own array)
            self._roughness_rows = np.full(B, float(self.roughness))
            self.drawn = np.tile([self._nominal(n) for n in self.randomize], (B, 1))

    def _buffers(self) -> None:
        """Per-world state and output buffers (allocated once), the sand's bed, the kernel's calls."""
        d, B, n, R, n_grains = self.dim, self.n_worlds, self.n_balls, self.bowl_radius, self.n_grains
        # --- per-world state and output buffers, allocated once
        self.goal = np.zeros((B, d))
        runner = self.world.runner
        self.buffers = KE.new_buffers(B, self.obs_size, runner.status)
        self.obs = self.buffers.obs
        self.actions = np.zeros((B, self.action_size))
        self.stepping = np.ones(B, dtype=np.bool_)  # off for a world just reset: observed, not stepped
        self._all = np.arange(B, dtype=np.int64)
        self._chunks = self._split(self._all)
        self._velocity_zeros = np.zeros((B, n, d))
        self._ids = np.zeros((_runner.buffer_threads(), B), dtype=np.int64)  # per thread: the worlds it steps
        # with grains: the sand's height map around the ball; the settled bed (made once per
        # configuration, see ``settled_bed``)
        self.heightmap = (
            None
            if not n_grains
            else KE.HeightMap(
                first=self.n_bodies,
                cells=HEIGHTMAP_CELLS,
                cell=HEIGHTMAP_CELL,
                bowl_radius=R if self.terrain_kind == "bowl" else 0.0,
                offset=self.layout.heightmap_offset,
                top=2.0 * R,
            )
        )
        if n_grains:  # (settled_bed also sets settle_time and settle_speed: how long the bed was
            # settled and how fast its fastest grain still moved)
            self.bed = settled_bed(self)
        self._tail = (
            self.world.gravity,
            self.task,
            self.layout.table,
            np.stack([self.layout.low, self.layout.high]),
            self.goal,
            self.buffers,
            self.heightmap,
        )
        # the arguments of a whole-batch step, made once, and the kernel compiled for their types
        # (called without Numba's per-call type resolution: the arguments are fixed)
        self._step_calls = self._calls(self._chunks)
        phys = runner.physics
        self._act_tail = (self.actions, self.stepping, phys.status, phys.control.throttle, self._ids[0])
        self._observe_calls = self._observing(self._step_calls)
        self._step_kernel: Any = self._kernels()

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_step_kernel"] = None  # compiled code: found again (cached) on the first step after
        # a randomised scene's reset kernel and its arguments (views of the World's arrays, which
        # a copy must not share): made again on the first reset after
        state.pop("_derive_kernel", None)
        state.pop("_derive_tail", None)
        return state

    # ------------------------------------------------------------------ construction helpers
    def _placeholder_positions(self) -> np.ndarray:
        """Non-overlapping resting positions on a line (overwritten by the first reset); with grains
        the grains stand on their start lattice and the bodies' line floats above it."""
        d, n = self.dim, len(self.radii)
        pos = np.zeros((self.n_worlds, n, d))
        bodies = self.radii[: self.n_bodies]
        x = -0.5 * float(np.sum(2.0 * bodies + 0.1))
        for i, r in enumerate(bodies):
            x += r + 0.05
            pos[:, i, 0] = x
            pos[:, i, d - 1] = r
            x += r + 0.05
        if self.n_grains:
            lattice = self.grain_lattice()
            pos[:, self.n_bodies :] = lattice
            pos[:, : self.n_bodies, d - 1] += lattice[:, d - 1].max() + self.radii[-1] + 0.1
        return pos

    def _split(self, worlds: np.ndarray) -> list[np.ndarray]:
        return _runner.split(worlds, self.n_balls * self.substeps)

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        """Advance every world whose ``stepping`` flag is set by one control period, using
        ``self.actions``; observe every world (a world with the flag off was just reset)."""
        self._run(self._all, self._chunks)

    def _calls(self, chunks: Sequence[np.ndarray]) -> list[tuple]:
        runner = self.world.runner
        lanes = runner.lane_scratch
        return [
            (c, self.actions, self.stepping, runner.physics, None if lanes is None else lanes[t], self._ids[t])
            + self._tail
            for t, c in enumerate(chunks)
        ]

    def _kernels(self) -> Any:
        """The compiled step: one fused kernel (act, physics, observe: one call per batch); with
        sand, the act and observe kernels around ``World.step``'s own, so that the physics
        compiles once for the scene and for its bed's settling (measured: 1 s less of the first
        make's compiling), at the price of a few microseconds per step against a sand step's
        hundreds."""
        call = self._step_calls[0]
        with compile_notice(f"{self.dim}D {self.world.runner.path} environment step"):
            if not self.n_grains:
                return _runner.entry_point(KE.step_worlds, call)
            act_kernel = _runner.entry_point(KE.act_worlds, (call[0],) + self._act_tail)
            observe_kernel = _runner.entry_point(KE.observe_worlds, self._observe_calls[0])
            return act_kernel, observe_kernel

    @staticmethod
    def _observing(calls: list[tuple]) -> list[tuple]:
        """The arguments of :func:`.kernel.observe_worlds` in the step calls ``calls``."""
        return [(c[0], c[2], c[3]) + c[6:] for c in calls]

    def _run(self, worlds: np.ndarray, chunks: Sequence[np.ndarray]) -> None:
        if self._step_kernel is None:  # unpickled or copied
            self._step_kernel = self._kernels()
        whole = chunks is self._chunks
        calls = self._step_calls if whole else self._calls(chunks)
        if not self.n_grains:
            codes = _runner.dispatch(self._step_kernel, calls)
            code = min(codes) if min(codes) < 0 else sum(codes)
        else:
            act_kernel, observe_kernel = self._step_kernel
            code = act_kernel(worlds, *self._act_tail)
            if code >= 0:
                code = self.world.runner.step(self.substeps, self._ids[0][:code]) if code else KE.OK
                _runner.dispatch(observe_kernel, self._observe_calls if whole else self._observing(calls))
        if code != KE.OK:
            self._raise(code)

    def _raise(self, code: int) -> None:
        if code < 0:
            b = -code - 1
            where = "" if self.n_worlds == 1 else f" of world {b}"
            raise ValueError(f"the action{where} contains NaN or inf: {self.actions[b].tolist()}")
        bad = np.flatnonzero(self.buffers.status).tolist()
        raise FloatingPointError(
            f"the physics produced NaN or inf in world(s) {bad[:10]} (dt={self.dt:g}, "
            f"substeps={self.substeps}); the scene's parameters are outside what the contact model "
            f"can integrate"
        )

    # ------------------------------------------------------------------ resets
    def reset_worlds(
        self,
        worlds: Sequence[int] | np.ndarray,
        rngs: Sequence[np.random.Generator | None],
        observe: bool = True,
        randomize: Any = None,
    ) -> None:
        """Draw a new start for each world in ``worlds`` from the matching generator in ``rngs``,
        and (``observe``) compute its observation. With ``observe=False`` the world's flag is left
        off, so the next ``step`` observes it without stepping it. A randomised scene first draws
        each world's physics (``randomize``: ranges that replace some of the make-time ones for
        these resets, each within its make-time range)."""
        idx = np.asarray(worlds, dtype=np.int64)
        # horizontal positions (k, n + 1, d - 1): the balls, then the goal; lifted onto the
        # terrain together below
        gens = [rng for rng in rngs if rng is not None]
        if len(gens) != len(rngs):
            raise ValueError("every world reset needs its random generator (reset the env, with or without a seed)")
        if self.randomize:  # each world's physics, drawn before its start
            self._apply_draws(idx, gens, randomize)
            flat = np.array([self._sample(rng, int(b)) for b, rng in zip(idx, gens)])
        else:
            check_randomize_override(randomize, self.randomize)  # (refuses ranges: none at make)
            flat = np.array([self._sample(rng) for rng in gens])
        flat = flat.reshape(idx.size, self.n_bodies + 1, -1)
        if self.terrain_kind == "bumpy":
            rough = [self.roughness] * idx.size if not self.randomize else self._roughness_rows[idx].tolist()
            heights = np.array([self._bump_heights(rng, h) for rng, h in zip(gens, rough)])
            self.world.set_heights(0, heights, worlds=idx)
            self.terrain_version[idx] += 1
        pos = self._on_terrain(flat, idx)
        if self.n_grains:  # the settled bed, turned about the vertical (mirrored in 2D); bodies on it
            grains = self._bed_copies([rng.random() for rng in rngs if rng is not None])
            pos = np.concatenate([pos[:, : self.n_bodies], grains, pos[:, -1:]], axis=1)
            nb = self.n_bodies  # resting on the floor (as without sand), or on the highest grain under it
            pos[:, :nb, -1] = np.maximum(pos[:, :nb, -1], self._on_sand(flat[:, :nb], grains))
        self.goal[idx] = pos[:, -1]
        zeros = self._velocity_zeros[: idx.size]
        if self.rolling:
            spin = zeros if self.dim == 3 else zeros[..., :1]
            self.world.set_state(positions=pos[:, :-1], velocities=zeros, angular_velocities=spin, worlds=idx)
        else:
            self.world.set_state(positions=pos[:, :-1], velocities=zeros, worlds=idx)
        self.stepping[idx] = False
        if observe:
            self._run(idx, self._split(idx))
            self.stepping[idx] = True

    # ------------------------------------------------------------------ read-out
    INFO_KEYS = KE.INFO_KEYS

    def info(self, b: int) -> dict[str, Any]:
        """World b's info dict of the last step or reset: numpy float64 scalars, and ``is_success``
        a Python bool (Gymnasium's own vector envs batch a numpy bool into an object array)."""
        buf = self.buffers
        info = dict(zip(KE.INFO_KEYS, buf.info[:, b]))  # iterating a float64 array gives its scalars
        info["is_success"] = bool(buf.success[b])
        if self.randomize:
            info["randomization"] = self.randomization(b)
        return info

    def describe(self) -> str:
        """The derived physics, one line."""
        return (
            f"ks={self.ks:.4g} N/m, kd={self.kd:.4g} N s/m, ks_terrain={self.ks_terrain:.4g} N/m, "
            f"kd_terrain={self.kd_terrain:.4g} N s/m, "
            f"mu={self.mu:g}, kf={self.kf:.4g} N s/m, dt={self.dt:.4g} s x {self.substeps} substeps "
            f"per {self.control_period:g} s step"
        )
