"""Tolerance-driven configuration: from what a user knows to ks, kd, an integrator and dt.

A user knows the masses and radii, the largest impact speed, how deep a contact may overlap (a
fraction of the radius), the restitution wanted, and how accurately that restitution must come out.
:func:`configure` turns that into the contact parameters and the cheapest (integrator, dt, event
location) that meets the accuracy, from the *measured* error models of the accuracy benchmark:

* ``ks`` from the penetration tolerance: delta_max = v / omega0 <= tol r  =>  ks >= m_eff v^2 / (tol r)^2
  (docs/physics.md, "Closed forms"), for the heaviest contact (the deepest), then raised until the
  exact peak overlap (damping, gravity) times (1 + the chosen method's predicted peak error) fits;
* ``kd`` from the target restitution, by the closed form of the chosen damping mode
  (:func:`.theory.zeta_for_restitution`);
* the integrator, event location and steps per contact from the worst-case (over the contact's
  phase in the step grid) restitution errors measured by ``python -m penalty_env.bench accuracy``
  (:data:`ERROR_MODELS`: per integrator, event location, damping mode, metric and zeta, the
  measured worst cases from the first usable steps per contact on, interpolated in log-log, and
  ``err = C (steps per contact)^-p`` fitted to the asymptotic tail for beyond the sweep; the
  ``p`` are the measured convergence orders). The cost of a choice is its force-evaluation
  equivalents per contact duration (:data:`COST_PER_STEP`, :data:`EVENT_EXTRA_EVALS`). The time
  step resolves the *shortest* contact the scene can form (the lightest pair) and respects the
  World's stability guard.

The error models (:mod:`.error_models`, re-exported here) are package data
(``penalty_env/physics/data/error_models.json``), read at import; ``python -m penalty_env.bench
accuracy --fit`` measures them again and writes that file (into the working tree, or where
``--models`` says; never into an installed package), and :func:`load_error_models` reads another.

The exact solution of one contact (:func:`.theory.contact_response` and its companions) is the
oracle of the models; it lives in :mod:`.theory` and is re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .. import _validate as V
from .._results import cached
from . import error_models as _error_models
from . import theory
from .error_models import (
    COST_PER_STEP,
    ERROR_MODELS,
    EVENT_EXTRA_EVALS,
    METRICS,
    MODELS_PATH,
    SAFETY,
    config_cost,
    load_error_models,
    predicted_error,
)
from .error_models import _model_key as _model_key  # re-exported (the accuracy bench's tests)
from .error_models import _steps_needed as _steps_needed
from .theory import (
    DAMPING_MODES,
    ContactResponse,
    contact_response,
    peak_overlap_ratio,
    restitution_for_zeta,
    zeta_for_restitution,
)

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
    "load_error_models",
    "ERROR_MODELS",
    "COST_PER_STEP",
    "EVENT_EXTRA_EVALS",
    "MODELS_PATH",
    "SAFETY",
]


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
    # the penetration scale s: ks and ks_terrain were multiplied by s^2, kd and kd_terrain by s (and dt
    # divided by s) so that the exact peak overlap meets the tolerance; 1 when the impact rule alone does
    stiffening: float = 1.0

    def world_kwargs(self) -> dict:
        return dict(
            ks=self.ks,
            kd=self.kd,
            ks_terrain=self.ks_terrain,
            kd_terrain=self.kd_terrain,
            damping=self.damping,
            integrator=self.integrator,
            dt=self.dt,
            events=self.events,
        )

    def as_dict(self) -> dict:
        return asdict(self)


def configure(
    masses: Any,
    radii: Any,
    max_impact_speed: float,
    penetration: float = 0.05,
    restitution: float = 0.5,
    accuracy: float = 0.01,
    *,
    damping: str = "linear",
    terrain: bool = True,
    integrators: Sequence[str] = theory.INTEGRATORS,
    events: bool | None = None,
    max_dt: float | None = None,
    max_force: float | None = None,
    gravity: float = 0.0,
    energy_budget: float | None = theory.ENERGY_BUDGET,
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
        energy_budget: the largest mean relative energy gain per collision allowed
            (``theory.energy_dt``: nearly elastic contacts heat a scene at steps the stability
            limit allows); None ignores it (the rule ``PenaltyBalls-v0`` was made with).

    The penetration tolerance is a hard bound: ks starts at m_eff v^2 / delta^2 and is then raised
    until the exact peak overlap (with damping and gravity, :func:`peak_overlap_ratio`) times
    (1 + the chosen method's predicted peak-overlap error) fits under delta. The restitution
    accuracy and the method's cost depend only on zeta and the steps per contact, so raising ks
    (with kd raised to keep zeta) shortens dt but changes neither the choice nor its accuracy.

    Returns:
        A :class:`ContactConfig`. Raises ValueError when no integrator in the measured models meets
        the accuracy (tighter than the models' floors).
    """
    m, r = _checked(
        masses, radii, max_impact_speed, penetration, accuracy, damping, terrain, events, integrators, max_dt, gravity
    )
    if energy_budget is not None:
        V.positive("energy_budget", energy_budget)
    if not ERROR_MODELS:
        raise RuntimeError("no measured error models: run python -m penalty_env.bench accuracy --fit")
    args: tuple[Any, ...] = (max_impact_speed, penetration, restitution, accuracy, damping, terrain)
    args += (tuple(integrators), events, max_dt, max_force, gravity, energy_budget)
    key = (tuple(m.tolist()), tuple(r.tolist()), _exact(args), _error_models.MODELS_STAMP)
    return cached("configure", key, lambda: _configured(m, r, *args))


