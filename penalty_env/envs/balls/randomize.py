"""Per-world domain randomisation of the PenaltyBalls scene (``randomize=``; the env docstring's
"Domain randomisation" section): its fields, the physics each world's draws derive (the one
derivation of :mod:`..contact`, compiled for a reset's worlds), and the make-time guard that fixes
a substep every draw is stable at.

A randomised scene steps a ``per_world=True`` :class:`~penalty_env.physics.World`: each world's
masses, radii, contact parameters and motor strength are its own, set at its reset. The draws come
from the world's own generator, before the start's, one uniform per randomised field in
:data:`FIELDS` order.
"""

from __future__ import annotations

import itertools
import math
import warnings
from typing import Any, NamedTuple

import numpy as np

from ..._jit import compile_notice, entry_point, njit, python_twin
from ...physics import theory
from ...physics.model import inertia_factor
from ...physics.world.parameters import rolling_defaults
from ..contact import ContactRule, configure_task, derive, pair_springs, sliding_kf, substeps_for, terrain_springs
from ..randomize import MAX_SUBSTEPS, Field, RandomizationWarning, check_override, check_ranges, draw
from ..terrains import TERRAINS
from .params import PARAMETERS, check_parameters

__all__ = ["FIELDS", "STIFFNESS_FACTOR", "Draws", "Randomizer", "check_randomize"]

STIFFNESS_FACTOR = (0.25, 4.0)  # the allowed range of the ``stiffness`` factor


def _field(name: str, meaning: str, keyword: str | None = None) -> Field:
    allowed = STIFFNESS_FACTOR if keyword is None else tuple(PARAMETERS[keyword][1:3])
    return Field(name, allowed, meaning, keyword)


# the fields a range may be given for, in the order a reset draws them
FIELDS: dict[str, Field] = {
    f.name: f
    for f in (
        _field("pusher_mass", "the pusher's mass, kg", "pusher_mass"),
        _field("ball_mass", "the ball's mass, kg", "ball_mass"),
        _field("obstacle_mass", "every obstacle's mass, kg", "obstacle_mass"),
        _field("pusher_radius", "the pusher's radius, m", "pusher_radius"),
        _field("ball_radius", "the ball's radius, m", "ball_radius"),
        _field("obstacle_radius", "every obstacle's radius, m", "obstacle_radius"),
        _field("friction", "Coulomb friction coefficient mu of every contact", "friction"),
        _field("restitution", "restitution of a pusher-ball impact (sets the dashpots)", "restitution"),
        _field("stiffness", "a factor on the derived contact stiffness ks (and the terrain's)"),
        _field("max_force", "the pusher motor's stall force, N", "max_force"),
        _field("roughness", "terrain='bumpy': the largest bump height, m", "roughness"),
    )
}


class Draws(NamedTuple):
    """The fields of some worlds, one (k,) array each (a field not randomised: its fixed value)."""

    pusher_mass: np.ndarray
    ball_mass: np.ndarray
    obstacle_mass: np.ndarray
    pusher_radius: np.ndarray
    ball_radius: np.ndarray
    obstacle_radius: np.ndarray
    friction: np.ndarray
    restitution: np.ndarray
    stiffness: np.ndarray
    max_force: np.ndarray
    roughness: np.ndarray


class DeriveRule(NamedTuple):
    """What a reset's derivation reads besides the draws (the scene's constants)."""

    speed: float  # the pair's impact speed (the motor's top speed), m/s
    tol: float  # the penetration tolerance
    gravity: float
    dt: float  # the substep
    zeta: float  # the fixed scene's damping ratio (restitution not drawn)
    restitution_drawn: bool
    inertia_factor: float  # I / (m r^2) (0 for balls that slide)
    rolling: bool


class WorldArrays(NamedTuple):
    """The World's per-world arrays a reset writes (its model's and its spin's)."""

    radii: np.ndarray  # (B, n)
    inv_mass: np.ndarray  # (B, n)
    ks: np.ndarray  # (B,)
    kd: np.ndarray
    ks_terrain: np.ndarray
    kd_terrain: np.ndarray
    mu: np.ndarray
    kf: np.ndarray
    max_force: np.ndarray  # (B, motors)
    inv_inertia: np.ndarray  # (B, n) (balls that slide: a placeholder)
    kr: np.ndarray  # (B,) (balls that slide: a placeholder)


class TaskRows(NamedTuple):
    """The scene's per-world rows a reset writes."""

    rest: np.ndarray  # (B, bodies + 1): resting centres' distance from the terrain (the goal as the ball)
    push: np.ndarray  # (B,): the push point's distance behind the ball (pusher + ball radius)
    roughness: np.ndarray  # (B,)
    scratch: np.ndarray  # (2, bodies): the derivation's working rows (kernels allocate nothing)


