"""Integrator limits on a linear spring-dashpot contact: the stability boundary of each method, the
guard's step, and the mean energy gain per collision (docs/physics.md sections 4 and 6).

Units as in :mod:`.closed_forms`.
"""

from __future__ import annotations

import math

import numpy as np

from ..._validate import non_negative as _non_negative
from ..._validate import positive as _positive
from .closed_forms import DAMPING_MODES, INTEGRATORS, damping_ratio, natural_frequency

__all__ = [
    "amplification_matrix",
    "critical_omega_dt",
    "critical_dt",
    "GUARD_SAFETY",
    "PACKING_MODE",
    "guard_omega_dt",
    "guard_dt",
    "ENERGY_BUDGET",
    "ENERGY_PHASES",
    "energy_gain_per_collision",
    "energy_gain_envelope",
    "energy_omega_dt",
    "energy_dt",
]


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

    Closed forms (docs/physics.md section 4): explicit Euler 2 zeta (0: never stable); symplectic Euler
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


# --- energy per collision (the guard's energy budget) ------------------------------------------
# Symplectic Euler and velocity Verlet are symplectic only for a smooth force. A contact switch (the
# spring's kink where a contact begins and ends) leaves an energy error that depends on where in
# its step the switch falls, and its mean over that phase is not zero: each elastic collision gains
# energy on average, and many of them heat a scene at a step the stability limit allows
# (docs/physics.md section 6). The mean is a property of the method, omega0 dt, zeta and the damping
# mode: ``energy_gain_per_collision`` computes it from the methods' own one-step maps, applied to a
# ball hitting a wall (one contact, normal motion), and ``energy_omega_dt`` finds the largest
# omega0 dt whose mean gain stays within ENERGY_BUDGET.

ENERGY_BUDGET = 1e-5  # mean relative energy gain per collision: 1% per 1,000 collisions
ENERGY_PHASES = 512  # phases of the switch within the step that the mean is taken over


def _collision_gains(integrator: str, h: np.ndarray, c: float, clip: bool, phases: int) -> np.ndarray:
    """e_num^2 - 1 of a ball hitting a wall head on, shape (len(h), phases): every omega0 dt in ``h``
    (units omega0 = 1, approach speed 1, 2 zeta = c) at every phase of the contact's start within
    the step; where the contact never ended (overdamped), the energy it kept less 1 if that is not
    a gain, else inf."""
    h = np.asarray(h, dtype=np.float64)[:, None]
    ph = (np.arange(phases) + 0.5) / phases
    q = h * ph[None, :]  # the gap (< 0 in contact)
    u = -np.ones_like(q)

    def acc(q: np.ndarray, u: np.ndarray) -> np.ndarray:
        f = -q - c * u
        if clip:
            f = np.maximum(f, 0.0)
        return np.where(q < 0.0, f, 0.0)

    a0 = acc(q, u)
    touched = np.zeros(q.shape, dtype=bool)
    clear = np.zeros(q.shape, dtype=np.int64)  # steps since the contact ended
    for _ in range(int(4.0 * math.pi / float(h.min())) + 20):
        if integrator == "symplectic_euler":
            u = u + h * acc(q, u)
            q = q + h * u
        elif integrator == "explicit_euler":
            a = acc(q, u)
            q = q + h * u
            u = u + h * a
        elif integrator == "velocity_verlet":
            q1 = q + h * u + 0.5 * h * h * a0
            a1 = acc(q1, u + h * a0)
            u = u + 0.5 * h * (a0 + a1)
            q, a0 = q1, a1
        elif integrator == "rk4":
            k1q, k1u = u, acc(q, u)
            k2q, k2u = u + 0.5 * h * k1u, acc(q + 0.5 * h * k1q, u + 0.5 * h * k1u)
            k3q, k3u = u + 0.5 * h * k2u, acc(q + 0.5 * h * k2q, u + 0.5 * h * k2u)
            k4q, k4u = u + h * k3u, acc(q + h * k3q, u + h * k3u)
            q = q + h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
            u = u + h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u)
        else:  # implicit Euler, linearised about the contact set at the start of the step
            u = np.where(q < 0.0, (u - h * q) / (1.0 + h * c + h * h), u)
            q = q + h * u
        touched |= q < 0.0
        clear = np.where(touched & (q >= 0.0), clear + 1, 0)
        if np.all(clear >= 2):
            break
    with np.errstate(over="ignore", invalid="ignore"):
        gain = u * u - 1.0
        # a contact still on at the end (overdamped, zeta >= 1: the ball settles against the wall)
        # has gained nothing: its energy, kinetic plus spring, is what it kept
        kept = u * u + q * q - 1.0
    return np.where(clear >= 2, gain, np.where(np.isfinite(kept) & (kept <= 0.0), kept, np.inf))


