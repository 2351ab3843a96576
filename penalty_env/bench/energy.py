"""Energy per collision against the step: ``python -m penalty_env.bench energy [--quick] [--out DIR]``.

(a) For every integrator and omega0 dt from 0.05 to its stability guard: the mean and spread, over
512 phases of where the contact starts within the step, of the relative energy change of one
elastic collision (a ball hitting a floor head on, the World's own stepping), beside the energy
model ``theory.energy_gain_per_collision`` that the guard's energy budget uses, and the budget.
(b) A dense elastic gas (192 worlds of 8 balls in a spherical cage, no gravity, 20,000 steps) at
fractions of the stability guard's step and at the energy limit: the distribution of the energy
ratio over the worlds.

Writes ``energy_per_collision.csv`` and ``energy_per_collision.png`` (default ``docs/``).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import warnings

import numpy as np

from ..physics import World, theory
from ..physics.world import EnergyDriftWarning
from ..scenarios import elastic_gas, wall_collision_gains

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4", "implicit_euler")
PHASES = 512


def gas(frac_or_dt, B=192, n=8, steps=20_000, seed=0, energy_limit=False):
    """Energy ratio after ``steps`` of each world of an elastic gas (``scenarios.elastic_gas``) at
    ``frac`` x the stability guard's dt (or at the energy limit); returns (pair omega0 dt, ratios)."""
    x, v, r, kw = elastic_gas(B, n, seed)
    probe = World(x, np.full(n, r), np.ones(n), v, dt=1.0, allow_unstable=True, **kw)
    dt = probe.energy_limit() if energy_limit else frac_or_dt * probe.stability_limit()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EnergyDriftWarning)
        w = World(x, np.full(n, r), np.ones(n), v, dt=dt, **kw)
    e0 = w.energy()
    w.step(steps)
    return dt * math.sqrt(kw["ks"] / 0.5), w.energy() / e0


def _collision_rows(quick: bool) -> list[dict]:
    """(a): the energy change per elastic collision of each integrator over its omega0 dt grid,
    beside the model; prints a sample of each and the largest difference."""
    rows = []
    print(
        f"(a) mean relative energy gain per elastic collision, over {PHASES} phases (budget "
        f"{theory.ENERGY_BUDGET:g}: 1% per 1,000 collisions)"
    )
    worst_mismatch = 0.0
    for integ in INTEGRATORS:
        top = min(theory.guard_omega_dt(integ, 0.0), 3.0)
        grid = np.exp(np.linspace(math.log(0.05), math.log(top), 12 if quick else 40))
        limit = theory.energy_omega_dt(integ, 0.0)
        print(
            f"  {integ}: energy limit omega0 dt = {limit:.4g} (stability guard {theory.guard_omega_dt(integ, 0.0):.4g})"
        )
        for h in grid:
            gains = wall_collision_gains(integ, h, phases=PHASES)
            model = theory.energy_gain_per_collision(integ, h, phases=PHASES)[0]
            worst_mismatch = max(worst_mismatch, abs(gains.mean() - model))
            rows.append(
                dict(integrator=integ, omega_dt=h, mean_gain=gains.mean(), spread=gains.std(), model=model, limit=limit)
            )
        sel = [r for r in rows if r["integrator"] == integ]
        for r in sel[:: max(1, len(sel) // 6)]:
            print(
                f"    omega0 dt {r['omega_dt']:.3f}: {r['mean_gain']:+.3e} (spread {r['spread']:.2e}; model {r['model']:+.3e})"
            )
    print(f"  largest difference between the World and the model: {worst_mismatch:.2e}")
    return rows


def _print_gas() -> None:
    """(b): the elastic gas's energy ratio over the worlds at fractions of the guard's step and at
    the energy limit."""
    print("(b) elastic gas, 192 worlds x 8 balls, 20,000 steps: energy ratio over the worlds")
    for label, frac, lim in (
        ("guard", 1.0, False),
        ("guard / 2", 0.5, False),
        ("guard / 4", 0.25, False),
        ("energy limit", None, True),
    ):
        od, ratio = gas(frac, energy_limit=lim)
        print(
            f"  {label:13s} (pair omega0 dt {od:.3f}): median {np.median(ratio):.4f}, mean {ratio.mean():.4f}, "
            f"90th percentile {np.percentile(ratio, 90):.4f}, worst {ratio.max():.4g}, "
            f"{np.mean(ratio > 10):.0%} above 10x"
        )


def _plot(rows: list[dict], out: str) -> None:
    """The chart of (a) (none, said so, without matplotlib)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no chart")
        return
    fig, ax = plt.subplots(figsize=(7, 4.2))
    colors = {
        "symplectic_euler": "tab:blue",
        "velocity_verlet": "tab:green",
        "rk4": "tab:purple",
        "implicit_euler": "tab:orange",
    }
    for integ in INTEGRATORS:
        sel = [r for r in rows if r["integrator"] == integ]
        h = [r["omega_dt"] for r in sel]
        ax.plot(
            h,
            [abs(r["mean_gain"]) for r in sel],
            "o-",
            ms=3,
            color=colors[integ],
            label=f"{integ.replace('_', ' ')} ({'gains' if sel[-1]['mean_gain'] > 0 else 'loses'})",
        )
        ax.plot(h, [abs(r["model"]) for r in sel], ":", color=colors[integ], lw=1)
        if math.isfinite(sel[0]["limit"]) and sel[0]["limit"] < h[-1]:
            ax.axvline(sel[0]["limit"], color=colors[integ], ls="--", lw=0.8)
    ax.axhline(theory.ENERGY_BUDGET, color="k", lw=0.8, ls="--", label="budget (1% per 1,000 collisions)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(1e-9, 1.0)
    ax.set_xlabel("omega0 dt")
    ax.set_ylabel("|mean relative energy change| per elastic collision")
    ax.set_title("Energy per collision (dots: the World; dotted: the model; dashed: the energy limit)", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    path = os.path.join(out, "energy_per_collision.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print("wrote", path)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench energy",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="fewer steps and no gas (a smoke run)")
    ap.add_argument("--out", default=None, help="folder for the CSV and PNG (default: docs/ of the repository)")
    args = ap.parse_args(argv)
    out = args.out or os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs")
    if args.quick and args.out is None:
        import tempfile

        out = os.path.join(tempfile.gettempdir(), "penalty_env_bench_quick")
    os.makedirs(out, exist_ok=True)
    rows = _collision_rows(args.quick)
    with open(os.path.join(out, "energy_per_collision.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    if not args.quick:
        _print_gas()
    _plot(rows, out)


if __name__ == "__main__":
    main()