def check_randomize(randomize: Any, params: dict[str, Any], dim: int) -> dict[str, tuple[float, float]]:
    """``randomize`` checked against :data:`FIELDS` (:func:`..randomize.check_ranges`) and the
    scene: sand refuses randomisation, ``roughness`` needs a terrain drawn per reset, and every
    draw's obstacles must fit their start region."""
    ranges = check_ranges(randomize, FIELDS)
    if ranges and params["grains"]:
        raise ValueError(
            f"randomize is not supported with sand yet (grains={params['grains']}): the settled bed is made "
            "once for the scene's fixed grains and bodies; use a PenaltyBalls id (grains=0)"
        )
    if "roughness" in ranges and not TERRAINS[params["terrain"]].per_world:
        raise ValueError(f"randomize['roughness'] needs terrain='bumpy' (got terrain={params['terrain']!r})")
    if "obstacle_radius" in ranges and params["n_obstacles"]:  # every draw's obstacles must fit their region
        try:
            check_parameters(dim, dict(params, obstacle_radius=ranges["obstacle_radius"][1]))
        except ValueError as exc:
            raise ValueError(
                f"randomize['obstacle_radius'] = {ranges['obstacle_radius']}: at its largest, {exc}"
            ) from None
    return ranges


class Randomizer:
    """A PenaltyBalls scene's randomisation (see the module docstring).

    Args:
        ranges: the checked ranges (:func:`check_randomize`).
        params: the scene's checked keyword arguments (the fields' fixed values).
        n_worlds, n_obstacles: the scene's.
        rule: the scene's contact rule; ``config``: configure's answer for its fixed values.
        rolling: the balls roll (the World's defaults for kf, the inertia and kr follow each draw).
    """

    def __init__(
        self,
        ranges: dict[str, tuple[float, float]],
        params: dict[str, Any],
        n_worlds: int,
        n_obstacles: int,
        rule: ContactRule,
        config: Any,
        rolling: bool,
    ) -> None:
        self.ranges = ranges
        self.params = params
        self.n_obstacles = n_obstacles
        self.rule = rule
        self.config = config
        self.rolling = rolling
        self.names = tuple(ranges)
        B, nb = n_worlds, 2 + n_obstacles
        self.drawn = np.tile([self.nominal(n) for n in ranges], (B, 1))  # (B, names): each world's last draws
        self.rows: TaskRows | None = None
        self._grid, self._zetas = self._zeta_table()
        self._kernel: Any = None
        self._nb = nb

    def nominal(self, name: str) -> float:
        """A field's fixed-scene value (the stiffness factor: 1)."""
        keyword = FIELDS[name].keyword
        return 1.0 if keyword is None else float(self.params[keyword])

    def _zeta_table(self) -> tuple[np.ndarray, np.ndarray]:
        """The no-tension zeta over the make-time restitution range: 2,049 nodes (one node pair at
        the fixed value when restitution is not drawn)."""
        if "restitution" not in self.ranges:
            e0 = float(self.params["restitution"])
            return np.array([e0, e0 + 1.0]), np.array([self.config.zeta] * 2)
        lo, hi = self.ranges["restitution"]
        grid = np.linspace(lo, hi, 2049) if hi > lo else np.array([lo, lo + 1.0])
        return grid, theory.zeta_for_restitution_no_tension(np.minimum(grid, 1.0))

    # ------------------------------------------------------------------ the make-time guard
    def substeps(self, probe: Any, substeps: int, dt: float, control_period: float) -> int:
        """The substeps per control period every draw is stable at: the fixed scene's rule
        (configure's accuracy step and the guard's stability limit) and the motor's speed feedback
        (F / v_max dt / m <= 1) over every corner of the ranges: the fixed scene's ``substeps`` if
        they cover every corner, else more (with a :class:`RandomizationWarning` naming the ranges
        that need them), or a ValueError when even :data:`MAX_SUBSTEPS` are not enough."""
        dt_need, corner = self._corners_dt(probe, list(self.ranges))
        need = substeps_for(control_period, dt_need, slack=1e-9)
        if need <= substeps:  # the fixed scene's substep covers every corner
            return substeps
        alone = {n: self._corners_dt(probe, [n])[0] for n in self.ranges}
        culprits = [n for n, t in alone.items() if substeps_for(control_period, t, slack=1e-9) > substeps]
        worst = ", ".join(f"{n}={v:g}" for n, v in corner.items())
        named = (
            "randomize={" + ", ".join(f"{n!r}: {r}" for n, r in self.ranges.items()) + "}"
            f" needs a physics step of at most {dt_need:.4g} s at its worst corner ({worst})"
        )
        if culprits:
            named += " (alone: " + ", ".join(f"randomize[{n!r}] needs {alone[n]:.4g} s" for n in culprits) + ")"
        if need > MAX_SUBSTEPS:
            raise ValueError(
                f"{named}: {need} substeps per control period of {control_period:g} s, more than "
                f"{MAX_SUBSTEPS}; narrow the range"
            )
        warnings.warn(
            f"{named}; the fixed scene's step is {dt:.4g} s: the randomised scene takes {need} substeps per "
            f"control period instead of {substeps}",
            RandomizationWarning,
            stacklevel=6,
        )
        return need

    def _corners_dt(self, probe: Any, names: list[str]) -> tuple[float, dict[str, float]]:
        """The largest substep stable at every corner of the ranges of ``names`` (the others at
        their fixed values), and the corner that needs the smallest."""
        names = [n for n in names if n not in ("friction", "roughness")]  # (neither changes the step)
        best, worst = math.inf, {}
        units = {}
        for values in itertools.product(*[self.ranges[n] for n in names]):
            corner = dict(zip(names, values))
            d = self.draws({n: np.array([v]) for n, v in corner.items()}, 1)
            masses, radii = self._bodies(d, 0)
            e = float(d.restitution[0])
            zeta = self._zeta(e)
            springs = derive(self.rule, masses, radii, (0, 1), float(d.ball_mass[0]), zeta,
                             stiffness=float(d.stiffness[0]), force=float(d.max_force[0]))  # fmt: skip
            if e not in units:
                units[e] = self._accuracy_units(e)
            omega = math.sqrt(springs.ks / theory.effective_mass(masses[0], masses[1]))
            dt = min(
                units[e] / omega,  # configure's accuracy step: steps per contact fixed by zeta
                probe.stability_limit_for(masses, radii, *springs),
                masses[0] * self.rule.speed / float(d.max_force[0]),  # the motor's feedback
            )
            if dt < best:
                best, worst = dt, corner
        return best, worst

    def _accuracy_units(self, restitution: float) -> float:
        """configure's accuracy step times omega0 (it depends on zeta only) at this restitution (inf
        where the control period, not the accuracy, set the step)."""
        p = self.params
        rule = self.rule._replace(restitution=restitution)
        masses, radii = [p["pusher_mass"], p["ball_mass"]], [p["pusher_radius"], p["ball_radius"]]
        cfg = self.config if restitution == p["restitution"] else configure_task(rule, masses, radii)
        clipped = cfg.dt >= rule.control_period * (1.0 - 1e-12)
        return math.inf if clipped else cfg.dt * math.sqrt(cfg.ks / theory.effective_mass(masses[0], masses[1]))

    def _zeta(self, e: float) -> float:
        return (
            float(python_twin(zeta_of)(e, self._grid, self._zetas))
            if "restitution" in self.ranges
            else self.config.zeta
        )

    def _bodies(self, d: Draws, t: int) -> tuple[np.ndarray, np.ndarray]:
        """World t's masses and radii (pusher, ball, obstacles) from its draws."""
        no = self.n_obstacles
        masses = np.array([d.pusher_mass[t], d.ball_mass[t]] + [d.obstacle_mass[t]] * no)
        radii = np.array([d.pusher_radius[t], d.ball_radius[t]] + [d.obstacle_radius[t]] * no)
        return masses, radii

    def draws(self, values: dict[str, np.ndarray], k: int) -> Draws:
        """:class:`Draws` of k worlds: ``values`` for the fields given, the fixed values elsewhere."""
        return Draws(**{n: values[n] if n in values else np.full(k, self.nominal(n)) for n in FIELDS})

    # ------------------------------------------------------------------ resets
    def attach(self, world: Any, dt: float, rest: np.ndarray) -> None:
        """Bind the World (``per_world=True``) the draws are written into, the substep and the
        scene's resting radii of the fixed values (``rest``: (bodies + 1,))."""
        B = world.n_worlds
        model, spin = world.model, world.spin
        self.world_arrays = WorldArrays(
            model.radii,
            model.inv_mass,
            model.ks,
            model.kd,
            model.ks_terrain,
            model.kd_terrain,
            model.mu,
            model.kf,
            model.motors.max_force,
            spin.inv_inertia if self.rolling else model.inv_mass,
            spin.kr if self.rolling else model.ks,
        )
        p = self.params
        self.rows = TaskRows(
            rest=np.tile(rest, (B, 1)),
            push=np.full(B, p["pusher_radius"] + p["ball_radius"]),
            roughness=np.full(B, float(p["roughness"])),
            scratch=np.zeros((2, world.model.radii.shape[1])),
        )
        self.derive_rule = DeriveRule(
            speed=self.rule.speed,
            tol=self.rule.penetration,
            gravity=self.rule.gravity,
            dt=dt,
            zeta=self.config.zeta,
            restitution_drawn="restitution" in self.ranges,
            inertia_factor=inertia_factor(world.dim) if self.rolling else 0.0,
            rolling=self.rolling,
        )

    def apply(self, idx: np.ndarray, rngs: list, override: Any) -> None:
        """Draw and set the physics of the worlds ``idx`` (before their starts are drawn), in one
        Numba call (:func:`derive_worlds`: a reset is on the env's hot path, and numpy's per-call
        cost over a few worlds would be most of it)."""
        ranges = check_override(override, self.ranges)
        drawn = draw(rngs, ranges)
        self.drawn[idx] = drawn
        d = self.draws({n: drawn[:, j] for j, n in enumerate(ranges)}, len(idx))
        assert self.rows is not None
        args = (idx, d, self.derive_rule, self._grid, self._zetas, self.world_arrays, self.rows)
        if self._kernel is None:
            with compile_notice("randomisation"):
                self._kernel = entry_point(derive_worlds, args)
        self._kernel(*args)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_kernel"] = None  # compiled code: found again (cached) on the first reset after
        return state


