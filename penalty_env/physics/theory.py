"""Closed forms for a linear spring-dashpot contact, and integrator stability limits.

Units are whatever the caller uses consistently (SI in the examples): ``ks`` force per length,
``kd`` force per speed, ``m_eff`` mass. ``m_eff = m_i m_j / (m_i + m_j)`` for a pair of balls and
``m_eff = m_i`` for a ball against static terrain (PHYSICS.md section 3).

The contact is the seed's: the spring and the dashpot act while the overlap is positive and the
contact ends when the overlap returns to zero, so for ``zeta >= 1`` it never ends (``e = 0``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "INTEGRATORS",
    "natural_frequency",
    "damping_ratio",
    "restitution",
    "contact_time",
    "damping_for_restitution",
    "peak_overlap",
    "resting_overlap",
    "stiffness_for_penetration",
    "critical_omega_dt",
    "critical_dt",
    "amplification_matrix",
]

INTEGRATORS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler")


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return value


def _non_negative(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return value


def natural_frequency(ks: float, m_eff: float) -> float:
    """omega0 = sqrt(ks / m_eff), rad per unit time."""
    return math.sqrt(_positive("ks", ks) / _positive("m_eff", m_eff))


def damping_ratio(ks: float, kd: float, m_eff: float) -> float:
    """zeta = kd / (2 sqrt(ks m_eff)); 0 undamped, 1 critically damped."""
    return _non_negative("kd", kd) / (2.0 * math.sqrt(_positive("ks", ks) * _positive("m_eff", m_eff)))


def restitution(ks: float, kd: float, m_eff: float) -> float:
    """Normal coefficient of restitution e = exp(-pi zeta / sqrt(1 - zeta^2)) (0 when zeta >= 1)."""
    zeta = damping_ratio(ks, kd, m_eff)
    if zeta >= 1.0:
        return 0.0
    return math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta))


def contact_time(ks: float, kd: float, m_eff: float) -> float:
    """Contact duration t_c = pi / omega_d, omega_d = omega0 sqrt(1 - zeta^2) (inf when zeta >= 1)."""
    zeta = damping_ratio(ks, kd, m_eff)
    if zeta >= 1.0:
        return math.inf
    return math.pi / (natural_frequency(ks, m_eff) * math.sqrt(1.0 - zeta * zeta))


def damping_for_restitution(e: float, ks: float, m_eff: float) -> float:
    """The kd that gives restitution ``e`` in (0, 1]: zeta = -ln e / sqrt(pi^2 + ln^2 e).

    Same as LIGGGHTS' gamma_n = sqrt(4 m_eff k_n / (1 + (pi / ln e)^2)).
    """
    e = float(e)
    if not (math.isfinite(e) and 0.0 < e <= 1.0):
        raise ValueError(f"e (restitution) must be in (0, 1], got {e!r}")
    log_e = math.log(e)
    zeta = -log_e / math.sqrt(math.pi**2 + log_e**2)
    return 2.0 * zeta * math.sqrt(_positive("ks", ks) * _positive("m_eff", m_eff))


def peak_overlap(ks: float, m_eff: float, v_n: float) -> float:
    """Largest overlap of an undamped contact hit at normal speed v_n: v_n / omega0."""
    return abs(float(v_n)) / natural_frequency(ks, m_eff)


def resting_overlap(m: float, g: float, ks: float) -> float:
    """Overlap of a ball resting on terrain under gravity: m g / ks."""
    return _positive("m", m) * abs(float(g)) / _positive("ks", ks)


def stiffness_for_penetration(m_eff: float, v: float, delta_tol: float) -> float:
    """Smallest ks that keeps the overlap of an impact at speed v under delta_tol: m v^2 / delta^2."""
    return _positive("m_eff", m_eff) * float(v) ** 2 / _positive("delta_tol", delta_tol) ** 2


# --- stability -------------------------------------------------------------------------------
# Each explicit integrator applied to the damped oscillator x'' = -omega^2 x - 2 zeta omega x' is a
# linear map of its state; it is stable while the spectral radius of that map is <= 1. We compute
# the boundary from the map itself, so the limit matches the implementation exactly (including
# velocity Verlet's damping at the predicted velocity, whose state carries the cached acceleration).


def amplification_matrix(integrator: str, omega_dt: float, zeta: float) -> np.ndarray:
    """One-step map of ``integrator`` on the damped linear oscillator, in units where omega = 1."""
    h = float(omega_dt)
    c = 2.0 * float(zeta)  # a = -x - c v
    if integrator == "explicit_euler":
        return np.array([[1.0, h], [-h, 1.0 - c * h]])
    if integrator == "symplectic_euler":
        # v1 = v + h a(x, v); x1 = x + h v1
        return np.array([[1.0 - h * h, h * (1.0 - c * h)], [-h, 1.0 - c * h]])
    if integrator == "velocity_verlet":
        # state (x, v, a): x1 = x + h v + h^2/2 a; vp = v + h a; a1 = -x1 - c vp; v1 = v + h/2 (a + a1)
        x1 = np.array([1.0, h, 0.5 * h * h])
        vp = np.array([0.0, 1.0, h])
        a1 = -x1 - c * vp
        v1 = np.array([0.0, 1.0, 0.5 * h]) + 0.5 * h * a1
        return np.vstack([x1, v1, a1])
    if integrator == "rk4":
        a = np.array([[0.0, 1.0], [-1.0, -c]]) * h
        out, term = np.eye(2), np.eye(2)
        for k in range(1, 5):
            term = term @ a / k
            out = out + term
        return out
    if integrator == "implicit_euler":
        a = np.array([[0.0, 1.0], [-1.0, -c]])
        # v1 = v + h a(x1, v1), x1 = x + h v1: exact backward Euler on a linear system
        return np.linalg.inv(np.eye(2) - h * a)
    raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")


def _spectral_radius(integrator: str, omega_dt: float, zeta: float) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(integrator, omega_dt, zeta)))))


_CRIT_CACHE: dict[tuple[str, float], float] = {}


def critical_omega_dt(integrator: str, zeta: float = 0.0) -> float:
    """Largest omega*dt for which ``integrator`` is stable on a contact of damping ratio ``zeta``.

    Closed forms (PHYSICS.md section 4): explicit Euler 2 zeta (0: never stable); symplectic Euler
    2 (sqrt(1 + zeta^2) - zeta); velocity Verlet 2 when undamped; RK4 2 sqrt(2) when undamped;
    implicit Euler inf. Damped Verlet and RK4 come from the amplification matrix.
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    zeta = _non_negative("zeta", zeta)
    if integrator == "implicit_euler":
        return math.inf
    if integrator == "symplectic_euler":
        return 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta)
    if integrator == "explicit_euler" and zeta <= 1.0:
        return 2.0 * zeta
    if integrator == "velocity_verlet" and zeta == 0.0:
        return 2.0
    if integrator == "rk4" and zeta == 0.0:
        return 2.0 * math.sqrt(2.0)
    key = (integrator, zeta)
    if key not in _CRIT_CACHE:
        tol = 1e-12
        lo, hi = 1e-6, 1e-6
        # walk up until unstable, then bisect (the stable set starts at 0 for these methods)
        while _spectral_radius(integrator, hi, zeta) <= 1.0 + tol:
            lo, hi = hi, hi * 1.25
            if hi > 1e6:
                return math.inf
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if _spectral_radius(integrator, mid, zeta) <= 1.0 + tol:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-13 * hi:
                break
        _CRIT_CACHE[key] = lo
    return _CRIT_CACHE[key]