def energy_gain_per_collision(
    integrator: str, omega_dt: float, zeta: float = 0.0, damping: str = "linear", phases: int = ENERGY_PHASES
) -> tuple[float, float]:
    """(mean, standard deviation) over where the contact starts within the step of e_num^2 - 1:
    the relative change of the normal kinetic energy over one collision of a linear spring-dashpot
    contact, integrated by ``integrator`` at ``omega_dt`` (0 for the exact elastic contact; about
    e^2 - 1 < 0 with damping; the energy kept less 1 for an overdamped contact that never ends; inf
    if it grows without ending). Each method is applied exactly as the
    World applies it (the dashpot explicit, velocity Verlet's at the predicted velocity, implicit
    Euler's contact set frozen at the start of the step), to a ball hitting a wall head on, gravity
    off. The mean oscillates with omega_dt (it nearly vanishes where a contact lasts a whole number
    of steps) under an envelope that grows about as omega_dt^4 for symplectic Euler and Verlet."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    if damping not in DAMPING_MODES:
        raise ValueError(f"damping must be one of {DAMPING_MODES}, got {damping!r}")
    h = _positive("omega_dt", omega_dt)
    c = 2.0 * _non_negative("zeta", zeta)
    gain = _collision_gains(integrator, np.array([h]), c, damping == "no_tension", phases)[0]
    if not np.all(np.isfinite(gain)):
        return math.inf, math.inf
    return float(gain.mean()), float(gain.std())


_ENERGY_CACHE: dict[tuple[str, float, str, float], float] = {}


def _energy_scan(integrator: str, top: float, zeta: float, damping: str) -> tuple[np.ndarray, np.ndarray]:
    """The omega0 dt of the scan up to ``top`` and the mean gain per collision at each."""
    lo, factor, phases = ENERGY_SCAN
    grid = lo * factor ** np.arange(int(math.ceil(math.log(max(top, lo) / lo) / math.log(factor))) + 1)
    grid = np.append(grid[grid < top], top)
    return grid, _collision_gains(integrator, grid, 2.0 * zeta, damping == "no_tension", phases).mean(axis=1)


def energy_gain_envelope(integrator: str, omega_dt: float, zeta: float = 0.0, damping: str = "linear") -> float:
    """The largest mean gain per collision at any omega0 dt of the scan up to ``omega_dt``: what a
    scene whose contacts differ in length can expect at that step (the mean itself dips where a
    contact lasts a whole number of steps)."""
    _, gains = _energy_scan(integrator, _positive("omega_dt", omega_dt), _non_negative("zeta", zeta), damping)
    return float(np.max(gains))


ENERGY_SCAN = (
    0.05,
    1.02,
    64,
)  # omega0 dt scanned from this value (a mean gain ~1e-7), by this factor, over these phases


def energy_omega_dt(
    integrator: str, zeta: float = 0.0, damping: str = "linear", budget: float = ENERGY_BUDGET
) -> float:
    """Largest omega0 dt, up to the stability guard's, below which no collision gains more than
    ``budget`` of its energy on average (``energy_gain_per_collision``, taken at every omega0 dt of
    a fine scan from below: the mean dips where a contact lasts a whole number of steps, and a scene
    whose contacts differ in length must not rely on a dip); 0 where none qualifies (explicit Euler
    without damping gains at any dt)."""
    zeta = _non_negative("zeta", zeta)
    key = (integrator, round(zeta, 9), damping, budget)
    if key in _ENERGY_CACHE:
        return _ENERGY_CACHE[key]
    top = guard_omega_dt(integrator, zeta)
    unbounded = not math.isfinite(top)  # implicit Euler: stable at any dt
    if unbounded:
        top = 10.0
    if top <= 0.0:
        _ENERGY_CACHE[key] = 0.0
        return 0.0
    grid, gains = _energy_scan(integrator, top, zeta, damping)
    bad = np.flatnonzero(~(gains <= budget))
    limit = float(top if bad.size == 0 else (grid[bad[0] - 1] if bad[0] > 0 else 0.0))
    if unbounded and bad.size == 0:
        limit = math.inf  # dissipative at every step scanned (it only damps more at larger ones)
    _ENERGY_CACHE[key] = limit
    return limit


def energy_dt(
    integrator: str, ks: float, kd: float, m_eff: float, damping: str = "linear", budget: float = ENERGY_BUDGET
) -> float:
    """Largest dt at which a collision of this contact gains at most ``budget`` of its energy on
    average (``energy_omega_dt``)."""
    return energy_omega_dt(integrator, damping_ratio(ks, kd, m_eff), damping, budget) / natural_frequency(ks, m_eff)
