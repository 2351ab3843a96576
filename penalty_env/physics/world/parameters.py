"""The parameters part of a :class:`~.world.World`: each world's physics parameters read
(:meth:`Parameters.get`) and, for a World made with ``per_world=True`` (domain randomisation), set
(:meth:`Parameters.set`: checked, and held to the stability guard world by world); the model's
per-world arrays; the derived defaults (kf, kr, inertia) shared with the randomised envs' resets."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ... import _validate as V
from ..._jit import njit, python_twin
from ..model import Model, inertia_factor
from .guard import StabilityGuard, lightest_inertia, lightest_tangential_mass

__all__ = ["Parameters", "per_world_model", "lightest_pair", "rolling_defaults", "Tangential", "tangential_parameters"]

_SCALARS = ("ks", "kd", "ks_terrain", "kd_terrain", "mu", "kf")


def per_world_model(model: Model, B: int) -> Model:
    """``model`` with its parameters per world (:mod:`.per_world`): every world's as given."""
    m = model.motors
    fields: dict[str, Any] = {name: np.full(B, float(getattr(model, name))) for name in _SCALARS}
    fields.update(
        radii=np.tile(model.radii, (B, 1)),
        inv_mass=np.tile(model.inv_mass, (B, 1)),
        motors=m._replace(max_force=np.tile(m.max_force, (B, 1))),
    )
    return model._replace(**fields)


