"""``World``: B independent worlds of n balls in a static implicit terrain, stepped in Numba.

The static scene (radii, masses, terrain, stiffness: the *model*) is kept apart from the dynamic
*state* (positions, velocities). Python touches the simulation once per ``step`` call; the steps
themselves, over all worlds, run inside one Numba call.
"""

from __future__ import annotations

import math
import warnings
from concurrent.futures import ThreadPoolExecutor
from typing import Iterable, NamedTuple, Sequence

import numba
import numpy as np

from . import events as _events
from . import kernels as K
from . import lanes as _lanes
from . import theory
from .shapes import Shape, pack_terrain

__all__ = ["World", "KernelState", "GRID_MIN_BALLS", "LANES_MAX_BALLS", "LANES_MIN_WORLDS", "LARGE_WORLD_MIN_BALLS", "NEIGHBOUR_SKIN",
           "STABILITY_SAFETY"]

# ``broadphase="auto"`` uses the grid from this many balls per world (measured crossover:
# ``python -m penalty_env.bench core``, section c).
GRID_MIN_BALLS = 64
# A world this large is stepped with its force loop parallel over balls (symplectic / explicit
# Euler) instead of one world per thread.
LARGE_WORLD_MIN_BALLS = 128
# ... with a Verlet neighbour list: every pair within r_i + r_j + skin, skin = this fraction of the
# largest diameter (rebuilt, and the storage re-sorted by grid cell, once a ball has moved skin / 2)
NEIGHBOUR_SKIN = 0.1
# ... and up to n / 256 (at least 64, at most this many) balls that have moved skin / 2 since (their
# contacts are searched each step, escaped pairs pair by pair) before the list is rebuilt
LARGE_WORLD_MAX_ESCAPES = 256
# All-pairs worlds of at most this many balls step one world per SIMD lane (``lanes``) with
# symplectic / explicit Euler (measured crossover: ``python -m penalty_env.bench core``, section d).
LANES_MAX_BALLS = 24
# ... in batches of at least this many worlds: the vectorised loops take 16 lanes per iteration,
# fewer run their scalar remainder (measured, 6 balls: 0.44x the scalar kernel at 1 world, 0.79x
# at 8, 1.16x at 16, 2.3x at 32)
LANES_MIN_WORLDS = 16
# The guard allows dt <= theory.guard_dt of the stiffest contact: STABILITY_SAFETY x its critical dt,
# and no more than a dense pile's fastest mode allows (a ball in 12 contacts vibrates at twice the
# frequency and twice the damping ratio of one contact; see theory.guard_omega_dt).
STABILITY_SAFETY = theory.GUARD_SAFETY

# Below this many ball-steps per call, threads cost more than they save.
PARALLEL_MIN_WORK = 20_000

_RUNNERS = {
    K.EXPLICIT_EULER: K.run_explicit_euler,
    K.SYMPLECTIC_EULER: K.run_symplectic_euler,
    K.VELOCITY_VERLET: K.run_velocity_verlet,
    K.RK4: K.run_rk4,
    K.IMPLICIT_EULER: K.run_implicit_euler,
}
_POOL: ThreadPoolExecutor | None = None


def _new_grid(B: int, n: int) -> K.Grid:
    """Grid buffers for B worlds of n balls (up to 4 n cells; the cells grow if a ball flies off)."""
    cap = max(4 * n, 64)
    return K.Grid(
        start=np.zeros((B, cap + 1), dtype=np.int64),
        items=np.zeros((B, n), dtype=np.int64),
        cell=np.zeros((B, n), dtype=np.int64),
        geom=np.zeros((B, 7)),
        dims=np.ones((B, 4), dtype=np.int64),
    )


def _thread_count() -> int:
    """Worker threads for batched worlds: NUMBA_NUM_THREADS (default: the CPU count)."""
    return int(numba.config.NUMBA_NUM_THREADS)


def _pool() -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=_thread_count(), thread_name_prefix="penalty_env")
    return _POOL


DAMPING_MODES = ("linear", "no_tension")
BROADPHASES = ("all_pairs", "grid", "auto")