def _exact(value: Any) -> Any:
    """``value`` as a results-cache key: every number by its type and its exact value (a NumPy
    float32 0.04 is not the float 0.04, whatever its repr prints), containers item by item."""
    if isinstance(value, (tuple, list)):
        return tuple(_exact(v) for v in value)
    if isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, str):
        return (type(value).__name__, value if not isinstance(value, np.bool_) else bool(value))
    if isinstance(value, (int, float, np.integer, np.floating)):
        return (type(value).__name__, float(value).hex())
    return (type(value).__name__, repr(value))


def _configured(
    m: np.ndarray,
    r: np.ndarray,
    max_impact_speed: float,
    penetration: float,
    restitution: float,
    accuracy: float,
    damping: str,
    terrain: bool,
    integrators: Sequence[str],
    events: bool | None,
    max_dt: float | None,
    max_force: float | None,
    gravity: float,
    energy_budget: float | None,
) -> ContactConfig:
    """:func:`configure` on checked arguments (what the results cache keeps)."""
    v = float(max_impact_speed)
    delta_tol = float(penetration) * float(r.min())
    ks, kd, ks_t, kd_t, contacts, zetas, zeta_ref = _contacts(m, v, delta_tol, restitution, damping, terrain, max_force)
    t_cs = [theory.contact_time(k, c, me) for k, c, me in contacts]
    options = _options(integrators, events, damping, accuracy, contacts, zetas, t_cs, max_dt, energy_budget)
    if not options:
        raise ValueError(
            f"no measured integrator meets accuracy {accuracy:g} on restitution at zeta {zeta_ref:.3g} "
            f"({damping}); loosen the tolerance"
        )
    options.sort(key=lambda o: o[0])
    springs = (ks, kd, ks_t, kd_t)
    return _chosen(options, springs, contacts, zetas, zeta_ref, t_cs, v, delta_tol, gravity, damping)


def _chosen(
    options: list,
    springs: tuple[float, float, float, float],
    contacts: list,
    zetas: list,
    zeta_ref: float,
    t_cs: list,
    v: float,
    delta_tol: float,
    gravity: float,
    damping: str,
) -> ContactConfig:
    """The cheapest option (``options`` sorted by cost), its predicted errors, and the springs
    stiffened (dt shortened) until its peak overlap meets the penetration tolerance."""
    ks, kd, ks_t, kd_t = springs
    t_c_min = min(t_cs)
    cost, integ, ev, spc, dt = options[0]
    pred = {}
    for mt in METRICS + ("peak_overlap",):
        pred[mt] = max(predicted_error(integ, ev, damping, z, tc / dt, mt) for z, tc in zip(zetas, t_cs))
    scale = _penetration_scale(integ, ev, damping, zetas, t_cs, dt, contacts, v, delta_tol, gravity)
    ks, ks_t, kd, kd_t = ks * scale**2, ks_t * scale**2, kd * scale, kd_t * scale
    dt /= scale
    t_c_min /= scale
    return ContactConfig(
        ks=ks,
        kd=kd,
        ks_terrain=ks_t,
        kd_terrain=kd_t,
        damping=damping,
        integrator=integ,
        events=ev,
        dt=dt,
        steps_per_contact=spc,
        zeta=zeta_ref,
        zeta_range=(min(zetas), max(zetas)),
        restitution_range=(restitution_for_zeta(max(zetas), damping), restitution_for_zeta(min(zetas), damping)),
        contact_time=t_c_min,
        predicted_error=pred,
        cost_per_contact=cost,
        cost_per_second=cost / t_c_min,
        alternatives=[(round(o[0], 3), o[1], o[2], round(o[3], 3)) for o in options],
        stiffening=scale,
    )


