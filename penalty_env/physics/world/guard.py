"""The guard of a :class:`~.world.World`: the largest step its integrator keeps stable on the
stiffest contact the scene can form (docs/physics.md section 4), the energy budget of many elastic
collisions (section 6), the messages that say which contact limits the step and how many substeps
meet it, and the check of a starting state (overlaps deep enough to launch balls through others)."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .. import theory
from ..geometry.pack import is_static_round
from ..model import inertia_factor

__all__ = [
    "StabilityGuard",
    "StartCheck",
    "STABILITY_SAFETY",
    "StartOverlapWarning",
    "EnergyDriftWarning",
    "lightest_contact_mass",
    "lightest_tangential_mass",
    "lightest_inertia",
]

# The guard allows dt <= theory.guard_dt of the stiffest contact: STABILITY_SAFETY x its critical dt,
# and no more than a dense pile's fastest mode allows (a ball in 12 contacts vibrates at twice the
# frequency and twice the damping ratio of one contact; see theory.guard_omega_dt).
STABILITY_SAFETY = theory.GUARD_SAFETY


class StartOverlapWarning(RuntimeWarning):
    """A state in which two balls, or a ball and the terrain, overlap by the smaller radius or more:
    the spring stores more energy than the contact model resolves (it launches the balls fast
    enough to drive other contacts through each other)."""


class EnergyDriftWarning(RuntimeWarning):
    """A time step at which elastic collisions gain energy on average beyond
    ``theory.ENERGY_BUDGET`` (docs/physics.md section 6): stable, but a scene of many collisions
    heats up."""


def lightest_contact_mass(masses: np.ndarray) -> float:
    """Smallest effective mass of any contact the scene can form (pair or ball-terrain)."""
    m = np.sort(masses)
    pair = theory.effective_mass(m[0], m[1]) if m.size >= 2 else math.inf
    return float(min(pair, m[0]))


def lightest_tangential_mass(masses: np.ndarray, rotation: bool, dim: int) -> float:
    """The smallest effective mass a tangential force sees: m_eff, or with rotation
    1 / sum(1/m + r^2/I) = m_eff c / (1 + c), c = I / (m r^2)."""
    if not rotation:
        return lightest_contact_mass(masses)
    c = inertia_factor(dim)
    return lightest_contact_mass(masses) * c / (1.0 + c)


def lightest_inertia(masses: np.ndarray, radii: np.ndarray, dim: int) -> float:
    """The smallest effective moment of inertia of a contact (pair: 1 / (1/I_i + 1/I_j))."""
    inertia = np.sort(inertia_factor(dim) * masses * radii**2)
    pair = theory.effective_mass(inertia[0], inertia[1]) if inertia.size >= 2 else math.inf
    return float(min(pair, inertia[0]))


@dataclass(frozen=True)
class StabilityGuard:
    """The step limits of a scene: its balls' masses and radii, its contact parameters, its
    integrator and step. Built from those values alone (a World holds one; :meth:`with_scene`
    gives the guard of other masses, radii or springs, as a randomised scene's corners need)."""

    masses: np.ndarray
    radii: np.ndarray
    ks: float
    kd: float
    ks_terrain: float
    kd_terrain: float
    kt: float
    kd_t: float
    history: bool  # the tangential springs of the history model (held to the same limit)
    integrator: str
    damping: str
    rotation: bool
    has_terrain: bool
    dim: int
    dt: float

    def with_scene(
        self, masses: Any, radii: Any, ks: float, kd: float, ks_terrain: float, kd_terrain: float
    ) -> StabilityGuard:
        """This guard for other masses, radii and normal springs (the rest as they are)."""
        return replace(
            self,
            masses=np.asarray(masses, dtype=np.float64),
            radii=np.asarray(radii, dtype=np.float64),
            ks=float(ks),
            kd=float(kd),
            ks_terrain=float(ks_terrain),
            kd_terrain=float(kd_terrain),
        )

    def lightest_tangential_mass(self) -> float:
        return lightest_tangential_mass(self.masses, self.rotation, self.dim)

    def tangential_springs(self) -> list[tuple[str, float, float, float]]:
        """(label, kt, kd_t, tangential m_eff) of the extreme contacts' tangential springs (the
        history model), which the guard holds to the same limit as a normal spring."""
        if not self.history:
            return []
        c = inertia_factor(self.dim)
        share = c / (1.0 + c) if self.rotation else 1.0
        return [
            (f"{label} tangential spring", self.kt, self.kd_t, me * share)
            for label, _, _, me in self.stiffest_contacts()
        ]

    def stiffest_contacts(self) -> list[tuple[str, float, float, float]]:
        """(label, ks, kd, m_eff) of the extreme contacts this scene can form."""
        m = np.sort(self.masses)
        out = []
        if m.size >= 2:
            for a, b in ((m[0], m[1]), (m[-2], m[-1])):
                out.append(("ball-ball", self.ks, self.kd, theory.effective_mass(a, b)))
        if self.has_terrain:
            for mi in (m[0], m[-1]):
                out.append(("ball-terrain", self.ks_terrain, self.kd_terrain, float(mi)))
        return out

    def stability_limit(self) -> float:
        """Largest dt the guard accepts: ``theory.guard_dt`` of the stiffest contact, STABILITY_SAFETY
        x its critical dt (docs/physics.md, "Stability") or less when damped (a dense pile's fastest
        mode, twice the frequency and twice the damping ratio, must be stable too); inf when the
        scene can form no contact or the integrator is implicit; 0 for explicit Euler on undamped
        contacts (unstable at any dt)."""
        springs = self.stiffest_contacts() + self.tangential_springs()
        limits = [theory.guard_dt(self.integrator, ks, kd, me) for _, ks, kd, me in springs]
        return min(limits) if limits else math.inf

    def energy_limit(self) -> float:
        """Largest dt at which no contact the scene can form gains more than ``theory.ENERGY_BUDGET``
        of its energy per collision on average (``theory.energy_dt``; docs/physics.md section 6). A
        larger dt is accepted with an :class:`EnergyDriftWarning`."""
        limits = [
            theory.energy_dt(self.integrator, ks, kd, me, self.damping) for _, ks, kd, me in self.stiffest_contacts()
        ]
        return min(limits) if limits else math.inf

    def energy_message(self) -> str:
        """What the :class:`EnergyDriftWarning` says: the contact, its gain, the step that keeps it
        within the budget."""
        dt_energy = self.energy_limit()
        label, ks, kd, me = min(
            self.stiffest_contacts(), key=lambda c: theory.energy_dt(self.integrator, c[1], c[2], c[3], self.damping)
        )
        omega = theory.natural_frequency(ks, me)
        zeta = theory.damping_ratio(ks, kd, me)
        gain = theory.energy_gain_envelope(self.integrator, omega * self.dt, zeta, self.damping)
        substeps = math.ceil(self.dt / dt_energy) if dt_energy > 0.0 else math.inf
        return (
            f"dt={self.dt:g}: a {label} contact (ks={ks:g}, kd={kd + 0.0:g}, m_eff={me:g}: omega*dt={omega * self.dt:.3g}, "
            f"zeta={abs(zeta):.3g}) can gain up to {gain:.3g} of its energy per collision on average with "
            f"{self.integrator} at this step, above the budget of {theory.ENERGY_BUDGET:g} (1% per 1,000 collisions): "
            f"a scene of many collisions heats up. dt <= {dt_energy:.6g} ({substeps} substeps per step of "
            f"{self.dt:g}) keeps it within the budget; more damping does too; allow_unstable=True silences this warning."
        )

    def stability_message(self) -> str:
        """What the refusal of a step above :meth:`stability_limit` says: the contact that limits
        it, and the substeps that meet it."""
        dt_max = self.stability_limit()
        springs = self.stiffest_contacts() + self.tangential_springs()
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
        if dt_max <= 0.0:
            return (
                f"{head}: explicit Euler gains energy at any dt on a contact with zeta={zeta:.3g} "
                f"(it is stable only for omega*dt <= 2 zeta). Add damping (kd > 0), choose another "
                f"integrator, or pass allow_unstable=True."
            )
        substeps = math.ceil(self.dt / dt_max)
        return (
            f"{head}. The guard allows dt <= {dt_max:.6g} (the contact's critical dt is "
            f"{theory.critical_dt(self.integrator, ks, kd, me):.6g}; the guard keeps {STABILITY_SAFETY}x of it, "
            f"less for a damped contact, whose dense-pile mode fails sooner): use {substeps} substeps of "
            f"{self.dt / substeps:.6g} per step of {self.dt:g}, or pass allow_unstable=True."
        )


class StartCheck:
    """The check of a starting state: warns (:class:`StartOverlapWarning`, with the balls and the
    figures) about a state in which two balls, or a ball and the terrain, overlap by the smaller
    radius or more: the spring would release 1/2 ks overlap^2 as a speed that drives any contact as
    stiff through a ball, so the energy of the scene is not what the state says (coincident centres
    are the extreme case).

    Args:
        enabled: off with the World's ``allow_unstable=True`` or ``start_check=False``.
        guard: the scene's masses, radii and springs.
        positions: the World's ``(B, n, d)`` position buffer.
        penetration: ``(worlds, out)`` -> each listed world's largest overlap / smaller radius.
        terrain: the World's shapes; ``rows`` their table rows; ``evaluate``: ``(b, points)`` ->
            every table row's phi and normal in world b.
        batched: the World was given a world axis (the message then names the world).
    """

    def __init__(
        self,
        enabled: bool,
        guard: StabilityGuard,
        positions: np.ndarray,
        penetration: Any,
        terrain: tuple,
        rows: tuple,
        evaluate: Any,
        batched: bool,
    ) -> None:
        self.enabled = enabled
        self.guard = guard
        self.positions = positions
        self.penetration = penetration
        self.terrain = terrain
        self.rows = rows
        self.evaluate = evaluate
        self.batched = batched
        self.deepest = np.zeros(positions.shape[0])

    def __call__(self, worlds: np.ndarray) -> None:
        if not self.enabled or worlds.size == 0:
            return
        frac = self.deepest[: worlds.size]
        self.penetration(worlds, frac)
        bad = np.flatnonzero(frac >= 1.0)
        if not bad.size:
            return
        t = int(bad[np.argmax(frac[bad])])
        b = int(worlds[t])
        where = "" if not self.batched else f" of world {b}"
        what, ks, m_eff, r = self.deepest_contact(b)
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

    def deepest_contact(self, b: int) -> tuple[str, float, float, float]:
        """(which bodies, ks, m_eff, the smaller radius) of world b's deepest contact, by brute force
        (only when a start is refused; pairs only up to 4,096 balls)."""
        g = self.guard
        x = self.positions[b]
        r = g.radii
        best, label, ks, m_eff, rs = -1.0, "some balls", g.ks, float(g.masses.min()), float(r.min())
        if len(x) <= 4096:
            gap = r[:, None] + r[None, :] - np.linalg.norm(x[:, None] - x[None, :], axis=-1)
            frac = gap / np.minimum(r[:, None], r[None, :])
            np.fill_diagonal(frac, -np.inf)
            a, c = (int(k) for k in np.unravel_index(np.argmax(frac), frac.shape))
            i, j = min(a, c), max(a, c)
            if frac[i, j] > best:
                best, label = float(frac[i, j]), f"balls {i} and {j}"
                ks, m_eff, rs = g.ks, theory.effective_mass(g.masses[i], g.masses[j]), float(min(r[i], r[j]))
        ev = self.evaluate(b, np.ascontiguousarray(x)) if self.terrain else None
        for s, shape in enumerate(self.terrain):
            phi = shape.phi(x) if is_static_round(shape) else ev[:, self.rows[s], 0]  # type: ignore[index]
            pen = (r - phi) / r
            k = int(np.argmax(pen))
            if pen[k] > best:
                best, label = float(pen[k]), f"ball {k} and terrain shape {s}"
                ks, m_eff, rs = g.ks_terrain, float(g.masses[k]), float(r[k])
        return label, ks, m_eff, rs
