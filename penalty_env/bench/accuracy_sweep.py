"""The sweep of ``python -m penalty_env.bench accuracy`` (:mod:`penalty_env.bench.accuracy`): the
grid of runs (:func:`cells`: integrator, event mode, damping mode, zeta, steps per contact, per
scenario), measuring them serially or as Ray tasks (:func:`sweep`), and the CSV of every run.
"""

from __future__ import annotations

import csv
import math
import os
import time
from typing import NamedTuple

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