def critical_dt(integrator: str, ks: float, kd: float, m_eff: float) -> float:
    """Largest stable dt for one contact (ks, kd) of effective mass m_eff; inf for implicit Euler,
    0 for explicit Euler on an undamped contact (it gains energy at any dt)."""
    omega = natural_frequency(ks, m_eff)
    return critical_omega_dt(integrator, damping_ratio(ks, kd, m_eff)) / omega


# The stability guard (``World`` refuses a larger dt). A ball in several contacts vibrates faster
# than one contact: in a dense pile of equal balls (12 contacts, face-centred cubic) the fastest
# mode has sum_j ks n_j n_j^T = 4 ks per ball against each moving neighbour, i.e. twice the
# frequency AND twice the damping ratio of one contact. An explicit dashpot at twice the damping
# ratio shrinks the stable step further: for symplectic Euler (omega dt)^2 + 4 zeta omega dt < 4
# per mode, so at zeta = 0.215 (e = 0.5) a pile needs 0.41x one contact's critical dt, not 0.5x (a
# pile of 30,000 such balls in a bowl at 0.5x kept gaining energy; at 0.41x it settles). The bound
# is for balls of one size: a big ball pressed by many small ones of similar mass has more contacts
# and a faster mode (40 contacts: 14.5 ks / m against the 8 ks / m assumed), which it does not cover.
GUARD_SAFETY = 0.5  # at least this margin on one contact's critical dt
PACKING_MODE = 4.0  # stiffness and damping multiplier of a dense pile's fastest mode


def guard_omega_dt(integrator: str, zeta: float = 0.0) -> float:
    """Largest omega0 * dt the stability guard accepts for a contact of damping ratio zeta:
    GUARD_SAFETY x its own critical value, and no more than the dense-pile mode's critical value
    (stiffness and damping x PACKING_MODE: frequency and damping ratio x 2)."""
    scale = math.sqrt(PACKING_MODE)
    return min(GUARD_SAFETY * critical_omega_dt(integrator, zeta), critical_omega_dt(integrator, scale * zeta) / scale)


def guard_dt(integrator: str, ks: float, kd: float, m_eff: float) -> float:
    """Largest dt the stability guard accepts for one contact (see ``guard_omega_dt``)."""
    return guard_omega_dt(integrator, damping_ratio(ks, kd, m_eff)) / natural_frequency(ks, m_eff)
