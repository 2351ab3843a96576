"""Speed against accuracy: ``python -m penalty_env.bench accuracy [--quick] [--fit] [--out DIR]``.

For every integrator (with and without event location, :mod:`penalty_env.physics.events`), time
steps from 2 to 512 steps per contact duration, damping ratios zeta in {0, 0.1, 0.3} and both
damping modes, on five scenarios:

1. ``pair``: a head-on collision of unequal masses (1 and 3, radii 0.1 and 0.15), gravity off:
   relative error of the restitution and of the contact duration against the closed forms;
2. ``drop``: a ball dropped into a 3D bowl (gravity on): rebound restitution and peak overlap
   against the exact solution of the spring-dashpot contact under gravity
   (:func:`penalty_env.physics.theory.contact_response`);
3. ``rest``: a ball set down on the bowl's floor: the overlap it settles at against m g / ks;
4. ``elastic_pile``: 64 balls in a bowl, kd = 0 (more than 1,000 contacts): relative energy drift
   over a fixed simulated time;
5. ``damped_pile``: the same pile damped: position error at a fixed time against a reference run
   of RK4 with event location at a 16x smaller step than the smallest of the sweep.

Errors of scenarios 1 and 2 are the worst case over 1,024 phases of where the contact starts within
the step grid (all in one batched World; the first-order error lives in narrow phase windows, so
a sparse sweep misses it). Cost is measured two ways: wall time per simulated second (per world,
in the same run) and force evaluations per simulated second (event location counts its trial,
landing and crossing evaluations).

Output (``--out``, default ``docs/``; ``--quick`` writes to a temporary folder): ``accuracy.csv.gz``
(every run), ``accuracy_linear_zeta0.3.png`` (log-log error against force evaluations per simulated
second, one panel per scenario and metric, one line per integrator, dashed with event location,
diverged runs as crosses along the top, the Pareto front in grey, the configuration
:func:`penalty_env.physics.configure.configure` picks for a 1% tolerance as a star),
``accuracy_walltime.png`` (the same against wall time) and ``accuracy_more.png`` (zeta = 0.1 and
the no-tension mode).
``--fit`` also fits ``err = C (steps per contact)^-p`` per integrator, event mode, damping mode
and zeta (worst of scenarios 1 and 2, with extra zetas 0.5 and 0.7) and writes them as JSON
(``--models PATH``; default the package's ``physics/data/error_models.json`` in a source checkout,
never an installed package), which :mod:`penalty_env.physics.configure` reads at import. ``--quick`` (a CI smoke run, < 2 minutes once
compiled) sweeps fewer steps, phases, zetas and methods.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import time
from typing import NamedTuple

import numpy as np

from ..physics import configure as CF
from ..physics import theory
from ..scenarios import (  # the scenarios live in the package, for the tests too
    DROP_KS,
    DROP_MASS,
    DROP_SPEED,
    PHASES,
    PILE_T_DAMPED,
    PILE_T_ELASTIC,
    PILE_WORLDS,
    G,
    Measure,
    bowl_drop,
    damped_pile,
    elastic_pile,
    pair_collision,
    resting,
)

INTEGRATORS = theory.INTEGRATORS
SPCS = (2, 4, 8, 16, 32, 64, 128, 256, 512)
ZETAS = (0.0, 0.1, 0.3)
FIT_EXTRA_ZETAS = (0.5, 0.7)
DAMPINGS = ("linear", "no_tension")
# --------------------------------------------------------------------------------------------
# The sweep
# --------------------------------------------------------------------------------------------


def supported(integrator, damping):
    """World refuses implicit Euler with the no-tension clip (its linearised solve cannot see it)."""
    return not (integrator == "implicit_euler" and damping == "no_tension")


FIELDS = [
    "scenario",
    "metric",
    "integrator",
    "events",
    "damping",
    "zeta",
    "steps_per_contact",
    "error",
    "diverged",
    "wall_per_sim_s",
    "evals_per_sim_s",
    "events_per_sim_s",
    "fallbacks",
    "sim_time",
]


def _rows(scenario, integ, events, damping, zeta, spc, m: Measure):
    for metric, err in m.errors.items():
        yield dict(
            scenario=scenario,
            metric=metric,
            integrator=integ,
            events=int(events),
            damping=damping,
            zeta=zeta,
            steps_per_contact=spc,
            error=err,
            diverged=int(m.diverged),
            wall_per_sim_s=m.wall_per_sim_s,
            evals_per_sim_s=m.evals_per_sim_s,
            events_per_sim_s=m.events_per_sim_s,
            fallbacks=m.fallbacks,
            sim_time=m.sim_time,
        )


def _drop_ends(zeta, damping):
    """Does the dropped ball leave the floor again (gravity holds a heavily damped one)?"""
    omega = math.sqrt(DROP_KS / DROP_MASS)
    try:
        theory.contact_response(zeta, damping, G / (omega * DROP_SPEED))
    except ValueError:
        return False
    return True


class Cell(NamedTuple):
    """One run of the sweep: a scenario measured for one method, damping, zeta and step."""

    scenario: str
    integrator: str
    events: bool
    damping: str
    zeta: float
    spc: int
    kwargs: dict  # the scenario function's other arguments (phases, t_end, worlds, spc_reference)


def run_cell(cell: Cell) -> Measure:
    """Measure one cell (the same call, serial or in a Ray task)."""
    i, ev, d, z, spc, kw = cell.integrator, cell.events, cell.damping, cell.zeta, cell.spc, cell.kwargs
    if cell.scenario == "pair":
        return pair_collision(i, ev, d, z, spc, **kw)
    if cell.scenario == "drop":
        return bowl_drop(i, ev, d, z, spc, **kw)
    if cell.scenario == "rest":
        return resting(i, ev, d, z, spc)
    if cell.scenario == "elastic_pile":
        return elastic_pile(i, ev, spc, **kw)
    if cell.scenario == "damped_pile":
        return damped_pile(i, ev, d, z, spc, **kw)
    raise ValueError(f"unknown scenario {cell.scenario!r}; known: {', '.join(SCENARIOS)}")


SCENARIOS = ("pair", "drop", "rest", "elastic_pile", "damped_pile")


def cells(quick=False, scenarios=SCENARIOS, fit=False) -> list[Cell]:
    """Every run of the chart (and, with ``fit``, the extra zetas of the fitted models), in the
    order of the CSV's rows."""
    unknown = [sc for sc in scenarios if sc not in SCENARIOS]
    if unknown:
        raise ValueError(f"scenarios: unknown scenario {unknown[0]!r}; known: {', '.join(SCENARIOS)}")
    spcs = (4, 16, 64) if quick else SPCS
    zetas = (0.3,) if quick else ZETAS
    dampings = ("linear",) if quick else DAMPINGS
    phases = 128 if quick else PHASES
    methods = [(i, e) for i in INTEGRATORS for e in (False, True)]
    if quick:
        methods = [("symplectic_euler", False), ("velocity_verlet", False), ("rk4", False), ("rk4", True)]
    out: list[Cell] = []
    fit_zetas = zetas + (FIT_EXTRA_ZETAS if fit and not quick else ())
    for integ, ev in methods:
        for damping in dampings:
            if not supported(integ, damping):
                continue
            for zeta in fit_zetas:
                if zeta == 0.0 and damping == "no_tension":
                    continue  # identical to linear without damping
                for spc in spcs:
                    if "pair" in scenarios:
                        out.append(Cell("pair", integ, ev, damping, zeta, spc, {"phases": phases}))
                    if "drop" in scenarios and _drop_ends(zeta, damping):
                        out.append(Cell("drop", integ, ev, damping, zeta, spc, {"phases": phases}))
                    if zeta in zetas and zeta > 0.0 and "rest" in scenarios:
                        out.append(Cell("rest", integ, ev, damping, zeta, spc, {}))
    pile_spcs = (8, 32) if quick else SPCS
    t_el = PILE_T_ELASTIC / (4 if quick else 1)
    t_dp = PILE_T_DAMPED / (2 if quick else 1)
    pile_worlds = 1 if quick else PILE_WORLDS
    if "elastic_pile" in scenarios:
        for integ, ev in methods:
            for spc in pile_spcs:
                kw = {"t_end": t_el, "worlds": pile_worlds}
                out.append(Cell("elastic_pile", integ, ev, "linear", 0.0, spc, kw))
    if "damped_pile" in scenarios:
        spc_ref = 16 * max(pile_spcs)
        for damping in dampings:
            for zeta in [z for z in zetas if z > 0]:
                for integ, ev in methods:
                    if not supported(integ, damping):
                        continue
                    for spc in pile_spcs:
                        kw = {"spc_reference": spc_ref, "t_end": t_dp, "worlds": pile_worlds}
                        out.append(Cell("damped_pile", integ, ev, damping, zeta, spc, kw))
    return out


