"""Where each integrator holds and where it fails: ``python -m penalty_env.bench stability [--quick]``.

(a) Stability map. A ball resting on the bowl's floor under gravity, displaced slightly from its
    resting overlap, is a linear oscillator of frequency omega0 = sqrt(ks / m) and damping ratio
    zeta while it stays in contact. For each integrator and each (omega0 dt, zeta) of a grid, the
    ball starts 1e-4 of the resting overlap off rest, and the run is *growing* if its largest
    oscillation energy (``World.energy()`` minus that of the ball at rest) over the last 200 of
    4,000 steps exceeds 1.01x that over the first 200, or its energy ever exceeds 1e4x the start,
    or the run produced NaN; else *bounded*. The
    measured boundary (the first growing omega0 dt at each zeta) is drawn against the theoretical
    curves of docs/physics.md section 4 (``theory.critical_omega_dt``, from each method's amplification
    matrix).
(b) Tunnelling. A ball (r = 0.1 m, m = 1 kg, ks = 1e4 N/m, zeta = 0.1) flies at speed v into the
    bowl's floor, gravity off, at 8 phases of the step grid. Outcomes: it *passes through* (its
    centre crosses the surface: overlap > r at some step), it is *launched with more energy* than
    it came with (exit kinetic energy > impact kinetic energy), or neither. Predicted boundaries:
    v / omega0 ~ r (the spring cannot stop the ball within a radius) and v dt ~ r (a single step
    goes a radius deep; LIGGGHTS warns when v_max dt > r_min), plus the stability limit.
(c) The environment. ``gymnasium.make("PenaltyBalls-v0")`` with its own settings; the pusher is
    driven at full throttle at the ball for 100,000 steps (it pushes the ball up the bowl's wall
    and holds it there, pressed between the pusher and the terrain), then the throttle is
    released: no NaN, no tunnelling (every overlap below the radius), no energy gain (the energy
    settles under the drive and falls at every step once released); the worst overlap is reported.

Output (``--out``, default ``docs/``; ``--quick`` writes to a temporary folder): ``stability_map.png``,
``tunnelling.png``, ``stability.csv.gz`` and ``tunnelling.csv.gz`` (every run).
"""

from __future__ import annotations

import argparse
import csv
import gzip
import math
import os
import time

import numpy as np

from ..physics import theory
from . import output_dir

# the measurements and charts, importable from here as before the split
from .stability_plot import plot_map, plot_tunnelling
from .stability_runs import (  # noqa: F401
    GROWING,
    INTEGRATORS,
    OSC_BOWL_R,
    OSC_G,
    OSC_KS,
    OSC_M,
    OSC_R,
    SHORT,
    TUN_KS,
    TUN_M,
    TUN_PHASES,
    TUN_R,
    TUN_ZETA,
    env_stress,
    floor_oscillator_growth,
    stability_map,
    tunnelling_map,
    tunnelling_outcome,
)


def _parser() -> argparse.ArgumentParser:
    """The command line (its description: this module's docstring)."""
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench stability",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="coarser maps and 5,000 env steps (CI smoke run)")
    ap.add_argument("--out", default=None, help="folder for the PNGs and CSVs (default: docs/ of the repository)")
    ap.add_argument("--env-steps", type=int, default=None, help="env steps of part (c) (default 100,000)")
    ap.add_argument("--skip", default="", help="comma-separated parts to skip: map, tunnelling, env")
    return ap


def _map_part(quick: bool, out: str, failed: list[str]) -> None:
    """(a): the stability map, its CSV and chart, and the measured boundary against the theory
    (a miss appended to ``failed``)."""
    omega_dts = np.round(np.arange(0.1, 3.301, 0.1 if quick else 0.05), 4)
    zetas = np.round(np.arange(0.0, 1.0001, 0.1 if quick else 0.05), 4)
    rows, boundary = stability_map(omega_dts, zetas)
    with gzip.open(os.path.join(out, "stability.csv.gz"), "wt", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["integrator", "omega_dt", "zeta", "energy_growth"])
        wr.writerows((i, h, z, f"{g:.4g}") for i, h, z, g in rows)
    plot_map(rows, boundary, omega_dts, zetas, os.path.join(out, "stability_map.png"))
    print("(a) measured first growing omega0 dt vs theory (docs/physics.md section 4):")
    for integ in INTEGRATORS:
        parts = []
        for z in (0.0, 0.1, 0.3, 1.0):
            k = int(np.argmin(np.abs(zetas - z)))
            measured, expected = boundary[integ][k], theory.critical_omega_dt(integ, z)
            parts.append(f"zeta {z:g}: {measured:.3g} (theory {expected:.3g})")
            # the first growing omega0 dt of the grid sits within a grid step of the theory (or is
            # the grid's first point, where the theory lies below the grid: explicit Euler at zeta 0)
            step = omega_dts[1] - omega_dts[0]
            lowest = max(expected, float(omega_dts[0]))
            near = (measured == expected == math.inf) or (lowest - step <= measured <= lowest + 1.5 * step)
            if not near and expected < omega_dts[-1]:
                failed.append(f"(a) {SHORT[integ]} at zeta {z:g}: {measured:.3g} against {expected:.3g}")
        print(f"    {SHORT[integ]:17s} " + "; ".join(parts))