@njit
def _restitution(z):
    """:func:`penalty_env.physics.theory.restitution_no_tension` of one zeta."""
    wd = math.sqrt(1.0 - z * z)
    theta = math.pi - math.atan2(2.0 * z * wd, 1.0 - 2.0 * z * z)
    return -math.exp(-z * theta / wd) * (math.cos(theta) - z / wd * math.sin(theta))


@njit
def zeta_of(e, grid, zetas):
    """The no-tension zeta of restitution e: linear interpolation in the table (grid ascending,
    e within it), then one Newton step on the closed form (central difference): the closed form's
    zeta to about 1e-15, at a few operations instead of 60 halvings."""
    if grid[0] == grid[-1] or e <= grid[0]:
        z = zetas[0]
    elif e >= grid[-1]:
        z = zetas[-1]
    else:
        lo, hi = 0, grid.shape[0] - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if grid[mid] <= e:
                lo = mid
            else:
                hi = mid
        z = zetas[lo] + (e - grid[lo]) * (zetas[hi] - zetas[lo]) / (grid[hi] - grid[lo])
    if zetas[0] == zetas[-1]:
        return z
    h = 1e-7
    slope = (_restitution(z + h) - _restitution(z - h)) / (2.0 * h)
    return z - (_restitution(z) - e) / slope


