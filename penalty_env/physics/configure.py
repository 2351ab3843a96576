"""Tolerance-driven configuration: from what a user knows to ks, kd, an integrator and dt.

A user knows the masses and radii, the largest impact speed, how deep a contact may overlap (a
fraction of the radius), the restitution wanted, and how accurately that restitution must come out.
:func:`configure` turns that into the contact parameters and the cheapest (integrator, dt, event
location) that meets the accuracy, from the *measured* error models of the accuracy benchmark:

* ``ks`` from the penetration tolerance: delta_max = v / omega0 <= tol r  =>  ks >= m_eff v^2 / (tol r)^2
  (PHYSICS.md section 3), for the heaviest contact (the deepest);
* ``kd`` from the target restitution, by the closed form of the chosen damping mode (linear:
  zeta = -ln e / sqrt(pi^2 + ln^2 e); no-tension: the exact solution below, inverted numerically);
* the integrator, event location and steps per contact from the worst-case (over the contact's
  phase in the step grid) restitution and peak-overlap errors measured by
  ``python -m penalty_env.bench accuracy`` and fitted as ``err = C (steps per contact)^-p``
  (:data:`ERROR_MODELS`); the cost of each choice is its force evaluations per contact duration
  (:data:`COST_PER_STEP`, :data:`EVENT_EXTRA_EVALS`). The time step resolves the *shortest* contact
  the scene can form (the lightest pair) and respects the World's stability guard.

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
ERROR_MODELS: dict = {}
COST_PER_STEP: dict = {"explicit_euler": 1.0, "symplectic_euler": 1.0, "velocity_verlet": 1.0, "rk4": 4.0,
                       "implicit_euler": 3.0}
EVENT_EXTRA_EVALS: dict = {}
MODEL_SOURCE = "placeholder"
# END MEASURED

# configure() asks for SAFETY x the steps per contact that the fitted model says meet the tolerance
# (the fit is an upper envelope of the measured worst cases; this covers phases between samples)
SAFETY = 1.15
METRICS = ("restitution", "peak_overlap")


def _model_key(integrator: str, events: bool, damping: str, metric: str, zeta: float) -> str:
    return f"{integrator}|{'events' if events else 'plain'}|{damping}|{metric}|{zeta:g}"


def _models_at(integrator: str, events: bool, damping: str, metric: str, zeta: float):
    """The fitted models at the measured zetas that bracket ``zeta`` (one or two)."""
    zetas = sorted({float(k.split("|")[4]) for k in ERROR_MODELS
                    if k.startswith(f"{integrator}|{'events' if events else 'plain'}|{damping}|{metric}|")})
    if not zetas:
        return []
    if zeta >= zetas[-1]:
        chosen = [zetas[-1]]
    else:
        above = next(z for z in zetas if z >= zeta)
        below = max((z for z in zetas if z <= zeta), default=above)
        chosen = sorted({below, above})
    return [ERROR_MODELS[_model_key(integrator, events, damping, metric, z)] for z in chosen]


def predicted_error(integrator: str, events: bool, damping: str, zeta: float, steps_per_contact: float,
                    metric: str = "restitution") -> float:
    """Worst-case relative error predicted by the fitted model (the larger of the two measured
    zetas around ``zeta``); inf where no model covers the point (unstable, or outside the fit)."""
    worst = 0.0
    models = _models_at(integrator, events, damping, metric, zeta)
    if not models:
        return math.inf
    for mdl in models:
        if steps_per_contact < mdl["spc_min"] or steps_per_contact > mdl["spc_max"] * 4:
            return math.inf
        err = max(mdl["C"] * steps_per_contact ** (-mdl["p"]), mdl["floor"])
        worst = max(worst, err)
    return worst


def _steps_needed(integrator, events, damping, zeta, tol, metric) -> float:
    """Smallest steps per contact with predicted error <= tol (inf if none in the model's range)."""
    models = _models_at(integrator, events, damping, metric, zeta)
    if not models:
        return math.inf
    need = 0.0
    for mdl in models:
        if mdl["floor"] > tol:
            return math.inf
        spc = (mdl["C"] / tol) ** (1.0 / mdl["p"]) if mdl["C"] > 0.0 else 0.0
        spc = max(spc, mdl["spc_min"])
        if spc > mdl["spc_max"] * 4:
            return math.inf
        need = max(need, spc)
    return need


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
    predicted_error: dict  # metric -> predicted worst-case relative error
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
    t_cs = [theory.contact_time(k, c, me) for k, c, me in contacts]
    t_c_min = min(t_cs)

    event_choices = (False, True) if events is None else (bool(events),)
    options = []
    for integ in integrators:
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
            from .world import STABILITY_SAFETY

            for k, c, me in contacts:
                dt = min(dt, STABILITY_SAFETY * theory.critical_dt(integ, k, c, me))
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
    for mt in METRICS:
        pred[mt] = max(predicted_error(integ, ev, damping, z, tc / dt, mt) for z, tc in zip(zetas, t_cs))
    return ContactConfig(
        ks=ks, kd=kd, ks_terrain=ks_t, kd_terrain=kd_t, damping=damping, integrator=integ, events=ev, dt=dt,
        steps_per_contact=spc, zeta=zeta_ref, zeta_range=(min(zetas), max(zetas)),
        restitution_range=(restitution_for_zeta(max(zetas), damping), restitution_for_zeta(min(zetas), damping)),
        contact_time=t_c_min, predicted_error=pred, cost_per_contact=cost, cost_per_second=cost / t_c_min,
        alternatives=[(round(o[0], 3), o[1], o[2], round(o[3], 3)) for o in options],
    )