def _tunnelling_part(quick: bool, out: str) -> None:
    """(b): the tunnelling map, its CSV and chart, and where each integrator gains energy or lets
    the ball through."""
    omega = math.sqrt(TUN_KS / TUN_M)
    n = 12 if quick else 26
    dts = np.logspace(-3, 1, n) / omega
    speeds = np.logspace(-2, 2, n) * omega * TUN_R
    trows = tunnelling_map(speeds, dts)
    with gzip.open(os.path.join(out, "tunnelling.csv.gz"), "wt", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["integrator", "speed", "dt", "outcome", "max_overlap_over_r", "exit_energy_ratio"])
        wr.writerows((i, f"{s:.4g}", f"{dt:.4g}", o, f"{p:.4g}", f"{g:.4g}") for i, s, dt, o, p, g in trows)
    plot_tunnelling(trows, speeds, dts, os.path.join(out, "tunnelling.png"))
    print(
        "(b) tunnelling: smallest omega0 dt with an energy gain, at v / (omega0 r) = 0.1; "
        "smallest v / (omega0 r) passing through at omega0 dt = 0.01"
    )
    for integ in INTEGRATORS:
        gain = [
            dt * omega for i, s, dt, o, _, _ in trows if i == integ and o == 1 and abs(s / (omega * TUN_R) - 0.1) < 0.05
        ]
        thru = [s / (omega * TUN_R) for i, s, dt, o, _, _ in trows if i == integ and o == 2 and dt * omega < 0.012]
        print(
            f"    {SHORT[integ]:17s} energy gain from omega0 dt = {min(gain) if gain else float('nan'):.3g}; "
            f"passes through from v = {min(thru) if thru else float('nan'):.3g} omega0 r"
        )


def _env_part(n: int, failed: list[str]) -> None:
    """(c): the environment stress test of ``n`` steps (a failure appended to ``failed``; an env
    that cannot run is reported, not failed)."""
    try:
        res = env_stress(n)
    except Exception as exc:  # the env is optional for the physics benchmarks
        print(f"(c) environment stress test could not run: {type(exc).__name__}: {exc}")
    else:
        print(
            f"(c) PenaltyBalls-v0, pusher at full throttle into the ball for {res['steps']:,} steps "
            f"({res['integrator']}, dt {res['dt']:.4g} s x {res['substeps']} substeps, {res['wall_s']:.1f} s): "
            f"worst overlap {res['worst_overlap']:.4f} r (tolerance {res['penetration_tolerance']:g} r); "
            f"energy {res['drive_energy_final']:.4f} J at the end of the drive (growth over the last fifth "
            f"{res['drive_energy_growth']:.2g}; checked from 50,000 steps), at most "
            f"{res['energy_beyond_motor_work']:.3g} J above the start plus the motor's work "
            f"({res['motor_work_bound']:.4g} J), then falls by {res['release_energy_drop']:.4f} J with the "
            f"throttle released (largest one-step rise {res['release_largest_rise']:.3g} J); NaN: {res['nan']}; "
            f"{'OK' if res['ok'] else 'FAILED'}"
        )
        if not res["ok"]:
            failed.append("(c) environment stress test")


def main(argv=None) -> None:
    args = _parser().parse_args(argv)
    out = output_dir(args)
    skip = set(filter(None, args.skip.split(",")))
    t0 = time.perf_counter()
    failed = []
    if "map" not in skip:
        _map_part(args.quick, out, failed)
    if "tunnelling" not in skip:
        _tunnelling_part(args.quick, out)
    if "env" not in skip:
        _env_part(args.env_steps or (5_000 if args.quick else 100_000), failed)
    print(f"stability benchmark done in {time.perf_counter() - t0:.1f} s")
    if failed:
        print("FAILED: " + ", ".join(failed))
        raise SystemExit(1)


if __name__ == "__main__":
    main()
