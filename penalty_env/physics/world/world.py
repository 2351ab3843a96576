"""``World``: B independent worlds of n balls in implicit terrain, stepped in Numba.

The public face of the core: it validates the arguments, builds the scene's :class:`~..model.Model`
and :class:`~..model.State`, applies the stability guard (:mod:`.guard`), and hands the stepping to
its :class:`~..stepping.runner.Runner`. Python touches the simulation once per ``step`` call; the
steps themselves, over all worlds, run inside Numba.

A World is composed of its parts, each built from explicit inputs once the model, the state and
the runner exist: ``guard`` (:class:`.guard.StabilityGuard`: the step limits of its scene),
``start_check`` (:class:`.guard.StartCheck`), ``state_view`` (:class:`.state.StateView`: views of
the state, writing it, energy and momenta), ``terrain_view`` (:class:`.terrain.TerrainView`: the
shapes' poses and heights, distances) and ``params`` (:class:`.parameters.Parameters`: each world's
physics parameters). The World's public methods are theirs, delegated.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from ... import _validate as V
from ..._jit import readonly_paths, restore_readonly
from ..broadphase.grid import GRID_MIN_BALLS, new_grid, no_grid
from ..geometry.pack import pack_table, user_addresses
from ..geometry.shapes import Shape
from ..geometry.user import SDF
from ..model import TANGENTIAL, Model, Spin, State, new_control, new_spin
from ..stepping.common import STATUS_CG, STATUS_NONFINITE
from ..stepping.integrators import INTEGRATORS, allocate_work
from ..stepping.runner import PATHS, Runner
from .checks import Motor, ball_arrays, gravity_vector, motor_arrays, state_arrays, terrain_tuple, world_index
from .guard import EnergyDriftWarning, StabilityGuard, StartCheck
from .parameters import Parameters, per_world_model, tangential_parameters
from .paths import Options, check_combinations, stepping_path
from .state import Penetration, StateView
from .terrain import TerrainView, probe_user_sdf

__all__ = ["World", "DAMPING_MODES", "BROADPHASES", "STEPPING"]

DAMPING_MODES = ("linear", "no_tension")
BROADPHASES = ("all_pairs", "grid", "auto")
STEPPING = ("auto",) + PATHS
MAX_STEPS_PER_CALL = 2**62  # ``step(n)``: the kernels count steps in int64
# the scalar path stores the tangential springs' history per ball pair and per ball and shape:
# refuse a scene whose store would exceed this (the neighbour list stores them per listed pair)
MAX_HISTORY_BYTES = 2 * 2**30


class World:
    """Balls (spheres in 3D, circles in 2D) with penalty contacts, in implicit terrain.

    Args:
        positions: ``(n, d)`` or ``(B, n, d)`` ball centres, d = 2 or 3; B independent worlds.
        radii, masses: ``(n,)``, shared by the B worlds; > 0.
        velocities: same shape as ``positions``; zeros when None.
        terrain: the shapes (:mod:`penalty_env.physics.geometry`: spheres, bowls, planes, boxes,
            capsules, cylinders, cones, tori, height fields, CSG, a user's SDF; a single shape is
            accepted too). The shapes are data the kernels read: any terrain runs on the same
            compiled code. Kinematic shapes (given a velocity or angular velocity) move on every
            step, and :meth:`set_shape_pose` moves any shape between steps.
        gravity: length-d acceleration; default ``-9.81`` along the last axis.
        ks, kd: sphere-sphere penalty spring (force/length, > 0) and dashpot (force/speed, >= 0).
        ks_terrain, kd_terrain: sphere-terrain spring and dashpot; default ``ks``, ``kd``.
        damping: ``"linear"`` (the seed's dashpot, which pulls at separation) or
            ``"no_tension"`` (the normal force is clipped at zero, as LAMMPS ``limit_damping``).
        mu, kf: regularised Coulomb friction |f_t| = min(kf |v_t|, mu |f_n|); off when mu = 0.
            ``kf`` (force per sliding speed) defaults to, and may not exceed, ``m_eff / dt`` of
            the lightest contact: the explicit limit at which sliding stops in one step (with
            rotation, the tangential m_eff: 2/7 of it for spheres, 1/3 for disks).
        rotation: balls spin (docs/physics.md, "Rotation"): each has an angular velocity
            (``angular_velocities``: 3 components in 3D, 1 in 2D) and the inertia of a solid
            sphere (2/5 m r^2) or disk (1/2 m r^2); the tangential force acts at the contact
            point and exerts a torque. Scalar stepping only (``stepping`` ``auto`` or ``scalar``),
            without ``events``. Off by default: then nothing of it is compiled or paid for.
        tangential: ``"coulomb"`` (the regularised friction above) or ``"history"`` (a tangential
            spring per contact, carried from step to step and capped at mu |f_n|, Cundall-Strack as
            LAMMPS ``gran/hooke/history``: a contact below the cap sticks instead of creeping;
            symplectic or explicit Euler, which advance it once per step; scalar stepping; with
            ``rotation=False`` the balls slide without spinning, as pucks).
        kt, kd_t: the history model's spring (force/length, default 2/7 ks) and dashpot (force
            per sliding speed, default kd / 2), as LAMMPS's defaults for Kt and gamma_t.
        mu_r, kr: rolling resistance (with rotation; off when mu_r = 0): a torque against rolling
            of at most mu_r R* |f_n| (Ai et al. 2011, model A), regularised as the friction is:
            |M_r| = min(kr |w_r|, mu_r R* |f_n|); ``kr`` (torque per angular speed) defaults to,
            and may not exceed, the lightest contact's I_eff / dt.
        integrator: ``explicit_euler``, ``symplectic_euler``, ``velocity_verlet``, ``rk4`` or
            ``implicit_euler`` (linearised backward Euler, conjugate gradients).
        dt: time step (> 0).
        broadphase: ``all_pairs``, ``grid`` or ``auto`` (grid from ``GRID_MIN_BALLS`` balls).
        grid_lead: the first ``grid_lead`` balls stay out of the grid and meet every other ball
            directly (a few large bodies among many small grains: the cells are sized for the
            rest). 0 by default.
        stepping: how the batch is stepped (the result is the same up to round-off, and bit for
            bit between ``scalar`` and ``lanes``): ``auto`` (the fastest that applies), ``scalar``
            (one world at a time per thread; every integrator), ``lanes`` (a block of worlds per
            SIMD vector: all pairs, symplectic or explicit Euler) or ``neighbour_list`` (each world
            through its own Verlet list: a batch a share of its worlds per thread, a single large
            world parallel over its balls; the grid, symplectic or explicit Euler).
        motors: :class:`Motor` s (each drives one ball along its first axes with a DC motor's
            force-speed law, ``max_force (throttle - v / max_speed)``, re-evaluated at every step;
            :meth:`step` takes their throttles). Scalar and lanes stepping.
        allow_unstable: skip the stability guard (for stability studies).
        start_check: warn (:class:`StartOverlapWarning`) when a state given here or to
            :meth:`set_state` has two balls, or a ball and the terrain, overlapping by the smaller
            radius or more. On by default; a caller whose placement cannot overlap (the envs) turns
            it off, and spares its compile and its cost per reset.
        per_world: the World's physics parameters may differ between its worlds (domain
            randomisation): the masses, radii, contact parameters (``ks, kd, ks_terrain,
            kd_terrain, mu, kf``) and the motors' ``max_force`` start as given here for every world,
            and :meth:`set_parameters` changes them for some worlds. The kernels read them through
            :mod:`penalty_env.physics.per_world` (compiled once for a per-world scene, and not at all
            for a fixed one, which runs exactly the code it ran before). Scalar and lanes stepping,
            without ``events`` (the history model's spring kt and dashpot kd_t stay one per scene).
        events: event-located stepping (:mod:`penalty_env.physics.stepping.events`): each step
            stops at every contact switch (a contact beginning or ending) and crosses it, which
            restores the integrator's order (RK4: 4th order instead of 1st with damping) at the
            cost of extra force evaluations in the steps that hold a switch. Off by default: then
            the stepping is exactly the plain path. Only with ``stepping`` ``auto`` or ``scalar``.

    Raises:
        ValueError: a bad argument (named in the message), or ``dt`` above the stability limit
            (the message gives the limit and the substeps that meet it).
    """

    def __init__(
        self,
        positions: Any,
        radii: Any,
        masses: Any,
        velocities: Any = None,
        *,
        terrain: Sequence[Shape] | Shape = (),
        gravity: Any = None,
        ks: float,
        kd: float = 0.0,
        ks_terrain: float | None = None,
        kd_terrain: float | None = None,
        damping: str = "linear",
        mu: float = 0.0,
        kf: float | None = None,
        integrator: str = "symplectic_euler",
        dt: float,
        broadphase: str = "auto",
        stepping: str = "auto",
        allow_unstable: bool = False,
        start_check: bool = True,
        events: bool = False,
        rotation: bool = False,
        tangential: str = "coulomb",
        kt: float | None = None,
        kd_t: float | None = None,
        mu_r: float = 0.0,
        kr: float | None = None,
        motors: Sequence[Motor] = (),
        grid_lead: int = 0,
        per_world: bool = False,
    ) -> None:
        x, v, self._batched = state_arrays(positions, velocities)
        B, n, d = x.shape
        self.radii, self.masses = ball_arrays(radii, masses, n)
        self.terrain = terrain_tuple(terrain, d)
        self.gravity = gravity_vector(gravity, d)
        self.ks = V.positive("ks", ks)
        self.kd = V.non_negative("kd", kd)
        self.ks_terrain = self.ks if ks_terrain is None else V.positive("ks_terrain", ks_terrain)
        self.kd_terrain = self.kd if kd_terrain is None else V.non_negative("kd_terrain", kd_terrain)
        self.damping = V.choice("damping", damping, DAMPING_MODES)
        self.mu = V.non_negative("mu", mu)
        self.integrator = V.choice("integrator", integrator, INTEGRATORS)
        self.dt = V.positive("dt", dt)
        self.broadphase = V.choice("broadphase", broadphase, BROADPHASES)
        self.allow_unstable = V.flag("allow_unstable", allow_unstable)
        self.start_check_enabled = V.flag("start_check", start_check)
        self.events = V.flag("events", events)
        self.rotation = V.flag("rotation", rotation)
        self.tangential = V.choice("tangential", tangential, TANGENTIAL)
        self.mu_r = V.non_negative("mu_r", mu_r)
        self._motors = motor_arrays(motors, n, d)
        self.per_world = V.flag("per_world", per_world)
        self.use_grid = self.broadphase == "grid" or (self.broadphase == "auto" and n >= GRID_MIN_BALLS)
        options = Options(
            self.rotation,
            self.mu_r,
            self.tangential,
            self.events,
            self.integrator,
            self.per_world,
            self.damping,
            self.use_grid,
            self.broadphase,
            self._motors.ball.shape[0],
        )
        check_combinations(options)
        self._spinning = options.spinning
        law = tangential_parameters(
            self.masses, self.radii, self.rotation, len(self.gravity), self.dt, self.ks, self.kd, self.mu, self.mu_r,
            kf, kt, kd_t, kr, self.allow_unstable,
        )  # fmt: skip
        self.kf, self.kf_max, self.kt, self.kd_t, self.kr, self.kr_max = law
        self._kf_default, self._kr_default = kf is None, kr is None  # (per-world Worlds re-derive defaults)
        self._history = self.tangential == "history" and self.mu > 0.0
        lead = V.integer("grid_lead", grid_lead, 0, n - 1, "balls kept out of the grid")
        self.stepping = stepping_path(options, V.choice("stepping", stepping, STEPPING), B, n)
        self.guard = StabilityGuard(
            masses=self.masses,
            radii=self.radii,
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            kt=self.kt,
            kd_t=self.kd_t,
            history=self._history,
            integrator=self.integrator,
            damping=self.damping,
            rotation=self.rotation,
            has_terrain=bool(self.terrain),
            dim=d,
            dt=self.dt,
        )
        self._build(x, v, lead)
        self.dt_max = self.guard.stability_limit()
        if self.dt > self.dt_max and not self.allow_unstable:
            raise ValueError(self.guard.stability_message())
        self.start_check(self._all_worlds)
        self.dt_energy = self.guard.energy_limit()
        if self.dt > self.dt_energy and not self.allow_unstable:
            warnings.warn(self.guard.energy_message(), EnergyDriftWarning, stacklevel=2)

    # ---------------------------------------------------------------- construction
    def _new_spin(self, B: int, n: int, d: int) -> Spin | None:
        if not self._spinning:
            return None
        slots = len(self.terrain)
        pair_store = self.stepping != "neighbour_list"  # (the list keeps its springs per list slot)
        need = B * n * (n + slots) * 32 if self._history and pair_store else 0
        if need > MAX_HISTORY_BYTES:
            raise ValueError(
                f"tangential='history' stores a spring per ball pair and per ball and shape: {B} worlds of {n} "
                f"balls would need {need / 2**30:.3g} GiB, above {MAX_HISTORY_BYTES / 2**30:g} GiB; use fewer "
                "balls per world, or tangential='coulomb'"
            )
        spin = new_spin(
            B,
            n,
            d,
            self.masses,
            self.radii,
            slots,
            rotation=self.rotation,
            kt=self.kt if self._history else 0.0,
            kd_t=self.kd_t,
            mu_r=self.mu_r,
            kr=self.kr,
            dt=self.dt,
            pair_store=pair_store,
        )
        if self.per_world:  # per world: each world's inertia and rolling-resistance slope
            kr: Any = np.full(B, spin.kr)
            spin = spin._replace(inv_inertia=np.tile(spin.inv_inertia, (B, 1)), kr=kr)
        return spin

    def _build(self, x: np.ndarray, v: np.ndarray, lead: int) -> None:
        """The model, the state, the buffers (allocated once: nothing is allocated while stepping)
        and the runner."""
        B, n, d = x.shape
        packed = pack_table(self.terrain, B, d)
        self._rows = packed.rows
        for shape in self.terrain:
            if isinstance(shape, SDF):
                probe_user_sdf(shape, x)
        self._spin = self._new_spin(B, n, d)
        others = self.radii[lead:] if lead else self.radii
        self._lead = lead
        self._model = Model(
            radii=self.radii,
            inv_mass=1.0 / self.masses,
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            no_tension=self.damping == "no_tension",
            mu=self.mu,
            kf=self.kf,
            cell_size=2.0 * float(others.max()),
            shapes=packed.table,
            motors=self._motors,
        )
        if self.per_world:
            self._model = per_world_model(self._model, B)
        self._state = State(x, v)
        self._status = np.zeros(B, dtype=np.int64)
        self._control = new_control(B, n, d, self._motors.ball.shape[0])
        self._all_worlds = np.arange(B, dtype=np.int64)
        cells = 16 if lead else 4
        self._grid = new_grid(B, n, lead=lead, cells_per_ball=cells) if self.use_grid else no_grid()
        self._runner = Runner(  # (a per-world model: the runner's lanes scratch holds parameter rows too)
            self.stepping,
            self.integrator,
            self.events,
            self._model,
            self._state,
            allocate_work(self.integrator, B, n, d),
            self._grid,
            self._control,
            self._status,
            self.dt,
            self.gravity,
            spin=self._spin,
        )
        self._parts(lead, self._kf_default, self._kr_default)

    def _parts(self, lead: int, kf_default: bool, kr_default: bool) -> None:
        """The World's parts, each built from the model, the state and the runner."""
        B, d = self.n_worlds, self.dim
        self.terrain_view = TerrainView(
            self.terrain, self._rows, self._model.shapes, B, d, self.gravity, self._runner.forget
        )
        penetration = Penetration(self._state, self._model, self._runner, self._grid, self.gravity)
        self.start_check = StartCheck(
            not self.allow_unstable and self.start_check_enabled,
            self.guard,
            self._state.positions,
            penetration,
            self.terrain,
            self._rows,
            self.terrain_view.evaluate,
            self._batched,
        )
        self.state_view = StateView(
            self._state,
            self._spin,
            self._model,
            self._runner,
            self._grid,
            self._batched,
            self.gravity,
            self.rotation,
            penetration,
            self.start_check,
        )
        cell = self._model.cell_size if self.use_grid else None
        self.params = Parameters(
            self._model, self._spin, self.guard, self.per_world, self.allow_unstable, cell, lead, kf_default, kr_default
        )

    # ---------------------------------------------------------------- sizes and buffers
    @property
    def n_worlds(self) -> int:
        return self._state.positions.shape[0]

    @property
    def n_balls(self) -> int:
        return self._state.positions.shape[1]

    @property
    def dim(self) -> int:
        return self._state.positions.shape[2]

    @property
    def model(self) -> Model:
        """The scene's static description (radii, masses, terrain, every contact parameter)."""
        return self._model

    @property
    def spin(self) -> Any:
        """The rotation's parameters and buffers (:class:`~..model.Spin`: inverse inertias, rolling
        resistance, tangential history), or None for balls that neither spin nor carry a history."""
        return self._spin

    @property
    def state(self) -> State:
        """The World's own ``(B, n, d)`` position and velocity buffers, always batched. For code
        that fuses its own per-step work with the core's kernels (the environments do): after
        writing them directly, call :meth:`invalidate_cache` for the worlds written."""
        return self._state

    @property
    def runner(self) -> Any:
        """The runner that steps this World (its path, buffers and thread pool)."""
        return self._runner

    @property
    def event_buffers(self) -> Any:
        """The event location's buffers and counters (``events.stats(world)`` sums them), or None."""
        return self._runner.event_buffers

    @property
    def status(self) -> np.ndarray:
        """Per world, after the last step: 0 ok, 1 NaN or inf, 2 implicit Euler's solve did not converge."""
        out = self._status.view()
        out.flags.writeable = False
        return out

    @property
    def cg_tol(self) -> float:
        """implicit Euler: the conjugate gradients' relative residual tolerance (default 1e-10)."""
        return float(self._cg()[0])

    @cg_tol.setter
    def cg_tol(self, value: float) -> None:
        self._cg()[0] = V.positive("cg_tol", value)

    @property
    def cg_max_iter(self) -> int:
        """implicit Euler: the largest number of conjugate-gradient iterations per step."""
        return int(self._cg()[1])

    @cg_max_iter.setter
    def cg_max_iter(self, value: int) -> None:
        self._cg()[1] = V.integer("cg_max_iter", value, 1)

    def _cg(self) -> np.ndarray:
        work = self._runner.work
        if not hasattr(work, "cg"):
            raise AttributeError(f"cg_tol and cg_max_iter belong to implicit_euler, not {self.integrator}")
        return work.cg

    def neighbour_list_stats(self, world: int = 0) -> dict:
        """The neighbour list of one world (``stepping='neighbour_list'``): builds so far, balls
        escaped now, mean listed neighbours per ball at the last build, and its capacity."""
        if self._runner.lists is None:
            raise ValueError(f"this World steps {self.stepping!r}, without a neighbour list")
        return self._runner.lists.stats(V.integer("world", world, 0, self.n_worlds - 1))

    @property
    def force_evaluations_per_step(self) -> int:
        """Full contact passes per step (implicit Euler: one, plus its CG iterations' products)."""
        return 4 if self.integrator == "rk4" else 1

    # ---------------------------------------------------------------- the state (StateView)
    @property
    def positions(self) -> np.ndarray:
        """Current centres, shaped as given (read-only view; change them with ``set_state``)."""
        return self.state_view.positions

    @positions.setter
    def positions(self, value: Any) -> None:
        self.state_view.set_state(positions=value)

    @property
    def velocities(self) -> np.ndarray:
        """Current velocities, shaped as given (read-only view)."""
        return self.state_view.velocities

    @velocities.setter
    def velocities(self, value: Any) -> None:
        self.state_view.set_state(velocities=value)

    @property
    def angular_velocities(self) -> np.ndarray:
        """Current angular velocities, ``(n, 3)`` in 3D and ``(n, 1)`` in 2D (about the axis out of
        the plane), ``(B, n, .)`` when batched (read-only view; zeros when ``rotation=False``)."""
        return self.state_view.angular_velocities

    @angular_velocities.setter
    def angular_velocities(self, value: Any) -> None:
        self.state_view.set_state(angular_velocities=value)

    def set_state(
        self, positions: Any = None, velocities: Any = None, worlds: Any = None, angular_velocities: Any = None
    ) -> None:
        """Overwrite positions, velocities and/or (with rotation) angular velocities, of all worlds or
        of the worlds indexed by ``worlds`` (then the arrays are ``(len(worlds), n, .)``). New
        positions end every contact's tangential history in those worlds."""
        self.state_view.set_state(positions, velocities, worlds, angular_velocities)

    def invalidate_cache(self, worlds: Any = None) -> None:
        """Forget what was derived from the state (velocity Verlet's cached acceleration, a large
        world's neighbour list and storage order), after writing ``state``'s arrays directly."""
        self.state_view.invalidate_cache(worlds)

    def energy(self) -> Any:
        """Kinetic + gravitational + penalty-spring potential (1/2 ks overlap^2), per world; with
        rotation also the rotational kinetic energy (1/2 I w^2) and the tangential springs' (1/2 kt
        xi^2, the history model)."""
        return self.state_view.energy()

    def max_penetration(self) -> Any:
        """Largest overlap as a fraction of the (smaller) radius in contact, per world."""
        return self.state_view.max_penetration()

    def momentum(self) -> np.ndarray:
        """Total linear momentum per world, ``(d,)`` or ``(B, d)``."""
        return self.state_view.momentum()

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the origin per world, sum of m x cross v + I w: ``(3,)`` in
        3D, ``(1,)`` in 2D (about the axis out of the plane), ``(B, .)`` when batched."""
        return self.state_view.angular_momentum()

    # ---------------------------------------------------------------- the terrain (TerrainView)
    def shape_pose(self, shape: int, world: int = 0) -> dict[str, np.ndarray]:
        """The current pose of ``terrain[shape]`` in one world: ``position`` (its centre), ``rotation``,
        ``velocity`` and ``angular_velocity`` (3 components in 3D, 1 in 2D). Static spheres and
        bowls report their fixed pose."""
        return self.terrain_view.shape_pose(shape, world)

    def set_shape_pose(
        self,
        shape: int,
        position: Any = None,
        rotation: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
        worlds: Any = None,
    ) -> None:
        """Move ``terrain[shape]`` between steps, in every world or in ``worlds``: its centre, its
        rotation matrix, and (for a shape made kinematic, with a velocity or angular velocity at
        construction) the velocity and angular velocity it moves on with in every step. A paddle or
        a lid a policy moves sets them at every control step. Values are one for all the chosen
        worlds, or one per world (a leading axis of len(worlds))."""
        self.terrain_view.set_shape_pose(shape, position, rotation, velocity, angular_velocity, worlds)

    def set_heights(self, shape: int, heights: Any, worlds: Any = None) -> None:
        """Replace the node heights of the HeightField ``terrain[shape]`` in every world or in
        ``worlds`` (one grid for all of them, or one per world), between steps. Balls are not moved
        (see :meth:`set_shape_pose`)."""
        self.terrain_view.set_heights(shape, heights, worlds)

    def shape_heights(self, shape: int, world: int = 0) -> np.ndarray:
        """The node heights of the HeightField ``terrain[shape]`` in one world (a copy):
        ``(nx, ny)`` in 3D, ``(nx,)`` in 2D."""
        return self.terrain_view.shape_heights(shape, world)

    def height_table(self, shape: int) -> tuple[np.ndarray, int]:
        """The live node heights of the HeightField ``terrain[shape]`` as the kernels read them:
        ``(table, start)``, ``table`` the World's (B, m) height table (every height field's nodes,
        one row per world; not a copy: :meth:`set_heights` writes it) and ``start`` this field's
        first column (its ``nx * ny`` nodes follow, x-major)."""
        return self.terrain_view.height_table(shape)

    def shape_distance(self, shape: int, points: Any, world: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """phi and the outward normal of ``terrain[shape]`` at its current pose in one world, at
        ``points`` (..., d): ``(phi (...), normal (..., d))``."""
        return self.terrain_view.shape_distance(shape, points, world)

    def shape_distances(self, shape: int, points: Any, worlds: Any) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`shape_distance` in many worlds at once: ``points`` (k, ..., d) of the worlds
        ``worlds`` (k,), world ``worlds[t]``'s in ``points[t]``; ``(phi (k, ...), normal (k, ..., d))``,
        bit for bit :meth:`shape_distance` of each world in turn, in one compiled call."""
        return self.terrain_view.shape_distances(shape, points, worlds)

    def terrain_distance(self, points: Any, world: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """The terrain's signed distance at ``points`` (..., d) in one world, the smallest phi of
        its shapes at their current poses (the union of their solids), and the outward normal of
        that shape: ``(phi (...), normal (..., d))``; inf and zeros without terrain."""
        return self.terrain_view.terrain_distance(points, world)

    # ---------------------------------------------------------------- parameters and the guard
    def parameters(self, world: int = 0) -> dict[str, Any]:
        """World ``world``'s physics parameters: ``masses``, ``radii`` (``(n,)`` arrays), ``ks, kd,
        ks_terrain, kd_terrain, mu, kf`` and the motors' ``max_force`` (``(m,)``); with rotation also
        ``kr``. The same for every world unless the World was made with ``per_world=True``."""
        return self.params.get(int(world_index([world], self.n_worlds)[0]))

    def set_parameters(
        self,
        worlds: Any = None,
        *,
        masses: Any = None,
        radii: Any = None,
        ks: Any = None,
        kd: Any = None,
        ks_terrain: Any = None,
        kd_terrain: Any = None,
        mu: Any = None,
        kf: Any = None,
        max_force: Any = None,
        guard: bool = True,
    ) -> None:
        """Set the physics parameters of ``worlds`` (all when None) of a ``per_world=True`` World
        (:meth:`.parameters.Parameters.set` says each argument's shape, what follows from them and
        the guard they are held to)."""
        idx = self._all_worlds if worlds is None else world_index(worlds, self.n_worlds)
        values = dict(masses=masses, radii=radii, ks=ks, kd=kd, ks_terrain=ks_terrain, kd_terrain=kd_terrain)
        self.params.set(idx, mu=mu, kf=kf, max_force=max_force, guard=guard, **values)

    def stability_limit(self) -> float:
        """Largest dt the guard accepts (:meth:`.guard.StabilityGuard.stability_limit`)."""
        return self.guard.stability_limit()

    def energy_limit(self) -> float:
        """Largest dt within the energy budget (:meth:`.guard.StabilityGuard.energy_limit`)."""
        return self.guard.energy_limit()

    def stability_limit_for(
        self, masses: Any, radii: Any, ks: float, kd: float, ks_terrain: float, kd_terrain: float
    ) -> float:
        """The guard's stability limit (:meth:`stability_limit`) of this World's scene with these
        masses, radii and contact parameters (the World is left as it is): for a caller that checks
        parameters before it sets them (a randomised environment, its ranges' corners)."""
        return self.params.stability_limit_for(masses, radii, ks, kd, ks_terrain, kd_terrain)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_readonly"] = readonly_paths(self)  # pickling drops numpy's writeable flag
        return state

    def __setstate__(self, state: dict) -> None:
        """After unpickling: the read-only arrays read-only again (else every kernel compiles anew
        for writable ones); the user SDFs' compiled callbacks have new addresses."""
        paths = state.pop("_readonly", [])
        self.__dict__.update(state)
        restore_readonly(self, paths)
        if any(isinstance(s, SDF) for s in self.terrain):
            self._model.shapes.user[:] = user_addresses(self.terrain)

    # ---------------------------------------------------------------- stepping
    def step(self, n: int = 1, forces: Any = None, throttle: Any = None, worlds: Any = None) -> None:
        """Advance the worlds (every world, or those listed in ``worlds``) by ``n`` steps of dt.

        ``forces`` (an external force per ball, shaped like ``positions``, or ``(len(worlds), n, d)``)
        is held constant over the n steps. ``throttle`` sets the motors' throttles, ``(m, axes)`` or
        ``(B, m, axes)`` (m motors; ``(len(worlds), m, axes)`` with ``worlds``), each in [-1, 1]
        (a motor's force is re-evaluated at the velocity of every step); a motor holds its last
        throttle (0 at first) until it is given another."""
        n = V.integer("n", n, 0, MAX_STEPS_PER_CALL, "number of steps")
        idx = None if worlds is None else world_index(worlds, self.n_worlds)
        count = self.n_worlds if idx is None else len(idx)
        control = self._control
        if forces is not None:
            x = self._state.positions
            expected = (count,) + x.shape[1:] if (self._batched or idx is not None) else x.shape[1:]
            f = V.real_array("forces", forces, shape=expected)
            control.forces[slice(None) if idx is None else idx] = f if len(expected) == 3 else f[None]
        if throttle is not None:
            self._set_throttle(throttle, idx, count)
        if n == 0:
            return
        control.flags[0] = 1 if forces is not None else 0
        try:
            self._runner.step(int(n), idx)
        finally:
            control.flags[0] = 0
        self._check_status(self._all_worlds if idx is None else idx)

    def _set_throttle(self, throttle: Any, idx: Any, count: int) -> None:
        m = self._motors.ball.shape[0]
        if m == 0:
            raise ValueError("throttle: this World has no motors (give World(..., motors=[Motor(...)]))")
        axes = int(self._motors.axes.max())
        T = V.real_array("throttle", throttle)
        if T.shape == (m, axes):
            T = np.broadcast_to(T, (count, m, axes))
        if T.shape != (count, m, axes):
            raise ValueError(
                f"throttle must have shape ({m}, {axes}) (every chosen world) or ({count}, {m}, {axes}) (one row "
                f"per world), got {T.shape}"
            )
        if np.any(np.abs(T) > 1.0):
            raise ValueError(f"throttle must lie in [-1, 1], got values up to {float(np.abs(T).max()):g}")
        self._control.throttle[slice(None) if idx is None else idx, :, :axes] = T

    def _check_status(self, worlds: np.ndarray) -> None:
        status = self._status[worlds]
        bad = np.asarray(worlds)[status == STATUS_NONFINITE]
        if bad.size:
            raise FloatingPointError(
                f"the simulation produced NaN or inf in world(s) {bad[:10].tolist()} (dt={self.dt:g}, "
                f"integrator={self.integrator}, allow_unstable={self.allow_unstable}); reduce dt"
            )
        if np.any(status == STATUS_CG):
            warnings.warn(
                f"implicit_euler: conjugate gradients did not reach tol {self.cg_tol:g} in "
                f"{self.cg_max_iter} iterations; the step used the last iterate",
                RuntimeWarning,
                stacklevel=3,
            )

    def __repr__(self) -> str:
        return (
            f"World(B={self.n_worlds}, n={self.n_balls}, d={self.dim}, integrator={self.integrator!r}, "
            f"dt={self.dt:g}, broadphase={'grid' if self.use_grid else 'all_pairs'}, stepping={self.stepping!r}, "
            f"{'rotation=True, ' if self.rotation else ''}"
            f"terrain={len(self.terrain)} shapes)"
        )