def _checked(
    masses: Any,
    radii: Any,
    max_impact_speed: float,
    penetration: float,
    accuracy: float,
    damping: str,
    terrain: bool,
    events: bool | None,
    integrators: Sequence[str],
    max_dt: float | None,
    gravity: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The masses and radii as arrays, every argument checked (a ValueError names the bad one)."""
    m = V.real_array("masses", masses).reshape(-1)
    r = V.real_array("radii", radii).reshape(-1)
    if m.size == 0 or r.size != m.size or np.any(m <= 0) or np.any(r <= 0):
        raise ValueError(
            f"masses and radii must be equal-length sequences of numbers > 0, got {m.size} masses "
            f"(min {m.min() if m.size else 'none'}) and {r.size} radii (min {r.min() if r.size else 'none'})"
        )
    for name, val in (("max_impact_speed", max_impact_speed), ("penetration", penetration), ("accuracy", accuracy)):
        V.positive(name, val)
    V.choice("damping", damping, DAMPING_MODES)
    V.flag("terrain", terrain)
    if events is not None:
        V.flag("events", events)
    for integ in integrators:
        V.choice("integrators[...]", integ, theory.INTEGRATORS)
    if max_dt is not None:
        V.positive("max_dt", max_dt)
    V.real("gravity", gravity)
    return m, r


def _contacts(
    m: np.ndarray, v: float, delta_tol: float, restitution: float, damping: str, terrain: bool, max_force: float | None
) -> tuple[float, float, float, float, list, list, float]:
    """(ks, kd, ks_terrain, kd_terrain, every contact type as (ks, kd, m_eff), their zetas, the
    reference zeta) before the penetration scaling: ks from the heaviest contact's impact, kd from
    the target restitution."""
    ms = np.sort(m)
    # effective masses of the contacts the scene can form: heaviest and lightest pair, and terrain
    pair_meff = []
    if m.size >= 2:
        pair_meff = [theory.effective_mass(ms[-1], ms[-2]), theory.effective_mass(ms[0], ms[1])]
    terr_meff = [ms[-1], ms[0]] if terrain else []
    if not pair_meff and not terr_meff:
        raise ValueError("a single ball without terrain forms no contact")
    zeta_ref = zeta_for_restitution(restitution, damping)
    ks = theory.stiffness_for_penetration(pair_meff[0], v, delta_tol) if pair_meff else 1.0
    ks_t = theory.stiffness_for_penetration(terr_meff[0], v, delta_tol) if terr_meff else ks
    if max_force is not None:
        V.non_negative("max_force", max_force)
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
            f"closer masses"
        )
    zeta_models = max(float(k.split("|")[4]) for k in ERROR_MODELS)
    if max(zetas) > zeta_models * (1.0 + 1e-9):
        e_min = restitution_for_zeta(zeta_models, damping)
        raise ValueError(
            f"the most damped contact would have zeta = {max(zetas):.3g}, beyond the measured error models "
            f"(zeta <= {zeta_models:g}, restitution >= {e_min:.3g} with {damping} damping); ask for a larger "
            f"restitution or closer masses"
        )
    return ks, kd, ks_t, kd_t, contacts, zetas, zeta_ref


def _options(
    integrators: Sequence[str],
    events: bool | None,
    damping: str,
    accuracy: float,
    contacts: list,
    zetas: list,
    t_cs: list,
    max_dt: float | None,
    energy_budget: float | None,
) -> list:
    """Every (cost, integrator, events, steps per contact, dt) that meets the accuracy on every
    contact, within the guard and the energy budget."""
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
            for tc, z in zip(t_cs, zetas):
                need = max(_steps_needed(integ, ev, damping, z, accuracy, mt) for mt in METRICS)
                if not math.isfinite(need):
                    dt = 0.0
                    break
                dt = min(dt, tc / (SAFETY * need))
            if not dt > 0.0:
                continue
            # the World's stability guard must accept it, and its energy budget hold
            for k, c, me in contacts:
                dt = min(dt, theory.guard_dt(integ, k, c, me))
                if energy_budget is not None:
                    dt = min(dt, theory.energy_dt(integ, k, c, me, damping, energy_budget))
            if max_dt is not None:
                dt = min(dt, float(max_dt))
            if not dt > 0.0:
                continue
            spc = t_c_min / dt
            cost = config_cost(integ, ev, spc)
            options.append((cost, integ, ev, spc, dt))
    return options


def _penetration_scale(
    integ: str,
    ev: bool,
    damping: str,
    zetas: list,
    t_cs: list,
    dt: float,
    contacts: list,
    v: float,
    delta_tol: float,
    gravity: float,
) -> float:
    """Hold the penetration tolerance: the factor s by which every omega0 grows (every stiffness by
    s^2, every kd by s, keeping zeta) until peak * (1 + numerical peak error) <= delta_tol."""
    err_peak = [min(predicted_error(integ, ev, damping, z, tc / dt, "peak_overlap"), 1.0) for z, tc in zip(zetas, t_cs)]
    omegas = [math.sqrt(k / me) for k, _, me in contacts]
    scale = 1.0
    g = abs(float(gravity))
    for _ in range(30):
        need = max(
            peak_overlap_ratio(z, g / (w * scale * v)) * (1.0 + ep) * v / (w * delta_tol)
            for z, w, ep in zip(zetas, omegas, err_peak)
        )
        new_scale = max(1.0, need)
        if abs(new_scale - scale) <= 1e-12 * scale:
            break
        scale = new_scale
    return scale