def sweep(quick=False, log=print, scenarios=SCENARIOS, fit=False, ray=False, address=None):
    """Every run of the chart (and, with ``fit``, the extra zetas of the fitted models): the rows
    of the CSV. ``ray``: each cell is a Ray task of one CPU (Numba on one thread), on the cluster
    at ``address`` (None: ``RAY_ADDRESS`` if set, else a local one); the rows, their order and every
    value but the wall times are those of the serial sweep."""
    todo = cells(quick, scenarios, fit)
    rows = []
    t0 = time.perf_counter()
    measures = _ray_measures(todo, address) if ray else map(run_cell, todo)
    try:
        for c, m in zip(todo, measures):
            new = list(_rows(c.scenario, c.integrator, c.events, c.damping, c.zeta, c.spc, m))
            rows.extend(new)
            errs = " ".join(f"{r['metric']}={r['error']:.3g}" for r in new)
            log(
                f"[{time.perf_counter() - t0:7.1f}s] {c.scenario:12s} {c.integrator:16s} events={int(c.events)} "
                f"{c.damping:10s} zeta={c.zeta:<4g} spc={c.spc:<4d} {errs}{'  DIVERGED' if m.diverged else ''}"
            )
    finally:
        close = getattr(measures, "close", None)
        if close is not None:
            close()  # the Ray generator shuts down the cluster it started
    return rows


