"""Closed forms for a linear spring-dashpot contact: its frequency, damping, restitution, duration
and overlaps, with and without gravity or the no-tension clip.

Units are whatever the caller uses consistently (SI in the examples): ``ks`` force per length,
``kd`` force per speed, ``m_eff`` mass. ``m_eff = m_i m_j / (m_i + m_j)`` for a pair of balls and
``m_eff = m_i`` for a ball against static terrain (docs/physics.md section 3).

The contact is the seed's: the spring and the dashpot act while the overlap is positive and the
contact ends when the overlap returns to zero, so for ``zeta >= 1`` it never ends (``e = 0``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..._validate import non_negative as _non_negative
from ..._validate import positive as _positive

__all__ = [
    "restitution_no_tension",
    "zeta_for_restitution_no_tension",
    "INTEGRATORS",
    "DAMPING_MODES",
    "effective_mass",
    "ContactResponse",
    "contact_response",
    "restitution_for_zeta",
    "zeta_for_restitution",
    "peak_overlap_ratio",
    "natural_frequency",
    "damping_ratio",
    "restitution",
    "contact_time",
    "damping_for_restitution",
    "peak_overlap",
    "resting_overlap",
    "stiffness_for_penetration",
]

INTEGRATORS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler")
DAMPING_MODES = ("linear", "no_tension")


def effective_mass(m_i: float, m_j: float) -> float:
    """m_eff = m_i m_j / (m_i + m_j) of a pair (a ball against static terrain: m_eff = m_i)."""
    return m_i * m_j / (m_i + m_j)


def natural_frequency(ks: float, m_eff: float) -> float:
    """omega0 = sqrt(ks / m_eff), rad per unit time."""
    return math.sqrt(_positive("ks", ks) / _positive("m_eff", m_eff))


def damping_ratio(ks: float, kd: float, m_eff: float) -> float:
    """zeta = kd / (2 sqrt(ks m_eff)); 0 undamped, 1 critically damped."""
    return _non_negative("kd", kd) / (2.0 * math.sqrt(_positive("ks", ks) * _positive("m_eff", m_eff)))


def restitution(ks: float, kd: float, m_eff: float) -> float:
    """Normal coefficient of restitution e = exp(-pi zeta / sqrt(1 - zeta^2)) (0 when zeta >= 1)."""
    return restitution_for_zeta(damping_ratio(ks, kd, m_eff))


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
    zeta = zeta_for_restitution(e)
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


# --- the exact solution of one contact, either damping mode, optional gravity --------------------
# (the oracle of the accuracy benchmark, of configure and of the tests)


@dataclass(frozen=True)
class ContactResponse:
    """One contact hit at normal speed v (units: omega0 = 1, v = 1).

    restitution: exit speed / impact speed; duration: omega0 x the time from first touch to the
    overlap's return to zero; peak_overlap: omega0 / v x the largest overlap.
    """

    restitution: float
    duration: float
    peak_overlap: float


# exp, cos and sin of the closed forms below go through libm (Python's math) one element at a time,
# never through NumPy's ufunc loops: NumPy's float64 np.exp has an AVX-512 (X86_V4) SIMD path that
# is not correctly rounded and differs from libm's exp in the last bit for ~5% of arguments, and
# the roots found below sit where these functions cancel, so their last bits decide comparisons:
# zeta_for_restitution(0.8, "no_tension") came out 4 ulp apart on AVX-512 and AVX2 hosts (and with
# it kd, and every PenaltyBalls-v0 episode with restitution=0.8). libm's results are the ones NumPy
# gives on a host without AVX-512.


def _libm(fn: Callable[[float], float]) -> Callable[[np.ndarray], np.ndarray]:
    def f(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        return np.fromiter(map(fn, x.ravel().tolist()), np.float64, x.size).reshape(x.shape)

    return f


_exp, _cos, _sin = _libm(math.exp), _libm(math.cos), _libm(math.sin)


def _first_root(f: Callable[[np.ndarray], np.ndarray], t_max: float, n: int = 4000) -> float:
    """First t in (0, t_max] where f changes sign (from its sign just after 0), to machine precision."""
    ts = np.linspace(0.0, t_max, n + 1)[1:]
    vals = f(ts)
    s0 = np.sign(vals[0])
    idx = np.flatnonzero(np.sign(vals) != s0)
    if idx.size == 0:
        return math.inf
    k = int(idx[0])
    lo = ts[k - 1] if k > 0 else 0.5 * ts[0]
    hi = ts[k]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.sign(f(np.array([mid]))[0]) == s0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 4e-16 * hi:
            break
    return 0.5 * (lo + hi)


def _response(zeta: float, gamma: float) -> tuple[float, Callable, Callable, Callable]:
    """(omega_d, delta, delta', clipped force) of delta'' + 2 zeta delta' + delta = gamma from
    delta = 0, delta' = 1 (units v / omega0 and 1 / omega0): the functions take arrays of t."""
    wd = math.sqrt(1.0 - zeta * zeta)
    A = -gamma
    Bc = (1.0 + zeta * A) / wd
    D = -zeta * Bc - wd * A

    def delta(t: np.ndarray) -> np.ndarray:
        return gamma + _exp(-zeta * t) * (A * _cos(wd * t) + Bc * _sin(wd * t))

    def ddelta(t: np.ndarray) -> np.ndarray:
        return _exp(-zeta * t) * (_cos(wd * t) + D * _sin(wd * t))

    def force(t: np.ndarray) -> np.ndarray:  # delta + 2 zeta ddelta, each libm call made once
        x, c, s = _exp(-zeta * t), _cos(wd * t), _sin(wd * t)
        return (gamma + x * (A * c + Bc * s)) + 2.0 * zeta * (x * (c + D * s))

    return wd, delta, ddelta, force


def _peak(wd: float, delta: Callable, ddelta: Callable) -> tuple[float, float]:
    """(t, delta) at the response's first maximum (delta' = 0)."""
    t_peak = _first_root(ddelta, 2.0 * math.pi / wd)
    return t_peak, float(delta(np.array([t_peak]))[0])


def contact_response(zeta: float, damping: str = "linear", gravity_ratio: float = 0.0) -> ContactResponse:
    """Exact solution of delta'' + 2 zeta delta' + delta = gamma, delta(0) = 0, delta'(0) = 1
    (overlap delta in units of v / omega0, time in 1 / omega0; gamma = g / (omega0 v) is gravity
    pressing into the contact, 0 for a collision in free space).

    ``linear``: the contact lasts until the overlap returns to zero (the seed's law).
    ``no_tension``: the force ks delta + kd delta' is clipped at zero, so the contact stops pushing
    when ks delta + kd delta' = 0 and the bodies then fly apart (under gravity) until the overlap is zero.
    Raises ValueError if the contact never ends (zeta >= 1 for the linear law, or gravity too strong).
    """
    if damping not in DAMPING_MODES:
        raise ValueError(f"damping must be one of {DAMPING_MODES}, got {damping!r}")
    zeta = float(zeta)
    gamma = float(gravity_ratio)
    if not (0.0 <= zeta < 1.0):
        raise ValueError(f"zeta must be in [0, 1) for a contact that ends, got {zeta!r}")
    wd, delta, ddelta, force = _response(zeta, gamma)
    t_max = 2.0 * math.pi / wd
    t_peak, peak = _peak(wd, delta, ddelta)
    if damping == "linear" or zeta == 0.0:
        # delta starts at 0 and grows: look for its return through zero after the peak
        t_end = t_peak + _first_root(lambda t: delta(t + t_peak), t_max)
        if not math.isfinite(t_end):
            raise ValueError("the contact never ends (gravity holds the ball in contact)")
        exit_speed = -float(ddelta(np.array([t_end]))[0])
        return ContactResponse(exit_speed, t_end, peak)
    # no tension: contact force ks delta + kd delta' (units m omega0^2) hits zero first
    t_clip = _first_root(force, t_max)
    if not math.isfinite(t_clip):
        raise ValueError("the contact never ends (gravity holds the ball in contact)")
    d1 = float(delta(np.array([t_clip]))[0])
    v1 = float(ddelta(np.array([t_clip]))[0])  # < 0: separating
    disc = v1 * v1 - 2.0 * gamma * d1
    if v1 >= 0.0 or disc < 0.0:
        raise ValueError("the contact never ends (gravity pulls the ball back before it leaves)")
    exit_speed = math.sqrt(disc)
    flight = (d1 / -v1) if gamma == 0.0 else (-v1 - exit_speed) / gamma
    return ContactResponse(exit_speed, t_clip + flight, peak)


def peak_overlap_ratio(zeta: float, gravity_ratio: float = 0.0) -> float:
    """Largest overlap of a contact hit at speed v, in units of v / omega0 (1 when undamped without
    gravity; either damping mode: the no-tension clip acts only after the peak)."""
    zeta = float(zeta)
    gamma = float(gravity_ratio)
    if not (0.0 <= zeta < 1.0):
        raise ValueError(f"zeta must be in [0, 1), got {zeta!r}")
    return _peak(*_response(zeta, gamma)[:3])[1]


def restitution_for_zeta(zeta: float, damping: str = "linear") -> float:
    """Coefficient of restitution of a contact of damping ratio zeta (no gravity)."""
    if damping == "linear":
        if zeta >= 1.0:
            return 0.0
        return math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta))
    return contact_response(zeta, damping).restitution


