"""The measured error models and costs that :func:`.configure.configure` chooses from.

Package data (``penalty_env/physics/data/error_models.json``), read at import; ``python -m
penalty_env.bench accuracy --fit`` measures them again and writes that file, and
:func:`load_error_models` reads another one. Per integrator, event location, damping mode, metric
and zeta: the measured worst cases (over a contact's phase in the step grid) from the first usable
steps per contact on, interpolated in log-log, and ``err = C (steps per contact)^-p`` fitted to the
asymptotic tail for beyond the sweep (the ``p`` are the measured convergence orders). The cost of a
choice is its force-evaluation equivalents per contact duration (:data:`COST_PER_STEP`,
:data:`EVENT_EXTRA_EVALS`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from typing import Any

__all__ = [
    "predicted_error",
    "config_cost",
    "load_error_models",
    "ERROR_MODELS",
    "COST_PER_STEP",
    "EVENT_EXTRA_EVALS",
    "MODELS_PATH",
    "SAFETY",
    "METRICS",
]

MODELS_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "error_models.json")
ERROR_MODELS: dict = {}
COST_PER_STEP: dict = {}
EVENT_EXTRA_EVALS: dict = {}
MODELS_STAMP = ""  # a hash of the models file read last (results computed from them are keyed on it)


def load_error_models(path: str = MODELS_PATH) -> None:
    """Make the error models and costs in ``path`` (the JSON that ``bench accuracy --fit`` writes)
    the ones :func:`configure` uses."""
    global MODELS_STAMP
    with open(path, "rb") as f:
        raw = f.read()
    data: dict[str, Any] = json.loads(raw)
    MODELS_STAMP = hashlib.sha256(raw).hexdigest()[:20]
    ERROR_MODELS.clear()
    ERROR_MODELS.update(data["error_models"])
    COST_PER_STEP.clear()
    COST_PER_STEP.update(data["cost_per_step"])
    EVENT_EXTRA_EVALS.clear()
    EVENT_EXTRA_EVALS.update(data["event_extra_evals"])


load_error_models()

# configure() asks for SAFETY x the steps per contact that the fitted model says meet the tolerance
# (the fit is an upper envelope of the measured worst cases; this covers phases between samples)
SAFETY = 1.15
METRICS = ("restitution",)  # the accuracy tolerance; the peak overlap is held by ks (see configure)


def _model_key(integrator: str, events: bool, damping: str, metric: str, zeta: float) -> str:
    return f"{integrator}|{'events' if events else 'plain'}|{damping}|{metric}|{zeta:g}"


def _models_at(integrator: str, events: bool, damping: str, metric: str, zeta: float) -> list[tuple[float, dict]]:
    """[(zeta_k, model)] at the measured zetas that bracket ``zeta`` (one or two)."""
    zetas = sorted(
        {
            float(k.split("|")[4])
            for k in ERROR_MODELS
            if k.startswith(f"{integrator}|{'events' if events else 'plain'}|{damping}|{metric}|")
        }
    )
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


def predicted_error(
    integrator: str, events: bool, damping: str, zeta: float, steps_per_contact: float, metric: str = "restitution"
) -> float:
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


def _steps_needed(integrator: str, events: bool, damping: str, zeta: float, tol: float, metric: str) -> float:
    """Smallest steps per contact with predicted error <= tol (inf if none in the models' range)."""
    models = _models_at(integrator, events, damping, metric, zeta)
    if not models:
        return math.inf
    lo = max(m["spc_min"] for _, m in models)
    hi = min(m["spc_max"] for _, m in models) * 4.0

    def err(spc: float) -> float:
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