def _cell_task(cell: Cell, reference=None) -> Measure:
    """A Ray task: one thread of Numba per task (a task holds one CPU), the damped pile's
    reference (computed once, by :func:`_reference_task`) put where :func:`pile_reference` finds it."""
    import numba

    from .. import scenarios as SC

    numba.set_num_threads(1)
    if reference is not None:
        kw = cell.kwargs
        SC._REFERENCE_CACHE[(cell.damping, cell.zeta, kw["spc_reference"], kw["t_end"], kw["worlds"])] = reference
    return run_cell(cell)


def _reference_task(damping, zeta, spc_ref, t_end, worlds):
    import numba

    from .. import scenarios as SC

    numba.set_num_threads(1)
    return SC.pile_reference(damping, zeta, spc_ref, t_end, worlds)


def _ray_measures(todo: list[Cell], address=None):
    """The cells' measures, in order, from Ray tasks of one CPU each (yielded as they come in order)."""
    import ray

    started = not ray.is_initialized()
    if started:
        if address is None and not os.environ.get("RAY_ADDRESS"):
            address = "local"  # a new local cluster, even where `ray start` left one running
        ray.init(address=address, include_dashboard=False)
    try:
        cell_task = ray.remote(num_cpus=1)(_cell_task)
        ref_task = ray.remote(num_cpus=1)(_reference_task)
        references = {}
        refs = []
        for c in todo:
            reference = None
            if c.scenario == "damped_pile":
                key = (c.damping, c.zeta, c.kwargs["spc_reference"], c.kwargs["t_end"], c.kwargs["worlds"])
                if key not in references:
                    references[key] = ref_task.remote(*key)
                reference = references[key]
            refs.append(cell_task.remote(c, reference))
        for r in refs:
            yield ray.get(r)
    finally:
        if started:
            ray.shutdown()


def _open(path, mode):
    if path.endswith(".gz"):
        import gzip

        return gzip.open(path, mode + "t", newline="")
    return open(path, mode, newline="")


def write_csv(rows, path):
    """Every run; a ``.gz`` path is written gzipped."""
    with _open(path, "w") as f:
        wr = csv.DictWriter(f, fieldnames=FIELDS)
        wr.writeheader()
        for r in rows:
            wr.writerow({k: (f"{r[k]:.5g}" if isinstance(r[k], float) else r[k]) for k in FIELDS})


