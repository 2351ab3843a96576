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
import os
import time

from ..physics import configure as CF
from ..scenarios import PHASES
from . import output_dir

# the benchmark's parts, importable from here as before the split (the tests, the Ray tasks' cells)
from .accuracy_fit import (  # noqa: F401
    FLOOR,
    MODEL_MAX_ERROR,
    default_models_path,
    fit_models,
    fit_power_law,
    measure_costs,
    write_models,
)
from .accuracy_plot import (  # noqa: F401
    COLORS,
    MORE_PANELS,
    PANELS,
    SHORT,
    error_table,
    make_charts,
    order_table,
    plot,
    plot_more,
    recommendation_table,
)
from .accuracy_sweep import (  # noqa: F401
    DAMPINGS,
    FIELDS,
    FIT_EXTRA_ZETAS,
    INTEGRATORS,
    SCENARIOS,
    SPCS,
    ZETAS,
    Cell,
    cells,
    read_csv,
    run_cell,
    supported,
    sweep,
    write_csv,
)


def _parser() -> argparse.ArgumentParser:
    """The command line (its description: this module's docstring)."""
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
    return ap


def _checked(ap: argparse.ArgumentParser, args: argparse.Namespace) -> tuple[tuple[str, ...], str | None]:
    """The scenarios to run and where --fit writes, or the parser's error (exit 2) for a bad
    combination of options."""
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
    return scenarios, models_path


def _fit(rows, quick: bool, models_path: str) -> None:
    """Fit the error models and costs to the rows, write them to models_path and load them (so
    the charts' configure choice uses them)."""
    models = fit_models(rows)
    per_step, extra = measure_costs(rows)
    write_models(
        models,
        per_step,
        extra,
        models_path,
        source=f"{len(rows)} runs, {'quick' if quick else 'full'} sweep, phases={128 if quick else PHASES}",
    )
    CF.load_error_models(models_path)
    print(f"wrote {models_path}")
    print(f"fitted {len(models)} error models; cost per step {per_step}; event extra evals per contact {extra}")


def _print_summary(rows, tables: bool) -> None:
    """The measured convergence orders, the elastic pile's contacts, and with ``tables`` the
    README's markdown tables."""
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
    if tables:
        print("worst-case restitution error, pair collision, linear damping, zeta = 0.3:")
        print(error_table(rows))
        print(
            "configure's choice (method, steps per contact of the shortest contact, cost in force evaluations "
            "per contact):"
        )
        for damping in DAMPINGS:
            print(f"damping {damping}:")
            print(recommendation_table(damping=damping))


def main(argv=None) -> None:
    ap = _parser()
    args = ap.parse_args(argv)
    scenarios, models_path = _checked(ap, args)
    out = output_dir(args)
    t0 = time.perf_counter()
    if args.from_csv:
        rows = read_csv(args.from_csv)
    else:
        rows = sweep(args.quick, scenarios=scenarios, fit=args.fit, ray=args.ray, address=args.address)
        write_csv(rows, os.path.join(out, "accuracy.csv.gz"))
    if args.fit:
        _fit(rows, args.quick, models_path)
    if not args.no_plot:
        for p in make_charts(rows, out, args.quick):
            print("wrote", p)
    _print_summary(rows, args.tables)
    print(f"accuracy benchmark done in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