def zeta_for_restitution(e: float, damping: str = "linear") -> float:
    """The damping ratio that gives restitution e in (0, 1] (inverse of :func:`restitution_for_zeta`)."""
    e = float(e)
    if not (math.isfinite(e) and 0.0 < e <= 1.0):
        raise ValueError(f"restitution must be in (0, 1], got {e!r}")
    log_e = math.log(e)
    z_lin = -log_e / math.sqrt(math.pi**2 + log_e**2)
    if damping == "linear" or e == 1.0:
        return z_lin
    if damping not in DAMPING_MODES:
        raise ValueError(f"damping must be one of {DAMPING_MODES}, got {damping!r}")
    # no tension ends the contact earlier, so it needs more damping for the same e; e(zeta) is
    # decreasing: bisect on [0, 0.999]
    lo, hi = 0.0, 0.999
    if restitution_for_zeta(hi, damping) > e:
        raise ValueError(f"restitution {e} is below what the no-tension law can reach with zeta < 1")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if restitution_for_zeta(mid, damping) > e:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def restitution_no_tension(zeta: Any) -> np.ndarray:
    """Restitution of a no-tension contact of damping ratio(s) zeta in [0, 1), in closed form
    (elementwise; no gravity): the force ks delta + kd delta' of delta = exp(-zeta t) sin(wd t) / wd
    (omega0 = v = 1, wd = sqrt(1 - zeta^2)) first vanishes at wd t = theta = pi - atan2(2 zeta wd,
    1 - 2 zeta^2), where the balls part at the speed -delta'(t) they keep (the overlap then closes
    in free flight). The same law as :func:`restitution_for_zeta` (``no_tension``), which finds
    that instant numerically."""
    z = np.asarray(zeta, dtype=np.float64)
    wd = np.sqrt(1.0 - z * z)
    theta = np.pi - np.arctan2(2.0 * z * wd, 1.0 - 2.0 * z * z)
    return -np.exp(-z * theta / wd) * (np.cos(theta) - z / wd * np.sin(theta))


def zeta_for_restitution_no_tension(e: Any) -> np.ndarray:
    """The damping ratios that give restitutions e (elementwise, each in (0, 1], above the law's
    floor at zeta 0.999) under the no-tension law: :func:`zeta_for_restitution` (``no_tension``),
    with its bisection (60 halvings of [0, 0.999]) on the closed form
    :func:`restitution_no_tension`; microseconds per value instead of that function's numerical
    integration (the randomised environments derive a dashpot per world at every reset)."""
    e = np.asarray(e, dtype=np.float64)
    if not np.all(np.isfinite(e) & (e > 0.0) & (e <= 1.0)):
        raise ValueError(f"restitution must be in (0, 1], got {e.tolist()!r}")
    if np.any(restitution_no_tension(0.999) > e):
        raise ValueError(f"restitution {e.min()} is below what the no-tension law can reach with zeta < 1")
    lo = np.zeros_like(e)
    hi = np.full_like(e, 0.999)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = restitution_no_tension(mid) > e
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return np.where(e == 1.0, 0.0, 0.5 * (lo + hi))


# --- stability -------------------------------------------------------------------------------