def read_csv(path):
    rows = []
    with _open(path, "r") as f:
        for r in csv.DictReader(f):
            for k in ("zeta", "error", "wall_per_sim_s", "evals_per_sim_s", "events_per_sim_s", "sim_time"):
                r[k] = float(r[k])
            for k in ("events", "diverged", "steps_per_contact", "fallbacks"):
                r[k] = int(float(r[k]))
            rows.append(r)
    return rows


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


# --------------------------------------------------------------------------------------------
# Charts
# --------------------------------------------------------------------------------------------

PANELS = [
    ("pair", "restitution", "1. pair collision: restitution"),
    ("pair", "duration", "1. pair collision: contact duration"),
    ("drop", "restitution", "2. ball into bowl: rebound restitution"),
    ("drop", "peak_overlap", "2. ball into bowl: peak overlap"),
    ("rest", "resting_overlap", "3. resting: overlap vs m g / ks"),
    ("elastic_pile", "energy_drift", "4. elastic pile (kd = 0): energy drift"),
    ("damped_pile", "trajectory", "5. damped pile: position error / r"),
]
COLORS = {
    "explicit_euler": "tab:red",
    "symplectic_euler": "tab:blue",
    "velocity_verlet": "tab:green",
    "rk4": "tab:purple",
    "implicit_euler": "tab:orange",
}
SHORT = {
    "explicit_euler": "explicit Euler",
    "symplectic_euler": "symplectic Euler",
    "velocity_verlet": "velocity Verlet",
    "rk4": "RK4",
    "implicit_euler": "implicit Euler",
}


def _pareto(points):
    """Lower-left front of (cost, error) points."""
    pts = sorted(points)
    front = []
    best = math.inf
    for c, e in pts:
        if e < best:
            front.append((c, e))
            best = e
    return front


