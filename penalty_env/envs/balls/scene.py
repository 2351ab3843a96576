"""The PenaltyBalls scene: B worlds of the pushing task over one batched physics ``World``.

The scene is the engine's task (:class:`~penalty_env.envs.engine.Task`): the single env (B = 1),
the native vector env and the SB3 ``VecEnv`` all step it through :class:`~..engine.Batch`, so they
share its physics and its per-world random draws, and produce the same episodes.

It holds its parts, each built from explicit inputs:

* the **terrain** (:mod:`..terrains`: its shapes, its draw per reset, its floor, its picture);
* the **contact model** (:mod:`..contact`: ``configure``'s answer and the springs derived from it)
  and the substep;
* the **World** (its motor drives the pusher; the lanes path for balls that slide, the scalar path
  for balls that roll and for sand);
* the **start sampler** (:class:`.start.StartSampler`), the **sand bed** (:class:`.sand.SandBed`,
  with grains) and the **randomiser** (:class:`.randomize.Randomizer`, with ``randomize=``);
* the **step kernel**'s named buffers (:mod:`.kernel`): act, physics, observe and reward in one
  Numba call per batch.

Units are SI (metres, kilograms, seconds, newtons). The last axis is up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from ... import _validate as V
from ..._jit import compile_notice, python_twin
from ...physics import Motor, World
from ...physics.stepping import runner as runner_module
from ..contact import ContactRule, configure_task, derive, sliding_kf, substeps_for
from ..terrains import make_terrain
from . import kernel as KE
from .layout import ObservationLayout
from .params import (
    HEIGHTMAP_CELL,
    HEIGHTMAP_CELLS,
    PARAMETERS,
    SUCCESS_BONUS,
    W_GOAL,
    W_REACH,
    check_parameters,
)
from .randomize import Randomizer, check_randomize
from .sand import SandBed, grain_lattice
from .start import StartSampler

__all__ = ["PenaltyBallsScene", "PARAMETERS", "check_parameters"]


class PenaltyBallsScene:
    """B worlds of the PenaltyBalls task on one batched ``World``.

    Args:
        n_worlds: number of independent worlds B.
        dim: 3 (spheres in a bowl) or 2 (the vertical slice: circles in a circular bowl).
        owner: the caller named in the TypeError for an unknown keyword argument.
        randomize: None (the fixed scene) or per-world ranges, ``{name: (low, high)}`` with names
            of :data:`.randomize.FIELDS` (the env docstring's "Domain randomisation" section).
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
        self.dim = d = int(dim)
        self.n_worlds = B = int(n_worlds)
        self.randomize = check_randomize(randomize, p, d)
        # --- the bodies: pusher, ball, obstacles, then the grains
        self.n_obstacles = p["n_obstacles"]
        self.n_bodies = nb = 2 + self.n_obstacles
        self.n_grains = n_grains = p["grains"]
        self.n_balls = nb + n_grains
        self.radii = np.array(
            [p["pusher_radius"], p["ball_radius"]]
            + [p["obstacle_radius"]] * self.n_obstacles
            + [p["grain_radius"]] * n_grains
        )
        self.masses = np.array(
            [p["pusher_mass"], p["ball_mass"]] + [p["obstacle_mass"]] * self.n_obstacles + [p["grain_mass"]] * n_grains
        )
        self.bowl_radius = p["bowl_radius"]
        self.gravity = p["gravity"]
        self.control_period = p["control_period"]
        self.goal_tolerance = p["goal_tolerance"]
        self.mu = p["friction"]
        # physics="rolling": the balls spin (the World's rotation, regularised Coulomb friction at
        # the contact point, rolling resistance); the pusher's motor still pushes at its centre (so
        # an action means what it means in v0), and friction at the ground makes it roll
        self.rolling = p["physics"] == "rolling"
        # --- the terrain; its version per world, bumped at every reset that redraws it
        self.terrain = make_terrain(p["terrain"], d, self.bowl_radius, p["roughness"])
        self.terrain_version = np.zeros(B, dtype=np.int64)
        # --- the contact model, the substep, the World
        self.rule = ContactRule(
            speed=p["max_speed"],
            penetration=p["penetration_tolerance"],
            restitution=p["restitution"],
            accuracy=p["restitution_accuracy"],
            force=p["max_force"],
            gravity=self.gravity,
            control_period=self.control_period,
        )
        self._contact_model()
        self.sand = self._sand() if n_grains else None
        self.world = self._world(self._placeholder_positions())
        if self.rolling:
            self.kf = self.world.kf  # the largest the tangential effective mass allows (2/7 of v0's in 3D)
        # --- where bodies rest, the starts, the randomiser's rows
        rest_depth = self.masses * self.gravity / self.ks_terrain  # resting overlap m g / ks
        # a resting centre sits at radius - m g / ks above the terrain (per body; the goal as the ball)
        self.rest_radii = np.append(self.radii[:nb] - rest_depth[:nb], self.radii[1] - rest_depth[1])
        if self.randomizer is not None:
            self.randomizer.attach(self.world, self.dt, self.rest_radii)
            rows = self.randomizer.rows
            assert rows is not None
            self.start = StartSampler(
                d, self.n_obstacles, self.goal_tolerance, self.radii, rows.push, self.world.model.radii
            )
        else:
            self.start = StartSampler(d, self.n_obstacles, self.goal_tolerance, self.radii)
        self._spaces()
        self._kernel_buffers()

    # ------------------------------------------------------------------ construction
    def _contact_model(self) -> None:
        """ks, kd (pairs and terrain), the substep and kf from the task's tolerances (:mod:`..contact`).

        ``configure`` resolves the task's contact, the pusher-ball impact: ks keeps a head-on impact
        at the motor's top speed and the motor pressing the pusher into a blocked ball at full force
        under the penetration tolerance; kd gives the impact the target restitution (no-tension
        closed form); dt is the cheapest symplectic-Euler step whose worst-case restitution error,
        by the measured error models, stays within restitution_accuracy. Obstacles and grains share
        the spring and dashpot (one ks, kd per scene): a heavier pair rebounds more, a lighter one
        less, and the stability limit covers every pair. The terrain's spring is stiffened where a
        body would otherwise rest deeper than the tolerance; a body on the terrain is heavier than
        any pair's m_eff, so its contacts are longer than the pair contact configure resolved."""
        p = self.params
        self.config = configure_task(self.rule, self.masses[:2], self.radii[:2])
        springs = derive(
            self.rule, self.masses, self.radii, (0, 1), p["ball_mass"], self.config.zeta, self.config.stiffening
        )
        self.ks, self.kd, self.ks_terrain, self.kd_terrain = springs
        self.ks_rest = float(np.max(self.masses * self.gravity / (p["penetration_tolerance"] * self.radii)))
        self.world_kwargs: dict[str, Any] = dict(
            terrain=self.terrain.shapes(),
            gravity=(0.0,) * (self.dim - 1) + (-self.gravity,),
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            damping="no_tension",
            integrator="symplectic_euler",
            broadphase="grid" if self.n_grains else "all_pairs",
        )
        if self.n_grains:
            self.world_kwargs["stepping"] = "scalar"  # one world per thread, through the grid (the fused kernel's step)
        probe = World(
            self._placeholder_positions(),
            self.radii,
            self.masses,
            dt=self.control_period,
            allow_unstable=True,
            **self.world_kwargs,
        )
        dt_max = min(self.config.dt, probe.stability_limit())
        self.substeps = substeps_for(self.control_period, dt_max)
        self.dt = self.control_period / self.substeps
        self.randomizer = None
        if self.randomize:  # a substep every draw is stable at (more substeps, with a warning, if needed)
            self.randomizer = Randomizer(
                self.randomize, p, self.n_worlds, self.n_obstacles, self.rule, self.config, self.rolling
            )
            self.substeps = self.randomizer.substeps(probe, self.substeps, self.dt, self.control_period)
            self.dt = self.control_period / self.substeps
        # regularised Coulomb friction: the viscous slope kf is the largest that still brings the
        # lightest contact's sliding to rest within one substep without overshoot (kf dt / m = 1)
        self.kf = float(python_twin(sliding_kf)(self.masses, self.dt))
        # the motor's speed feedback F_max / v_max acts like a dashpot on the pusher, explicit in
        # each substep: keep it from overshooting (c dt / m <= 1)
        feedback = p["max_force"] / p["max_speed"] * self.dt / p["pusher_mass"]
        if feedback > 1.0:
            raise ValueError(
                f"max_force / max_speed * dt / pusher_mass = {feedback:.3g} must be <= 1 (dt = {self.dt:.3g} s, "
                f"the physics substep): the motor's speed feedback would overshoot. Lower max_force, or "
                f"raise max_speed or pusher_mass."
            )

    def _friction_kwargs(self) -> dict[str, Any]:
        """The World's friction (and rotation) keywords: v0's kf, or v1's rotation and rolling
        resistance with the World's own kf."""
        if self.rolling:
            return dict(mu=self.mu, rotation=True, mu_r=self.params["rolling_resistance"])
        return dict(mu=self.mu, kf=self.kf)

    def _sand(self) -> SandBed:
        """The settled bed (made once per configuration: :class:`.sand.SandBed`)."""
        p = self.params
        key = (self.gravity, self.ks, self.kd, self.ks_terrain, self.kd_terrain, self.kf, p["friction"])
        key += (p["physics"], p["rolling_resistance"])  # type: ignore[assignment]
        return SandBed(
            self.dim,
            self.terrain,
            self.n_grains,
            p["grain_radius"],
            p["grain_mass"],
            self.dt,
            key,
            dict(self.world_kwargs, **self._friction_kwargs()),
        )

    def _world(self, start: np.ndarray) -> World:
        """The batched World the scene steps: its motor, its stepping path, its grid."""
        d = self.dim
        motor = Motor(0, self.params["max_force"], self.params["max_speed"], axes=d - 1)
        stepping = "scalar" if (self.rolling or self.n_grains) else "lanes"
        # with grains the bodies (few, large) meet every ball directly; the grains meet each other
        # through a grid of the grains' own size (its lead balls): cells of the pusher's size would
        # hold ~(r_pusher / r_grain)^3 grains each
        # (no start check: the resets place every ball clear of the others and on the terrain)
        lead = self.n_bodies if self.n_grains else 0
        kwargs = dict(self.world_kwargs, stepping=stepping, motors=[motor], grid_lead=lead, start_check=False)
        if self.randomize:  # each world's physics its own, set at its reset
            kwargs["per_world"] = True
        return World(start, self.radii, self.masses, dt=self.dt, **self._friction_kwargs(), **kwargs)

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
            lattice = self._lattice()
            pos[:, self.n_bodies :] = lattice
            pos[:, : self.n_bodies, d - 1] += lattice[:, d - 1].max() + self.radii[-1] + 0.1
        return pos

    def _lattice(self) -> np.ndarray:
        return grain_lattice(self.dim, self.terrain, self.n_grains, self.params["grain_radius"])

    def _spaces(self) -> None:
        """The action and observation spaces and the observation's layout (one definition: the
        kernel, the bounds, the docs)."""
        d, R, p = self.dim, self.bowl_radius, self.params
        self.action_size = d - 1
        self.vel_bound = max(10.0 * p["max_speed"], math.sqrt(4.0 * self.gravity * R))
        self.layout = ObservationLayout(
            d,
            self.n_obstacles,
            R,
            self.vel_bound,
            heightmap=(HEIGHTMAP_CELLS, HEIGHTMAP_CELL) if self.n_grains else None,
        )
        self.obs_size = self.layout.size
        self.observation_space = spaces.Box(
            self.layout.low.astype(np.float32), self.layout.high.astype(np.float32), dtype=np.float32
        )
        self.action_space = spaces.Box(-1.0, 1.0, (self.action_size,), dtype=np.float32)

    def _kernel_buffers(self) -> None:
        """Per-world state and output buffers (allocated once) and the step kernel's calls."""
        d, B, n = self.dim, self.n_worlds, self.n_balls
        rows = None if self.randomizer is None else self.randomizer.rows
        self.task = KE.TaskParams(
            w_goal=W_GOAL,
            w_reach=W_REACH,
            success_bonus=SUCCESS_BONUS,
            goal_tolerance=self.goal_tolerance,
            push_offset=rows.push if rows is not None else self.params["pusher_radius"] + self.params["ball_radius"],
            substeps=self.substeps,
            goal_axes=d - 1 if self.n_grains else d,  # with sand, the goal is reached horizontally
        )
        self.goal = np.zeros((B, d))
        runner = self.world.runner
        self.buffers = KE.new_buffers(B, self.obs_size, runner.status)
        self.obs = self.buffers.obs
        self.actions = np.zeros((B, self.action_size))
        self.stepping = np.ones(B, dtype=np.bool_)  # off for a world just reset: observed, not stepped
        self._all = np.arange(B, dtype=np.int64)
        self._chunks = self._split(self._all)
        self._velocity_zeros = np.zeros((B, n, d))
        self._ids = np.zeros((runner_module.buffer_threads(), B), dtype=np.int64)  # per thread: the worlds it steps
        # with grains: the sand's height map around the ball (its floor: the terrain's height)
        self.heightmap = (
            None
            if not self.n_grains
            else KE.HeightMap(
                first=self.n_bodies,
                cells=HEIGHTMAP_CELLS,
                cell=HEIGHTMAP_CELL,
                floor=self.terrain.heights(self.world),
                offset=self.layout.heightmap_offset,
                top=2.0 * self.bowl_radius,
            )
        )
        self.scene_arrays = KE.SceneArrays(
            actions=self.actions,
            stepping=self.stepping,
            gravity=self.world.gravity,
            task=self.task,
            table=self.layout.table,
            bounds=np.stack([self.layout.low, self.layout.high]),
            goal=self.goal,
            buffers=self.buffers,
        )
        # the arguments of a whole-batch step, made once, and the kernel compiled for their types
        # (called without Numba's per-call type resolution: the arguments are fixed)
        self._step_calls = self._calls(self._chunks)
        self._step_args = [c + (self.scene_arrays, self.heightmap) for c in self._step_calls]  # (made once)
        self._step_kernel: Any = self._kernels()

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_step_kernel"] = None  # compiled code: found again (cached) on the first step after
        return state

    def _split(self, worlds: np.ndarray) -> list[np.ndarray]:
        return runner_module.split(worlds, self.n_balls * self.substeps)

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        """Advance every world whose ``stepping`` flag is set by one control period, using
        ``self.actions``; observe every world (a world with the flag off was just reset)."""
        self._run(self._all, self._chunks)

    def _calls(self, chunks: Sequence[np.ndarray]) -> list[KE.StepCall]:
        runner = self.world.runner
        lanes = runner.lane_scratch
        return [
            KE.StepCall(c, self._ids[t], runner.physics, None if lanes is None else lanes[t])
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
                return runner_module.entry_point(KE.step_worlds, call + (self.scene_arrays, self.heightmap))
            act_kernel = runner_module.entry_point(
                KE.act_worlds, (call.worlds, call.ids, call.physics, self.scene_arrays)
            )
            observe_kernel = runner_module.entry_point(
                KE.observe_worlds, (call.worlds, call.physics, self.scene_arrays, self.heightmap)
            )
            return act_kernel, observe_kernel

    def _run(self, worlds: np.ndarray, chunks: Sequence[np.ndarray]) -> None:
        if self._step_kernel is None:  # unpickled or copied
            self._step_kernel = self._kernels()
        whole = chunks is self._chunks
        calls = self._step_calls if whole else self._calls(chunks)
        tail = (self.scene_arrays, self.heightmap)
        if not self.n_grains:
            codes = runner_module.dispatch(self._step_kernel, self._step_args if whole else [c + tail for c in calls])
            code = min(codes) if min(codes) < 0 else sum(codes)
        else:
            act_kernel, observe_kernel = self._step_kernel
            physics = self.world.runner.physics
            code = act_kernel(worlds, self._ids[0], physics, self.scene_arrays)
            if code >= 0:
                code = self.world.runner.step(self.substeps, self._ids[0][:code]) if code else KE.OK
                runner_module.dispatch(observe_kernel, [(c.worlds, c.physics) + tail for c in calls])
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
        options: Any = None,
    ) -> None:
        """Draw a new start for each world in ``worlds`` from the matching generator in ``rngs``,
        and (``observe``) compute its observation. With ``observe=False`` the world's flag is left
        off, so the next ``step`` observes it without stepping it. A randomised scene first draws
        each world's physics (``options["randomize"]``: ranges that replace some of the make-time
        ones for these resets, each within its make-time range)."""
        idx = np.asarray(worlds, dtype=np.int64)
        override = None if options is None else options.get("randomize")
        gens = [rng for rng in rngs if rng is not None]
        if len(gens) != len(rngs):
            raise ValueError("every world reset needs its random generator (reset the env, with or without a seed)")
        # horizontal positions (k, n + 1, d - 1): the balls, then the goal; lifted onto the terrain together
        if self.randomizer is not None:  # each world's physics, drawn before its start
            self.randomizer.apply(idx, gens, override)
            flat = np.array([self.start.sample(rng, int(b)) for b, rng in zip(idx, gens)])
        elif override is not None:
            raise ValueError(
                "options['randomize'] needs an env made with randomize=... (the guard checks the ranges at make)"
            )
        else:
            flat = np.array([self.start.sample(rng) for rng in gens])
        flat = flat.reshape(idx.size, self.n_bodies + 1, -1)
        if self.terrain.per_world:  # a new terrain for each world (after the start's draws)
            rows = self.randomizer.rows if self.randomizer is not None else None
            rough = rows.roughness[idx] if rows is not None else [self.terrain.roughness] * idx.size
            self.world.set_heights(0, self.terrain.draw(gens, np.asarray(rough)), worlds=idx)
            self.terrain_version[idx] += 1
        pos = self.on_terrain(flat, idx)
        if self.sand is not None:  # the settled bed, turned about the vertical (mirrored in 2D); bodies on it
            grains = self.sand.copies([rng.random() for rng in gens])
            nb = self.n_bodies
            pos = np.concatenate([pos[:, :nb], grains, pos[:, -1:]], axis=1)
            # resting on the floor (as without sand), or on the highest grain under it
            pos[:, :nb, -1] = np.maximum(pos[:, :nb, -1], self.sand.on_sand(flat[:, :nb], grains, self.radii))
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

    def on_terrain(self, h: np.ndarray, worlds: np.ndarray | None = None) -> np.ndarray:
        """Centres resting on the terrain at horizontal positions ``h`` (k, n + 1, d - 1) of
        ``worlds``: each ball sunk by its resting overlap m g / ks (along the terrain's normal);
        the last slot (the goal) as the ball. ``worlds=None``: ``h`` is (n + 1, d - 1), world 0."""
        if worlds is None:
            return self.on_terrain(np.asarray(h)[None], np.zeros(1, dtype=np.int64))[0]
        rest = self.rest_radii if self.randomizer is None else self.randomizer.rows.rest[worlds]  # type: ignore[union-attr]
        z = self.terrain.rest(h, rest, worlds, self.world)
        return np.concatenate([h, z[..., None]], axis=-1)

    # ------------------------------------------------------------------ read-out (the engine's Task protocol)
    INFO_KEYS = KE.INFO_KEYS
    info_keys = KE.INFO_KEYS[:-1]
    int_info: tuple[str, ...] = ()
    reset_options = ("randomize",)
    owner = "PenaltyBalls"

    @property
    def reward(self) -> np.ndarray:
        return self.buffers.reward

    @property
    def success(self) -> np.ndarray:
        return self.buffers.success

    @property
    def info_values(self) -> np.ndarray:
        return self.buffers.info

    @property
    def nested_infos(self) -> dict[str, tuple[tuple[str, ...], np.ndarray]]:
        r = self.randomizer
        return {} if r is None else {"randomization": (r.names, r.drawn)}

    @property
    def drawn(self) -> np.ndarray:
        """(B, names): each world's draws at its last reset (a randomised scene)."""
        if self.randomizer is None:
            raise AttributeError("drawn: the scene is not randomised (randomize=None)")
        return self.randomizer.drawn

    def randomization(self, b: int) -> dict[str, float]:
        """World b's drawn values at its last reset (name -> float, in draw order)."""
        if self.randomizer is None:
            return {}
        return dict(zip(self.randomizer.names, self.randomizer.drawn[b].tolist()))

    @property
    def bed(self) -> np.ndarray:
        """The settled bed of grains (n_grains, d), read-only (a scene with sand)."""
        if self.sand is None:
            raise AttributeError("bed: the scene has no sand (grains=0)")
        return self.sand.bed

    def floor(self, h: np.ndarray) -> np.ndarray:
        """The bare floor's height at horizontal positions ``h`` (the terrain's)."""
        return self.terrain.floor(np.asarray(h, dtype=np.float64))

    def first_bad_action(self, skip: np.ndarray) -> int:
        return int(KE.first_bad_action(self.actions, skip))

    def view_subject(self) -> Any:
        """What the observation views read (:class:`..views.ViewSubject`): the balls (drawn: the
        grains, the obstacles, the pusher, the ball on top), the goal, the terrain, the height
        map centred on the pusher and bounded by the bowl's height."""
        from ..views import ViewSubject
        from ..views.raster import BALL_COLOR, GRAIN_COLOR, OBSTACLE_COLOR, PUSHER_COLOR

        nb = self.n_bodies
        colors = [PUSHER_COLOR, BALL_COLOR] + [OBSTACLE_COLOR] * self.n_obstacles + [GRAIN_COLOR] * self.n_grains
        return ViewSubject(
            dim=self.dim,
            n_worlds=self.n_worlds,
            state_space=self.observation_space,
            state=self.obs,
            world=self.world,
            # (B, n): a randomised scene's live rows, drawn at each reset; a fixed scene's, repeated
            radii=self.world.model.radii
            if self.randomize
            else np.ascontiguousarray(np.tile(self.radii, (self.n_worlds, 1))),
            colors=255.0 * np.array(colors),
            order=np.array([*range(nb, self.n_balls), *range(2, nb), 0, 1], dtype=np.int64),
            focus=None,
            goal=self.goal,
            goal_radius=self.goal_tolerance,
            terrain=self.terrain.heights(self.world),
            terrain_per_world=self.terrain.per_world,
            terrain_version=self.terrain_version,
            height_bound=2.0 * self.bowl_radius,
        )

    def renderer(self) -> Any:
        from ..views.render import Renderer

        return Renderer(self, self.params["render_width"], self.params["render_height"])

    def describe(self) -> str:
        """The derived physics, one line."""
        return (
            f"ks={self.ks:.4g} N/m, kd={self.kd:.4g} N s/m, ks_terrain={self.ks_terrain:.4g} N/m, "
            f"kd_terrain={self.kd_terrain:.4g} N s/m, "
            f"mu={self.mu:g}, kf={self.kf:.4g} N s/m, dt={self.dt:.4g} s x {self.substeps} substeps "
            f"per {self.control_period:g} s step"
        )
