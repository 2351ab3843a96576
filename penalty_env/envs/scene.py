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
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Sequence

import numba
import numpy as np
from gymnasium import spaces

from ..physics import Bowl, World
from ..physics.configure import configure
from ..physics.lanes import LANES
from . import _kernels as KE

__all__ = ["PenaltyBallsScene", "PARAMETERS", "check_parameters"]

# ----------------------------------------------------------------------------------------------
# Keyword arguments: default, allowed range, meaning. The env docstrings print this table.
# ----------------------------------------------------------------------------------------------
PARAMETERS: dict[str, tuple[Any, Any, Any, str]] = {
    "n_obstacles": (0, 0, 8, "passive obstacle balls"),
    "pusher_radius": (0.15, 0.05, 0.3, "pusher radius, m"),
    "ball_radius": (0.15, 0.05, 0.3, "ball radius, m"),
    "obstacle_radius": (0.15, 0.05, 0.3, "obstacle radius, m"),
    "pusher_mass": (1.0, 0.1, 10.0, "pusher mass, kg"),
    "ball_mass": (0.5, 0.05, 10.0, "ball mass, kg"),
    "obstacle_mass": (1.0, 0.05, 10.0, "obstacle mass, kg"),
    "friction": (0.3, 0.0, 1.5, "Coulomb friction coefficient mu of every contact"),
    "restitution": (0.3, 0.22, 1.0, "coefficient of restitution of a pusher-ball impact"),
    "penetration_tolerance": (0.1, 0.01, 0.5, "overlap / radius of a pusher-ball impact at max_speed"),
    "restitution_accuracy": (0.3, 0.05, 0.5, "largest relative error of the pusher-ball restitution (worst case); sets the substep"),
    "max_speed": (1.0, 0.1, 5.0, "pusher motor's no-load speed, m/s"),
    "max_force": (20.0, 0.5, 500.0, "pusher motor's stall force, N"),
    "goal_tolerance": (0.1, 0.02, 0.3, "success radius around the goal, m"),
    "control_period": (0.04, 0.005, 0.25, "simulated seconds per env step"),
    "bowl_radius": (8.0, 3.0, 100.0, "radius of the spherical terrain, m"),
    "gravity": (9.81, 0.1, 50.0, "gravitational acceleration, m/s^2"),
    "render_width": (256, 16, 4096, "rgb_array frame width, pixels"),
    "render_height": (256, 16, 4096, "rgb_array frame height, pixels"),
}
INT_PARAMETERS = ("n_obstacles", "render_width", "render_height")

# Start distribution (the env docstring's "Starting State" table)
BALL_START_RADIUS = 0.5  # the ball starts within this horizontal distance of the bowl's bottom
GOAL_DISTANCE = (0.4, 0.8)  # goal: this far from the ball's start, uniform
PUSHER_GAP = (0.1, 0.4)  # pusher: this surface gap from the ball, uniform
OBSTACLE_REGION = {3: 1.2, 2: 1.5}  # obstacles: disc radius (3D) / half-length (2D) around the bottom
OBSTACLE_GAP = 0.05  # minimum surface gap of an obstacle to any other ball at the start
OBSTACLE_DENSITY = 0.25  # obstacle footprints may cover at most this share of their region
OBSTACLE_TRIES = 10_000

# Reward (the env docstring's "Rewards" table)
W_GOAL = 10.0  # per metre the ball gets closer to the goal
W_REACH = 1.0  # per metre the pusher gets closer to the push point behind the ball
SUCCESS_BONUS = 10.0

# Batches with at least this many ball-substeps per step are spread over threads (measured with
# ``python -m penalty_env.bench env``: a thread hand-off costs about as much as ~2,000 of them).
PARALLEL_MIN_WORK = 2_000

_POOL: ThreadPoolExecutor | None = None


def _threads() -> int:
    return max(1, int(numba.config.NUMBA_NUM_THREADS))


def _pool() -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=_threads(), thread_name_prefix="penalty_env.envs")
    return _POOL