def _panel(ax, rows, scen, metric, label, damping, zeta, cost, auto, floor=1e-13):
    """One scenario and metric: error against cost, one line per method, diverged runs as crosses
    along the top, the Pareto front, and configure's choice as a star."""
    import matplotlib.ticker

    z = 0.0 if scen == "elastic_pile" else zeta
    d = "linear" if scen == "elastic_pile" else damping
    sel = [r for r in rows if r["scenario"] == scen and r["metric"] == metric and r["zeta"] == z and r["damping"] == d]
    if not sel:
        ax.set_title(label + " (n/a)", fontsize=8)
        ax.axis("off")
        return
    good = [r for r in sel if not r["diverged"] and r["error"] > 0 and math.isfinite(r[cost])]
    top = max([r["error"] for r in good] + [1.0]) * 3
    for integ in INTEGRATORS:
        for ev in (0, 1):
            pts = sorted(
                (r[cost], max(r["error"], floor)) for r in good if r["integrator"] == integ and r["events"] == ev
            )
            if pts:
                ax.plot(
                    *zip(*pts),
                    color=COLORS[integ],
                    ls="--" if ev else "-",
                    marker="o" if ev else ".",
                    ms=3,
                    lw=1.2 if ev else 1.0,
                    label=f"{SHORT[integ]}{' + events' if ev else ''}",
                )
            bad = [r for r in sel if r["diverged"] and r["integrator"] == integ and r["events"] == ev]
            if bad:
                xs = [_nominal_cost(r, cost, sel) for r in bad]
                ax.plot(xs, [top] * len(xs), ls="none", marker="x", color=COLORS[integ], ms=5)
    front = _pareto([(r[cost], max(r["error"], floor)) for r in good])
    if front:
        ax.step(*zip(*front), where="post", color="0.5", lw=3, alpha=0.35, zorder=0)
    if auto is not None and scen in ("pair", "drop", "rest"):
        integ, ev, spc = auto
        near = [r for r in good if r["integrator"] == integ and r["events"] == int(ev)]
        if len(near) >= 2:
            # configure's steps per contact, placed along its method's measured line (log-log)
            c_s = np.array([r["steps_per_contact"] for r in near], float)
            o = np.argsort(c_s)
            c_c = np.log(np.array([r[cost] for r in near]))[o]
            c_e = np.log(np.array([max(r["error"], floor) for r in near]))[o]
            xc = float(np.exp(np.interp(np.log(spc), np.log(c_s[o]), c_c)))
            ye = float(np.exp(np.interp(np.log(spc), np.log(c_s[o]), c_e)))
            ax.plot([xc], [ye], marker="*", ms=14, color="gold", mec="k", zorder=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(floor, top * 2)
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(label, fontsize=9)
    ax.set_xlabel(
        "force evaluations / simulated s" if cost == "evals_per_sim_s" else "wall s / simulated s (per world)",
        fontsize=8,
    )
    ax.set_ylabel("worst-case relative error", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())


def _legend(fig, ax, accuracy, **kw):
    from matplotlib.lines import Line2D

    handles, labels = ax.get_legend_handles_labels()
    handles += [
        Line2D([], [], ls="none", marker="x", color="k"),
        Line2D([], [], color="0.5", lw=3, alpha=0.35),
        Line2D([], [], ls="none", marker="*", ms=12, color="gold", mec="k"),
    ]
    labels += ["diverged", "Pareto front", f"configure(accuracy={accuracy:g})"]
    fig.legend(handles, labels, frameon=False, fontsize=8, **kw)


def _auto_or_none(zeta, damping, accuracy):
    try:
        return _auto_choice(zeta, damping, accuracy) if CF.ERROR_MODELS else None
    except ValueError:
        return None


def plot(rows, path, damping, zeta, cost="evals_per_sim_s", accuracy=0.01, title=None):
    """Every scenario for one damping mode and zeta (zeta = 0 in the elastic pile)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [p for p in PANELS if any(r["scenario"] == p[0] and r["metric"] == p[1] for r in rows)]
    ncol = 4
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.3 * nrow), squeeze=False)
    for ax in axes.flat[len(panels) :]:
        ax.axis("off")
    auto = _auto_or_none(zeta, damping, accuracy)
    for ax, (scen, metric, label) in zip(axes.flat, panels):
        _panel(ax, rows, scen, metric, label, damping, zeta, cost, auto)
    _legend(fig, axes.flat[0], accuracy, loc="lower right", ncol=2, bbox_to_anchor=(0.99, 0.02))
    fig.suptitle(
        title or f"Speed against accuracy: damping {damping}, zeta = {zeta:g} (zeta = 0 in panel 4)", fontsize=11
    )
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(path, dpi=60)
    plt.close(fig)


MORE_PANELS = [
    ("pair", "restitution", "pair: restitution"),
    ("drop", "peak_overlap", "ball into bowl: peak overlap"),
    ("rest", "resting_overlap", "resting overlap"),
    ("damped_pile", "trajectory", "damped pile: position / r"),
]


def plot_more(rows, path, combos=(("linear", 0.1), ("no_tension", 0.1), ("no_tension", 0.3)), accuracy=0.01):
    """The other zetas and the no-tension mode, four panels per row."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(combos), len(MORE_PANELS), figsize=(16, 3.1 * len(combos) + 0.6), squeeze=False)
    for row, (damping, zeta) in zip(axes, combos):
        auto = _auto_or_none(zeta, damping, accuracy)
        for ax, (scen, metric, label) in zip(row, MORE_PANELS):
            _panel(ax, rows, scen, metric, f"{damping}, zeta {zeta:g}: {label}", damping, zeta, "evals_per_sim_s", auto)
    _legend(fig, axes[0, 0], accuracy, loc="lower center", ncol=7)
    fig.suptitle("Speed against accuracy: other damping ratios and the no-tension mode", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 0.96))
    fig.savefig(path, dpi=60)
    plt.close(fig)


def _nominal_cost(r, cost, sel):
    """Cost of a diverged run, read off the same method's finite runs at the same steps per contact."""
    same = [
        q[cost]
        for q in sel
        if q["integrator"] == r["integrator"]
        and q["events"] == r["events"]
        and q["steps_per_contact"] == r["steps_per_contact"]
        and math.isfinite(q[cost])
    ]
    if same:
        return same[0]
    ref = [
        q
        for q in sel
        if q["steps_per_contact"] == r["steps_per_contact"]
        and math.isfinite(q[cost])
        and q["integrator"] == "symplectic_euler"
        and not q["events"]
    ]
    if ref and cost == "evals_per_sim_s":
        return ref[0][cost] * {"rk4": 4}.get(r["integrator"], 1)
    finite = [q[cost] for q in sel if math.isfinite(q[cost])]
    return min(finite) if finite else 1.0


