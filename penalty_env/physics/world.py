"""``World``: B independent worlds of n balls in a static implicit terrain, stepped in Numba.

The public face of the core: it validates the arguments, builds the scene's :class:`~.model.Model`
and :class:`~.model.State`, applies the stability guard, and hands the stepping to its
:class:`~.runner.Runner`. Python touches the simulation once per ``step`` call; the steps
themselves, over all worlds, run inside Numba.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _validate as V
from . import diagnostics as _diagnostics
from . import theory
from .broadphase import GRID_MIN_BALLS, new_grid
from .geometry import columns as _columns
from .geometry import evaluate as _evaluate_shapes
from .geometry import geometry_shape_count, pose_columns
from .integrators import INTEGRATORS, STATUS_CG, STATUS_NONFINITE, allocate_work
from .lanes import LANES_MAX_BALLS, LANES_MIN_WORLDS
from .model import Model, State
from .neighbour_list import LARGE_WORLD_MIN_BALLS, NEIGHBOUR_SKIN
from .rotation import TANGENTIAL, Spin, inertia_factor, new_spin
from .runner import PATHS, Runner
from .shapes import SDF, HeightField, Shape, is_static_round, pack_geometry, pack_terrain

__all__ = [
    "World",
    "EnergyDriftWarning",
    "StartOverlapWarning",
    "GRID_MIN_BALLS",
    "LANES_MAX_BALLS",
    "LANES_MIN_WORLDS",
    "LARGE_WORLD_MIN_BALLS",
    "NEIGHBOUR_SKIN",
    "STABILITY_SAFETY",
    "DAMPING_MODES",
    "BROADPHASES",
    "STEPPING",
    "TANGENTIAL",
]

# The guard allows dt <= theory.guard_dt of the stiffest contact: STABILITY_SAFETY x its critical dt,
# and no more than a dense pile's fastest mode allows (a ball in 12 contacts vibrates at twice the
# frequency and twice the damping ratio of one contact; see theory.guard_omega_dt).
STABILITY_SAFETY = theory.GUARD_SAFETY

DAMPING_MODES = ("linear", "no_tension")
BROADPHASES = ("all_pairs", "grid", "auto")
STEPPING = ("auto",) + PATHS
_EULERS = ("symplectic_euler", "explicit_euler")
MAX_STEPS_PER_CALL = 2**62  # ``step(n)``: the kernels count steps in int64
# the tangential springs' history is stored per ball pair and per ball and shape: refuse a scene
# whose store would exceed this (the neighbour list, which would store it per listed pair, refuses
# rotation for now)
MAX_HISTORY_BYTES = 2 * 2**30


def _probe_user(shape: Shape, x: np.ndarray) -> None:
    """Refuse a user SDF that is not finite where the balls start or on a
    lattice over their bounding box grown by twice its size (at least 2 either side) each way."""
    lo, hi = x.reshape(-1, x.shape[-1]).min(0), x.reshape(-1, x.shape[-1]).max(0)
    span = np.maximum(hi - lo, 1.0)
    axes = [np.linspace(lo[k] - 2.0 * span[k], hi[k] + 2.0 * span[k], 7) for k in range(x.shape[-1])]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, x.shape[-1])
    points = np.concatenate([x.reshape(-1, x.shape[-1])[:4096], lattice])
    assert isinstance(shape, SDF)
    shape.probe(points)


def _per_world(name: str, value: Any, shape: tuple[int, ...], count: int) -> np.ndarray:
    """``value`` of ``shape``, or one per world (``(count,) + shape``); finite."""
    arr = V.real_array(name, value)
    if arr.shape == (1,) and shape == ():
        arr = arr.reshape(())
    if arr.shape != shape and arr.shape != (count,) + shape:
        raise ValueError(
            f"{name} must have shape {shape} (all chosen worlds) or {(count,) + shape} (one per world), got {arr.shape}"
        )
    return arr


class StartOverlapWarning(RuntimeWarning):
    """A state in which two balls, or a ball and the terrain, overlap by the smaller radius or more:
    the spring stores more energy than the contact model resolves (it launches the balls fast
    enough to drive other contacts through each other)."""


class EnergyDriftWarning(RuntimeWarning):
    """A time step at which elastic collisions gain energy on average beyond
    ``theory.ENERGY_BUDGET`` (docs/physics.md section 6): stable, but a scene of many collisions
    heats up."""


class World:
    """Balls (spheres in 3D, circles in 2D) with penalty contacts, in static implicit terrain.

    Args:
        positions: ``(n, d)`` or ``(B, n, d)`` ball centres, d = 2 or 3; B independent worlds.
        radii, masses: ``(n,)``, shared by the B worlds; > 0.
        velocities: same shape as ``positions``; zeros when None.
        terrain: the shapes (:mod:`penalty_env.physics.shapes`: spheres, bowls, planes, boxes,
            capsules, cylinders, cones, tori, height fields, CSG, a user's SDF; a single shape is
            accepted too). Static spheres and bowls run in the core's original code; the other
            shapes compile into the step by kind (a scene pays for the kinds it has). Kinematic
            shapes (given a velocity or angular velocity) move on every step, and
            :meth:`set_shape_pose` moves any shape between steps.
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
        stepping: how the batch is stepped (the result is the same up to round-off, and bit for
            bit between ``scalar`` and ``lanes``): ``auto`` (the fastest that applies), ``scalar``
            (one world at a time per thread; every integrator), ``lanes`` (a block of worlds per
            SIMD vector: all pairs, symplectic or explicit Euler) or ``neighbour_list`` (each world
            through its own Verlet list: a batch a share of its worlds per thread, a single large
            world parallel over its balls; the grid, symplectic or explicit Euler).
        allow_unstable: skip the stability guard (for stability studies).
        events: event-located stepping (:mod:`penalty_env.physics.events`): each step stops at
            every contact switch (a contact beginning or ending) and crosses it, which restores
            the integrator's order (RK4: 4th order instead of 1st with damping) at the cost of
            extra force evaluations in the steps that hold a switch. Off by default: then the
            stepping is exactly the plain path. Only with ``stepping`` ``auto`` or ``scalar``.

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
        events: bool = False,
        rotation: bool = False,
        tangential: str = "coulomb",
        kt: float | None = None,
        kd_t: float | None = None,
        mu_r: float = 0.0,
        kr: float | None = None,
    ) -> None:
        x = V.real_array("positions", positions, ndim=(2, 3))
        self._batched = x.ndim == 3
        if not self._batched:
            x = x[None]
        B, n, d = x.shape
        if d not in (2, 3):
            raise ValueError(f"positions must have last dimension d = 2 or 3, got {d}")
        if n < 1 or B < 1:
            raise ValueError(f"positions must hold at least one ball and one world, got shape {x.shape}")
        x = np.ascontiguousarray(x)
        if velocities is None:
            v = np.zeros_like(x)
        else:
            v = V.real_array("velocities", velocities)
            if v.shape != np.shape(positions):
                raise ValueError(f"velocities must have the shape of positions {np.shape(positions)}, got {v.shape}")
            v = np.ascontiguousarray(v.reshape(x.shape))
        self.radii = V.real_array("radii", radii, ndim=(1,))
        self.masses = V.real_array("masses", masses, ndim=(1,))
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
            raise ValueError(
                f"terrain must be a Shape (Sphere, Bowl, Plane, Box, ..., from penalty_env.physics) or a sequence "
                f"of shapes, got {V.describe(terrain)}"
            )
        self.terrain = tuple(terrain)
        for k, shape in enumerate(self.terrain):
            if not isinstance(shape, Shape):
                raise V.ArgumentTypeError(f"terrain[{k}] must be a Shape, got {V.describe(shape)}")
            if shape.dim != d:
                raise ValueError(f"terrain[{k}] is {shape.dim}D but positions are {d}D")
        # static spheres and bowls: the original kernel code; every other shape: the Geometry
        legacy = [k for k, shape in enumerate(self.terrain) if is_static_round(shape)]
        general = [k for k in range(len(self.terrain)) if k not in legacy]
        kind, center, radius = pack_terrain([self.terrain[k] for k in legacy], d)
        geometry, where = pack_geometry([self.terrain[k] for k in general], B, d)
        # terrain[k] -> ("legacy", index) or (geometry group, index within it)
        self._shape_slot: dict[int, tuple[str, int]] = {k: ("legacy", j) for j, k in enumerate(legacy)}
        self._shape_slot.update({k: where[j] for j, k in enumerate(general)})
        for shape in self.terrain:
            if isinstance(shape, SDF):
                _probe_user(shape, x)

        if gravity is None:
            gravity = (0.0,) * (d - 1) + (-9.81,)
        g = V.real_array("gravity", gravity, ndim=(1,))
        if g.shape != (d,):
            raise ValueError(f"gravity must have length d = {d}, got {g.shape[0]}")
        self.gravity = tuple(float(c) for c in g)

        self.ks = V.positive("ks", ks)
        self.kd = V.non_negative("kd", kd)
        self.ks_terrain = self.ks if ks_terrain is None else V.positive("ks_terrain", ks_terrain)
        self.kd_terrain = self.kd if kd_terrain is None else V.non_negative("kd_terrain", kd_terrain)
        self.damping = V.choice("damping", damping, DAMPING_MODES)
        self.mu = V.non_negative("mu", mu)
        self.integrator = V.choice("integrator", integrator, INTEGRATORS)
        self.dt = V.positive("dt", dt)
        self.broadphase = V.choice("broadphase", broadphase, BROADPHASES)
        stepping = V.choice("stepping", stepping, STEPPING)
        self.allow_unstable = V.flag("allow_unstable", allow_unstable)
        self.events = V.flag("events", events)
        self.rotation = V.flag("rotation", rotation)
        self.tangential = V.choice("tangential", tangential, TANGENTIAL)
        self.mu_r = V.non_negative("mu_r", mu_r)
        if not self.rotation and self.mu_r != 0.0:
            raise ValueError(
                f"mu_r={self.mu_r!r} needs rotation=True (rolling resistance acts on the balls' spin); pass "
                "rotation=True or leave mu_r at 0"
            )
        # the rotating contact law: with rotation, or for the history model on balls that slide
        self._spinning = self.rotation or self.tangential == "history"
        if self._spinning and self.events:
            raise ValueError("events=True does not support rotation=True or tangential='history' yet: use events=False")
        if self.tangential == "history" and self.integrator not in _EULERS:  # (checked before the path)
            raise ValueError(
                f"tangential='history' advances each contact's spring once per step, which needs an integrator "
                f"with one force pass per step: symplectic_euler or explicit_euler (got {self.integrator!r})"
            )
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
        self.kf_max = self._lightest_tangential_mass() / self.dt
        if kf is None:
            kf = self.kf_max
        self.kf = V.positive("kf", kf)
        if self.mu > 0.0 and self.kf > self.kf_max * (1.0 + 1e-12) and not self.allow_unstable:
            raise ValueError(
                f"kf={self.kf:g} is above the explicit friction limit m_eff/dt = {self.kf_max:g} "
                f"(lightest contact {'tangential ' if self.rotation else ''}m_eff={self._lightest_tangential_mass():g}, "
                f"dt={self.dt:g}): sliding would overshoot and gain energy. Use kf <= {self.kf_max:g}, a smaller dt, "
                "or allow_unstable=True."
            )
        self.kt = 2.0 / 7.0 * self.ks if kt is None else V.positive("kt", kt)
        self.kd_t = 0.5 * self.kd if kd_t is None else V.non_negative("kd_t", kd_t)
        self.kr_max = self._lightest_inertia() / self.dt if self.rotation else math.inf
        self.kr = (self.kr_max if kr is None else V.positive("kr", kr)) if self.rotation else 0.0
        if self.mu_r > 0.0 and self.kr > self.kr_max * (1.0 + 1e-12) and not self.allow_unstable:
            raise ValueError(
                f"kr={self.kr:g} is above the explicit rolling-resistance limit I_eff/dt = {self.kr_max:g} "
                f"(lightest contact I_eff={self._lightest_inertia():g}, dt={self.dt:g}): rolling would overshoot "
                f"and gain energy. Use kr <= {self.kr_max:g}, a smaller dt, or allow_unstable=True."
            )

        self.use_grid = self.broadphase == "grid" or (self.broadphase == "auto" and n >= GRID_MIN_BALLS)
        self.stepping = self._stepping_path(stepping, B, n)
        self._spin: Spin | None = None
        if self._spinning:
            slots = len(legacy) + geometry_shape_count(geometry)
            history = self.tangential == "history" and self.mu > 0.0
            need = B * n * (n + slots) * 32 if history else 0
            if need > MAX_HISTORY_BYTES:
                raise ValueError(
                    f"tangential='history' stores a spring per ball pair and per ball and shape: {B} worlds of {n} "
                    f"balls would need {need / 2**30:.3g} GiB, above {MAX_HISTORY_BYTES / 2**30:g} GiB; use fewer "
                    "balls per world, or tangential='coulomb'"
                )
            self._spin = new_spin(
                B,
                n,
                d,
                self.masses,
                self.radii,
                slots,
                rotation=self.rotation,
                mu=self.mu,
                kf=self.kf,
                kt=self.kt if history else 0.0,
                kd_t=self.kd_t,
                mu_r=self.mu_r,
                kr=self.kr,
                dt=self.dt,
            )
        self._model = Model(
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
            mu=self.mu,
            kf=self.kf,
            gravity_vector=np.array(self.gravity),
            geometry=geometry,
        )
        # buffers, allocated once: nothing is allocated while stepping
        self._state = State(x, v)
        self._status = np.zeros(B, dtype=np.int64)
        self._ext = np.zeros((B, n, d))
        self._scalar = np.zeros(B)
        self._deepest = np.zeros(B)
        self._all_worlds = np.arange(B, dtype=np.int64)
        self._grid = new_grid(B, n) if self.use_grid else None  # None: all pairs, compiled without the grid
        self._runner = Runner(
            self.stepping,
            self.integrator,
            self.events,
            self._model,
            self._state,
            allocate_work(self.integrator, B, n, d),
            self._grid,
            self._status,
            self.dt,
            friction=self._spin,
        )

        self.dt_max = self.stability_limit()
        if self.dt > self.dt_max and not self.allow_unstable:
            raise ValueError(self._stability_message())
        self._check_start(self._all_worlds)
        self.dt_energy = self.energy_limit()
        if self.dt > self.dt_energy and not self.allow_unstable:
            warnings.warn(self._energy_message(), EnergyDriftWarning, stacklevel=2)

    def _stepping_path(self, stepping: str, B: int, n: int) -> str:
        """The stepping path: the one asked for (refused where it does not apply) or, for ``auto``,
        the fastest that applies (measured crossovers: ``python -m penalty_env.bench core``)."""
        if self.events and any(slot[0] != "legacy" for slot in self._shape_slot.values()):
            raise ValueError(
                "events=True locates contact switches of spheres and bowls only; this terrain has "
                f"{', '.join(sorted({type(t).__name__ for t in self.terrain if not is_static_round(t)}))}: "
                "use events=False (and a smaller dt for the same accuracy)"
            )
        euler = self.integrator in _EULERS
        if self._spinning and stepping in ("lanes", "neighbour_list"):
            raise ValueError(
                f"stepping={stepping!r} does not support rotation=True or tangential='history' yet: use "
                "stepping='scalar' or 'auto'"
            )
        if stepping == "auto":
            if self.events or self._spinning:
                return "scalar"
            if n >= LARGE_WORLD_MIN_BALLS and self.use_grid and euler:
                return "neighbour_list"
            if not self.use_grid and euler and n <= LANES_MAX_BALLS and B >= LANES_MIN_WORLDS:
                return "lanes"
            return "scalar"
        if self.events and stepping != "scalar":
            raise ValueError(
                f"stepping={stepping!r} cannot locate events; with events=True use stepping='scalar' or 'auto'"
            )
        if stepping == "lanes" and (self.use_grid or not euler):
            raise ValueError(
                f"stepping='lanes' needs broadphase='all_pairs' (got {self.broadphase!r}, "
                f"{'grid' if self.use_grid else 'all pairs'}) and symplectic or explicit Euler "
                f"(got {self.integrator!r})"
            )
        if stepping == "neighbour_list" and (not self.use_grid or not euler):
            raise ValueError(
                f"stepping='neighbour_list' needs the grid (broadphase='grid', or 'auto' from "
                f"{GRID_MIN_BALLS} balls; got {self.broadphase!r} with {n} balls) and symplectic or "
                f"explicit Euler (got {self.integrator!r})"
            )
        return stepping

    # ---------------------------------------------------------------- stability
    def _lightest_contact_mass(self) -> float:
        """Smallest effective mass of any contact the scene can form (pair or ball-terrain)."""
        m = np.sort(self.masses)
        pair = theory.effective_mass(m[0], m[1]) if m.size >= 2 else math.inf
        return float(min(pair, m[0]))

    def _lightest_tangential_mass(self) -> float:
        """The smallest effective mass a tangential force sees: m_eff, or with rotation
        1 / sum(1/m + r^2/I) = m_eff c / (1 + c), c = I / (m r^2)."""
        if not self.rotation:
            return self._lightest_contact_mass()
        c = inertia_factor(len(self.gravity))
        return self._lightest_contact_mass() * c / (1.0 + c)

    def _lightest_inertia(self) -> float:
        """The smallest effective moment of inertia of a contact (pair: 1 / (1/I_i + 1/I_j))."""
        inertia = np.sort(inertia_factor(len(self.gravity)) * self.masses * self.radii**2)
        pair = theory.effective_mass(inertia[0], inertia[1]) if inertia.size >= 2 else math.inf
        return float(min(pair, inertia[0]))

    def _tangential_springs(self) -> list[tuple[str, float, float, float]]:
        """(label, kt, kd_t, tangential m_eff) of the extreme contacts' tangential springs (the
        history model), which the guard holds to the same limit as a normal spring."""
        if self._spin is None or self._spin.kt <= 0.0:
            return []
        c = inertia_factor(self.dim)
        share = c / (1.0 + c) if self.rotation else 1.0
        return [
            (f"{label} tangential spring", self.kt, self.kd_t, me * share)
            for label, _, _, me in self._stiffest_contacts()
        ]

    def _stiffest_contacts(self) -> list[tuple[str, float, float, float]]:
        """(label, ks, kd, m_eff) of the extreme contacts this scene can form."""
        m = np.sort(self.masses)
        out = []
        if m.size >= 2:
            for a, b in ((m[0], m[1]), (m[-2], m[-1])):
                out.append(("ball-ball", self.ks, self.kd, theory.effective_mass(a, b)))
        if self.terrain:
            for mi in (m[0], m[-1]):
                out.append(("ball-terrain", self.ks_terrain, self.kd_terrain, float(mi)))
        return out

    def stability_limit(self) -> float:
        """Largest dt the guard accepts: ``theory.guard_dt`` of the stiffest contact, STABILITY_SAFETY
        x its critical dt (docs/physics.md, "Stability") or less when damped (a dense pile's fastest
        mode, twice the frequency and twice the damping ratio, must be stable too); inf when the
        scene can form no contact or the integrator is implicit; 0 for explicit Euler on undamped
        contacts (unstable at any dt)."""
        springs = self._stiffest_contacts() + self._tangential_springs()
        limits = [theory.guard_dt(self.integrator, ks, kd, me) for _, ks, kd, me in springs]
        return min(limits) if limits else math.inf

    def energy_limit(self) -> float:
        """Largest dt at which no contact the scene can form gains more than ``theory.ENERGY_BUDGET``
        of its energy per collision on average (``theory.energy_dt``; docs/physics.md section 6). A
        larger dt is accepted with an :class:`EnergyDriftWarning`."""
        limits = [
            theory.energy_dt(self.integrator, ks, kd, me, self.damping) for _, ks, kd, me in self._stiffest_contacts()
        ]
        return min(limits) if limits else math.inf

    def _energy_message(self) -> str:
        label, ks, kd, me = min(
            self._stiffest_contacts(), key=lambda c: theory.energy_dt(self.integrator, c[1], c[2], c[3], self.damping)
        )
        omega = theory.natural_frequency(ks, me)
        zeta = theory.damping_ratio(ks, kd, me)
        gain = theory.energy_gain_envelope(self.integrator, omega * self.dt, zeta, self.damping)
        substeps = math.ceil(self.dt / self.dt_energy) if self.dt_energy > 0.0 else math.inf
        return (
            f"dt={self.dt:g}: a {label} contact (ks={ks:g}, kd={kd + 0.0:g}, m_eff={me:g}: omega*dt={omega * self.dt:.3g}, "
            f"zeta={abs(zeta):.3g}) can gain up to {gain:.3g} of its energy per collision on average with "
            f"{self.integrator} at this step, above the budget of {theory.ENERGY_BUDGET:g} (1% per 1,000 collisions): "
            f"a scene of many collisions heats up. dt <= {self.dt_energy:.6g} ({substeps} substeps per step of "
            f"{self.dt:g}) keeps it within the budget; more damping does too; allow_unstable=True silences this warning."
        )

    def _stability_message(self) -> str:
        springs = self._stiffest_contacts() + self._tangential_springs()
        worst = min(springs, key=lambda c: theory.guard_dt(self.integrator, c[1], c[2], c[3]))
        label, ks, kd, me = worst
        spring = label.endswith("tangential spring")  # the history model's kt and kd_t
        omega = theory.natural_frequency(ks, me)
        zeta = theory.damping_ratio(ks, kd, me)
        head = (
            f"dt={self.dt:g} is above the stability limit of {self.integrator} for the stiffest "
            f"{label} contact ({'kt' if spring else 'ks'}={ks:g}, {'kd_t' if spring else 'kd'}={kd + 0.0:g}, "
            f"m_eff={me:g}: omega*dt={omega * self.dt:.3g}, zeta={zeta:.3g})"
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
    def state(self) -> State:
        """The World's own ``(B, n, d)`` position and velocity buffers, always batched. For code
        that fuses its own per-step work with the core's kernels (the environments do): after
        writing them directly, call :meth:`invalidate_cache` for the worlds written."""
        return self._state

    @property
    def runner(self) -> Runner:
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

    def _view(self, arr: np.ndarray) -> np.ndarray:
        out = arr if self._batched else arr[0]
        out = out.view()
        out.flags.writeable = False  # write through set_state, which keeps caches coherent
        return out

    @property
    def positions(self) -> np.ndarray:
        """Current centres, shaped as given (read-only view; change them with ``set_state``)."""
        return self._view(self._state.positions)

    @positions.setter
    def positions(self, value: Any) -> None:
        self.set_state(positions=value)

    @property
    def velocities(self) -> np.ndarray:
        """Current velocities, shaped as given (read-only view)."""
        return self._view(self._state.velocities)

    @velocities.setter
    def velocities(self, value: Any) -> None:
        self.set_state(velocities=value)

    @property
    def angular_velocities(self) -> np.ndarray:
        """Current angular velocities, ``(n, 3)`` in 3D and ``(n, 1)`` in 2D (about the axis out of
        the plane), ``(B, n, .)`` when batched (read-only view; zeros when ``rotation=False``)."""
        if self._spin is None:
            R = 3 if self.dim == 3 else 1
            return self._view(np.zeros(self._state.positions.shape[:2] + (R,)))
        return self._view(self._spin.w)  # (zeros without rotation: 1 / I = 0 keeps them so)

    @angular_velocities.setter
    def angular_velocities(self, value: Any) -> None:
        self.set_state(angular_velocities=value)

    def set_state(
        self, positions: Any = None, velocities: Any = None, worlds: Any = None, angular_velocities: Any = None
    ) -> None:
        """Overwrite positions, velocities and/or (with rotation) angular velocities, of all worlds or
        of the worlds indexed by ``worlds`` (then the arrays are ``(len(worlds), n, .)``). New
        positions end every contact's tangential history in those worlds."""
        if worlds is not None and np.asarray(worlds).dtype.kind not in "iu":
            raise ValueError(f"worlds must be integer world indices, got dtype {np.asarray(worlds).dtype}")
        chosen = np.arange(self.n_worlds) if worlds is None else np.atleast_1d(np.asarray(worlds, dtype=np.int64))
        if chosen.size and (chosen.min() < 0 or chosen.max() >= self.n_worlds):
            raise ValueError(f"worlds must index 0..{self.n_worlds - 1}, got {worlds!r}")
        idx: Any = slice(None) if worlds is None else chosen
        x = self._state.positions
        target = (chosen.size,) + x.shape[1:]
        if angular_velocities is not None and not self.rotation:
            raise ValueError(
                "angular_velocities: this World has rotation=False (its balls do not spin); pass rotation=True"
            )
        items = [("positions", positions, x), ("velocities", velocities, self._state.velocities)]
        if self.rotation and self._spin is not None:
            items.append(("angular_velocities", angular_velocities, self._spin.w))
        for name, value, dest in items:
            if value is None:
                continue
            arr = V.real_array(name, value)
            if not self._batched and worlds is None:
                arr = arr[None] if arr.ndim == 2 else arr
            want = target[:2] + dest.shape[2:]
            if arr.shape != want:
                raise ValueError(
                    f"{name} must have shape {want if self._batched or worlds is not None else want[1:]}, got {np.shape(value)}"
                )
            dest[idx] = arr
        if positions is not None:
            self._check_start(chosen.astype(np.int64))
            if self._spin is not None:
                self._spin.clock[idx] += 2  # every stamp is now stale: no contact continues
        self._runner.forget(idx)

    # ---------------------------------------------------------------- terrain poses
    def _slot(self, shape: Any) -> tuple[int, str, int]:
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        name, j = self._shape_slot[k]
        if name == "legacy":
            raise ValueError(
                f"terrain[{k}] is a static {type(self.terrain[k]).__name__}: static spheres and bowls run in the "
                f"core's original code, shared by every world, and cannot move; give it velocity=(0.0,) * d at "
                f"construction to make it kinematic"
            )
        return k, name, j

    def _pose_rows(self, name: str, j: int) -> np.ndarray:
        """The (B, P) pose rows of a general shape (a view into the model's arrays)."""
        grp = getattr(self._model.geometry, name)
        return grp[j].pose if name == "user" else grp.pose[:, j]

    def shape_pose(self, shape: int, world: int = 0) -> dict[str, np.ndarray]:
        """The current pose of ``terrain[shape]`` in one world: ``position`` (its centre), ``rotation``,
        ``velocity`` and ``angular_velocity`` (3 components in 3D, 1 in 2D). Static spheres and
        bowls report their fixed pose."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        b = V.integer("world", world, 0, self.n_worlds - 1)
        d = self.dim
        if self._shape_slot[k][0] == "legacy":
            t = self.terrain[k]
            return {
                "position": np.array(t.center),
                "rotation": np.eye(d),
                "velocity": np.zeros(d),
                "angular_velocity": np.zeros(3 if d == 3 else 1),
            }
        row = self._pose_rows(*self._shape_slot[k])[b]
        cols = pose_columns(d)
        omega = row[cols["angular_velocity"]]
        return {
            "position": row[cols["position"]].copy(),
            "rotation": row[cols["rotation"]].reshape(d, d).copy(),
            "velocity": row[cols["velocity"]].copy(),
            "angular_velocity": omega.copy() if d == 3 else omega[2:].copy(),
        }

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
        k, name, j = self._slot(shape)
        d = self.dim
        idx = self._world_index(worlds)
        count = self.n_worlds if worlds is None else len(np.atleast_1d(idx))
        if (velocity is not None or angular_velocity is not None) and self._model.geometry.motion is None:
            raise ValueError(
                f"terrain[{k}] was made static (this World compiled no shape motion): give it velocity=(0.0,) * {d} "
                f"at construction to set its velocity or angular velocity"
            )
        rows = self._pose_rows(name, j)
        cols = pose_columns(d)
        values = []
        if position is not None:
            values.append(("position", _per_world("position", position, (d,), count)))
        if rotation is not None:
            R = _per_world("rotation", rotation, (d, d), count)
            for m in R.reshape(-1, d, d):
                if np.abs(m.T @ m - np.eye(d)).max() > 1e-9 or np.linalg.det(m) < 0.0:
                    raise ValueError(
                        f"rotation must be a rotation matrix ({d}x{d}, orthonormal, det +1), got {m.tolist()}"
                    )
            values.append(("rotation", R.reshape(R.shape[:-2] + (d * d,))))
        if velocity is not None:
            values.append(("velocity", _per_world("velocity", velocity, (d,), count)))
        if angular_velocity is not None:
            w = _per_world("angular_velocity", angular_velocity, (3,) if d == 3 else (1,), count)
            if d == 2:
                full = np.zeros(w.shape[:-1] + (3,))
                full[..., 2] = w[..., 0]
                w = full
            values.append(("angular_velocity", w))
        for column, value in values:  # all checked before any is written
            if worlds is None:
                rows[:, cols[column]] = value
            else:
                rows[idx, cols[column]] = value
        self._runner.forget(idx)

    def set_heights(self, shape: int, heights: Any, worlds: Any = None) -> None:
        """Replace the node heights of the HeightField ``terrain[shape]`` in every world or in
        ``worlds`` (one grid for all of them, or one per world), between steps. Balls are not moved
        (see :meth:`set_shape_pose`)."""
        k, name, j = self._slot(shape)
        if name != "heights":
            raise ValueError(f"terrain[{k}] is a {type(self.terrain[k]).__name__}, not a HeightField")
        hf = self.terrain[k]
        assert isinstance(hf, HeightField)
        nx, ny = hf.grid_shape
        idx = self._world_index(worlds)
        count = self.n_worlds if worlds is None else len(np.atleast_1d(idx))
        shape_ = (nx,) if self.dim == 2 else (nx, ny)
        h = _per_world("heights", heights, shape_, count)
        grp = self._model.geometry.heights
        grp.heights[idx, j, :nx, :ny] = h.reshape(h.shape[:-1] + (nx, ny)) if self.dim == 2 else h
        self._runner.forget(idx)

    def shape_distance(self, shape: int, points: Any, world: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """phi and the outward normal of ``terrain[shape]`` at its current pose in one world, at
        ``points`` (..., d): ``(phi (...), normal (..., d))``."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        b = V.integer("world", world, 0, self.n_worlds - 1)
        pts, flat = self._points(points)
        if self._shape_slot[k][0] == "legacy":
            phi, normal = self.terrain[k].phi(flat), self.terrain[k].grad_phi(flat)
        else:
            ev = self._evaluate_general(b, flat)
            general = [j for j in range(len(self.terrain)) if self._shape_slot[j][0] != "legacy"]
            col = dict(zip(general, _columns([self._shape_slot[j] for j in general])))[k]
            phi, normal = ev[:, col, 0], ev[:, col, 1 : 1 + self.dim]
        return phi.reshape(pts.shape[:-1]), normal.reshape(pts.shape)

    def _points(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        pts = V.real_array("points", points)
        if pts.shape[-1:] != (self.dim,):
            raise ValueError(f"points must have last dimension {self.dim}, got shape {pts.shape}")
        return pts, np.ascontiguousarray(pts.reshape(-1, self.dim))

    def _evaluate_general(self, b: int, flat: np.ndarray) -> np.ndarray:
        ev = np.zeros((len(flat), sum(1 for n_, _ in self._shape_slot.values() if n_ != "legacy"), 4))
        _evaluate_shapes(self._model.geometry, b, flat, ev)
        return ev

    def terrain_distance(self, points: Any, world: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """The terrain's signed distance at ``points`` (..., d) in one world, the smallest phi of
        its shapes at their current poses (the union of their solids), and the outward normal of
        that shape: ``(phi (...), normal (..., d))``; inf and zeros without terrain."""
        b = V.integer("world", world, 0, self.n_worlds - 1)
        pts, flat = self._points(points)
        d = self.dim
        phi = np.full(len(flat), np.inf)
        normal = np.zeros((len(flat), d))
        for k, shape in enumerate(self.terrain):
            if self._shape_slot[k][0] == "legacy":
                p, n = shape.phi(flat), shape.grad_phi(flat)
                closer = p < phi
                phi = np.where(closer, p, phi)
                normal = np.where(closer[:, None], n, normal)
        if self._model.geometry is not None:
            ev = self._evaluate_general(b, flat)
            k = np.argmin(ev[:, :, 0], axis=1)
            best = ev[np.arange(len(flat)), k]
            closer = best[:, 0] < phi
            phi = np.where(closer, best[:, 0], phi)
            normal = np.where(closer[:, None], best[:, 1 : 1 + d], normal)
        return phi.reshape(pts.shape[:-1]), normal.reshape(pts.shape)

    def _world_index(self, worlds: Any) -> Any:
        if worlds is None:
            return slice(None)
        if np.asarray(worlds).dtype.kind not in "iu":
            raise ValueError(f"worlds must be integer world indices, got dtype {np.asarray(worlds).dtype}")
        chosen = np.atleast_1d(np.asarray(worlds, dtype=np.int64))
        if chosen.size and (chosen.min() < 0 or chosen.max() >= self.n_worlds):
            raise ValueError(f"worlds must index 0..{self.n_worlds - 1}, got {worlds!r}")
        return chosen

    def _check_start(self, worlds: np.ndarray) -> None:
        """Warn (:class:`StartOverlapWarning`, with the balls and the figures) about a state in
        which two balls, or a ball and the terrain, overlap by the smaller radius or more: the
        spring would release 1/2 ks overlap^2 as a speed that drives any contact as stiff through a
        ball, so the energy of the scene is not what the state says (coincident centres are the
        extreme case). ``allow_unstable=True`` silences it."""
        if self.allow_unstable or worlds.size == 0:
            return
        frac = self._deepest[: worlds.size]
        x, v = self._state
        _diagnostics.world_max_penetration(worlds, x, v, self._grid, self._model, self.gravity, frac)
        bad = np.flatnonzero(frac >= 1.0)
        if not bad.size:
            return
        t = int(bad[np.argmax(frac[bad])])
        b = int(worlds[t])
        where = "" if not self._batched else f" of world {b}"
        what, ks, m_eff, r = self._deepest_contact(b)
        overlap = frac[t] * r
        speed = overlap * theory.natural_frequency(ks, m_eff)
        warnings.warn(
            f"{what}{where} start overlapping by {overlap:.4g} ({frac[t]:.3g} x the smaller radius {r:g}; "
            f"{bad.size} world(s) so): the spring stores 1/2 ks overlap^2 = {0.5 * ks * overlap**2:.4g} and releases "
            f"it as a speed of {speed:.4g}, enough to drive any contact as stiff through a ball, and the scene's "
            f"energy will not stay what this state says. Move them apart (allow_unstable=True silences this "
            f"warning).",
            StartOverlapWarning,
            stacklevel=3,
        )

    def _deepest_contact(self, b: int) -> tuple[str, float, float, float]:
        """(which bodies, ks, m_eff, the smaller radius) of world b's deepest contact, by brute force
        (only when a start is refused; pairs only up to 4,096 balls)."""
        x = self._state.positions[b]
        r = self.radii
        best, label, ks, m_eff, rs = -1.0, "some balls", self.ks, float(self.masses.min()), float(r.min())
        if len(x) <= 4096:
            gap = r[:, None] + r[None, :] - np.linalg.norm(x[:, None] - x[None, :], axis=-1)
            frac = gap / np.minimum(r[:, None], r[None, :])
            np.fill_diagonal(frac, -np.inf)
            a, c = (int(k) for k in np.unravel_index(np.argmax(frac), frac.shape))
            i, j = min(a, c), max(a, c)
            if frac[i, j] > best:
                best, label = float(frac[i, j]), f"balls {i} and {j}"
                ks, m_eff, rs = self.ks, theory.effective_mass(self.masses[i], self.masses[j]), float(min(r[i], r[j]))
        geo = self._model.geometry
        ev = None
        if geo is not None:  # every general shape at its current pose in world b
            ev = np.zeros((len(x), sum(1 for n, _ in self._shape_slot.values() if n != "legacy"), 4))
            _evaluate_shapes(geo, b, np.ascontiguousarray(x), ev)
        general = [k for k in range(len(self.terrain)) if self._shape_slot[k][0] != "legacy"]
        column = dict(zip(general, _columns([self._shape_slot[k] for k in general])))
        for s, shape in enumerate(self.terrain):
            phi = shape.phi(x) if s not in column else ev[:, column[s], 0]  # type: ignore[index]
            pen = (r - phi) / r
            k = int(np.argmax(pen))
            if pen[k] > best:
                best, label = float(pen[k]), f"ball {k} and terrain shape {s}"
                ks, m_eff, rs = self.ks_terrain, float(self.masses[k]), float(r[k])
        return label, ks, m_eff, rs

    def invalidate_cache(self, worlds: Any = None) -> None:
        """Forget what was derived from the state (velocity Verlet's cached acceleration, a large
        world's neighbour list and storage order), after writing ``state``'s arrays directly."""
        self._runner.forget(slice(None) if worlds is None else worlds)

    # ---------------------------------------------------------------- stepping
    def step(self, n: int = 1, forces: Any = None) -> None:
        """Advance every world by ``n`` steps of ``dt``; ``forces`` (external force per ball,
        shaped like ``positions``) is held constant over the n steps."""
        n = V.integer("n", n, 0, MAX_STEPS_PER_CALL, "number of steps")
        ext = None
        if forces is not None:
            x = self._state.positions
            expected = x.shape if self._batched else x.shape[1:]
            f = V.real_array("forces", forces, shape=expected)
            self._ext[...] = f if self._batched else f[None]
            ext = self._ext
        if n == 0:
            return
        self._runner.step(int(n), ext)
        self._check_status()

    def _check_status(self) -> None:
        bad = np.flatnonzero(self._status == STATUS_NONFINITE)
        if bad.size:
            raise FloatingPointError(
                f"the simulation produced NaN or inf in world(s) {bad[:10].tolist()} (dt={self.dt:g}, "
                f"integrator={self.integrator}, allow_unstable={self.allow_unstable}); reduce dt"
            )
        if np.any(self._status == STATUS_CG):
            warnings.warn(
                f"implicit_euler: conjugate gradients did not reach tol {self.cg_tol:g} in "
                f"{self.cg_max_iter} iterations; the step used the last iterate",
                RuntimeWarning,
                stacklevel=3,
            )

    # ---------------------------------------------------------------- diagnostics
    def _per_world(self, out: np.ndarray) -> Any:
        return out.copy() if self._batched else float(out[0])

    def energy(self) -> Any:
        """Kinetic + gravitational + penalty-spring potential (1/2 ks overlap^2), per world; with
        rotation also the rotational kinetic energy (1/2 I w^2) and the tangential springs' (1/2 kt
        xi^2, the history model)."""
        x, v = self._state
        _diagnostics.world_energy(x, v, self._grid, self._model, self.gravity, self._scalar)
        if self._spin is not None:
            sp = self._spin
            if self.rotation:
                self._scalar += 0.5 * np.einsum("bnk,bnk,n->b", sp.w, sp.w, 1.0 / sp.inv_inertia)
            if sp.kt > 0.0:
                live = sp.stamp == sp.clock[:, None, None]
                self._scalar += 0.5 * sp.kt * np.einsum("bij,bijk,bijk->b", live, sp.hist, sp.hist)
        return self._per_world(self._scalar)

    def max_penetration(self) -> Any:
        """Largest overlap as a fraction of the (smaller) radius in contact, per world."""
        x, v = self._state
        _diagnostics.world_max_penetration(self._all_worlds, x, v, self._grid, self._model, self.gravity, self._scalar)
        return self._per_world(self._scalar)

    def momentum(self) -> np.ndarray:
        """Total linear momentum per world, ``(d,)`` or ``(B, d)``."""
        p = np.einsum("bnd,n->bd", self._state.velocities, self.masses)
        return p if self._batched else p[0]

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the origin per world, sum of m x cross v + I w: ``(3,)`` in
        3D, ``(1,)`` in 2D (about the axis out of the plane), ``(B, .)`` when batched."""
        x, v = self._state
        m = self.masses[None, :, None]
        if self.dim == 3:
            L = np.cross(x, m * v).sum(axis=1)
        else:
            L = (x[..., 0] * v[..., 1] - x[..., 1] * v[..., 0])[..., None] * m
            L = L.sum(axis=1)
        if self.rotation and self._spin is not None:
            L = L + np.einsum("bnk,n->bk", self._spin.w, 1.0 / self._spin.inv_inertia)
        return L if self._batched else L[0]

    def __repr__(self) -> str:
        return (
            f"World(B={self.n_worlds}, n={self.n_balls}, d={self.dim}, integrator={self.integrator!r}, "
            f"dt={self.dt:g}, broadphase={'grid' if self.use_grid else 'all_pairs'}, stepping={self.stepping!r}, "
            f"{'rotation=True, ' if self.rotation else ''}"
            f"terrain={len(self.terrain)} shapes)"
        )
