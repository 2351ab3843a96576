"""Tolerance-driven configuration: from what a user knows to ks, kd, an integrator and dt.

A user knows the masses and radii, the largest impact speed, how deep a contact may overlap (a
fraction of the radius), the restitution wanted, and how accurately that restitution must come out.
:func:`configure` turns that into the contact parameters and the cheapest (integrator, dt, event
location) that meets the accuracy, from the *measured* error models of the accuracy benchmark:

* ``ks`` from the penetration tolerance: delta_max = v / omega0 <= tol r  =>  ks >= m_eff v^2 / (tol r)^2
  (PHYSICS.md section 3), for the heaviest contact (the deepest), then raised until the exact peak
  overlap (damping, gravity) times (1 + the chosen method's predicted peak error) fits;
* ``kd`` from the target restitution, by the closed form of the chosen damping mode (linear:
  zeta = -ln e / sqrt(pi^2 + ln^2 e); no-tension: the exact solution below, inverted numerically);
* the integrator, event location and steps per contact from the worst-case (over the contact's
  phase in the step grid) restitution errors measured by ``python -m penalty_env.bench accuracy``
  (:data:`ERROR_MODELS`: per integrator, event location, damping mode, metric and zeta, the
  measured worst cases from the first usable steps per contact on, interpolated in log-log, and
  ``err = C (steps per contact)^-p`` fitted to the asymptotic tail for beyond the sweep; the
  ``p`` are the measured convergence orders). The cost of a choice is its force-evaluation
  equivalents per contact duration (:data:`COST_PER_STEP`, :data:`EVENT_EXTRA_EVALS`). The time
  step resolves the *shortest* contact the scene can form (the lightest pair) and respects the
  World's stability guard.

Regenerate the data block (between the ``BEGIN``/``END MEASURED`` markers) with
``python -m penalty_env.bench accuracy --fit`` (it rewrites this file in place).

The module also holds the exact solution of one linear spring-dashpot contact with optional
constant gravity and either damping mode (:func:`contact_response`), which is the oracle of the
accuracy benchmark and of the tests.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from . import theory

__all__ = [
    "ContactResponse",
    "contact_response",
    "restitution_for_zeta",
    "zeta_for_restitution",
    "peak_overlap_ratio",
    "ContactConfig",
    "configure",
    "predicted_error",
    "config_cost",
    "ERROR_MODELS",
    "COST_PER_STEP",
    "EVENT_EXTRA_EVALS",
    "SAFETY",
]

DAMPING_MODES = ("linear", "no_tension")

# --------------------------------------------------------------------------------------------
# Exact response of one contact (the oracle)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ContactResponse:
    """One contact hit at normal speed v (units: omega0 = 1, v = 1).

    restitution: exit speed / impact speed; duration: omega0 x the time from first touch to the
    overlap's return to zero; peak_overlap: omega0 / v x the largest overlap.
    """

    restitution: float
    duration: float
    peak_overlap: float


def _first_root(f, t_max: float, n: int = 4000) -> float:
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
    wd = math.sqrt(1.0 - zeta * zeta)
    A = -gamma
    Bc = (1.0 + zeta * A) / wd
    D = -zeta * Bc - wd * A

    def delta(t):
        return gamma + np.exp(-zeta * t) * (A * np.cos(wd * t) + Bc * np.sin(wd * t))

    def ddelta(t):
        return np.exp(-zeta * t) * (np.cos(wd * t) + D * np.sin(wd * t))

    t_max = 2.0 * math.pi / wd
    t_peak = _first_root(ddelta, t_max)
    peak = float(delta(np.array([t_peak]))[0])
    if damping == "linear" or zeta == 0.0:
        # delta starts at 0 and grows: look for its return through zero after the peak
        t_end = t_peak + _first_root(lambda t: delta(t + t_peak), t_max)
        if not math.isfinite(t_end):
            raise ValueError("the contact never ends (gravity holds the ball in contact)")
        exit_speed = -float(ddelta(np.array([t_end]))[0])
        return ContactResponse(exit_speed, t_end, peak)
    # no tension: contact force ks delta + kd delta' (units m omega0^2) hits zero first
    t_clip = _first_root(lambda t: delta(t) + 2.0 * zeta * ddelta(t), t_max)
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
    wd = math.sqrt(1.0 - zeta * zeta)
    A = -gamma
    Bc = (1.0 + zeta * A) / wd
    D = -zeta * Bc - wd * A
    t_peak = _first_root(lambda t: np.exp(-zeta * t) * (np.cos(wd * t) + D * np.sin(wd * t)), 2.0 * math.pi / wd)
    return float(gamma + math.exp(-zeta * t_peak) * (A * math.cos(wd * t_peak) + Bc * math.sin(wd * t_peak)))


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


# --------------------------------------------------------------------------------------------
# Measured error models and costs (generated: do not edit by hand)
# --------------------------------------------------------------------------------------------
# BEGIN MEASURED (python -m penalty_env.bench accuracy --fit)
# 4248 runs, full sweep, phases=1024
ERROR_MODELS: dict = {
    'explicit_euler|events|linear|peak_overlap|0': {'C': 2.667, 'p': 1.012, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3864), (16, 0.1729), (32, 0.08165), (64, 0.03967), (128, 0.01955), (256, 0.009707), (512, 0.004836))},
    'explicit_euler|events|linear|peak_overlap|0.1': {'C': 2.511, 'p': 1.011, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3551), (16, 0.1645), (32, 0.07708), (64, 0.03747), (128, 0.01847), (256, 0.009178), (512, 0.004575))},
    'explicit_euler|events|linear|peak_overlap|0.3': {'C': 2.409, 'p': 1.015, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.1568), (32, 0.07309), (64, 0.03537), (128, 0.01738), (256, 0.008601), (512, 0.004286))},
    'explicit_euler|events|linear|peak_overlap|0.5': {'C': 2.424, 'p': 1.015, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.1581), (32, 0.0745), (64, 0.03554), (128, 0.01749), (256, 0.008646), (512, 0.004306))},
    'explicit_euler|events|linear|peak_overlap|0.7': {'C': 2.858, 'p': 1.024, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.1937), (32, 0.08592), (64, 0.0405), (128, 0.01964), (256, 0.0097), (512, 0.004815))},
    'explicit_euler|events|linear|restitution|0': {'C': 5.565, 'p': 1.016, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3582), (32, 0.1678), (64, 0.08141), (128, 0.03993), (256, 0.01978), (512, 0.009841))},
    'explicit_euler|events|linear|restitution|0.1': {'C': 5.686, 'p': 1.016, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3719), (32, 0.1721), (64, 0.0831), (128, 0.04079), (256, 0.02017), (512, 0.01004))},
    'explicit_euler|events|linear|restitution|0.3': {'C': 6.573, 'p': 1.018, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4323), (32, 0.1997), (64, 0.09528), (128, 0.04659), (256, 0.02306), (512, 0.01146))},
    'explicit_euler|events|linear|restitution|0.5': {'C': 9.806, 'p': 1.023, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.2944), (64, 0.1395), (128, 0.06782), (256, 0.03346), (512, 0.01662))},
    'explicit_euler|events|linear|restitution|0.7': {'C': 12.48, 'p': 1.039, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.3656), (64, 0.166), (128, 0.07915), (256, 0.03867), (512, 0.01911))},
    'explicit_euler|events|no_tension|peak_overlap|0': {'C': 2.667, 'p': 1.012, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3864), (16, 0.1729), (32, 0.08165), (64, 0.03967), (128, 0.01955), (256, 0.009707), (512, 0.004836))},
    'explicit_euler|events|no_tension|peak_overlap|0.1': {'C': 2.511, 'p': 1.011, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3551), (16, 0.1645), (32, 0.07708), (64, 0.03747), (128, 0.01847), (256, 0.009178), (512, 0.004575))},
    'explicit_euler|events|no_tension|peak_overlap|0.3': {'C': 2.409, 'p': 1.015, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3524), (16, 0.1568), (32, 0.07309), (64, 0.03537), (128, 0.01738), (256, 0.008601), (512, 0.004286))},
    'explicit_euler|events|no_tension|peak_overlap|0.5': {'C': 2.424, 'p': 1.015, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.384), (16, 0.1581), (32, 0.0745), (64, 0.03554), (128, 0.01749), (256, 0.008646), (512, 0.004306))},
    'explicit_euler|events|no_tension|peak_overlap|0.7': {'C': 2.858, 'p': 1.024, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.1937), (32, 0.08592), (64, 0.0405), (128, 0.01964), (256, 0.0097), (512, 0.004815))},
    'explicit_euler|events|no_tension|restitution|0': {'C': 5.565, 'p': 1.016, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3582), (32, 0.1678), (64, 0.08141), (128, 0.03993), (256, 0.01978), (512, 0.009841))},
    'explicit_euler|events|no_tension|restitution|0.1': {'C': 5.357, 'p': 1.017, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3508), (32, 0.1628), (64, 0.07804), (128, 0.03822), (256, 0.01891), (512, 0.009416))},
    'explicit_euler|events|no_tension|restitution|0.3': {'C': 5.262, 'p': 1.018, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3486), (32, 0.1592), (64, 0.07636), (128, 0.03738), (256, 0.01848), (512, 0.009194))},
    'explicit_euler|events|no_tension|restitution|0.5': {'C': 5.809, 'p': 1.019, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.38), (32, 0.1742), (64, 0.08375), (128, 0.04082), (256, 0.02021), (512, 0.01004))},
    'explicit_euler|events|no_tension|restitution|0.7': {'C': 7.827, 'p': 1.022, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.5218), (32, 0.238), (64, 0.1118), (128, 0.05458), (256, 0.02687), (512, 0.01336))},
    'explicit_euler|plain|linear|peak_overlap|0': {'C': 2.667, 'p': 1.012, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3864), (16, 0.1729), (32, 0.08165), (64, 0.03967), (128, 0.01955), (256, 0.009707), (512, 0.004836))},
    'explicit_euler|plain|linear|peak_overlap|0.1': {'C': 3.208, 'p': 1.012, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4585), (16, 0.2094), (32, 0.09825), (64, 0.0477), (128, 0.0235), (256, 0.01167), (512, 0.005814))},
    'explicit_euler|plain|linear|peak_overlap|0.3': {'C': 4.571, 'p': 1.014, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.2971), (32, 0.1389), (64, 0.06729), (128, 0.03308), (256, 0.01639), (512, 0.008162))},
    'explicit_euler|plain|linear|peak_overlap|0.5': {'C': 6.402, 'p': 1.015, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4174), (32, 0.1956), (64, 0.09414), (128, 0.04632), (256, 0.02294), (512, 0.01141))},
    'explicit_euler|plain|linear|peak_overlap|0.7': {'C': 9.637, 'p': 1.017, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.2927), (64, 0.1402), (128, 0.06861), (256, 0.03399), (512, 0.0169))},
    'explicit_euler|plain|linear|restitution|0': {'C': 5.571, 'p': 1.016, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3708), (32, 0.1705), (64, 0.08144), (128, 0.03994), (256, 0.01978), (512, 0.009843))},
    'explicit_euler|plain|linear|restitution|0.1': {'C': 6.966, 'p': 1.039, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4163), (32, 0.1882), (64, 0.09272), (128, 0.04346), (256, 0.02144), (512, 0.01065))},
    'explicit_euler|plain|linear|restitution|0.3': {'C': 11.83, 'p': 1.095, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.5562), (32, 0.2707), (64, 0.1214), (128, 0.05515), (256, 0.02396), (512, 0.01277))},
    'explicit_euler|plain|linear|restitution|0.5': {'C': 7.736, 'p': 0.9243, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.3991), (64, 0.1571), (128, 0.08726), (256, 0.03968), (512, 0.02414))},
    'explicit_euler|plain|linear|restitution|0.7': {'C': 7.349, 'p': 0.8304, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.3765), (64, 0.1631), (128, 0.1307), (256, 0.06257), (512, 0.03062))},
    'explicit_euler|plain|no_tension|peak_overlap|0': {'C': 2.667, 'p': 1.012, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3864), (16, 0.1729), (32, 0.08165), (64, 0.03967), (128, 0.01955), (256, 0.009707), (512, 0.004836))},
    'explicit_euler|plain|no_tension|peak_overlap|0.1': {'C': 3.208, 'p': 1.012, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4585), (16, 0.2094), (32, 0.09825), (64, 0.0477), (128, 0.0235), (256, 0.01167), (512, 0.005814))},
    'explicit_euler|plain|no_tension|peak_overlap|0.3': {'C': 4.571, 'p': 1.014, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.2971), (32, 0.1389), (64, 0.06729), (128, 0.03308), (256, 0.01639), (512, 0.008162))},
    'explicit_euler|plain|no_tension|peak_overlap|0.5': {'C': 6.402, 'p': 1.015, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4174), (32, 0.1956), (64, 0.09414), (128, 0.04632), (256, 0.02294), (512, 0.01141))},
    'explicit_euler|plain|no_tension|peak_overlap|0.7': {'C': 9.637, 'p': 1.017, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.2927), (64, 0.1402), (128, 0.06861), (256, 0.03399), (512, 0.0169))},
    'explicit_euler|plain|no_tension|restitution|0': {'C': 5.571, 'p': 1.016, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3708), (32, 0.1705), (64, 0.08144), (128, 0.03994), (256, 0.01978), (512, 0.009843))},
    'explicit_euler|plain|no_tension|restitution|0.1': {'C': 6.136, 'p': 1.018, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4042), (32, 0.1859), (64, 0.08878), (128, 0.0434), (256, 0.02145), (512, 0.01068))},
    'explicit_euler|plain|no_tension|restitution|0.3': {'C': 7.764, 'p': 1.021, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.5177), (32, 0.2336), (64, 0.1112), (128, 0.05421), (256, 0.02676), (512, 0.01329))},
    'explicit_euler|plain|no_tension|restitution|0.5': {'C': 10.75, 'p': 1.023, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.3215), (64, 0.1527), (128, 0.07419), (256, 0.03659), (512, 0.01817))},
    'explicit_euler|plain|no_tension|restitution|0.7': {'C': 17.66, 'p': 1.025, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.531), (64, 0.2485), (128, 0.1205), (256, 0.05933), (512, 0.02945))},
    'implicit_euler|events|linear|peak_overlap|0': {'C': 2.297, 'p': 0.9882, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5027), (4, 0.3927), (8, 0.2477), (16, 0.1378), (32, 0.07285), (64, 0.03747), (128, 0.019), (256, 0.00957), (512, 0.004802))},
    'implicit_euler|events|linear|peak_overlap|0.1': {'C': 2.174, 'p': 0.9884, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4713), (4, 0.3715), (8, 0.2293), (16, 0.1283), (32, 0.06897), (64, 0.03544), (128, 0.01797), (256, 0.009047), (512, 0.00454))},
    'implicit_euler|events|linear|peak_overlap|0.3': {'C': 2.023, 'p': 0.9876, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4248), (4, 0.3323), (8, 0.2056), (16, 0.1188), (32, 0.06407), (64, 0.03312), (128, 0.01679), (256, 0.008462), (512, 0.00425))},
    'implicit_euler|events|linear|peak_overlap|0.5': {'C': 1.983, 'p': 0.983, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.3972), (4, 0.2936), (8, 0.2043), (16, 0.1165), (32, 0.06364), (64, 0.03289), (128, 0.01682), (256, 0.008479), (512, 0.004264))},
    'implicit_euler|events|linear|peak_overlap|0.7': {'C': 2.152, 'p': 0.9782, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.3832), (4, 0.2717), (8, 0.2007), (16, 0.1233), (32, 0.06864), (64, 0.03629), (128, 0.01868), (256, 0.009437), (512, 0.004753))},
    'implicit_euler|events|linear|restitution|0': {'C': 4.537, 'p': 0.9834, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4503), (16, 0.2648), (32, 0.1441), (64, 0.07529), (128, 0.03841), (256, 0.0194), (512, 0.009747))},
    'implicit_euler|events|linear|restitution|0.1': {'C': 4.582, 'p': 0.9817, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4626), (16, 0.2707), (32, 0.1472), (64, 0.07652), (128, 0.03913), (256, 0.01978), (512, 0.009942))},
    'implicit_euler|events|linear|restitution|0.3': {'C': 5.191, 'p': 0.9809, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.5062), (16, 0.3017), (32, 0.1657), (64, 0.08706), (128, 0.04449), (256, 0.02252), (512, 0.01133))},
    'implicit_euler|events|linear|restitution|0.5': {'C': 7.318, 'p': 0.9762, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4247), (32, 0.2363), (64, 0.1246), (128, 0.06416), (256, 0.03254), (512, 0.01638))},
    'implicit_euler|events|linear|restitution|0.7': {'C': 7.694, 'p': 0.9622, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4293), (32, 0.2529), (64, 0.138), (128, 0.0722), (256, 0.03693), (512, 0.01868))},
    'implicit_euler|events|no_tension|peak_overlap|0': {'C': 2.297, 'p': 0.9882, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5027), (4, 0.3927), (8, 0.2477), (16, 0.1378), (32, 0.07285), (64, 0.03747), (128, 0.019), (256, 0.00957), (512, 0.004802))},
    'implicit_euler|events|no_tension|restitution|0': {'C': 4.537, 'p': 0.9834, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4503), (16, 0.2648), (32, 0.1441), (64, 0.07529), (128, 0.03841), (256, 0.0194), (512, 0.009747))},
    'implicit_euler|plain|linear|peak_overlap|0': {'C': 2.297, 'p': 0.9882, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3926), (8, 0.2477), (16, 0.1378), (32, 0.07285), (64, 0.03747), (128, 0.019), (256, 0.00957), (512, 0.004802))},
    'implicit_euler|plain|linear|peak_overlap|0.1': {'C': 2.173, 'p': 0.9884, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3714), (8, 0.2291), (16, 0.1283), (32, 0.06897), (64, 0.03543), (128, 0.01796), (256, 0.009047), (512, 0.004538))},
    'implicit_euler|plain|linear|peak_overlap|0.3': {'C': 2.021, 'p': 0.9875, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.4501), (8, 0.2056), (16, 0.1188), (32, 0.06401), (64, 0.03309), (128, 0.01677), (256, 0.008455), (512, 0.004246))},
    'implicit_euler|plain|linear|peak_overlap|0.5': {'C': 1.972, 'p': 0.9823, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.322), (16, 0.129), (32, 0.06364), (64, 0.03283), (128, 0.01679), (256, 0.008466), (512, 0.004264))},
    'implicit_euler|plain|linear|peak_overlap|0.7': {'C': 4.236, 'p': 1.02, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.2805), (32, 0.1282), (64, 0.06091), (128, 0.02965), (256, 0.01469), (512, 0.007292))},
    'implicit_euler|plain|linear|restitution|0': {'C': 4.878, 'p': 0.9953, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.5064), (16, 0.288), (32, 0.1504), (64, 0.07749), (128, 0.03899), (256, 0.01954), (512, 0.009784))},
    'implicit_euler|plain|linear|restitution|0.1': {'C': 5.071, 'p': 0.9809, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4934), (16, 0.2945), (32, 0.1702), (64, 0.08217), (128, 0.04172), (256, 0.02202), (512, 0.01054))},
    'implicit_euler|plain|linear|restitution|0.3': {'C': 8.374, 'p': 1.031, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.5865), (16, 0.368), (32, 0.2141), (64, 0.1095), (128, 0.05636), (256, 0.02732), (512, 0.01289))},
    'implicit_euler|plain|linear|restitution|0.5': {'C': 10.02, 'p': 0.9774, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4924), (32, 0.3087), (64, 0.1369), (128, 0.08738), (256, 0.03373), (512, 0.01965))},
    'implicit_euler|plain|linear|restitution|0.7': {'C': 10.7, 'p': 0.9407, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.5752), (32, 0.364), (64, 0.2077), (128, 0.1114), (256, 0.05777), (512, 0.02942))},
    'implicit_euler|plain|no_tension|peak_overlap|0': {'C': 2.297, 'p': 0.9882, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3926), (8, 0.2477), (16, 0.1378), (32, 0.07285), (64, 0.03747), (128, 0.019), (256, 0.00957), (512, 0.004802))},
    'implicit_euler|plain|no_tension|restitution|0': {'C': 4.878, 'p': 0.9953, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.5064), (16, 0.288), (32, 0.1504), (64, 0.07749), (128, 0.03899), (256, 0.01954), (512, 0.009784))},
    'rk4|events|linear|peak_overlap|0': {'C': 0.5642, 'p': 4.135, 'spc_min': 2.0, 'spc_max': 256.0, 'floor': 1e-11, 'pts': ((2, 0.08855), (4, 0.01049), (8, 0.0001466), (16, 6.788e-06), (32, 3.373e-07), (64, 1.817e-08), (128, 1.041e-09), (256, 6.209e-11))},
    'rk4|events|linear|peak_overlap|0.1': {'C': 0.0041, 'p': 2.853, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.09553), (4, 0.004577), (8, 3.529e-05), (16, 4.208e-06), (32, 3.699e-07), (64, 2.588e-08), (128, 1.767e-09), (256, 1.78e-10), (512, 7.62e-11))},
    'rk4|events|linear|peak_overlap|0.3': {'C': 0.01116, 'p': 2.839, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4883), (4, 0.02595), (8, 0.0002667), (16, 1.778e-05), (32, 1.191e-06), (64, 7.491e-08), (128, 4.923e-09), (256, 5.053e-10), (512, 2.265e-10))},
    'rk4|events|linear|peak_overlap|0.5': {'C': 0.01808, 'p': 2.837, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.06275), (8, 0.0005866), (16, 3.324e-05), (32, 1.997e-06), (64, 1.209e-07), (128, 7.674e-09), (256, 7.573e-10), (512, 3.72e-10))},
    'rk4|events|linear|peak_overlap|0.7': {'C': 0.002432, 'p': 2.468, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.592), (8, 0.05137), (16, 2.912e-05), (32, 1.456e-06), (64, 7.974e-08), (128, 5.078e-09), (256, 7.602e-10), (512, 5.018e-10))},
    'rk4|events|linear|restitution|0': {'C': 6.478, 'p': 4.989, 'spc_min': 2.0, 'spc_max': 128.0, 'floor': 1e-11, 'pts': ((2, 0.1181), (4, 0.01328), (8, 0.0001999), (16, 6.34e-06), (32, 1.989e-07), (64, 6.316e-09), (128, 1.974e-10))},
    'rk4|events|linear|restitution|0.1': {'C': 2.179, 'p': 4.147, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1262), (4, 0.0061), (8, 0.0001566), (16, 1.123e-05), (32, 9.052e-07), (64, 6.077e-08), (128, 3.972e-09), (256, 2.164e-10), (512, 1.105e-11))},
    'rk4|events|linear|restitution|0.3': {'C': 7.88, 'p': 4.171, 'spc_min': 2.0, 'spc_max': 256.0, 'floor': 5.236e-10, 'pts': ((2, 0.4837), (4, 0.03292), (8, 0.0007977), (16, 5.247e-05), (32, 3.371e-06), (64, 2.107e-07), (128, 1.278e-08), (256, 5.594e-10))},
    'rk4|events|linear|restitution|0.5': {'C': 6.306, 'p': 3.936, 'spc_min': 4.0, 'spc_max': 256.0, 'floor': 1.792e-09, 'pts': ((4, 0.107), (8, 0.02754), (16, 0.0001228), (32, 7.175e-06), (64, 4.331e-07), (128, 2.48e-08), (256, 2.089e-09))},
    'rk4|events|linear|restitution|0.7': {'C': 0.01714, 'p': 1.989, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.05028), (16, 0.0009222), (32, 6.016e-05), (64, 3.694e-06), (128, 2.779e-07), (256, 2.779e-07), (512, 3.563e-08))},
    'rk4|events|no_tension|peak_overlap|0': {'C': 0.5642, 'p': 4.135, 'spc_min': 2.0, 'spc_max': 256.0, 'floor': 1e-11, 'pts': ((2, 0.08855), (4, 0.01049), (8, 0.0001466), (16, 6.788e-06), (32, 3.373e-07), (64, 1.817e-08), (128, 1.041e-09), (256, 6.209e-11))},
    'rk4|events|no_tension|peak_overlap|0.1': {'C': 0.0041, 'p': 2.853, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.09554), (4, 0.004577), (8, 3.529e-05), (16, 4.208e-06), (32, 3.699e-07), (64, 2.588e-08), (128, 1.767e-09), (256, 1.78e-10), (512, 7.62e-11))},
    'rk4|events|no_tension|peak_overlap|0.3': {'C': 0.01116, 'p': 2.839, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4883), (4, 0.02595), (8, 0.0002667), (16, 1.778e-05), (32, 1.191e-06), (64, 7.491e-08), (128, 4.923e-09), (256, 5.053e-10), (512, 2.265e-10))},
    'rk4|events|no_tension|peak_overlap|0.5': {'C': 0.01808, 'p': 2.837, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.06275), (8, 0.0005866), (16, 3.324e-05), (32, 1.997e-06), (64, 1.209e-07), (128, 7.674e-09), (256, 7.573e-10), (512, 3.72e-10))},
    'rk4|events|no_tension|peak_overlap|0.7': {'C': 0.01707, 'p': 2.78, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.592), (8, 0.05137), (16, 3.659e-05), (32, 2.388e-06), (64, 1.53e-07), (128, 7.718e-09), (256, 9.359e-10), (512, 5.018e-10))},
    'rk4|events|no_tension|restitution|0': {'C': 6.478, 'p': 4.989, 'spc_min': 2.0, 'spc_max': 128.0, 'floor': 1e-11, 'pts': ((2, 0.1181), (4, 0.01328), (8, 0.0001999), (16, 6.34e-06), (32, 1.989e-07), (64, 6.316e-09), (128, 1.974e-10))},
    'rk4|events|no_tension|restitution|0.1': {'C': 0.4074, 'p': 1.996, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1307), (4, 0.008643), (8, 0.006505), (16, 0.001594), (32, 0.000401), (64, 0.000101), (128, 2.538e-05), (256, 6.363e-06), (512, 1.593e-06))},
    'rk4|events|no_tension|restitution|0.3': {'C': 0.43, 'p': 1.986, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4411), (4, 0.02953), (8, 0.005705), (16, 0.001603), (32, 0.0004273), (64, 0.0001105), (128, 2.808e-05), (256, 7.08e-06), (512, 1.777e-06))},
    'rk4|events|no_tension|restitution|0.5': {'C': 0.5169, 'p': 1.974, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.08067), (8, 0.005272), (16, 0.001824), (32, 0.0005204), (64, 0.0001386), (128, 3.574e-05), (256, 9.075e-06), (512, 2.286e-06))},
    'rk4|events|no_tension|restitution|0.7': {'C': 0.7785, 'p': 1.956, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.06344), (16, 0.0026), (32, 0.0008029), (64, 0.0002229), (128, 5.873e-05), (256, 1.508e-05), (512, 3.819e-06))},
    'rk4|plain|linear|peak_overlap|0': {'C': 0.4113, 'p': 2.0, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1041), (4, 0.02354), (8, 0.00634), (16, 0.001604), (32, 0.0004015), (64, 0.0001004), (128, 2.51e-05), (256, 6.275e-06), (512, 1.569e-06))},
    'rk4|plain|linear|peak_overlap|0.1': {'C': 0.2292, 'p': 1.013, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1883), (4, 0.07802), (8, 0.03286), (16, 0.01479), (32, 0.006962), (64, 0.00339), (128, 0.00167), (256, 0.0008261), (512, 0.0004127))},
    'rk4|plain|linear|peak_overlap|0.3': {'C': 0.6781, 'p': 1.004, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4883), (4, 0.1964), (8, 0.08943), (16, 0.04296), (32, 0.02096), (64, 0.0104), (128, 0.005173), (256, 0.00258), (512, 0.001288))},
    'rk4|plain|linear|peak_overlap|0.5': {'C': 1.236, 'p': 1.003, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3503), (8, 0.1604), (16, 0.07752), (32, 0.03832), (64, 0.01903), (128, 0.00948), (256, 0.004718), (512, 0.002364))},
    'rk4|plain|linear|peak_overlap|0.7': {'C': 2.072, 'p': 1.001, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.592), (8, 0.2706), (16, 0.1315), (32, 0.06475), (64, 0.03218), (128, 0.01609), (256, 0.008032), (512, 0.004013))},
    'rk4|plain|linear|restitution|0': {'C': 8.719e-05, 'p': 1.091, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1248), (4, 0.01672), (8, 0.005324), (16, 0.002002), (32, 0.0004031), (64, 9.337e-07), (128, 3.992e-07), (256, 1.936e-07), (512, 9.56e-08))},
    'rk4|plain|linear|restitution|0.1': {'C': 0.3001, 'p': 0.9921, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.2376), (4, 0.1001), (8, 0.05142), (16, 0.01659), (32, 0.008514), (64, 0.004845), (128, 0.001866), (256, 0.001017), (512, 0.0005993))},
    'rk4|plain|linear|restitution|0.3': {'C': 0.9745, 'p': 1.006, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4611), (4, 0.2699), (8, 0.1095), (16, 0.05932), (32, 0.03616), (64, 0.01487), (128, 0.005995), (256, 0.003403), (512, 0.001758))},
    'rk4|plain|linear|restitution|0.5': {'C': 2.205, 'p': 1.042, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3235), (8, 0.23), (16, 0.1284), (32, 0.04446), (64, 0.02407), (128, 0.01406), (256, 0.005411), (512, 0.002981))},
    'rk4|plain|linear|restitution|0.7': {'C': 2.187, 'p': 1.01, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.5919), (8, 0.3012), (16, 0.1398), (32, 0.06711), (64, 0.03283), (128, 0.01623), (256, 0.008067), (512, 0.004022))},
    'rk4|plain|no_tension|peak_overlap|0': {'C': 0.4113, 'p': 2.0, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1041), (4, 0.02354), (8, 0.00634), (16, 0.001604), (32, 0.0004015), (64, 0.0001004), (128, 2.51e-05), (256, 6.275e-06), (512, 1.569e-06))},
    'rk4|plain|no_tension|peak_overlap|0.1': {'C': 0.2292, 'p': 1.013, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1883), (4, 0.07802), (8, 0.03286), (16, 0.01479), (32, 0.006962), (64, 0.00339), (128, 0.00167), (256, 0.0008261), (512, 0.0004127))},
    'rk4|plain|no_tension|peak_overlap|0.3': {'C': 0.6781, 'p': 1.004, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4883), (4, 0.1964), (8, 0.08943), (16, 0.04296), (32, 0.02096), (64, 0.0104), (128, 0.005173), (256, 0.00258), (512, 0.001288))},
    'rk4|plain|no_tension|peak_overlap|0.5': {'C': 1.236, 'p': 1.003, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3503), (8, 0.1604), (16, 0.07752), (32, 0.03832), (64, 0.01903), (128, 0.00948), (256, 0.004718), (512, 0.002364))},
    'rk4|plain|no_tension|peak_overlap|0.7': {'C': 2.072, 'p': 1.001, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.592), (8, 0.2706), (16, 0.1315), (32, 0.06475), (64, 0.03218), (128, 0.01609), (256, 0.008032), (512, 0.004013))},
    'rk4|plain|no_tension|restitution|0': {'C': 8.719e-05, 'p': 1.091, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1248), (4, 0.01672), (8, 0.005324), (16, 0.002002), (32, 0.0004031), (64, 9.337e-07), (128, 3.992e-07), (256, 1.936e-07), (512, 9.56e-08))},
    'rk4|plain|no_tension|restitution|0.1': {'C': 0.2231, 'p': 1.007, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.1566), (4, 0.08389), (8, 0.03532), (16, 0.01538), (32, 0.007113), (64, 0.003382), (128, 0.001687), (256, 0.0008383), (512, 0.000417))},
    'rk4|plain|no_tension|restitution|0.3': {'C': 0.7108, 'p': 1.004, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5234), (4, 0.2101), (8, 0.09712), (16, 0.04572), (32, 0.0222), (64, 0.01092), (128, 0.005445), (256, 0.002713), (512, 0.001354))},
    'rk4|plain|no_tension|restitution|0.5': {'C': 1.407, 'p': 1.004, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.4222), (8, 0.1847), (16, 0.08789), (32, 0.04367), (64, 0.02163), (128, 0.01077), (256, 0.00537), (512, 0.002682))},
    'rk4|plain|no_tension|restitution|0.7': {'C': 2.769, 'p': 1.003, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3627), (16, 0.1748), (32, 0.08603), (64, 0.04271), (128, 0.02128), (256, 0.01062), (512, 0.005304))},
    'symplectic_euler|events|linear|peak_overlap|0': {'C': 0.1306, 'p': 1.187, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1149), (8, 0.02995), (16, 0.008773), (32, 0.002799), (64, 0.0009361), (128, 0.0003863), (256, 0.00017), (512, 7.918e-05))},
    'symplectic_euler|events|linear|peak_overlap|0.1': {'C': 0.4803, 'p': 0.995, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.3682), (4, 0.08918), (8, 0.05323), (16, 0.03109), (32, 0.01515), (64, 0.007649), (128, 0.003844), (256, 0.001927), (512, 0.0009663))},
    'symplectic_euler|events|linear|peak_overlap|0.3': {'C': 1.625, 'p': 0.9974, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3732), (8, 0.1968), (16, 0.101), (32, 0.0508), (64, 0.02561), (128, 0.01285), (256, 0.006433), (512, 0.003219))},
    'symplectic_euler|events|linear|peak_overlap|0.5': {'C': 3.102, 'p': 0.9975, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3743), (16, 0.193), (32, 0.09701), (64, 0.04892), (128, 0.02451), (256, 0.01228), (512, 0.006146))},
    'symplectic_euler|events|linear|peak_overlap|0.7': {'C': 5.497, 'p': 1.0, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3411), (32, 0.1712), (64, 0.08583), (128, 0.04288), (256, 0.02144), (512, 0.01073))},
    'symplectic_euler|events|linear|restitution|0': {'C': 0.07547, 'p': 0.9964, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4703), (4, 0.1362), (8, 0.03717), (16, 0.009545), (32, 0.002403), (64, 0.001193), (128, 0.0006), (256, 0.0003005), (512, 0.0001503))},
    'symplectic_euler|events|linear|restitution|0.1': {'C': 0.1971, 'p': 1.206, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5951), (4, 0.1545), (8, 0.04144), (16, 0.01174), (32, 0.003686), (64, 0.00131), (128, 0.0005235), (256, 0.0002291), (512, 0.0001064))},
    'symplectic_euler|events|linear|restitution|0.3': {'C': 0.5627, 'p': 1.007, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.228), (8, 0.08249), (16, 0.03639), (32, 0.01738), (64, 0.008529), (128, 0.004227), (256, 0.002104), (512, 0.00105))},
    'symplectic_euler|events|linear|restitution|0.5': {'C': 3.33, 'p': 1.008, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4934), (16, 0.2081), (32, 0.1013), (64, 0.05034), (128, 0.02481), (256, 0.01238), (512, 0.006182))},
    'symplectic_euler|events|linear|restitution|0.7': {'C': 9.425, 'p': 1.002, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.5713), (32, 0.292), (64, 0.146), (128, 0.07278), (256, 0.03635), (512, 0.01817))},
    'symplectic_euler|events|no_tension|peak_overlap|0': {'C': 0.1306, 'p': 1.187, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1149), (8, 0.02995), (16, 0.008773), (32, 0.002799), (64, 0.0009361), (128, 0.0003863), (256, 0.00017), (512, 7.918e-05))},
    'symplectic_euler|events|no_tension|peak_overlap|0.1': {'C': 0.4803, 'p': 0.995, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.3682), (4, 0.08918), (8, 0.05323), (16, 0.03109), (32, 0.01515), (64, 0.007649), (128, 0.003844), (256, 0.001927), (512, 0.0009663))},
    'symplectic_euler|events|no_tension|peak_overlap|0.3': {'C': 1.625, 'p': 0.9974, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3732), (8, 0.1968), (16, 0.101), (32, 0.0508), (64, 0.02561), (128, 0.01285), (256, 0.006433), (512, 0.003219))},
    'symplectic_euler|events|no_tension|peak_overlap|0.5': {'C': 3.102, 'p': 0.9975, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3743), (16, 0.193), (32, 0.09701), (64, 0.04892), (128, 0.02451), (256, 0.01228), (512, 0.006146))},
    'symplectic_euler|events|no_tension|peak_overlap|0.7': {'C': 5.497, 'p': 1.0, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3411), (32, 0.1712), (64, 0.08583), (128, 0.04288), (256, 0.02144), (512, 0.01073))},
    'symplectic_euler|events|no_tension|restitution|0': {'C': 0.07547, 'p': 0.9964, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4703), (4, 0.1362), (8, 0.03717), (16, 0.009545), (32, 0.002403), (64, 0.001193), (128, 0.0006), (256, 0.0003005), (512, 0.0001503))},
    'symplectic_euler|events|no_tension|restitution|0.1': {'C': 0.3949, 'p': 1.014, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1714), (8, 0.05914), (16, 0.02512), (32, 0.01193), (64, 0.005814), (128, 0.002868), (256, 0.001422), (512, 0.0007051))},
    'symplectic_euler|events|no_tension|restitution|0.3': {'C': 1.343, 'p': 1.002, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3616), (8, 0.1711), (16, 0.08517), (32, 0.04194), (64, 0.02078), (128, 0.01037), (256, 0.005173), (512, 0.002585))},
    'symplectic_euler|events|no_tension|restitution|0.5': {'C': 2.901, 'p': 1.002, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3688), (16, 0.1785), (32, 0.08903), (64, 0.04488), (128, 0.02229), (256, 0.01117), (512, 0.005574))},
    'symplectic_euler|events|no_tension|restitution|0.7': {'C': 6.274, 'p': 1.004, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4032), (32, 0.1947), (64, 0.0963), (128, 0.04782), (256, 0.02389), (512, 0.01192))},
    'symplectic_euler|plain|linear|peak_overlap|0': {'C': 0.1306, 'p': 1.187, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1149), (8, 0.02995), (16, 0.008773), (32, 0.002799), (64, 0.0009361), (128, 0.0003863), (256, 0.00017), (512, 7.918e-05))},
    'symplectic_euler|plain|linear|peak_overlap|0.1': {'C': 0.4429, 'p': 0.9813, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1362), (8, 0.0429), (16, 0.02456), (32, 0.01411), (64, 0.0074), (128, 0.003789), (256, 0.00192), (512, 0.0009618))},
    'symplectic_euler|plain|linear|peak_overlap|0.3': {'C': 1.596, 'p': 0.9949, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3759), (8, 0.1847), (16, 0.09663), (32, 0.05044), (64, 0.02542), (128, 0.01277), (256, 0.006413), (512, 0.003211))},
    'symplectic_euler|plain|linear|peak_overlap|0.5': {'C': 3.09, 'p': 0.997, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3743), (16, 0.193), (32, 0.09701), (64, 0.04886), (128, 0.02449), (256, 0.01227), (512, 0.006146))},
    'symplectic_euler|plain|linear|peak_overlap|0.7': {'C': 5.513, 'p': 1.001, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3407), (32, 0.171), (64, 0.08583), (128, 0.04288), (256, 0.02142), (512, 0.01071))},
    'symplectic_euler|plain|linear|restitution|0': {'C': 0.07864, 'p': 1.003, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4952), (4, 0.03648), (8, 0.01464), (16, 0.008145), (32, 0.003609), (64, 0.001213), (128, 0.0006035), (256, 0.0003014), (512, 0.0001506))},
    'symplectic_euler|plain|linear|restitution|0.1': {'C': 0.8043, 'p': 1.079, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.2409), (8, 0.09306), (16, 0.03423), (32, 0.01589), (64, 0.009054), (128, 0.003817), (256, 0.001896), (512, 0.0009453))},
    'symplectic_euler|plain|linear|restitution|0.3': {'C': 1.429, 'p': 0.9165, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.5124), (8, 0.2205), (16, 0.1045), (32, 0.04998), (64, 0.02724), (128, 0.01641), (256, 0.005573), (512, 0.004699))},
    'symplectic_euler|plain|linear|restitution|0.5': {'C': 14.0, 'p': 1.157, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3185), (32, 0.1735), (64, 0.1028), (128, 0.04056), (256, 0.0229), (512, 0.008582))},
    'symplectic_euler|plain|linear|restitution|0.7': {'C': 9.027, 'p': 0.9885, 'spc_min': 32.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((32, 0.4224), (64, 0.147), (128, 0.07457), (256, 0.03753), (512, 0.01883))},
    'symplectic_euler|plain|no_tension|peak_overlap|0': {'C': 0.1306, 'p': 1.187, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1149), (8, 0.02995), (16, 0.008773), (32, 0.002799), (64, 0.0009361), (128, 0.0003863), (256, 0.00017), (512, 7.918e-05))},
    'symplectic_euler|plain|no_tension|peak_overlap|0.1': {'C': 0.4429, 'p': 0.9813, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1362), (8, 0.0429), (16, 0.02456), (32, 0.01411), (64, 0.0074), (128, 0.003789), (256, 0.00192), (512, 0.0009618))},
    'symplectic_euler|plain|no_tension|peak_overlap|0.3': {'C': 1.596, 'p': 0.9949, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3759), (8, 0.1847), (16, 0.09663), (32, 0.05044), (64, 0.02542), (128, 0.01277), (256, 0.006413), (512, 0.003211))},
    'symplectic_euler|plain|no_tension|peak_overlap|0.5': {'C': 3.09, 'p': 0.997, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3743), (16, 0.193), (32, 0.09701), (64, 0.04886), (128, 0.02449), (256, 0.01227), (512, 0.006146))},
    'symplectic_euler|plain|no_tension|peak_overlap|0.7': {'C': 5.513, 'p': 1.001, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.3407), (32, 0.171), (64, 0.08583), (128, 0.04288), (256, 0.02142), (512, 0.01071))},
    'symplectic_euler|plain|no_tension|restitution|0': {'C': 0.07864, 'p': 1.003, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4952), (4, 0.03648), (8, 0.01464), (16, 0.008145), (32, 0.003609), (64, 0.001213), (128, 0.0006035), (256, 0.0003014), (512, 0.0001506))},
    'symplectic_euler|plain|no_tension|restitution|0.1': {'C': 0.3871, 'p': 1.008, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.216), (8, 0.07113), (16, 0.02534), (32, 0.0128), (64, 0.005858), (128, 0.00287), (256, 0.001441), (512, 0.0007183))},
    'symplectic_euler|plain|no_tension|restitution|0.3': {'C': 1.308, 'p': 0.9985, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.4853), (8, 0.1657), (16, 0.07888), (32, 0.04043), (64, 0.02057), (128, 0.01027), (256, 0.005155), (512, 0.002577))},
    'symplectic_euler|plain|no_tension|restitution|0.5': {'C': 2.895, 'p': 1.002, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3689), (16, 0.1783), (32, 0.08899), (64, 0.04484), (128, 0.02228), (256, 0.01116), (512, 0.005574))},
    'symplectic_euler|plain|no_tension|restitution|0.7': {'C': 6.26, 'p': 1.004, 'spc_min': 16.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((16, 0.4035), (32, 0.1945), (64, 0.09622), (128, 0.0478), (256, 0.02389), (512, 0.01192))},
    'velocity_verlet|events|linear|peak_overlap|0': {'C': 1.235, 'p': 2.0, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5797), (4, 0.08701), (8, 0.01985), (16, 0.004854), (32, 0.001207), (64, 0.0003013), (128, 7.531e-05), (256, 1.883e-05), (512, 4.706e-06))},
    'velocity_verlet|events|linear|peak_overlap|0.1': {'C': 0.6649, 'p': 2.006, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5631), (4, 0.05019), (8, 0.01105), (16, 0.00267), (32, 0.0006411), (64, 0.0001582), (128, 3.927e-05), (256, 9.781e-06), (512, 2.44e-06))},
    'velocity_verlet|events|linear|peak_overlap|0.3': {'C': 0.1048, 'p': 1.991, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.0253), (8, 0.001637), (16, 0.0004265), (32, 0.0001001), (64, 2.629e-05), (128, 6.696e-06), (256, 1.667e-06), (512, 4.204e-07))},
    'velocity_verlet|events|linear|peak_overlap|0.5': {'C': 0.4606, 'p': 1.947, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.08818), (8, 0.001724), (16, 0.001422), (32, 0.0004501), (64, 0.0001371), (128, 3.615e-05), (256, 9.434e-06), (512, 2.387e-06))},
    'velocity_verlet|events|linear|peak_overlap|0.7': {'C': 2.715, 'p': 1.961, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.04986), (16, 0.009488), (32, 0.002782), (64, 0.000765), (128, 0.0002001), (256, 5.117e-05), (512, 1.298e-05))},
    'velocity_verlet|events|linear|restitution|0': {'C': 0.2978, 'p': 3.478, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.2461), (4, 0.01037), (8, 0.0006156), (16, 3.732e-05), (32, 2.288e-06), (64, 1.414e-07), (128, 8.784e-09), (256, 5.938e-10), (512, 1.122e-10))},
    'velocity_verlet|events|linear|restitution|0.1': {'C': 1.435, 'p': 1.997, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.533), (4, 0.08672), (8, 0.02156), (16, 0.005536), (32, 0.001407), (64, 0.0003539), (128, 8.885e-05), (256, 2.225e-05), (512, 5.566e-06))},
    'velocity_verlet|events|linear|restitution|0.3': {'C': 4.98, 'p': 2.007, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3237), (8, 0.08026), (16, 0.01961), (32, 0.004793), (64, 0.001183), (128, 0.0002935), (256, 7.305e-05), (512, 1.822e-05))},
    'velocity_verlet|events|linear|restitution|0.5': {'C': 11.12, 'p': 2.026, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.1869), (16, 0.04446), (32, 0.01029), (64, 0.002442), (128, 0.0005925), (256, 0.0001458), (512, 3.616e-05))},
    'velocity_verlet|events|linear|restitution|0.7': {'C': 13.22, 'p': 2.123, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.1968), (16, 0.04766), (32, 0.009527), (64, 0.001932), (128, 0.000421), (256, 9.727e-05), (512, 2.331e-05))},
    'velocity_verlet|events|no_tension|peak_overlap|0': {'C': 1.235, 'p': 2.0, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5797), (4, 0.08701), (8, 0.01985), (16, 0.004854), (32, 0.001207), (64, 0.0003013), (128, 7.531e-05), (256, 1.883e-05), (512, 4.706e-06))},
    'velocity_verlet|events|no_tension|peak_overlap|0.1': {'C': 0.6649, 'p': 2.006, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5631), (4, 0.05019), (8, 0.01105), (16, 0.00267), (32, 0.0006411), (64, 0.0001582), (128, 3.927e-05), (256, 9.781e-06), (512, 2.44e-06))},
    'velocity_verlet|events|no_tension|peak_overlap|0.3': {'C': 0.1048, 'p': 1.991, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.2861), (4, 0.0253), (8, 0.001637), (16, 0.0004265), (32, 0.0001001), (64, 2.629e-05), (128, 6.696e-06), (256, 1.667e-06), (512, 4.204e-07))},
    'velocity_verlet|events|no_tension|peak_overlap|0.5': {'C': 0.4606, 'p': 1.947, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.08818), (8, 0.001724), (16, 0.001422), (32, 0.0004501), (64, 0.0001371), (128, 3.615e-05), (256, 9.434e-06), (512, 2.387e-06))},
    'velocity_verlet|events|no_tension|peak_overlap|0.7': {'C': 2.704, 'p': 1.958, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.04986), (16, 0.00982), (32, 0.002832), (64, 0.0007659), (128, 0.0002028), (256, 5.187e-05), (512, 1.31e-05))},
    'velocity_verlet|events|no_tension|restitution|0': {'C': 0.2978, 'p': 3.478, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.2461), (4, 0.01037), (8, 0.0006156), (16, 3.732e-05), (32, 2.288e-06), (64, 1.414e-07), (128, 8.784e-09), (256, 5.938e-10), (512, 1.122e-10))},
    'velocity_verlet|events|no_tension|restitution|0.1': {'C': 1.318, 'p': 1.995, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5695), (4, 0.07885), (8, 0.01951), (16, 0.005039), (32, 0.001294), (64, 0.0003281), (128, 8.245e-05), (256, 2.069e-05), (512, 5.181e-06))},
    'velocity_verlet|events|no_tension|restitution|0.3': {'C': 3.819, 'p': 2.002, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.2404), (8, 0.05974), (16, 0.01484), (32, 0.003709), (64, 0.0009243), (128, 0.0002306), (256, 5.757e-05), (512, 1.438e-05))},
    'velocity_verlet|events|no_tension|restitution|0.5': {'C': 7.001, 'p': 2.014, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.4031), (8, 0.1136), (16, 0.02752), (32, 0.00663), (64, 0.001612), (128, 0.0003962), (256, 9.825e-05), (512, 2.444e-05))},
    'velocity_verlet|events|no_tension|restitution|0.7': {'C': 14.4, 'p': 2.04, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.2134), (16, 0.05342), (32, 0.01293), (64, 0.002978), (128, 0.0007132), (256, 0.0001734), (512, 4.284e-05))},
    'velocity_verlet|plain|linear|peak_overlap|0': {'C': 1.235, 'p': 2.0, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5797), (4, 0.08701), (8, 0.01985), (16, 0.004854), (32, 0.001207), (64, 0.0003013), (128, 7.531e-05), (256, 1.883e-05), (512, 4.706e-06))},
    'velocity_verlet|plain|linear|peak_overlap|0.1': {'C': 0.3401, 'p': 1.011, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1298), (8, 0.04925), (16, 0.02194), (32, 0.01039), (64, 0.005067), (128, 0.0025), (256, 0.001239), (512, 0.0006187))},
    'velocity_verlet|plain|linear|peak_overlap|0.3': {'C': 1.024, 'p': 1.006, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3013), (8, 0.1356), (16, 0.06503), (32, 0.03166), (64, 0.01562), (128, 0.007757), (256, 0.003865), (512, 0.001929))},
    'velocity_verlet|plain|linear|peak_overlap|0.5': {'C': 1.919, 'p': 1.009, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.2651), (16, 0.1234), (32, 0.05929), (64, 0.02893), (128, 0.01431), (256, 0.007112), (512, 0.003553))},
    'velocity_verlet|plain|linear|peak_overlap|0.7': {'C': 3.358, 'p': 1.014, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3828), (16, 0.2138), (32, 0.1019), (64, 0.04959), (128, 0.02443), (256, 0.0121), (512, 0.006026))},
    'velocity_verlet|plain|linear|restitution|0': {'C': 0.03164, 'p': 1.955, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4674), (4, 0.03329), (8, 0.005125), (16, 0.003352), (32, 0.001206), (64, 9.321e-06), (128, 1.6e-06), (256, 4.16e-07), (512, 1.596e-07))},
    'velocity_verlet|plain|linear|restitution|0.1': {'C': 0.5714, 'p': 0.9835, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1646), (8, 0.1008), (16, 0.0385), (32, 0.01822), (64, 0.009482), (128, 0.004836), (256, 0.002442), (512, 0.001227))},
    'velocity_verlet|plain|linear|restitution|0.3': {'C': 2.109, 'p': 1.01, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.2958), (16, 0.136), (32, 0.06481), (64, 0.03162), (128, 0.01562), (256, 0.007765), (512, 0.003871))},
    'velocity_verlet|plain|linear|restitution|0.5': {'C': 3.494, 'p': 0.9939, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.549), (16, 0.2461), (32, 0.1105), (64, 0.05584), (128, 0.02812), (256, 0.01411), (512, 0.00707))},
    'velocity_verlet|plain|linear|restitution|0.7': {'C': 4.686, 'p': 0.955, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.441), (16, 0.2537), (32, 0.1554), (64, 0.08632), (128, 0.04555), (256, 0.0234), (512, 0.01186))},
    'velocity_verlet|plain|no_tension|peak_overlap|0': {'C': 1.235, 'p': 2.0, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.5797), (4, 0.08701), (8, 0.01985), (16, 0.004854), (32, 0.001207), (64, 0.0003013), (128, 7.531e-05), (256, 1.883e-05), (512, 4.706e-06))},
    'velocity_verlet|plain|no_tension|peak_overlap|0.1': {'C': 0.3401, 'p': 1.011, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1298), (8, 0.04925), (16, 0.02194), (32, 0.01039), (64, 0.005067), (128, 0.0025), (256, 0.001239), (512, 0.0006187))},
    'velocity_verlet|plain|no_tension|peak_overlap|0.3': {'C': 1.024, 'p': 1.006, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.3013), (8, 0.1356), (16, 0.06503), (32, 0.03166), (64, 0.01562), (128, 0.007757), (256, 0.003865), (512, 0.001929))},
    'velocity_verlet|plain|no_tension|peak_overlap|0.5': {'C': 1.919, 'p': 1.009, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.2651), (16, 0.1234), (32, 0.05929), (64, 0.02893), (128, 0.01431), (256, 0.007112), (512, 0.003553))},
    'velocity_verlet|plain|no_tension|peak_overlap|0.7': {'C': 3.358, 'p': 1.014, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.4424), (16, 0.2138), (32, 0.1019), (64, 0.04959), (128, 0.02443), (256, 0.0121), (512, 0.006026))},
    'velocity_verlet|plain|no_tension|restitution|0': {'C': 0.03164, 'p': 1.955, 'spc_min': 2.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((2, 0.4674), (4, 0.03329), (8, 0.005125), (16, 0.003352), (32, 0.001206), (64, 9.321e-06), (128, 1.6e-06), (256, 4.16e-07), (512, 1.596e-07))},
    'velocity_verlet|plain|no_tension|restitution|0.1': {'C': 0.3681, 'p': 1.022, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.1412), (8, 0.04605), (16, 0.02392), (32, 0.01095), (64, 0.00524), (128, 0.002535), (256, 0.001251), (512, 0.0006248))},
    'velocity_verlet|plain|no_tension|restitution|0.3': {'C': 1.215, 'p': 1.024, 'spc_min': 4.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((4, 0.4487), (8, 0.179), (16, 0.07842), (32, 0.03578), (64, 0.01719), (128, 0.008333), (256, 0.004112), (512, 0.002043))},
    'velocity_verlet|plain|no_tension|restitution|0.5': {'C': 2.451, 'p': 1.026, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.3804), (16, 0.1607), (32, 0.07244), (64, 0.03431), (128, 0.0166), (256, 0.008176), (512, 0.004055))},
    'velocity_verlet|plain|no_tension|restitution|0.7': {'C': 5.128, 'p': 1.035, 'spc_min': 8.0, 'spc_max': 512.0, 'floor': 1e-11, 'pts': ((8, 0.5938), (16, 0.3356), (32, 0.1481), (64, 0.06932), (128, 0.03313), (256, 0.01628), (512, 0.008042))},
}
COST_PER_STEP: dict = {'explicit_euler': 1.0, 'symplectic_euler': 1.0, 'velocity_verlet': 1.0, 'rk4': 4.0, 'implicit_euler': 4.36}
EVENT_EXTRA_EVALS: dict = {'explicit_euler': 7.99, 'symplectic_euler': 9.95, 'velocity_verlet': 13.9, 'rk4': 30.0, 'implicit_euler': 46.4}
MODEL_SOURCE = '4248 runs, full sweep, phases=1024'
# END MEASURED

# configure() asks for SAFETY x the steps per contact that the fitted model says meet the tolerance
# (the fit is an upper envelope of the measured worst cases; this covers phases between samples)
SAFETY = 1.15
METRICS = ("restitution",)  # the accuracy tolerance; the peak overlap is held by ks (see configure)


def _model_key(integrator: str, events: bool, damping: str, metric: str, zeta: float) -> str:
    return f"{integrator}|{'events' if events else 'plain'}|{damping}|{metric}|{zeta:g}"


def _models_at(integrator: str, events: bool, damping: str, metric: str, zeta: float):
    """[(zeta_k, model)] at the measured zetas that bracket ``zeta`` (one or two)."""
    zetas = sorted({float(k.split("|")[4]) for k in ERROR_MODELS
                    if k.startswith(f"{integrator}|{'events' if events else 'plain'}|{damping}|{metric}|")})
    if not zetas:
        return []
    if zeta > zetas[-1] * (1.0 + 1e-9):
        return []  # beyond the measured damping ratios: errors grow faster than linearly, no model
    if zeta >= zetas[-1]:
        chosen = [zetas[-1]]
    else:
        above = next(z for z in zetas if z >= zeta)
        below = max((z for z in zetas if z <= zeta), default=above)
        chosen = sorted({below, above})
    return [(z, ERROR_MODELS[_model_key(integrator, events, damping, metric, z)]) for z in chosen]


def _model_error(mdl: dict, spc: float) -> float:
    """One fitted model at ``spc`` steps per contact: the measured worst cases (a non-increasing
    envelope) interpolated in log-log inside the sweep, the tail's C spc^-p beyond it (up to 4x),
    inf below the first usable point."""
    if spc < mdl["spc_min"] or spc > 4.0 * mdl["spc_max"]:
        return math.inf
    pts = mdl["pts"]
    if spc >= pts[-1][0]:
        return max(min(mdl["C"] * spc ** (-mdl["p"]), pts[-1][1]), mdl["floor"])
    for (s0, e0), (s1, e1) in zip(pts[:-1], pts[1:]):
        if s0 <= spc <= s1:
            w = math.log(spc / s0) / math.log(s1 / s0)
            return max(math.exp((1.0 - w) * math.log(e0) + w * math.log(e1)), mdl["floor"])
    return max(pts[0][1], mdl["floor"])


def predicted_error(integrator: str, events: bool, damping: str, zeta: float, steps_per_contact: float,
                    metric: str = "restitution") -> float:
    """Worst-case relative error predicted by the fitted models, interpolated linearly in zeta
    between the two measured zetas around it (errors grow about linearly with the dashpot's jump
    2 zeta omega0 v); inf where no model covers the point (unstable, or outside the fit)."""
    models = _models_at(integrator, events, damping, metric, zeta)
    if not models:
        return math.inf
    errs = []
    for _, mdl in models:
        err = _model_error(mdl, steps_per_contact)
        if not math.isfinite(err):
            return math.inf
        errs.append(err)
    if len(errs) == 1:
        return errs[0]
    (z0, _), (z1, _) = models
    w = min(max((zeta - z0) / (z1 - z0), 0.0), 1.0)
    return (1.0 - w) * errs[0] + w * errs[1]


def _steps_needed(integrator, events, damping, zeta, tol, metric) -> float:
    """Smallest steps per contact with predicted error <= tol (inf if none in the models' range)."""
    models = _models_at(integrator, events, damping, metric, zeta)
    if not models:
        return math.inf
    lo = max(m["spc_min"] for _, m in models)
    hi = min(m["spc_max"] for _, m in models) * 4.0

    def err(spc):
        return predicted_error(integrator, events, damping, zeta, spc, metric)

    if err(hi) > tol:
        return math.inf
    if err(lo) <= tol:
        return lo
    for _ in range(60):  # the models fall monotonically with the steps per contact
        mid = math.sqrt(lo * hi)
        if err(mid) > tol:
            lo = mid
        else:
            hi = mid
    return hi


def config_cost(integrator: str, events: bool, steps_per_contact: float) -> float:
    """Force-evaluation equivalents per contact duration of one isolated contact."""
    cost = COST_PER_STEP[integrator] * steps_per_contact
    if events:
        cost += EVENT_EXTRA_EVALS.get(integrator, math.inf)
    return cost


@dataclass
class ContactConfig:
    """What :func:`configure` chose. ``world_kwargs()`` gives the ``World`` arguments."""

    ks: float
    kd: float
    ks_terrain: float
    kd_terrain: float
    damping: str
    integrator: str
    events: bool
    dt: float
    steps_per_contact: float  # of the shortest contact (the lightest pair, or ball on terrain)
    zeta: float  # of the contact the restitution was set for (the heaviest)
    zeta_range: tuple  # smallest and largest damping ratio over the contacts the scene can form
    restitution_range: tuple
    contact_time: float  # shortest contact duration
    predicted_error: dict  # metric -> predicted worst-case relative error of the chosen method
    cost_per_contact: float  # force-evaluation equivalents per contact duration
    cost_per_second: float  # force-evaluation equivalents per simulated second
    alternatives: list = field(default_factory=list)  # (cost, integrator, events, steps) considered

    def world_kwargs(self) -> dict:
        return dict(ks=self.ks, kd=self.kd, ks_terrain=self.ks_terrain, kd_terrain=self.kd_terrain,
                    damping=self.damping, integrator=self.integrator, dt=self.dt, events=self.events)

    def as_dict(self) -> dict:
        return asdict(self)


def configure(
    masses,
    radii,
    max_impact_speed: float,
    penetration: float = 0.05,
    restitution: float = 0.5,
    accuracy: float = 0.01,
    *,
    damping: str = "linear",
    terrain: bool = True,
    integrators=theory.INTEGRATORS,
    events: bool | None = None,
    max_dt: float | None = None,
    max_force: float | None = None,
    gravity: float = 0.0,
) -> ContactConfig:
    """Contact parameters and the cheapest integrator / dt for a penetration and an accuracy tolerance.

    Args:
        masses, radii: of the balls the scene holds (all > 0).
        max_impact_speed: the largest normal speed at which two bodies meet (> 0).
        penetration: largest overlap allowed, as a fraction of the smaller radius in contact.
        restitution: target coefficient of restitution in (0, 1], met exactly (closed form) by the
            heaviest contact; lighter contacts get a larger damping ratio, so a smaller e
            (``restitution_range`` reports it).
        accuracy: largest relative error of the restitution (and of the peak overlap) allowed, worst
            case over where a contact starts within the step grid.
        damping: ``"linear"`` or ``"no_tension"`` (see :class:`World`).
        terrain: the balls also touch static terrain (adds the ball-terrain contacts).
        integrators: the integrators to choose from.
        events: force event location on (True) or off (False); None lets the cost decide.
        max_dt: an upper bound on dt (e.g. a control period); the step never exceeds it.
        max_force: the largest steady force pressing two bodies together (a motor, a weight);
            ks also keeps its static overlap F / ks under the penetration tolerance.
        gravity: acceleration pressing the bodies into their contacts while they collide (g for
            balls falling on terrain); it deepens the peak overlap, which ks accounts for.

    The penetration tolerance is a hard bound: ks starts at m_eff v^2 / delta^2 and is then raised
    until the exact peak overlap (with damping and gravity, :func:`peak_overlap_ratio`) times
    (1 + the chosen method's predicted peak-overlap error) fits under delta. The restitution
    accuracy and the method's cost depend only on zeta and the steps per contact, so raising ks
    (with kd raised to keep zeta) shortens dt but changes neither the choice nor its accuracy.

    Returns:
        A :class:`ContactConfig`. Raises ValueError when no integrator in the measured models meets
        the accuracy (tighter than the models' floors).
    """
    m = np.asarray(masses, dtype=np.float64).reshape(-1)
    r = np.asarray(radii, dtype=np.float64).reshape(-1)
    if m.size == 0 or r.size != m.size or np.any(m <= 0) or np.any(r <= 0):
        raise ValueError("masses and radii must be equal-length sequences of numbers > 0")
    for name, val in (("max_impact_speed", max_impact_speed), ("penetration", penetration),
                      ("accuracy", accuracy)):
        if not (math.isfinite(float(val)) and float(val) > 0.0):
            raise ValueError(f"{name} must be a finite number > 0, got {val!r}")
    if damping not in DAMPING_MODES:
        raise ValueError(f"damping must be one of {DAMPING_MODES}, got {damping!r}")
    if not ERROR_MODELS:
        raise RuntimeError("no measured error models: run python -m penalty_env.bench accuracy --fit")
    v = float(max_impact_speed)
    delta_tol = float(penetration) * float(r.min())
    ms = np.sort(m)
    # effective masses of the contacts the scene can form: heaviest and lightest pair, and terrain
    pair_meff = []
    if m.size >= 2:
        pair_meff = [ms[-1] * ms[-2] / (ms[-1] + ms[-2]), ms[0] * ms[1] / (ms[0] + ms[1])]
    terr_meff = [ms[-1], ms[0]] if terrain else []
    if not pair_meff and not terr_meff:
        raise ValueError("a single ball without terrain forms no contact")
    zeta_ref = zeta_for_restitution(restitution, damping)
    ks = theory.stiffness_for_penetration(pair_meff[0], v, delta_tol) if pair_meff else 1.0
    ks_t = theory.stiffness_for_penetration(terr_meff[0], v, delta_tol) if terr_meff else ks
    if max_force is not None:
        if not (math.isfinite(float(max_force)) and float(max_force) >= 0.0):
            raise ValueError(f"max_force must be a finite number >= 0, got {max_force!r}")
        ks = max(ks, float(max_force) / delta_tol)
        ks_t = max(ks_t, float(max_force) / delta_tol)
    kd = 2.0 * zeta_ref * math.sqrt(ks * pair_meff[0]) if pair_meff else 0.0
    kd_t = 2.0 * zeta_ref * math.sqrt(ks_t * terr_meff[0]) if terr_meff else kd
    # every contact type: (ks, kd, m_eff); zeta grows as m_eff falls
    contacts = [(ks, kd, me) for me in pair_meff] + [(ks_t, kd_t, me) for me in terr_meff]
    zetas = [theory.damping_ratio(k, c, me) for k, c, me in contacts]
    if max(zetas) >= 1.0:
        raise ValueError(
            f"the lightest contact would be overdamped (zeta = {max(zetas):.3g} >= 1: it never ends) "
            f"with restitution {restitution} set for the heaviest; ask for a larger restitution or "
            f"closer masses")
    zeta_models = max(float(k.split("|")[4]) for k in ERROR_MODELS)
    if max(zetas) > zeta_models * (1.0 + 1e-9):
        e_min = restitution_for_zeta(zeta_models, damping)
        raise ValueError(
            f"the most damped contact would have zeta = {max(zetas):.3g}, beyond the measured error models "
            f"(zeta <= {zeta_models:g}, restitution >= {e_min:.3g} with {damping} damping); ask for a larger "
            f"restitution or closer masses")
    t_cs = [theory.contact_time(k, c, me) for k, c, me in contacts]
    t_c_min = min(t_cs)

    event_choices = (False, True) if events is None else (bool(events),)
    options = []
    for integ in integrators:
        if integ == "implicit_euler" and damping == "no_tension":
            continue  # World refuses it: the linearised solve cannot see the clip
        for ev in event_choices:
            # dt must resolve every contact: the needed steps per contact of each contact type,
            # converted to a dt, the smallest wins
            dt = math.inf
            for (k, c, me), tc, z in zip(contacts, t_cs, zetas):
                need = max(_steps_needed(integ, ev, damping, z, accuracy, mt) for mt in METRICS)
                if not math.isfinite(need):
                    dt = 0.0
                    break
                dt = min(dt, tc / (SAFETY * need))
            if not dt > 0.0:
                continue
            # the World's stability guard must accept it
            for k, c, me in contacts:
                dt = min(dt, theory.guard_dt(integ, k, c, me))
            if max_dt is not None:
                dt = min(dt, float(max_dt))
            if not dt > 0.0:
                continue
            spc = t_c_min / dt
            cost = config_cost(integ, ev, spc)
            options.append((cost, integ, ev, spc, dt))
    if not options:
        raise ValueError(
            f"no measured integrator meets accuracy {accuracy:g} on restitution at zeta {zeta_ref:.3g} "
            f"({damping}); loosen the tolerance")
    options.sort(key=lambda o: o[0])
    cost, integ, ev, spc, dt = options[0]
    pred = {}
    for mt in METRICS + ("peak_overlap",):
        pred[mt] = max(predicted_error(integ, ev, damping, z, tc / dt, mt) for z, tc in zip(zetas, t_cs))
    # hold the penetration tolerance: scale every stiffness by s^2 (and every kd by s, keeping
    # zeta), so each omega0 grows by s, until peak * (1 + numerical peak error) <= delta_tol
    err_peak = [min(predicted_error(integ, ev, damping, z, tc / dt, "peak_overlap"), 1.0) for z, tc in zip(zetas, t_cs)]
    omegas = [math.sqrt(k / me) for k, _, me in contacts]
    scale = 1.0
    g = abs(float(gravity))
    for _ in range(30):
        need = max(peak_overlap_ratio(z, g / (w * scale * v)) * (1.0 + ep) * v / (w * delta_tol)
                   for z, w, ep in zip(zetas, omegas, err_peak))
        new_scale = max(1.0, need)
        if abs(new_scale - scale) <= 1e-12 * scale:
            break
        scale = new_scale
    ks, ks_t, kd, kd_t = ks * scale**2, ks_t * scale**2, kd * scale, kd_t * scale
    dt /= scale
    t_c_min /= scale
    return ContactConfig(
        ks=ks, kd=kd, ks_terrain=ks_t, kd_terrain=kd_t, damping=damping, integrator=integ, events=ev, dt=dt,
        steps_per_contact=spc, zeta=zeta_ref, zeta_range=(min(zetas), max(zetas)),
        restitution_range=(restitution_for_zeta(max(zetas), damping), restitution_for_zeta(min(zetas), damping)),
        contact_time=t_c_min, predicted_error=pred, cost_per_contact=cost, cost_per_second=cost / t_c_min,
        alternatives=[(round(o[0], 3), o[1], o[2], round(o[3], 3)) for o in options],
    )