def _auto_choice(zeta, damping, accuracy):
    """(integrator, events, steps per contact) that configure picks for one contact of this zeta."""
    best = None
    for integ in INTEGRATORS:
        if not supported(integ, damping):
            continue
        for ev in (False, True):
            need = max(CF._steps_needed(integ, ev, damping, zeta, accuracy, mt) for mt in CF.METRICS)
            if not math.isfinite(need):
                continue
            spc = CF.SAFETY * need
            # the stability guard, in steps per contact
            crit = theory.guard_omega_dt(integ, zeta)
            if math.isfinite(crit):
                if crit <= 0:
                    continue
                spc = max(spc, math.pi / math.sqrt(1 - zeta * zeta) / crit)
            c = CF.config_cost(integ, ev, spc)
            if best is None or c < best[0]:
                best = (c, integ, ev, spc)
    if best is None:
        raise ValueError("no configuration")
    return best[1:]


def make_charts(rows, out, quick=False):
    paths = []
    p = os.path.join(out, "accuracy_linear_zeta0.3.png")
    plot(rows, p, "linear", 0.3)
    paths.append(p)
    p = os.path.join(out, "accuracy_walltime.png")
    plot(
        rows,
        p,
        "linear",
        0.3,
        cost="wall_per_sim_s",
        title="Speed against accuracy: wall time per simulated second (same runs), damping linear, zeta = 0.3",
    )
    paths.append(p)
    if not quick:
        p = os.path.join(out, "accuracy_more.png")
        plot_more(rows, p)
        paths.append(p)
    return paths


def order_table(rows, damping="linear", zeta=0.3, scenario="pair", metric="restitution", spcs=(16, 32, 64, 128)):
    """Measured convergence order (slope of log error against log steps per contact) per method."""
    out = {}
    for integ in INTEGRATORS:
        for ev in (0, 1):
            pts = {
                r["steps_per_contact"]: r["error"]
                for r in rows
                if r["scenario"] == scenario
                and r["metric"] == metric
                and r["integrator"] == integ
                and r["events"] == ev
                and r["damping"] == damping
                and r["zeta"] == zeta
                and not r["diverged"]
            }
            s = [k for k in spcs if k in pts and pts[k] > FLOOR]
            if len(s) >= 2:
                out[(integ, ev)] = float(-np.polyfit(np.log(s), np.log([pts[k] for k in s]), 1)[0])
    return out


