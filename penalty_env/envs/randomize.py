"""Per-world domain randomisation of the PenaltyBalls scene (``randomize=``; the env docstring's
"Domain randomisation" section): the draws, the physics each draw derives, and the make-time
guard that fixes a substep every draw is stable at.

A randomised scene steps a ``per_world=True`` :class:`~..physics.World`: each world's masses, radii,
contact parameters and motor strength are its own (:mod:`..physics.per_world`), set at its reset.
The draws come from the world's own generator, before the start's, one uniform per randomised name
in :data:`.params.RANDOMIZE` order: ``value = low + (high - low) u``. From a draw the scene derives
what the fixed scene derives from its keyword arguments, by the same closed forms
(:meth:`RandomizedScene._derive`): ks from the pusher-ball impact at the motor's top speed and the
motor's stall force under the penetration tolerance (``physics.configure``'s rule) times the
``stiffness`` factor, kd from the restitution (the no-tension closed form), the terrain's spring
stiffened for the heaviest resting body and its dashpot, kf from the lightest pair, the resting
overlap and the push point from the radii.
"""

from __future__ import annotations

import itertools
import math
import warnings
from typing import Any

import numpy as np

from .._jit import entry_point, njit
from ..physics import theory
from ..physics.model import inertia_factor
from .params import RANDOMIZE, check_randomize_override

__all__ = ["RandomizedScene", "RandomizationWarning", "MAX_SUBSTEPS"]

# a range that needs more substeps per control period than this is refused (no practical step)
MAX_SUBSTEPS = 1000


class RandomizationWarning(UserWarning):
    """Randomisation ranges that need a smaller substep than the fixed scene's: the scene takes more
    substeps per control period (slower), and says which range asked for it."""