def _float_array(name: str, value, ndim: Sequence[int] | None = None) -> np.ndarray:
    if np.asarray(value).dtype.kind not in "iuf":
        raise ValueError(f"{name} must be an array of real numbers, got dtype {np.asarray(value).dtype}")
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be an array of numbers: {exc}") from None
    if ndim is not None and arr.ndim not in ndim:
        raise ValueError(f"{name} must have {' or '.join(map(str, ndim))} dimensions, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr


def _positive(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number > 0, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def _non_negative(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number >= 0, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return v


def _choice(name: str, value, allowed: Iterable[str]) -> str:
    allowed = tuple(allowed)
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
    return value


class KernelState(NamedTuple):
    """What ``World.kernel_state()`` returns: the arguments of the kernels' step functions."""

    x: np.ndarray  # (B, n, d) positions
    v: np.ndarray  # (B, n, d) velocities
    work: np.ndarray  # (K, B, n, d) integrator scratch
    ext: np.ndarray  # (B, n, d) external force buffer
    grid: object  # kernels.Grid or None (all pairs)
    model: "K.Model"
    friction: tuple | None  # (mu, kf) or None when off
    gravity: tuple


class World:
    """Balls (spheres in 3D, circles in 2D) with penalty contacts, in static implicit terrain.

    Args:
        positions: ``(n, d)`` or ``(B, n, d)`` ball centres, d = 2 or 3; B independent worlds.
        radii, masses: ``(n,)``, shared by the B worlds; > 0.
        velocities: same shape as ``positions``; zeros when None.
        terrain: static :class:`Sphere` / :class:`Bowl` shapes (a single shape is accepted too).
        gravity: length-d acceleration; default ``-9.81`` along the last axis.
        ks, kd: sphere-sphere penalty spring (force/length, > 0) and dashpot (force/speed, >= 0).
        ks_terrain, kd_terrain: sphere-terrain spring and dashpot; default ``ks``, ``kd``.
        damping: ``"linear"`` (the seed's dashpot, which pulls at separation) or
            ``"no_tension"`` (the normal force is clipped at zero, as LAMMPS ``limit_damping``).
        mu, kf: regularised Coulomb friction |f_t| = min(kf |v_t|, mu |f_n|); off when mu = 0.
            ``kf`` (force per sliding speed) defaults to, and may not exceed, ``m_eff / dt`` of
            the lightest contact: the explicit limit at which sliding stops in one step.
        integrator: ``explicit_euler``, ``symplectic_euler``, ``velocity_verlet``, ``rk4`` or
            ``implicit_euler`` (linearised backward Euler, conjugate gradients).
        dt: time step (> 0).
        broadphase: ``all_pairs``, ``grid`` or ``auto`` (grid from ``GRID_MIN_BALLS`` balls).
        allow_unstable: skip the stability guard (for stability studies).
        events: event-located stepping (:mod:`penalty_env.physics.events`): each step stops at
            every contact switch (a contact beginning or ending) and crosses it, which restores
            the integrator's order (RK4: 4th order instead of 1st with damping) at the cost of
            extra force evaluations in the steps that hold a switch. Off by default: then the
            stepping is exactly the plain path.

    Raises:
        ValueError: a bad argument (named in the message), or ``dt`` above the stability limit
            (the message gives the limit and the substeps that meet it).
    """

    def __init__(
        self,
        positions,
        radii,
        masses,
        velocities=None,
        *,
        terrain: Sequence[Shape] | Shape = (),
        gravity=None,
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
        allow_unstable: bool = False,
        events: bool = False,
    ) -> None:
        x = _float_array("positions", positions, ndim=(2, 3))
        self._batched = x.ndim == 3
        if not self._batched:
            x = x[None]
        B, n, d = x.shape
        if d not in (2, 3):
            raise ValueError(f"positions must have last dimension d = 2 or 3, got {d}")
        if n < 1 or B < 1:
            raise ValueError(f"positions must hold at least one ball and one world, got shape {x.shape}")
        self._x = np.ascontiguousarray(x)
        if velocities is None:
            self._v = np.zeros_like(self._x)
        else:
            v = _float_array("velocities", velocities)
            if v.shape != np.shape(positions):
                raise ValueError(f"velocities must have the shape of positions {np.shape(positions)}, got {v.shape}")
            self._v = np.ascontiguousarray(v.reshape(self._x.shape))
        self.radii = _float_array("radii", radii, ndim=(1,))
        self.masses = _float_array("masses", masses, ndim=(1,))
        for name, arr in (("radii", self.radii), ("masses", self.masses)):
            if arr.shape != (n,):
                raise ValueError(f"{name} must have shape ({n},) (one per ball), got {arr.shape}")
            if np.any(arr <= 0.0):
                raise ValueError(f"{name} must all be > 0, got min {arr.min()}")
        self.radii.flags.writeable = False
        self.masses.flags.writeable = False

        if isinstance(terrain, Shape):
            terrain = (terrain,)
        if terrain is None or isinstance(terrain, (str, bytes)) or not hasattr(terrain, "__iter__"):
            raise ValueError(f"terrain must be a Sphere, a Bowl or a sequence of them, got {terrain!r}")
        self.terrain = tuple(terrain)
        kind, center, radius = pack_terrain(self.terrain, d)

        if gravity is None:
            gravity = (0.0,) * (d - 1) + (-9.81,)
        g = _float_array("gravity", gravity, ndim=(1,))
        if g.shape != (d,):
            raise ValueError(f"gravity must have length d = {d}, got {g.shape[0]}")
        self.gravity = tuple(float(c) for c in g)

        self.ks = _positive("ks", ks)
        self.kd = _non_negative("kd", kd)
        self.ks_terrain = self.ks if ks_terrain is None else _positive("ks_terrain", ks_terrain)
        self.kd_terrain = self.kd if kd_terrain is None else _non_negative("kd_terrain", kd_terrain)
        self.damping = _choice("damping", damping, DAMPING_MODES)
        self.mu = _non_negative("mu", mu)
        self.integrator = _choice("integrator", integrator, theory.INTEGRATORS)
        self.dt = _positive("dt", dt)
        self.broadphase = _choice("broadphase", broadphase, BROADPHASES)
        for flag, value in (("allow_unstable", allow_unstable), ("events", events)):
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{flag} must be True or False, got {value!r}")
        self.allow_unstable = bool(allow_unstable)
        if self.integrator == "implicit_euler" and self.damping == "no_tension":
            # its frozen-contact Jacobian cannot see the clip: the solve would pull separating
            # balls together, which is what no_tension exists to prevent
            raise ValueError(
                "damping='no_tension' is not supported with integrator='implicit_euler' (the linearised "
                "solve would reintroduce tension); use damping='linear' or an explicit integrator"
            )
        # Friction's viscous branch -kf v_t is integrated explicitly (also by implicit Euler):
        # it brings sliding to rest without overshoot only while kf dt / m_eff <= 1 (at 2 it
        # reverses v_t every step and feeds energy in). The default sits at that limit, which is
        # the closest a regularised law gets to Coulomb's stick at this dt.
        self.kf_max = self._lightest_contact_mass() / self.dt
        if kf is None:
            kf = self.kf_max
        self.kf = _positive("kf", kf)
        if self.mu > 0.0 and self.kf > self.kf_max * (1.0 + 1e-12) and not self.allow_unstable:
            raise ValueError(
                f"kf={self.kf:g} is above the explicit friction limit m_eff/dt = {self.kf_max:g} "
                f"(lightest contact m_eff={self._lightest_contact_mass():g}, dt={self.dt:g}): sliding would "
                f"overshoot and gain energy. Use kf <= {self.kf_max:g}, a smaller dt, or allow_unstable=True."
            )
        self.events = bool(events)

        self.use_grid = self.broadphase == "grid" or (self.broadphase == "auto" and n >= GRID_MIN_BALLS)
        self._integ = K.INTEGRATOR_CODES[self.integrator]
        self._large = (
            n >= LARGE_WORLD_MIN_BALLS
            and self.use_grid
            and self._integ in (K.SYMPLECTIC_EULER, K.EXPLICIT_EULER)
        )
        # few balls per world, all pairs, symplectic / explicit Euler: one world per SIMD lane
        # (``lanes``: bit-identical to the scalar kernels, faster where most pairs are near)
        self._lanes = (
            not self.use_grid
            and self._integ in (K.SYMPLECTIC_EULER, K.EXPLICIT_EULER)
            and n <= LANES_MAX_BALLS
            and B >= LANES_MIN_WORLDS
        )
        self._model = K.Model(
            radii=self.radii,
            inv_mass=1.0 / self.masses,
            shape_kind=kind,
            shape_center=center,
            shape_radius=radius,
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            no_tension=self.damping == "no_tension",
            cell_size=2.0 * float(self.radii.max()),
        )
        self._friction = (self.mu, self.kf) if self.mu > 0.0 else None

        # buffers, allocated once: nothing is allocated while stepping
        self._work = np.zeros((K.WORK_ARRAYS[self._integ], B, n, d))
        self._a0_valid = np.zeros(B, dtype=np.bool_)
        self._status = np.zeros(B, dtype=np.int64)
        self._ext = np.zeros((B, n, d))
        self._scalar = np.zeros(B)
        self._events = _events.allocate(B, n, d) if self.events else None
        if self._lanes:
            self._lane_scratch = np.zeros((max(1, _thread_count()), 5, n, d, _lanes.LANES))
        if self.use_grid:
            self._grid = _new_grid(B, n)
        else:
            self._grid = None  # all pairs: the kernels compile without the grid code
        # each large world keeps a copy of its state sorted by grid cell (memory locality) and a
        # neighbour list, with the Model's radii / inv_mass in the same order (its own arrays,
        # permuted with the balls) and a grid cell wide enough for the list's reach
        self._larges = []
        if self._large and not self.events:
            skin = NEIGHBOUR_SKIN * 2.0 * float(self.radii.max())
            for _ in range(B):
                self._larges.append((
                    self._new_large(4 * (d - 1) ** 2 + 5, skin),
                    self._model._replace(radii=self.radii.copy(), inv_mass=1.0 / self.masses,
                                         cell_size=self._model.cell_size + skin),
                ))
            self._reset_large()
        self.cg_tol = 1e-10
        self.cg_max_iter = max(50, 4 * n * d)

        self.dt_max = self.stability_limit()
        if self.dt > self.dt_max and not self.allow_unstable:
            raise ValueError(self._stability_message())

    # ---------------------------------------------------------------- stability
    def _lightest_contact_mass(self) -> float:
        """Smallest effective mass of any contact the scene can form (pair or ball-terrain)."""
        m = np.sort(self.masses)
        pair = m[0] * m[1] / (m[0] + m[1]) if m.size >= 2 else math.inf
        return float(min(pair, m[0]))

    def _stiffest_contacts(self) -> list[tuple[str, float, float, float]]:
        """(label, ks, kd, m_eff) of the extreme contacts this scene can form."""
        m = np.sort(self.masses)
        out = []
        if m.size >= 2:
            for a, b in ((m[0], m[1]), (m[-2], m[-1])):
                out.append(("ball-ball", self.ks, self.kd, a * b / (a + b)))
        if self.terrain:
            for mi in (m[0], m[-1]):
                out.append(("ball-terrain", self.ks_terrain, self.kd_terrain, float(mi)))
        return out

    def stability_limit(self) -> float:
        """Largest dt the guard accepts: ``theory.guard_dt`` of the stiffest contact, STABILITY_SAFETY
        x its critical dt (PHYSICS.md section 4) or less when damped (a dense pile's fastest mode,
        twice the frequency and twice the damping ratio, must be stable too); inf when the scene can
        form no contact or the integrator is implicit; 0 for explicit Euler on undamped contacts
        (unstable at any dt)."""
        limits = [theory.guard_dt(self.integrator, ks, kd, me) for _, ks, kd, me in self._stiffest_contacts()]
        return min(limits) if limits else math.inf

    def _stability_message(self) -> str:
        worst = min(self._stiffest_contacts(), key=lambda c: theory.guard_dt(self.integrator, c[1], c[2], c[3]))
        label, ks, kd, me = worst
        omega = theory.natural_frequency(ks, me)
        zeta = theory.damping_ratio(ks, kd, me)
        head = (
            f"dt={self.dt:g} is above the stability limit of {self.integrator} for the stiffest "
            f"{label} contact (ks={ks:g}, kd={kd:g}, m_eff={me:g}: omega*dt={omega * self.dt:.3g}, zeta={zeta:.3g})"
        )
        if self.dt_max <= 0.0:
            return (
                f"{head}: explicit Euler gains energy at any dt on a contact with zeta={zeta:.3g} "
                f"(it is stable only for omega*dt <= 2 zeta). Add damping (kd > 0), choose another "
                f"integrator, or pass allow_unstable=True."
            )
        substeps = math.ceil(self.dt / self.dt_max)
        return (
            f"{head}. The guard allows dt <= {self.dt_max:.6g} (the contact's critical dt is "
            f"{theory.critical_dt(self.integrator, ks, kd, me):.6g}; the guard keeps {STABILITY_SAFETY}x of it, "
            f"less for a damped contact, whose dense-pile mode fails sooner): use {substeps} substeps of "
            f"{self.dt / substeps:.6g} per step of {self.dt:g}, or pass allow_unstable=True."
        )

    # ---------------------------------------------------------------- state
    @property
    def n_worlds(self) -> int:
        return self._x.shape[0]

    @property
    def n_balls(self) -> int:
        return self._x.shape[1]

    @property
    def dim(self) -> int:
        return self._x.shape[2]

    @property
    def force_evaluations_per_step(self) -> int:
        """Full contact passes per step (implicit Euler: one, plus its CG iterations' products)."""
        return {K.RK4: 4}.get(self._integ, 1)

    def _view(self, arr: np.ndarray) -> np.ndarray:
        out = arr if self._batched else arr[0]
        out = out.view()
        out.flags.writeable = False  # write through set_state, which keeps caches coherent
        return out

    @property
    def positions(self) -> np.ndarray:
        """Current centres, shaped as given (read-only view; change them with ``set_state``)."""
        return self._view(self._x)

    @property
    def velocities(self) -> np.ndarray:
        """Current velocities, shaped as given (read-only view)."""
        return self._view(self._v)

    @positions.setter
    def positions(self, value) -> None:
        self.set_state(positions=value)

    @velocities.setter
    def velocities(self, value) -> None:
        self.set_state(velocities=value)

    def set_state(self, positions=None, velocities=None, worlds=None) -> None:
        """Overwrite positions and/or velocities, of all worlds or of the worlds indexed by
        ``worlds`` (then the arrays are ``(len(worlds), n, d)``)."""
        if worlds is not None and np.asarray(worlds).dtype.kind not in "iu":
            raise ValueError(f"worlds must be integer world indices, got dtype {np.asarray(worlds).dtype}")
        idx = slice(None) if worlds is None else np.atleast_1d(np.asarray(worlds, dtype=np.int64))
        if worlds is not None and (idx.size and (idx.min() < 0 or idx.max() >= self.n_worlds)):
            raise ValueError(f"worlds must index 0..{self.n_worlds - 1}, got {worlds!r}")
        target = (self.n_worlds if worlds is None else idx.size,) + self._x.shape[1:]
        for name, value, dest in (("positions", positions, self._x), ("velocities", velocities, self._v)):
            if value is None:
                continue
            arr = _float_array(name, value)
            if not self._batched and worlds is None:
                arr = arr[None] if arr.ndim == 2 else arr
            if arr.shape != target:
                raise ValueError(f"{name} must have shape {target if self._batched or worlds is not None else target[1:]}, got {np.shape(value)}")
            dest[idx] = arr
        self._a0_valid[idx] = False
        self._reset_large(idx)

    def _new_large(self, cap: int, skin: float) -> K.LargeWorld:
        n, d = self.n_balls, self.dim
        return K.LargeWorld(
            x=np.zeros((1, n, d)), v=np.zeros((1, n, d)), a=np.zeros((1, n, d)), ext=np.zeros((1, n, d)),
            grid=_new_grid(1, n), perm=np.arange(n), order=np.zeros(n, dtype=np.int64),
            itmp=np.zeros(n, dtype=np.int64), tmp=np.zeros((n, max(d, 2))), nbr=np.zeros((n, cap), dtype=np.int32),
            count=np.zeros(n, dtype=np.int32), near=np.zeros(n, dtype=np.int8), xref=np.zeros((n, d)),
            escaped=np.zeros(n, dtype=np.int8),
            escapes=np.zeros(int(np.clip(n // 256, 64, LARGE_WORLD_MAX_ESCAPES)), dtype=np.int64),
            moved=np.zeros(max(1, _thread_count()), dtype=np.int64),  # one per thread
            skin=skin, state=np.zeros(4, dtype=np.int64),
        )

    def _reset_large(self, worlds=slice(None)) -> None:
        """A large world's storage order and neighbour list are history: after new state, start
        afresh, so the world steps exactly as a new World made from that state would."""
        if not self._larges:
            return
        for b in np.atleast_1d(np.arange(self.n_worlds)[worlds]):
            lw, model = self._larges[b]
            lw.perm[:] = np.arange(self.n_balls)
            lw.state[0] = 0
            model.radii[:] = self.radii
            model.inv_mass[:] = 1.0 / self.masses

    def _step_large(self, n: int, ext) -> None:
        for b, (lw, model) in enumerate(self._larges):
            w = slice(b, b + 1)
            done = 0
            while done < n:
                done += K.run_large(self._integ, n - done, self.dt, self._x[w], self._v[w],
                                    None if ext is None else ext[w], model, self._friction, self.gravity,
                                    self._status[w], lw, max(1, _thread_count()))
                if self._status[b] != K.STATUS_OK:
                    break
                if done < n:  # a ball has more neighbours than the list holds: grow it, go on
                    grown = self._new_large(int(lw.state[1]) + 9, lw.skin)
                    for field in ("perm", "state"):
                        getattr(grown, field)[:] = getattr(lw, field)
                    lw = grown
                    self._larges[b] = (lw, model)

    def kernel_state(self) -> KernelState:
        """The World's own buffers and model as the Numba kernels take them, for code that fuses
        its own per-step work with the core's step functions (the environments do). Writing the
        arrays changes the World's state; call ``invalidate_cache`` after writing positions or
        velocities (velocity Verlet's cached force and a large world's neighbour list are then
        stale)."""
        return KernelState(self._x, self._v, self._work, self._ext, self._grid, self._model, self._friction,
                           self.gravity)

    def invalidate_cache(self, worlds=None) -> None:
        """Forget what was derived from the state (velocity Verlet's cached acceleration, a large
        world's neighbour list and storage order), after writing state directly."""
        self._a0_valid[slice(None) if worlds is None else worlds] = False
        self._reset_large(slice(None) if worlds is None else worlds)

    # ---------------------------------------------------------------- stepping
    def step(self, n: int = 1, forces=None) -> None:
        """Advance every world by ``n`` steps of ``dt``; ``forces`` (external force per ball,
        shaped like ``positions``) is held constant over the n steps."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n (number of steps) must be an int >= 0, got {n!r}")
        ext = None
        if forces is not None:
            f = np.asarray(forces, dtype=np.float64)
            expected = self._x.shape if self._batched else self._x.shape[1:]
            if f.shape != expected:
                raise ValueError(f"forces must have the shape of positions {expected}, got {f.shape}")
            if not np.all(np.isfinite(f)):
                raise ValueError("forces contains NaN or inf")
            self._ext[...] = f if self._batched else f[None]
            ext = self._ext
        if n == 0:
            return
        if self._events is not None:
            _events.run(self, int(n), ext)
        elif self._large:
            self._step_large(int(n), ext)
        else:
            self._run_worlds(int(n), ext)
        self._check_status()

    def _run_worlds(self, n: int, ext, runners=None, extra: tuple = ()) -> None:
        """Run the integrator's driver over world ranges, spread over threads when it pays.
        ``runners``/``extra``: another driver table and the arguments it takes before ``status``
        (event location uses this)."""
        integ = self._integ
        B = self.n_worlds
        threads = _thread_count()
        parts = 1 if threads < 2 or B < 2 or B * self.n_balls * n < PARALLEL_MIN_WORK else min(threads, B)
        if self._lanes and runners is None:
            # ranges in whole blocks of LANES worlds, one lane scratch per range
            blocks = -(-B // _lanes.LANES)
            parts = min(parts, blocks)
            bounds = np.minimum(np.linspace(0, blocks, parts + 1).astype(int) * _lanes.LANES, B)
            sym = integ == K.SYMPLECTIC_EULER
            calls = [
                (_lanes.run_lanes, (sym, int(b0), int(b1), n, self.dt, self._x, self._v, self._lane_scratch[i], ext,
                                    self._model, self._friction, self.gravity, self._status))
                for i, (b0, b1) in enumerate(zip(bounds[:-1], bounds[1:]))
            ]
        else:
            tail = (self._x, self._v, self._work)
            common = (self._grid, self._model, self._friction, self.gravity)
            if integ == K.VELOCITY_VERLET:
                args = (n, self.dt) + tail + (self._a0_valid, ext) + common + extra + (self._status,)
            elif integ == K.IMPLICIT_EULER:
                args = (n, self.dt) + tail + (ext,) + common + (self.cg_tol, self.cg_max_iter) + extra + (self._status,)
            else:
                args = (n, self.dt) + tail + (ext,) + common + extra + (self._status,)
            fn = (runners or _RUNNERS)[integ]
            bounds = np.linspace(0, B, parts + 1).astype(int)
            calls = [(fn, (int(b0), int(b1)) + args) for b0, b1 in zip(bounds[:-1], bounds[1:])]
        if len(calls) == 1:
            calls[0][0](*calls[0][1])
            return
        futures = [_pool().submit(fn, *a) for fn, a in calls]
        for f in futures:
            f.result()

    def _check_status(self) -> None:
        bad = np.flatnonzero(self._status == K.STATUS_NONFINITE)
        if bad.size:
            raise FloatingPointError(
                f"the simulation produced NaN or inf in world(s) {bad[:10].tolist()} (dt={self.dt:g}, "
                f"integrator={self.integrator}, allow_unstable={self.allow_unstable}); reduce dt"
            )
        if np.any(self._status == K.STATUS_CG):
            warnings.warn(
                f"implicit_euler: conjugate gradients did not reach tol {self.cg_tol:g} in "
                f"{self.cg_max_iter} iterations; the step used the last iterate",
                RuntimeWarning,
                stacklevel=3,
            )

    # ---------------------------------------------------------------- diagnostics
    def _per_world(self, out: np.ndarray):
        return out.copy() if self._batched else float(out[0])

    def energy(self):
        """Kinetic + gravitational + penalty-spring potential (1/2 ks overlap^2), per world."""
        K.world_energy(self._x, self._v, self._grid, self._model, self.gravity, self._scalar)
        return self._per_world(self._scalar)

    def max_penetration(self):
        """Largest overlap as a fraction of the (smaller) radius in contact, per world."""
        K.world_max_penetration(self._x, self._v, self._grid, self._model, self.gravity, self._scalar)
        return self._per_world(self._scalar)

    def momentum(self):
        """Total linear momentum per world, ``(d,)`` or ``(B, d)``."""
        p = np.einsum("bnd,n->bd", self._v, self.masses)
        return p if self._batched else p[0]

    def __repr__(self) -> str:
        return (
            f"World(B={self.n_worlds}, n={self.n_balls}, d={self.dim}, integrator={self.integrator!r}, "
            f"dt={self.dt:g}, broadphase={'grid' if self.use_grid else 'all_pairs'}, terrain={len(self.terrain)} shapes)"
        )