class Parameters:
    """A World's physics parameters per world.

    Args:
        model: the scene (its per-world arrays are written in place); ``spin``: the rotation's
            parameters and buffers, or None.
        guard: the World's stability guard (its step; :meth:`StabilityGuard.with_scene` for each
            world's values).
        per_world: the model holds its parameters per world (else they are read only).
        allow_unstable: the guard is skipped.
        grid_cell: the broadphase grid's cell (a radius must fit it), or None without a grid;
            ``lead``: balls kept out of the grid.
        kf_default, kr_default: kf and kr were derived (re-derived from each world's masses).
    """

    def __init__(
        self,
        model: Model,
        spin: Any,
        guard: StabilityGuard,
        per_world: bool,
        allow_unstable: bool,
        grid_cell: float | None,
        lead: int,
        kf_default: bool,
        kr_default: bool,
    ) -> None:
        self._model, self._spin, self.guard = model, spin, guard
        self.per_world, self.allow_unstable = per_world, allow_unstable
        self.grid_cell, self.lead = grid_cell, lead
        self.kf_default, self.kr_default = kf_default, kr_default
        self.rotation, self.dt, self.dim = guard.rotation, guard.dt, guard.dim

    def get(self, b: int) -> dict[str, Any]:
        """World ``b``'s physics parameters (``World.parameters``)."""
        m = self._model
        pw = self.per_world
        out: dict[str, Any] = {
            "masses": 1.0 / (m.inv_mass[b] if pw else m.inv_mass),
            "radii": (m.radii[b] if pw else m.radii).copy(),
        }
        for name in _SCALARS:
            value = getattr(m, name)
            out[name] = float(value[b] if pw else value)
        out["max_force"] = (m.motors.max_force[b] if pw else m.motors.max_force).copy()
        if self._spin is not None and self.rotation:
            kr = self._spin.kr
            out["kr"] = float(kr[b] if pw else kr)
        return out

    def set(
        self,
        idx: np.ndarray,
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
        """Set the physics parameters of ``worlds`` (all when None) of a ``per_world=True`` World.

        Each argument left None keeps its value. ``masses``, ``radii``: ``(n,)`` (every listed world)
        or ``(k, n)`` (one row per listed world); ``ks, kd, ks_terrain, kd_terrain, mu, kf``: a float
        or ``(k,)``; ``max_force``: ``(m,)`` or ``(k, m)``. What the World derives from them follows:
        a default ``kf`` (the lightest contact's m_eff / dt) and, with rotation, the inertia and a
        default ``kr``. The state is left as it is: a new radius or mass applies from the next step.

        ``guard``: each listed world is held to the guards of the constructor (dt within the
        stability limit of its stiffest contact, kf and kr within their explicit limits), unless the
        World was made with ``allow_unstable=True``; ``guard=False`` skips that for a caller that
        checked every value against the guard beforehand (a randomised environment checks the
        corners of its ranges once, when it is made).

        Raises:
            ValueError: the World is not ``per_world``; a value that is not finite, not positive
                (``kd``, ``kd_terrain``, ``mu``: negative), of the wrong shape, a radius larger than
                the grid's cells hold, or above the guard (the message names the world and the step
                it needs).
        """
        if not self.per_world:
            raise ValueError("set_parameters needs a World made with per_world=True (its parameters are per world)")
        k = len(idx)
        model, n = self._model, self._model.radii.shape[1]
        q = model.motors.ball.shape[0]
        new: dict[str, np.ndarray] = {}
        if masses is not None:
            new["inv_mass"] = 1.0 / _rows("masses", masses, k, n, positive=True)
        if radii is not None:
            r = _rows("radii", radii, k, n, positive=True)
            if self.grid_cell is not None:
                cell = self.grid_cell
                big = r[:, self.lead :].max() if n > self.lead else 0.0
                if 2.0 * big > cell:
                    raise ValueError(
                        f"radii: a radius of {big:g} does not fit the grid's cells of {cell:g} (made for the "
                        f"constructor's largest radius); give the World its largest radius at construction"
                    )
            new["radii"] = r
        given = dict(ks=ks, kd=kd, ks_terrain=ks_terrain, kd_terrain=kd_terrain, mu=mu, kf=kf)
        for name, value in given.items():
            if value is not None:
                new[name] = _column(name, value, k, positive=name in ("ks", "kf"))
        if max_force is not None:
            if q == 0:
                raise ValueError("max_force: this World has no motors")
            new["max_force"] = _rows("max_force", max_force, k, q, positive=True)
        self.store(idx, new, guard)

    def store(self, idx: np.ndarray, new: dict[str, np.ndarray], guard: bool = False) -> None:
        """:meth:`set_parameters` after its argument checks: ``new`` maps model fields (``inv_mass``,
        ``radii``, the contact scalars, ``max_force``) to float64 arrays of the listed worlds, (k, n),
        (k,) and (k, m), already finite and positive; derives what follows and writes them. For a
        caller that made its values itself (the randomised environments' resets, which skip the
        checks' cost: a reset is on the env's hot path)."""
        model = self._model
        kf_given = "kf" in new
        cur = {name: (model.motors.max_force if name == "max_force" else getattr(model, name))[idx] for name in new}
        cur.update({name: getattr(model, name)[idx] for name in ("inv_mass", "radii", "kf") if name not in cur})
        merged = dict(cur, **new)
        masses_now = 1.0 / merged["inv_mass"]
        spin = self._spin
        if spin is not None and self.rotation:  # (the constructor's defaults, world by world)
            c = inertia_factor(self.dim)
            inv_inertia = np.empty_like(merged["radii"])
            scratch = np.zeros((2, inv_inertia.shape[1]))
            defaults = python_twin(rolling_defaults)
            kf_kr = np.array(
                [
                    defaults(merged["inv_mass"][t], merged["radii"][t], c, self.dt, inv_inertia[t], scratch)
                    for t in range(len(idx))
                ]
            ).reshape(len(idx), 2)
            merged["inv_inertia"] = inv_inertia
            merged["kr"] = spin.kr[idx] if not self.kr_default else kf_kr[:, 1]
            if self.kf_default and not kf_given:
                merged["kf"] = kf_kr[:, 0]
        elif self.kf_default and not kf_given:
            merged["kf"] = _lightest(masses_now) / self.dt
        if guard and not self.allow_unstable:
            self.guard_worlds(idx, merged)
        for name, value in merged.items():
            if name == "max_force":
                model.motors.max_force[idx] = value
            elif name in ("inv_inertia", "kr"):
                getattr(spin, name)[idx] = value
            else:
                getattr(model, name)[idx] = value

    def stability_limit_for(
        self, masses: Any, radii: Any, ks: float, kd: float, ks_terrain: float, kd_terrain: float
    ) -> float:
        """The guard's stability limit of this scene with these masses, radii and springs."""
        return float(self.guard.with_scene(masses, radii, ks, kd, ks_terrain, kd_terrain).stability_limit())

    def guard_worlds(self, idx: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Refuse values for which some world's step is above its stability limit, or its kf above
        the explicit friction limit."""
        model = self._model
        dt = self.guard.dt
        for t, b in enumerate(idx.tolist()):
            springs = [
                float((values[name] if name in values else np.asarray(getattr(model, name))[idx])[t])
                for name in ("ks", "kd", "ks_terrain", "kd_terrain")
            ]
            view = self.guard.with_scene(1.0 / values["inv_mass"][t], values["radii"][t], *springs)
            if dt > view.stability_limit():
                raise ValueError(f"set_parameters, world {b}: {view.stability_message()}")
            kf_max = view.lightest_tangential_mass() / dt
            mu = float((values["mu"] if "mu" in values else np.asarray(model.mu)[idx])[t])
            if mu > 0.0 and values["kf"][t] > kf_max * (1.0 + 1e-12):
                raise ValueError(
                    f"set_parameters, world {b}: kf={values['kf'][t]:g} is above the explicit friction limit "
                    f"m_eff/dt = {kf_max:g} (dt={dt:g}): sliding would overshoot and gain energy"
                )


@njit
def lightest_pair(values):
    """Of one world's masses (or moments of inertia): the smallest effective mass of a contact, a
    pair's m_i m_j / (m_i + m_j) or a ball's own against the terrain (the guard's)."""
    s0, s1 = np.inf, np.inf  # the two smallest
    for i in range(values.shape[0]):
        m = values[i]
        if m < s0:
            s0, s1 = m, s0
        elif m < s1:
            s1 = m
    if s1 == np.inf:
        return s0
    return min(s0 * s1 / (s0 + s1), s0)


@njit
def rolling_defaults(inv_mass, radii, c, dt, inv_inertia, scratch):
    """One world's derived parameters with rotation, from its ``inv_mass`` and ``radii`` (rows):
    its inverse inertias (``c m r^2``, written into ``inv_inertia``), and the default ``kf`` (the
    lightest contact's tangential effective mass, ``c / (1 + c)`` of its m_eff, over dt) and ``kr``
    (the lightest contact's inertia over dt), returned (``scratch``: two working rows at least as
    long as the balls). :meth:`ParameterAccess.set_parameters` and the randomised environments'
    resets (compiled) both derive them here."""
    n = inv_mass.shape[0]
    masses = scratch[0, :n]
    inertia = scratch[1, :n]
    for i in range(n):
        masses[i] = 1.0 / inv_mass[i]
        inertia[i] = c * masses[i] * radii[i] ** 2
        inv_inertia[i] = 1.0 / inertia[i]
    return lightest_pair(masses) * c / (1.0 + c) / dt, lightest_pair(inertia) / dt


def _lightest(rows: np.ndarray) -> np.ndarray:
    """Per row of masses (or moments of inertia): :func:`lightest_pair`, row by row."""
    lightest = python_twin(lightest_pair)
    return np.array([lightest(row) for row in rows])


def _rows(name: str, value: Any, k: int, n: int, positive: bool) -> np.ndarray:
    """``value`` as (k, n) rows: given as (n,) for every world or (k, n)."""
    a = V.real_array(name, value)
    if a.shape == (n,):
        a = np.broadcast_to(a, (k, n))
    if a.shape != (k, n):
        raise ValueError(
            f"{name} must have shape ({n},) (every listed world) or ({k}, {n}) (one row each), got {a.shape}"
        )
    _check_values(name, a, positive)
    return np.array(a, dtype=np.float64)


def _column(name: str, value: Any, k: int, positive: bool) -> np.ndarray:
    """``value`` as (k,): a float for every listed world, or one per world."""
    a = V.real_array(name, value)
    if a.shape == ():
        a = np.full(k, float(a))
    if a.shape != (k,):
        raise ValueError(f"{name} must be a float or have shape ({k},) (one per listed world), got {a.shape}")
    _check_values(name, a, positive)
    return np.array(a, dtype=np.float64)


def _check_values(name: str, a: np.ndarray, positive: bool) -> None:
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {a.tolist()}")
    bad = a <= 0.0 if positive else a < 0.0
    if np.any(bad):
        raise ValueError(f"{name} must be {'> 0' if positive else '>= 0'}, got {float(a[bad][0])!r}")


class Tangential(NamedTuple):
    """A World's tangential and rolling law's slopes and springs, and the explicit limits they are
    held to (:func:`tangential_parameters`)."""

    kf: float  # friction's viscous slope below the Coulomb cap
    kf_max: float  # its explicit limit: the lightest contact's tangential m_eff / dt
    kt: float  # the history model's spring (default 2/7 ks)
    kd_t: float  # its dashpot (default kd / 2)
    kr: float  # rolling resistance's viscous slope (0 without rotation)
    kr_max: float  # its explicit limit: the lightest contact's inertia / dt (inf without rotation)


def tangential_parameters(
    masses: np.ndarray,
    radii: np.ndarray,
    rotation: bool,
    d: int,
    dt: float,
    ks: float,
    kd: float,
    mu: float,
    mu_r: float,
    kf: Any,
    kt: Any,
    kd_t: Any,
    kr: Any,
    allow_unstable: bool,
) -> Tangential:
    """kf, kt, kd_t, kr: given or defaulted, and held to their explicit limits (ValueError naming
    the argument, unless ``allow_unstable``)."""
    # Friction's viscous branch -kf v_t is integrated explicitly (also by implicit Euler):
    # it brings sliding to rest without overshoot only while kf dt / m_eff <= 1 (at 2 it
    # reverses v_t every step and feeds energy in). The default sits at that limit, which is
    # the closest a regularised law gets to Coulomb's stick at this dt.
    kf_max = lightest_tangential_mass(masses, rotation, d) / dt
    kf = V.positive("kf", kf_max if kf is None else kf)
    if mu > 0.0 and kf > kf_max * (1.0 + 1e-12) and not allow_unstable:
        raise ValueError(
            f"kf={kf:g} is above the explicit friction limit m_eff/dt = {kf_max:g} "
            f"(lightest contact {'tangential ' if rotation else ''}m_eff={kf_max * dt:g}, "
            f"dt={dt:g}): sliding would overshoot and gain energy. Use kf <= {kf_max:g}, a smaller dt, "
            "or allow_unstable=True."
        )
    kt = 2.0 / 7.0 * ks if kt is None else V.positive("kt", kt)
    kd_t = 0.5 * kd if kd_t is None else V.non_negative("kd_t", kd_t)
    kr_max = lightest_inertia(masses, radii, d) / dt if rotation else math.inf
    kr = (kr_max if kr is None else V.positive("kr", kr)) if rotation else 0.0
    if mu_r > 0.0 and kr > kr_max * (1.0 + 1e-12) and not allow_unstable:
        raise ValueError(
            f"kr={kr:g} is above the explicit rolling-resistance limit I_eff/dt = {kr_max:g} "
            f"(lightest contact I_eff={kr_max * dt:g}, dt={dt:g}): rolling would overshoot "
            f"and gain energy. Use kr <= {kr_max:g}, a smaller dt, or allow_unstable=True."
        )
    return Tangential(kf, kf_max, kt, kd_t, kr, kr_max)