class RandomizedScene:
    """The scene's randomisation methods (its ``params``, ``dim``, ``n_bodies``, ``n_obstacles``,
    ``config``, ``gravity``, ``control_period``, ``rolling``, ``world``...)."""

    params: dict[str, Any]
    dim: int
    n_worlds: int
    n_bodies: int
    n_obstacles: int
    n_balls: int
    config: Any
    gravity: float
    control_period: float
    rolling: bool
    world: Any
    dt: float
    substeps: int
    randomize: dict[str, tuple[float, float]]
    drawn: np.ndarray  # (B, names): each world's draws at its last reset
    _rest_radii: np.ndarray
    _radii_rows: np.ndarray
    _push_offset: np.ndarray
    _roughness_rows: np.ndarray

    # ------------------------------------------------------------------ derivation
    def _nominal(self, name: str) -> float:
        """A randomised name's fixed-scene value (the stiffness factor: 1)."""
        param = RANDOMIZE[name][0]
        return 1.0 if param is None else float(self.params[param])

    def _derive(self, values: dict[str, np.ndarray], dt: float | None) -> dict[str, np.ndarray]:
        """Each world's physics from its draws ``values`` (name -> (k,), the others at their fixed
        values), as the fixed scene derives it (module docstring); ``dt`` the substep (kf; None:
        not derived)."""
        p = self.params
        k = len(next(iter(values.values()))) if values else 1

        def get(name: str) -> np.ndarray:
            return values[name] if name in values else np.full(k, self._nominal(name))

        m_p, m_b, m_o = get("pusher_mass"), get("ball_mass"), get("obstacle_mass")
        r_p, r_b, r_o = get("pusher_radius"), get("ball_radius"), get("obstacle_radius")
        n_obs = self.n_obstacles
        masses = np.column_stack([m_p, m_b] + [m_o] * n_obs)
        radii = np.column_stack([r_p, r_b] + [r_o] * n_obs)
        v, tol, g = p["max_speed"], p["penetration_tolerance"], self.gravity
        force = get("max_force")
        # physics.configure's rule for the pusher-ball contact: the impact at v under delta, the
        # motor pressing at full force under delta; then the stiffness factor
        m_eff = m_p * m_b / (m_p + m_b)
        delta = tol * np.minimum(r_p, r_b)
        ks = np.maximum(m_eff * v**2 / delta**2, force / delta) * get("stiffness")
        if "restitution" in values:
            zeta = self._zeta(values["restitution"])
        else:
            zeta = np.full(k, self.config.zeta)
        kd = 2.0 * zeta * np.sqrt(ks * m_eff)
        ks_rest = np.max(masses * g / (tol * radii), axis=1)
        ks_t = np.maximum(ks, ks_rest)
        kd_t = 2.0 * zeta * np.sqrt(ks_t * m_b)
        out = dict(masses=masses, radii=radii, ks=ks, kd=kd, ks_terrain=ks_t, kd_terrain=kd_t, zeta=zeta)
        out["mu"], out["max_force"] = get("friction"), force
        out["roughness"] = get("roughness") if "roughness" in values else np.full(k, float(p["roughness"]))
        if dt is not None and not self.rolling:  # v0's kf: the lightest pair's sliding stops in one substep
            s = np.sort(masses, axis=1)
            out["kf"] = s[:, 0] * s[:, 1] / (s[:, 0] + s[:, 1]) / dt
        return out

    def _zeta(self, e: np.ndarray) -> np.ndarray:
        """The no-tension damping ratio of restitutions ``e`` (within the make-time range):
        :func:`..physics.theory.zeta_for_restitution_no_tension` tabulated once over the range
        (2,049 nodes), interpolated, then one Newton step on the closed form (central difference):
        the same zeta to about 1e-15, at a few numpy calls per reset instead of 60 halvings."""
        table = self.__dict__.get("_zeta_table")
        if table is None:
            lo, hi = self.randomize["restitution"]
            grid = np.linspace(lo, hi, 2049)
            table = self._zeta_table = (grid, theory.zeta_for_restitution_no_tension(grid))
        if table[0][0] == table[0][-1]:  # a single value
            return np.full(len(e), table[1][0])
        z = np.interp(e, table[0], table[1])
        h = 1e-7
        slope = (theory.restitution_no_tension(z + h) - theory.restitution_no_tension(z - h)) / (2.0 * h)
        return z - (theory.restitution_no_tension(z) - e) / slope

    # ------------------------------------------------------------------ the make-time guard
    def _randomized_substeps(self, probe: Any, dt_fixed: float) -> None:
        """The substep every draw is stable at: the fixed scene's rule (``configure``'s accuracy
        step and the guard's stability limit) and the motor's speed feedback (F / v_max dt / m <= 1)
        over every corner of the ranges; more substeps than the fixed scene's (with a
        :class:`RandomizationWarning` naming the ranges that need them), or a ValueError when even
        :data:`MAX_SUBSTEPS` are not enough."""
        dt_need, corner = self._corners_dt(probe, list(self.randomize))
        substeps = self._substeps_for(dt_need)
        if substeps <= self.substeps:  # the fixed scene's substep covers every corner
            return
        alone = {n: self._corners_dt(probe, [n])[0] for n in self.randomize}
        culprits = [n for n, dt in alone.items() if self._substeps_for(dt) > self.substeps]
        worst = ", ".join(f"{n}={v:g}" for n, v in corner.items())
        named = (
            "randomize={" + ", ".join(f"{n!r}: {r}" for n, r in self.randomize.items()) + "}"
            f" needs a physics step of at most {dt_need:.4g} s at its worst corner ({worst})"
        )
        if culprits:
            named += " (alone: " + ", ".join(f"randomize[{n!r}] needs {alone[n]:.4g} s" for n in culprits) + ")"
        if substeps > MAX_SUBSTEPS:
            raise ValueError(
                f"{named}: {substeps} substeps per control period of {self.control_period:g} s, more than "
                f"{MAX_SUBSTEPS}; narrow the range"
            )
        warnings.warn(
            f"{named}; the fixed scene's step is {self.dt:.4g} s: the randomised scene takes {substeps} substeps per "
            f"control period instead of {self.substeps}",
            RandomizationWarning,
            stacklevel=5,
        )
        self.substeps = substeps
        self.dt = self.control_period / substeps

    def _substeps_for(self, dt_need: float) -> int:
        """Substeps per control period that keep the step at most ``dt_need`` (the fixed scene's rule,
        with a relative slack of 1e-9 for the round-off of a corner that is the fixed scene itself)."""
        dt_need *= 1.0 + 1e-9
        substeps = max(1, math.ceil(self.control_period / dt_need))
        if self.control_period / substeps > dt_need:  # rounding
            substeps += 1
        return substeps

    def _corners_dt(self, probe: Any, names: list[str]) -> tuple[float, dict[str, float]]:
        """The largest substep stable at every corner of the ranges of ``names`` (the others at
        their fixed values), and the corner that needs the smallest."""
        names = [n for n in names if n not in ("friction", "roughness")]  # (neither changes the step)
        corners = list(itertools.product(*[self.randomize[n] for n in names]))
        values = {n: np.array([c[j] for c in corners]) for j, n in enumerate(names)}
        d = self._derive(values, None)
        units = np.broadcast_to(self._accuracy_units(values.get("restitution")), (len(corners),))
        p = self.params
        best, worst = math.inf, {}
        for t in range(len(corners)):
            m_eff = d["masses"][t, 0] * d["masses"][t, 1] / (d["masses"][t, 0] + d["masses"][t, 1])
            omega = math.sqrt(d["ks"][t] / m_eff)
            dt = min(
                units[t] / omega,  # configure's accuracy step: steps per contact fixed by zeta
                probe.stability_limit_for(
                    d["masses"][t], d["radii"][t], d["ks"][t], d["kd"][t], d["ks_terrain"][t], d["kd_terrain"][t]
                ),
                d["masses"][t, 0] * p["max_speed"] / d["max_force"][t],  # the motor's feedback
            )
            if dt < best:
                best, worst = dt, {n: float(values[n][t]) for n in names}
        return best, worst

    def _accuracy_units(self, restitution: np.ndarray | None) -> np.ndarray:
        """configure's accuracy step times omega0 (it depends on zeta only) for each restitution
        (None: the fixed scene's), from configure itself at the fixed masses (inf where the control
        period, not the accuracy, set the step)."""
        from ..physics.configure import configure

        if restitution is None:
            restitution = np.array([float(self.params["restitution"])])
        out = np.empty(len(restitution))
        p = self.params
        masses, radii = [p["pusher_mass"], p["ball_mass"]], [p["pusher_radius"], p["ball_radius"]]
        for t, e in enumerate(restitution.tolist()):
            cfg = (
                self.config
                if e == p["restitution"]
                else configure(
                    masses,
                    radii,
                    max_impact_speed=p["max_speed"],
                    penetration=p["penetration_tolerance"],
                    restitution=e,
                    accuracy=p["restitution_accuracy"],
                    damping="no_tension",
                    terrain=False,
                    integrators=("symplectic_euler",),
                    events=False,
                    max_dt=self.control_period,
                    max_force=p["max_force"],
                    energy_budget=None,
                )
            )
            m_eff = theory.effective_mass(masses[0], masses[1])
            clipped = cfg.dt >= self.control_period * (1.0 - 1e-12)
            out[t] = math.inf if clipped else cfg.dt * math.sqrt(cfg.ks / m_eff)
        return out

    # ------------------------------------------------------------------ resets
    def _draw(self, rngs: list, ranges: dict[str, tuple[float, float]]) -> np.ndarray:
        """One uniform per randomised name from each world's generator (in RANDOMIZE order), as
        values in ``ranges``: (k, names)."""
        lo = np.array([r[0] for r in ranges.values()])
        span = np.array([r[1] - r[0] for r in ranges.values()])
        u = np.array([rng.random(len(ranges)) for rng in rngs]).reshape(len(rngs), len(ranges))
        return lo + span * u

    def _apply_draws(self, idx: np.ndarray, rngs: list, override: Any) -> None:
        """Draw and set the physics of the worlds ``idx`` (before their starts are drawn), in one
        Numba call (:func:`derive_worlds`: a reset is on the env's hot path, and numpy's per-call
        cost over a few worlds would be most of it)."""
        ranges = check_randomize_override(override, self.randomize)
        drawn = self._draw(rngs, ranges)
        self.drawn[idx] = drawn
        args = (idx, drawn) + self._derive_args()
        kernel = self.__dict__.get("_derive_kernel")
        if kernel is None:
            kernel = self._derive_kernel = entry_point(derive_worlds, args)
        kernel(*args)

    def _derive_args(self) -> tuple:
        """:func:`derive_worlds`' arguments after ``idx`` and ``drawn`` (made once)."""
        args = self.__dict__.get("_derive_tail")
        if args is not None:
            return args
        p = self.params
        cols = np.array([list(self.randomize).index(n) if n in self.randomize else -1 for n in RANDOMIZE])
        nominal = np.array([self._nominal(n) for n in RANDOMIZE])
        e0 = float(p["restitution"])
        table = (
            (np.array([e0, e0 + 1.0]), np.array([self.config.zeta] * 2))
            if "restitution" not in self.randomize
            else self._zeta_grid()
        )
        model = self.world.model
        spin = self.world._spin
        c = inertia_factor(self.dim) if self.rolling else 0.0
        consts = np.array([p["max_speed"], p["penetration_tolerance"], self.gravity, self.dt, self.config.zeta, c])
        inv_inertia = spin.inv_inertia if self.rolling else model.inv_mass
        kr = spin.kr if self.rolling else model.ks
        args = (cols, nominal, np.empty(len(RANDOMIZE)), consts, table[0], table[1], self.n_obstacles, self.rolling)
        args += (model.radii, model.inv_mass, model.ks, model.kd, model.ks_terrain, model.kd_terrain, model.mu)
        args += (model.kf, model.motors.max_force, inv_inertia, kr)
        args += (self._rest_radii, self._push_offset, self._roughness_rows)
        self._derive_tail = args
        return args

    def _zeta_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """The no-tension zeta over the make-time restitution range: 2,049 nodes."""
        lo, hi = self.randomize["restitution"]
        grid = np.linspace(lo, hi, 2049) if hi > lo else np.array([lo, lo + 1.0])
        return grid, theory.zeta_for_restitution_no_tension(np.minimum(grid, 1.0))

    def _apply_draws_numpy(self, idx: np.ndarray, drawn: np.ndarray, ranges: dict) -> None:
        """:meth:`_apply_draws`' derivation in numpy (:meth:`_derive`): what the tests check the
        kernel against."""
        values = {n: drawn[:, j] for j, n in enumerate(ranges)}
        d = self._derive(values, self.dt)
        new: dict[str, np.ndarray] = dict(
            inv_mass=1.0 / d["masses"],
            radii=d["radii"],
            ks=d["ks"],
            kd=d["kd"],
            ks_terrain=d["ks_terrain"],
            kd_terrain=d["kd_terrain"],
            mu=d["mu"],
            max_force=d["max_force"][:, None],
        )
        if "kf" in d:
            new["kf"] = d["kf"]
        # made here, from ranges checked at make (finite, positive), and every value covered by the
        # make-time guard over the ranges' corners: World.set_parameters without its checks
        self.world._store_parameters(idx, new)
        nb = self.n_bodies
        rest_depth = d["masses"] * self.gravity / d["ks_terrain"][:, None]
        rest = d["radii"][:, :nb] - rest_depth[:, :nb]
        self._rest_radii[idx] = np.concatenate([rest, rest[:, 1:2]], axis=1)
        self._radii_rows[idx] = d["radii"]
        self._push_offset[idx] = d["radii"][:, 0] + d["radii"][:, 1]
        self._roughness_rows[idx] = d["roughness"]

    def randomization(self, b: int) -> dict[str, float]:
        """World b's drawn values at its last reset (name -> float, in draw order)."""
        return dict(zip(self.randomize, self.drawn[b].tolist()))