def error_table(rows, scenario="pair", metric="restitution", damping="linear", zeta=0.3, spcs=(8, 16, 32, 64, 128)):
    """Markdown table of the worst-case error per method at some steps per contact."""
    lines = ["| method | " + " | ".join(f"{s} steps" for s in spcs) + " |", "|---" * (len(spcs) + 1) + "|"]
    for integ in INTEGRATORS:
        for ev in (0, 1):
            cells = []
            for spc in spcs:
                r = [
                    q
                    for q in rows
                    if q["scenario"] == scenario
                    and q["metric"] == metric
                    and q["integrator"] == integ
                    and q["events"] == ev
                    and q["damping"] == damping
                    and q["zeta"] == zeta
                    and q["steps_per_contact"] == spc
                ]
                cells.append("diverged" if r and r[0]["diverged"] else (f"{100 * r[0]['error']:.2g}%" if r else "-"))
            lines.append(f"| {SHORT[integ]}{' + events' if ev else ''} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def recommendation_table(accuracies=(0.1, 0.03, 0.01, 1e-3, 1e-4), restitutions=(0.9, 0.5, 0.2), damping="linear"):
    """Markdown table of what :func:`configure` picks (one isolated contact, no gravity)."""
    lines = [
        "| restitution accuracy | " + " | ".join(f"e = {e:g}" for e in restitutions) + " |",
        "|---" * (len(restitutions) + 1) + "|",
    ]
    for acc in accuracies:
        cells = []
        for e in restitutions:
            try:
                c = CF.configure([1.0, 1.0], [0.1, 0.1], 1.0, 0.05, e, acc, damping=damping)
                cells.append(
                    f"{SHORT[c.integrator]}{' + events' if c.events else ''}, {c.steps_per_contact:.0f} steps "
                    f"({c.cost_per_contact:.0f})"
                )
            except ValueError:
                cells.append("none measured")
        lines.append(f"| {100 * acc:g}% | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench accuracy",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="a CI-sized sweep (< 2 minutes once compiled)")
    ap.add_argument("--fit", action="store_true", help="fit the error models and write them (see --models)")
    ap.add_argument(
        "--models",
        default=None,
        help="where --fit writes the error models (default: the package's data file in a source "
        "checkout; required for an installed package, which is never written)",
    )
    ap.add_argument("--out", default=None, help="folder for the CSV and PNGs (default: docs/ of the repository)")
    ap.add_argument("--from-csv", default=None, help="skip the runs: chart (and fit) an existing accuracy.csv[.gz]")
    ap.add_argument("--no-plot", action="store_true")
    ap.add_argument("--tables", action="store_true", help="print the README's markdown tables")
    ap.add_argument("--scenarios", default=",".join(SCENARIOS))
    ap.add_argument(
        "--ray",
        action="store_true",
        help="run the cells as Ray tasks of one CPU each (the `sweep` extra): a local cluster, or the one at "
        "--address / RAY_ADDRESS; the CSV equals the serial one but for the wall times",
    )
    ap.add_argument(
        "--address", default=None, help="with --ray: the Ray cluster's address (default: RAY_ADDRESS, else local)"
    )
    args = ap.parse_args(argv)
    if args.address and not args.ray:
        ap.error("--address needs --ray")
    scenarios = tuple(args.scenarios.split(","))
    try:
        cells(True, scenarios)
    except ValueError as e:
        ap.error(f"--scenarios {args.scenarios!r}: {e}")
    models_path = args.models or default_models_path()
    if args.fit and models_path is None:
        ap.error("--fit: penalty_env is installed, not a source checkout: say where to write with --models PATH")
    out = args.out or os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs")
    if args.quick and args.out is None:
        import tempfile

        out = os.path.join(tempfile.gettempdir(), "penalty_env_bench_quick")  # keep docs/ for the full run
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    if args.from_csv:
        rows = read_csv(args.from_csv)
    else:
        rows = sweep(args.quick, scenarios=scenarios, fit=args.fit, ray=args.ray, address=args.address)
        write_csv(rows, os.path.join(out, "accuracy.csv.gz"))
    if args.fit:
        models = fit_models(rows)
        per_step, extra = measure_costs(rows)
        write_models(
            models,
            per_step,
            extra,
            models_path,
            source=f"{len(rows)} runs, {'quick' if args.quick else 'full'} sweep, "
            f"phases={128 if args.quick else PHASES}",
        )
        CF.load_error_models(models_path)
        print(f"wrote {models_path}")
        print(f"fitted {len(models)} error models; cost per step {per_step}; event extra evals per contact {extra}")
    if not args.no_plot:
        for p in make_charts(rows, out, args.quick):
            print("wrote", p)
    print("convergence orders (pair restitution, linear, zeta 0.3, 16..128 steps per contact):")
    for (integ, ev), p in order_table(rows).items():
        print(f"  {SHORT[integ]:18s}{' + events' if ev else '         '}  p = {p:5.2f}")
    located = [
        r
        for r in rows
        if r["scenario"] == "elastic_pile" and r["integrator"] == "rk4" and r["events"] and not r["diverged"]
    ]
    if located:
        r = max(located, key=lambda q: q["steps_per_contact"])
        print(
            f"elastic pile: {r['events_per_sim_s'] * r['sim_time'] / 2:.0f} contacts per world "
            f"(switches located by RK4 + events at {r['steps_per_contact']} steps per contact / 2)"
        )
    if args.tables:
        print("worst-case restitution error, pair collision, linear damping, zeta = 0.3:")
        print(error_table(rows))
        print(
            "configure's choice (method, steps per contact of the shortest contact, cost in force evaluations "
            "per contact):"
        )
        for damping in DAMPINGS:
            print(f"damping {damping}:")
            print(recommendation_table(damping=damping))
    print(f"accuracy benchmark done in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