def check_parameters(dim: int, params: dict[str, Any]) -> dict[str, Any]:
    """Validated keyword arguments, defaults filled in. Raises ValueError naming the bad argument
    and its allowed range, TypeError for an unknown one."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    unknown = sorted(set(params) - set(PARAMETERS))
    if unknown:
        raise TypeError(f"unknown keyword argument(s) {unknown}; allowed: {sorted(PARAMETERS)}")
    out: dict[str, Any] = {}
    for name, (default, lo, hi, meaning) in PARAMETERS.items():
        value = params.get(name, default)
        if name in INT_PARAMETERS:
            ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and lo <= value <= hi
            if not ok:
                raise ValueError(f"{name} ({meaning}) must be an int in [{lo}, {hi}], got {value!r}")
            out[name] = int(value)
        else:
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = math.nan
            if isinstance(value, bool) or not (math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"{name} ({meaning}) must be a number in [{lo}, {hi}], got {value!r}")
            out[name] = v
    n_obs = out["n_obstacles"]
    if n_obs:
        region = OBSTACLE_REGION[dim]
        reach = out["obstacle_radius"] + OBSTACLE_GAP
        used = n_obs * (math.pi * reach**2 if dim == 3 else 2.0 * reach)
        room = math.pi * region**2 if dim == 3 else 2.0 * region
        if used > OBSTACLE_DENSITY * room:
            fit = int(OBSTACLE_DENSITY * room / (used / n_obs))
            raise ValueError(
                f"n_obstacles={n_obs} obstacles of radius {out['obstacle_radius']:g} do not fit the "
                f"{dim}D start region (at most {fit}); use fewer or smaller obstacles"
            )
    return out


class PenaltyBallsScene:
    """B worlds of the PenaltyBalls task on one batched ``World``.

    Args:
        n_worlds: number of independent worlds B.
        dim: 3 (spheres in a bowl) or 2 (the vertical slice: circles in a circular bowl).
        **params: keyword arguments of :data:`PARAMETERS`.
    """

    def __init__(self, n_worlds: int, dim: int = 3, **params: Any) -> None:
        if isinstance(n_worlds, bool) or not isinstance(n_worlds, (int, np.integer)) or n_worlds < 1:
            raise ValueError(f"the number of worlds must be an int >= 1, got {n_worlds!r}")
        p = check_parameters(dim, params)
        self.params = p
        self.dim = d = int(dim)
        self.n_worlds = B = int(n_worlds)
        self.n_obstacles = p["n_obstacles"]
        self.n_balls = n = 2 + self.n_obstacles
        self.radii = np.array([p["pusher_radius"], p["ball_radius"]] + [p["obstacle_radius"]] * self.n_obstacles)
        self.masses = np.array([p["pusher_mass"], p["ball_mass"]] + [p["obstacle_mass"]] * self.n_obstacles)
        self.bowl_radius = R = p["bowl_radius"]
        self.bowl = Bowl((0.0,) * (d - 1) + (R,), R)  # the floor's lowest point is the origin
        self.gravity = p["gravity"]
        self.control_period = p["control_period"]
        self.goal_tolerance = p["goal_tolerance"]

        # --- contact model and substep from the task's contact, the pusher-ball impact, by
        # physics.configure: ks keeps a head-on impact at the motor's top speed (ks >= m_eff v^2 /
        # delta^2) and the motor pressing the pusher into a blocked ball at full force (ks >= F /
        # delta) under delta; kd gives the impact the target restitution exactly (no-tension closed
        # form); dt is the cheapest symplectic-Euler step whose worst-case restitution error, by the
        # measured error models, stays within restitution_accuracy. Obstacles share the spring and
        # dashpot (one ks, kd per scene): a heavier pair rebounds more, a lighter one less, and the
        # stability limit below covers every pair.
        self.config = configure(
            self.masses[:2], self.radii[:2], max_impact_speed=p["max_speed"], penetration=p["penetration_tolerance"],
            restitution=p["restitution"], accuracy=p["restitution_accuracy"], damping="no_tension",
            terrain=False, integrators=("symplectic_euler",), events=False, max_dt=self.control_period,
            max_force=p["max_force"],
        )
        self.ks = self.config.ks
        self.kd = self.config.kd
        # terrain: the same spring; its dashpot gives the ball's bounce off the terrain the same
        # restitution. A body on the terrain is heavier than any pair's m_eff, so its contacts are
        # longer than the pair contact configure resolved: at least as many steps per contact.
        self.ks_terrain = self.ks
        self.kd_terrain = 2.0 * self.config.zeta * math.sqrt(self.ks_terrain * p["ball_mass"])
        gravity = (0.0,) * (d - 1) + (-self.gravity,)
        start = self._placeholder_positions()
        common = dict(
            terrain=(self.bowl,), gravity=gravity, ks=self.ks, kd=self.kd, ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain, damping="no_tension", integrator="symplectic_euler",
            broadphase="all_pairs",
        )
        probe = World(start[0], self.radii, self.masses, dt=self.control_period, allow_unstable=True, **common)
        dt_max = min(self.config.dt, probe.stability_limit())
        self.substeps = max(1, math.ceil(self.control_period / dt_max))
        if self.control_period / self.substeps > dt_max:  # rounding
            self.substeps += 1
        self.dt = self.control_period / self.substeps
        # regularised Coulomb friction: the viscous slope kf is the largest that still brings the
        # lightest contact's sliding to rest within one substep without overshoot (kf dt / m = 1)
        m_sorted = np.sort(self.masses)
        m_eff_min = m_sorted[0] * m_sorted[1] / (m_sorted[0] + m_sorted[1])
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
        self.mu = p["friction"]
        self.world = World(start, self.radii, self.masses, dt=self.dt, mu=self.mu, kf=self.kf, **common)

        # --- spaces
        self.action_size = d - 1
        self.obs_size = 7 * d + 2 * d * self.n_obstacles
        pos_bound = R
        self.vel_bound = max(10.0 * p["max_speed"], math.sqrt(4.0 * self.gravity * R))
        low, high = self._obs_bounds(pos_bound, self.vel_bound)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (self.action_size,), dtype=np.float32)

        # --- constants the kernel reads (the contact model is the World's own: kernel_state())
        self._envp = np.zeros(KE.N_ENVP)
        self._envp[KE.E_MAX_FORCE] = p["max_force"]
        self._envp[KE.E_MAX_SPEED] = p["max_speed"]
        self._envp[KE.E_W_GOAL] = W_GOAL
        self._envp[KE.E_W_REACH] = W_REACH
        self._envp[KE.E_BONUS] = SUCCESS_BONUS
        self._envp[KE.E_GOAL_TOL] = self.goal_tolerance
        self._envp[KE.E_PUSH_OFFSET] = p["pusher_radius"] + p["ball_radius"]
        self._envp[KE.E_POS_BOUND] = pos_bound
        self._envp[KE.E_VEL_BOUND] = self.vel_bound
        # resting overlap m g / ks puts each ball at rest on the terrain at the start
        rest_depth = self.masses * self.gravity / self.ks_terrain
        # a resting centre sits at radius - m g / ks above the terrain (per ball; the goal as the ball)
        self._rest_radii = np.append(self.radii - rest_depth, self.radii[1] - rest_depth[1])
        self._radii_list = self.radii.tolist()
        self._contact = float(self.radii[0] + self.radii[1])

        # --- per-world state and output buffers, allocated once
        self.goal = np.zeros((B, d))
        self._prev = np.zeros((B, 2))
        self.obs = np.zeros((B, self.obs_size), dtype=np.float32)
        self.out = np.zeros((B, KE.N_OUT))
        self.actions = np.zeros((B, self.action_size))
        self._stepping = np.ones(B, dtype=np.bool_)
        self._status = np.zeros(B, dtype=np.int64)
        self._all = np.arange(B, dtype=np.int64)
        self._chunks = self._split(self._all)
        self._velocity_zeros = np.zeros((B, n, d))
        # one SIMD-lane scratch per thread (the kernel's chunks run concurrently)
        threads = max(1, _threads())
        self._lane_scratch = np.zeros((threads, 6, n, d, LANES))
        self._lane_ids = np.zeros((threads, LANES), dtype=np.int64)
        self._args = self._kernel_args()

    # ------------------------------------------------------------------ construction helpers
    def _placeholder_positions(self) -> np.ndarray:
        """Non-overlapping resting positions on a line (overwritten by the first reset)."""
        d, n = self.dim, len(self.radii)
        pos = np.zeros((self.n_worlds, n, d))
        x = -0.5 * float(np.sum(2.0 * self.radii + 0.1))
        for i, r in enumerate(self.radii):
            x += r + 0.05
            pos[:, i, 0] = x
            pos[:, i, d - 1] = r
            x += r + 0.05
        return pos

    def _obs_bounds(self, pb: float, vb: float) -> tuple[np.ndarray, np.ndarray]:
        d = self.dim
        pos_lo = np.array([-pb] * (d - 1) + [0.0])
        pos_hi = np.array([pb] * (d - 1) + [2.0 * pb])
        vel = np.full(d, vb)
        rel = np.full(d, 2.0 * pb)
        low = [pos_lo, -vel, pos_lo, -vel, pos_lo, -rel, -rel] + [pos_lo, -vel] * self.n_obstacles
        high = [pos_hi, vel, pos_hi, vel, pos_hi, rel, rel] + [pos_hi, vel] * self.n_obstacles
        return np.concatenate(low).astype(np.float32), np.concatenate(high).astype(np.float32)

    def _kernel_args(self) -> tuple:
        """What the kernel steps: the World's own state, model, friction and gravity
        (``World.kernel_state``), so ``World.positions``, ``set_state``, ``energy`` and
        ``max_penetration`` see what the env steps, and the contact model has one source."""
        ks = self.world.kernel_state()
        # x, v: (B, n, d), written in place by the kernel and by set_state
        return (ks.x, ks.v), (ks.model, ks.friction, ks.gravity, self.dt, self.substeps, self._envp, self.goal,
                              self._prev, self.obs, self.out, self._status)

    def _split(self, worlds: np.ndarray) -> list[np.ndarray]:
        work = worlds.size * self.n_balls * self.substeps
        parts = min(_threads(), worlds.size) if work >= PARALLEL_MIN_WORK else 1
        return [c for c in np.array_split(worlds, parts)] if parts > 1 else [worlds]

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        """Advance every world whose ``stepping`` flag is set by one control period, using
        ``self.actions``; observe every world (a world with the flag off was just reset)."""
        self._run(self._all, self._chunks)

    def _run(self, worlds: np.ndarray, chunks: Sequence[np.ndarray]) -> None:
        kernel, act, stepping = KE.step_worlds, self.actions, self._stepping
        (x, v), tail = self._args
        scratch, ids = self._lane_scratch, self._lane_ids
        if len(chunks) == 1:
            code = kernel(worlds, act, stepping, x, v, scratch[0], ids[0], *tail)
        else:
            futures = [_pool().submit(kernel, c, act, stepping, x, v, scratch[i], ids[i], *tail)
                       for i, c in enumerate(chunks)]
            codes = [f.result() for f in futures]
            code = min(codes) if min(codes) < 0 else sum(codes)
        if code != KE.OK:
            self._raise(code)

    def _raise(self, code: int) -> None:
        if code < 0:
            b = -code - 1
            where = "" if self.n_worlds == 1 else f" of world {b}"
            raise ValueError(f"the action{where} contains NaN or inf: {self.actions[b].tolist()}")
        bad = np.flatnonzero(self._status).tolist()
        raise FloatingPointError(
            f"the physics produced NaN or inf in world(s) {bad[:10]} (dt={self.dt:g}, "
            f"substeps={self.substeps}); the scene's parameters are outside what the contact model "
            f"can integrate"
        )

    # ------------------------------------------------------------------ resets
    def reset_worlds(self, worlds: Sequence[int], rngs: Sequence[np.random.Generator], observe: bool = True) -> None:
        """Draw a new start for each world in ``worlds`` from the matching generator in ``rngs``,
        and (``observe``) compute its observation. With ``observe=False`` the world's flag is left
        off, so the next ``step`` observes it without stepping it."""
        idx = np.asarray(worlds, dtype=np.int64)
        # horizontal positions (k, n + 1, d - 1): the balls, then the goal; lifted onto the
        # terrain together below
        flat = np.array([self._sample(rngs[j]) for j in range(idx.size)]).reshape(idx.size, self.n_balls + 1, -1)
        pos = self._on_terrain(flat)
        self.goal[idx] = pos[:, -1]
        self.world.set_state(positions=pos[:, :-1], velocities=self._velocity_zeros[: idx.size], worlds=idx)
        self._stepping[idx] = False
        if observe:
            self._run(idx, self._split(idx))
            self._stepping[idx] = True

    def _on_terrain(self, h: np.ndarray) -> np.ndarray:
        """Centres resting on the terrain at horizontal positions ``h`` (..., n + 1, d - 1): each
        ball sunk by its resting overlap m g / ks; the last slot (the goal) as the ball."""
        R = self.bowl_radius
        depth = R - self._rest_radii  # distance of a resting centre from the bowl's centre
        z = R - np.sqrt(depth**2 - np.sum(h * h, axis=-1))
        return np.concatenate([h, z[..., None]], axis=-1)

    def _sample(self, rng: np.random.Generator) -> list[float]:
        """One start's horizontal coordinates, flat: pusher, ball, obstacles, goal. The draws
        (documented in the env's "Starting State") come in a fixed order. Plain floats: a start is
        a handful of scalars, and numpy's per-call cost would dominate."""
        contact = self._contact
        g0, g1 = GOAL_DISTANCE
        p0, p1 = PUSHER_GAP
        if self.dim == 3:
            u = rng.random(6).tolist()
            rho, phi = BALL_START_RADIUS * math.sqrt(u[0]), 2.0 * math.pi * u[1]
            ball = (rho * math.cos(phi), rho * math.sin(phi))
            dist, phi = g0 + (g1 - g0) * u[2], 2.0 * math.pi * u[3]
            target = (ball[0] + dist * math.cos(phi), ball[1] + dist * math.sin(phi))
            gap, phi = p0 + (p1 - p0) * u[4], 2.0 * math.pi * u[5]
            pusher = (ball[0] + (contact + gap) * math.cos(phi), ball[1] + (contact + gap) * math.sin(phi))
        else:
            u = rng.random(4).tolist()
            ball = (BALL_START_RADIUS * (2.0 * u[0] - 1.0),)
            side = 1.0 if u[1] < 0.5 else -1.0
            # on a line the pusher cannot pass the ball: it starts on the far side from the goal
            target = (ball[0] + side * (g0 + (g1 - g0) * u[2]),)
            pusher = (ball[0] - side * (contact + p0 + (p1 - p0) * u[3]),)
        placed = [pusher, ball]
        if self.n_obstacles:
            self._place_obstacles(rng, placed, target)
        placed.append(target)
        return [c for h in placed for c in h]

    def _place_obstacles(self, rng: np.random.Generator, placed: list, target: tuple) -> None:
        """Rejection sampling: uniform in the obstacle region, clear of every ball and the goal."""
        d = self.dim
        region = OBSTACLE_REGION[d]
        radii = self._radii_list
        r_o = radii[2]
        goal_clear = r_o + self.goal_tolerance
        for _ in range(self.n_obstacles):
            for _ in range(OBSTACLE_TRIES):
                if d == 3:
                    u = rng.random(2).tolist()
                    rho, phi = region * math.sqrt(u[0]), 2.0 * math.pi * u[1]
                    h = (rho * math.cos(phi), rho * math.sin(phi))
                else:
                    h = (region * (2.0 * rng.random() - 1.0),)
                clear = math.dist(h, target) >= goal_clear and all(
                    math.dist(h, q) >= r_o + radii[i] + OBSTACLE_GAP for i, q in enumerate(placed)
                )
                if clear:
                    break
            else:  # pragma: no cover - the density check in check_parameters makes this unreachable
                raise RuntimeError("could not place the obstacles without overlap; use fewer or smaller ones")
            placed.append(h)

    # ------------------------------------------------------------------ read-out
    def info(self, b: int) -> dict[str, Any]:
        """World b's info dict of the last step or reset (Python scalars)."""
        return self.info_from_row(self.out[b].tolist())

    @staticmethod
    def info_from_row(o: list[float]) -> dict[str, Any]:
        """The info dict of one world's ``out`` row (as a list of floats)."""
        return {
            "reward_goal": o[KE.O_REWARD_GOAL],
            "reward_reach": o[KE.O_REWARD_REACH],
            "reward_success": o[KE.O_REWARD_SUCCESS],
            "distance": o[KE.O_DISTANCE],
            "pusher_distance": o[KE.O_PUSHER_DISTANCE],
            "max_overlap": o[KE.O_MAX_OVERLAP],
            "is_success": o[KE.O_SUCCESS] > 0.5,
        }

    # the info dict's keys, in the order of the kernel's ``out`` columns 0 .. N_INFO - 1
    INFO_KEYS = ("reward_goal", "reward_reach", "reward_success", "distance", "pusher_distance", "max_overlap", "is_success")

    def describe(self) -> str:
        """The derived physics, one line."""
        return (
            f"ks={self.ks:.4g} N/m, kd={self.kd:.4g} N s/m, kd_terrain={self.kd_terrain:.4g} N s/m, "
            f"mu={self.mu:g}, kf={self.kf:.4g} N s/m, dt={self.dt:.4g} s x {self.substeps} substeps "
            f"per {self.control_period:g} s step"
        )