@njit
def _restitution(z):
    """:func:`..physics.theory.restitution_no_tension` of one zeta."""
    wd = math.sqrt(1.0 - z * z)
    theta = math.pi - math.atan2(2.0 * z * wd, 1.0 - 2.0 * z * z)
    return -math.exp(-z * theta / wd) * (math.cos(theta) - z / wd * math.sin(theta))


@njit
def _zeta_of(e, grid, zetas):
    """The no-tension zeta of restitution e: linear interpolation in the table (grid ascending,
    e within it), then one Newton step on the closed form (central difference)."""
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


@njit
def _body(i, a, b, c):
    """Body i's value of three: the pusher's (0), the ball's (1), an obstacle's (2..)."""
    return a if i == 0 else (b if i == 1 else c)


@njit(entry=True, nogil=True)
def derive_worlds(
    idx, drawn, cols, nominal, val, consts, grid, zetas, n_obs, rolling,
    radii, inv_mass, ks, kd, ks_t, kd_t, mu, kf, max_force, inv_inertia, kr, rest, push, rough,
):  # fmt: skip
    """Each listed world's physics from its draws (``drawn[t]`` for world ``idx[t]``, columns
    ``cols`` per :data:`.params.RANDOMIZE` name, -1: its ``nominal`` value; ``val`` a scratch of
    their size), written into the World's per-world arrays and the scene's (rest radii, push offset,
    roughness): the rule of :meth:`RandomizedScene._derive`, world by world (and, with ``rolling``,
    the World's default kf, inertia and kr, as ``World.set_parameters`` derives them). ``consts``:
    max speed, penetration tolerance, gravity, dt, the fixed scene's zeta, I / (m r^2)."""
    v, tol, g, dt, zeta0, c = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5]
    nb = 2 + n_obs
    for t in range(idx.shape[0]):
        b = idx[t]
        for q in range(nominal.shape[0]):
            val[q] = drawn[t, cols[q]] if cols[q] >= 0 else nominal[q]
        # RANDOMIZE order: pusher_mass, ball_mass, obstacle_mass, pusher_radius, ball_radius,
        # obstacle_radius, friction, restitution, stiffness, max_force, roughness
        m_p, m_b, m_o, r_p, r_b, r_o = val[0], val[1], val[2], val[3], val[4], val[5]
        m_eff = m_p * m_b / (m_p + m_b)
        delta = tol * min(r_p, r_b)
        k = max(m_eff * v**2 / delta**2, val[9] / delta) * val[8]
        zeta = _zeta_of(val[7], grid, zetas) if cols[7] >= 0 else zeta0
        rest_k = 0.0
        s0, s1 = math.inf, math.inf  # the two lightest bodies
        for i in range(nb):
            m, r = _body(i, m_p, m_b, m_o), _body(i, r_p, r_b, r_o)
            radii[b, i] = r
            inv_mass[b, i] = 1.0 / m
            rest_k = max(rest_k, m * g / (tol * r))
            if m < s0:
                s0, s1 = m, s0
            elif m < s1:
                s1 = m
        kt = max(k, rest_k)
        ks[b] = k
        kd[b] = 2.0 * zeta * math.sqrt(k * m_eff)
        ks_t[b] = kt
        kd_t[b] = 2.0 * zeta * math.sqrt(kt * m_b)
        mu[b] = val[6]
        max_force[b, 0] = val[9]
        rough[b] = val[10]
        push[b] = r_p + r_b
        for i in range(nb):
            rest[b, i] = radii[b, i] - _body(i, m_p, m_b, m_o) * g / kt
        rest[b, nb] = rest[b, 1]
        if not rolling:  # v0's kf: the lightest pair's sliding stops in one substep
            kf[b] = s0 * s1 / (s0 + s1) / dt
            continue
        # the World's defaults from its stored 1 / m: the tangential m_eff, the lightest inertia
        w0, w1, i0, i1 = math.inf, math.inf, math.inf, math.inf
        for i in range(nb):
            m = 1.0 / inv_mass[b, i]
            inertia = c * m * radii[b, i] ** 2
            inv_inertia[b, i] = 1.0 / inertia
            if m < w0:
                w0, w1 = m, w0
            elif m < w1:
                w1 = m
            if inertia < i0:
                i0, i1 = inertia, i0
            elif inertia < i1:
                i1 = inertia
        kf[b] = min(w0 * w1 / (w0 + w1), w0) * c / (1.0 + c) / dt
        kr[b] = min(i0 * i1 / (i0 + i1), i0) / dt
