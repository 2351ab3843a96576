"""The error models of ``python -m penalty_env.bench accuracy --fit`` (:mod:`penalty_env.bench.accuracy`):
a power law fitted to each convergence curve of the sweep, the cost of a step per integrator, and
the JSON that :mod:`penalty_env.physics.configure` reads.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..physics import configure as CF
from .accuracy_sweep import INTEGRATORS, SPCS

# --------------------------------------------------------------------------------------------
# Fitting the error models (for configure)
# --------------------------------------------------------------------------------------------

FLOOR = 1e-11  # below this the worst case is round-off, not truncation
# the models cover worst-case errors up to this (coarse steps still useful to a scene that only
# needs a rough bounce, such as the environments); beyond it a method is too far from the oracle
# (or about to diverge) to be worth modelling
MODEL_MAX_ERROR = 0.6


def fit_power_law(spcs, errs, tail=4):
    """The error model of one convergence curve: the measured worst cases, and a power law
    err = C spc^-p fitted to its asymptotic tail.

    Points used: finite, below MODEL_MAX_ERROR and above the round-off floor, from the first point after which
    every point is such (or at the floor); a low plateau at the end (below 1e-6, falling less than
    1.5x per doubling) is the measurement's floor and becomes the model's ``floor``. ``pts`` keeps them as a non-increasing envelope (each
    error replaced by the largest at that or more steps per contact), which :func:`configure`
    interpolates in log-log; ``p`` is the least-squares slope of the last ``tail`` points (the
    asymptotic order) and ``C`` the smallest constant that bounds them, for extrapolating beyond
    the sweep. Returns None if fewer than 3 usable points.
    """
    spcs = np.asarray(spcs, dtype=float)
    errs = np.asarray(errs, dtype=float)
    order = np.argsort(spcs)
    spcs, errs = spcs[order], errs[order]
    good = np.isfinite(errs) & (errs < MODEL_MAX_ERROR) & (errs > FLOOR)
    idx = np.flatnonzero(good)
    if idx.size < 3:
        return None
    start = idx[0]
    for k in idx:
        if np.all(good[k:] | (errs[k:] <= FLOOR)):
            start = k
            break
    sel = np.arange(start, len(spcs))
    sel = sel[good[sel]]
    after = errs[sel[-1] + 1 :] if sel.size else errs[:0]
    floor = float(after[after <= FLOOR].max()) if np.any(after <= FLOOR) else 0.0
    # a low plateau at the end is the measurement's floor (round-off, the interpolation of the
    # peak), not convergence: keep it out of the tail fit, as the model's floor
    while sel.size > 3 and errs[sel[-1]] < 1e-6 and errs[sel[-2]] / errs[sel[-1]] < 1.5:
        floor = max(floor, float(errs[sel[-1]]))
        sel = sel[:-1]
    if sel.size < 3:
        return None
    env = np.maximum.accumulate(errs[sel][::-1])[::-1]
    last = sel[-tail:]
    p = float(max(-np.polyfit(np.log(spcs[last]), np.log(errs[last]), 1)[0], 0.1))
    C = float(np.max(errs[last] * spcs[last] ** p))
    return {
        "C": C,
        "p": p,
        "spc_min": float(spcs[sel[0]]),
        "spc_max": float(spcs[sel[-1]]),
        "floor": max(floor, FLOOR),
        "pts": [[float(a), float(b)] for a, b in zip(spcs[sel], env)],
    }


def fit_models(rows):
    """ERROR_MODELS for configure: worst of scenarios 1 and 2 per (method, damping, zeta, metric)."""
    models = {}
    groups = {}
    for r in rows:
        if r["scenario"] not in ("pair", "drop") or r["metric"] not in ("restitution", "peak_overlap"):
            continue
        key = (r["integrator"], bool(r["events"]), r["damping"], r["metric"], r["zeta"])
        err = math.inf if r["diverged"] else r["error"]
        groups.setdefault(key, {})
        spc = r["steps_per_contact"]
        groups[key][spc] = max(groups[key].get(spc, 0.0), err)
    for (integ, ev, damping, metric, zeta), pts in sorted(groups.items()):
        spcs = sorted(pts)
        res = fit_power_law(spcs, [pts[s] for s in spcs])
        if res is None:
            continue
        res["pts"] = tuple((int(a), float(f"{b:.4g}")) for a, b in res["pts"])
        models[CF._model_key(integ, ev, damping, metric, zeta)] = {
            k: (float(f"{v:.4g}") if k != "pts" else v) for k, v in res.items()
        }
        if zeta == 0.0:  # no damping: both damping modes are the same law
            models[CF._model_key(integ, ev, "no_tension", metric, zeta)] = models[
                CF._model_key(integ, ev, damping, metric, zeta)
            ]
    return models


def measure_costs(rows):
    """COST_PER_STEP and EVENT_EXTRA_EVALS, in force-evaluation equivalents.

    A step of the explicit methods costs its force evaluations (1, RK4 4): counted, so the model
    does not inherit the noise of wall times on a shared machine. Implicit Euler's one evaluation
    hides its conjugate-gradient products, so its cost is its measured wall time per step relative
    to symplectic Euler (median over the pile runs without events, zeta 0 and 0.3 linear, 8 steps
    per contact and up, that did not diverge). EVENT_EXTRA_EVALS: the extra evaluations per
    contact of event location (pair collision, 90th percentile), times the integrator's cost per
    evaluation."""
    per_step = {"explicit_euler": 1.0, "symplectic_euler": 1.0, "velocity_verlet": 1.0, "rk4": 4.0}

    def wall(scen, integ, zeta, spc):
        return [
            r["wall_per_sim_s"]
            for r in rows
            if r["scenario"] == scen
            and r["integrator"] == integ
            and not r["events"]
            and r["steps_per_contact"] == spc
            and r["zeta"] == zeta
            and r["damping"] == "linear"
            and not r["diverged"]
            and math.isfinite(r["wall_per_sim_s"])
        ]

    ratios = []
    for scen, zeta in (("elastic_pile", 0.0), ("damped_pile", 0.3)):
        for spc in SPCS:
            a, b = wall(scen, "implicit_euler", zeta, spc), wall(scen, "symplectic_euler", zeta, spc)
            if spc >= 8 and a and b:
                ratios.append(a[0] / b[0])
    per_step["implicit_euler"] = float(f"{np.median(ratios):.3g}") if ratios else 8.0
    extra = {}
    evals_per_step = {"rk4": 4}
    for integ in INTEGRATORS:
        vals = []
        for r in rows:
            if r["scenario"] != "pair" or r["metric"] != "restitution" or r["integrator"] != integ or not r["events"]:
                continue
            if r["steps_per_contact"] < 8 or r["diverged"]:
                continue
            plain = [
                q
                for q in rows
                if q["scenario"] == "pair"
                and q["metric"] == "restitution"
                and q["integrator"] == integ
                and not q["events"]
                and q["damping"] == r["damping"]
                and q["zeta"] == r["zeta"]
                and q["steps_per_contact"] == r["steps_per_contact"]
            ]
            if not plain:
                continue
            extra_evals = (r["evals_per_sim_s"] - plain[0]["evals_per_sim_s"]) * r["sim_time"]  # one contact per run
            # one contact per run: extra evals per contact, in units of the integrator's cost per eval
            vals.append(extra_evals * per_step[integ] / evals_per_step.get(integ, 1))
        if vals:
            extra[integ] = float(f"{np.percentile(vals, 90):.3g}")
    return per_step, extra


def default_models_path() -> str | None:
    """Where ``--fit`` writes by default: the package's data file when the package is a source
    checkout (a working tree with ``pyproject.toml``), else None (an installed package is never
    written: give ``--models``)."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    tree = os.path.dirname(package)
    if os.path.isfile(os.path.join(tree, "pyproject.toml")) and "site-packages" not in package:
        return CF.MODELS_PATH
    return None


def write_models(models, per_step, extra, path, source=""):
    """Write the fitted error models and costs as the JSON that ``configure.load_error_models``
    reads (one model per line, so a refit's diff shows what moved)."""
    import json

    lines = [
        "{",
        f' "source": {json.dumps(source)},',
        ' "generated_by": "python -m penalty_env.bench accuracy --fit",',
        f' "cost_per_step": {json.dumps(per_step, sort_keys=True)},',
        f' "event_extra_evals": {json.dumps(extra, sort_keys=True)},',
        ' "error_models": {',
    ]
    items = sorted(models.items())
    for i, (k, v) in enumerate(items):
        v = {kk: ([list(p) for p in vv] if kk == "pts" else vv) for kk, vv in v.items()}
        lines.append(f"  {json.dumps(k)}: {json.dumps(v, sort_keys=True)}" + ("," if i < len(items) - 1 else ""))
    lines += [" }", "}"]
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