@njit(entry=True, nogil=True)
def derive_worlds(idx, d, rule, grid, zetas, w, rows):
    """Each listed world's physics from its draws (``d``, :class:`Draws`: world ``idx[t]``'s in
    entry t), by :mod:`..contact`'s rule, written into the World's per-world arrays ``w``
    (:class:`WorldArrays`; with ``rule.rolling`` also the World's defaults for kf, the inertia and
    kr, by :func:`penalty_env.physics.world.parameters.rolling_defaults`) and the scene's ``rows``
    (:class:`TaskRows`)."""
    nb = w.radii.shape[1]
    masses = rows.scratch[0]
    g = rule.gravity
    for t in range(idx.shape[0]):
        b = idx[t]
        m_p, m_b, m_o = d.pusher_mass[t], d.ball_mass[t], d.obstacle_mass[t]
        r_p, r_b, r_o = d.pusher_radius[t], d.ball_radius[t], d.obstacle_radius[t]
        for i in range(nb):
            masses[i] = m_p if i == 0 else (m_b if i == 1 else m_o)
            w.radii[b, i] = r_p if i == 0 else (r_b if i == 1 else r_o)
            w.inv_mass[b, i] = 1.0 / masses[i]
        zeta = zeta_of(d.restitution[t], grid, zetas) if rule.restitution_drawn else rule.zeta
        ks, kd = pair_springs(m_p, m_b, r_p, r_b, rule.speed, rule.tol, d.max_force[t], d.stiffness[t], 1.0, zeta)
        kt, kdt = terrain_springs(ks, zeta, masses, w.radii[b], rule.tol, g, m_b)
        w.ks[b] = ks
        w.kd[b] = kd
        w.ks_terrain[b] = kt
        w.kd_terrain[b] = kdt
        w.mu[b] = d.friction[t]
        w.max_force[b, 0] = d.max_force[t]
        rows.roughness[b] = d.roughness[t]
        rows.push[b] = r_p + r_b
        for i in range(nb):
            rows.rest[b, i] = w.radii[b, i] - masses[i] * g / kt
        rows.rest[b, nb] = rows.rest[b, 1]
        if rule.rolling:
            kf, kr = rolling_defaults(
                w.inv_mass[b], w.radii[b], rule.inertia_factor, rule.dt, w.inv_inertia[b], rows.scratch
            )
            w.kf[b] = kf
            w.kr[b] = kr
        else:  # v0's kf: the lightest pair's sliding stops in one substep
            w.kf[b] = sliding_kf(masses, rule.dt)
