"""The guard of a :class:`~.world.World`: the largest step its integrator keeps stable on the
stiffest contact the scene can form (docs/physics.md section 4), the energy budget of many elastic
collisions (section 6), the messages that say which contact limits the step and how many substeps
meet it, and the check of a starting state (overlaps deep enough to launch balls through others)."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from . import theory
from .geometry.pack import is_static_round
from .model import inertia_factor

__all__ = ["StabilityGuard", "STABILITY_SAFETY", "StartOverlapWarning", "EnergyDriftWarning"]

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


class StabilityGuard:
    """The guard's part of a World (its scene's masses, radii, contact parameters and integrator)."""

    masses: np.ndarray
    radii: np.ndarray
    ks: float
    kd: float
    ks_terrain: float
    kd_terrain: float
    kt: float
    kd_t: float
    integrator: str
    damping: str
    rotation: bool
    terrain: tuple
    gravity: tuple
    dt: float
    dt_max: float
    dt_energy: float
    allow_unstable: bool
    start_check: bool
    _batched: bool
    _deepest: np.ndarray
    _state: Any
    _rows: tuple
    _max_penetration_of: Any
    _evaluate: Any

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
        if not self._history:
            return []
        c = inertia_factor(len(self.gravity))
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

    def _check_start(self, worlds: np.ndarray) -> None:
        """Warn (:class:`StartOverlapWarning`, with the balls and the figures) about a state in
        which two balls, or a ball and the terrain, overlap by the smaller radius or more: the
        spring would release 1/2 ks overlap^2 as a speed that drives any contact as stiff through a
        ball, so the energy of the scene is not what the state says (coincident centres are the
        extreme case). ``allow_unstable=True`` silences it."""
        if self.allow_unstable or not self.start_check or worlds.size == 0:
            return
        frac = self._deepest[: worlds.size]
        self._max_penetration_of(worlds, frac)
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
        ev = self._evaluate(b, np.ascontiguousarray(x)) if self.terrain else None
        for s, shape in enumerate(self.terrain):
            phi = shape.phi(x) if is_static_round(shape) else ev[:, self._rows[s], 0]  # type: ignore[index]
            pen = (r - phi) / r
            k = int(np.argmax(pen))
            if pen[k] > best:
                best, label = float(pen[k]), f"ball {k} and terrain shape {s}"
                ks, m_eff, rs = self.ks_terrain, float(self.masses[k]), float(r[k])
        return label, ks, m_eff, rs
