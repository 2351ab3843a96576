"""``python -m penalty_env.bench granular [case ...]``: granular physics against experiments and laws.

Cases (all by default; docs/granular.md has the figures and the numbers):

- ``packing3d``: monodisperse frictionless spheres poured into a box and settled: interior solid
  fraction against random close packing, 0.64 (Scott and Kilgour 1969; Berryman 1983); and the same
  pour with mu = 0.5 (lower).
- ``packing2d``: bidisperse disks (50:50, radius ratio 1.4), frictionless: 0.84 (O'Hern et al. 2003);
  and with mu = 0.5.
- ``repose2d``, ``repose3d``: a pile released by lifting a tube (a kinematic shape moving up): its
  angle from a fit of the surface profile, against sliding friction mu and rolling friction mu_r
  (3D: slowly lifted, on a base of grains held at rest; against Zhou et al. 2002's correlation).
- ``beverloo2d``, ``beverloo3d``: a flat-bottomed silo discharging through a slot (2D) or a round
  orifice (3D): the rate W against the orifice D, fitted to W = C rho_b sqrt(g) (D - k d)^b
  (Beverloo et al. 1961: b = 5/2 in 3D; 3/2 in 2D).
- ``lammps``: a 3D silo discharged here and in LAMMPS from the same settled states (the same
  Hooke contact with Cundall-Strack history, nve/sphere; the same walls, the orifice's edges
  covered by a rim of spheres, frozen atoms in LAMMPS, static Sphere terrain here), over four
  fills and replicas: the ratio of the discharge rates and its run-to-run scatter.
- ``lammps_repose``: the 3D pile of ``repose3d`` filled and settled here, then lifted and measured
  here and in LAMMPS from the same states (the same normal and tangential laws, the rolling
  torque's cap; LAMMPS's ``rolling sds``), over six fills at mu_r = 0.2 and two at 0.1.

Units: the grain diameter d (the mean one), the solid density rho_s = 1 (3D: per volume, 2D: per
area) and g = 1; time in sqrt(d / g). The contact spring is chosen so that a grain under
``layers`` grains overlaps its neighbour by about 1% of its radius, ks = m g layers / (0.01 r); the
dashpot gives a normal restitution of 0.5 between two grains; the time step is t_c / ``STEPS_PER_CONTACT``
(t_c the pair's contact duration), never above ``World.stability_limit()``.

Writes docs/granular_*.png and docs/granular_*.csv (``--out`` to put them elsewhere).

The code, by module. Everything is importable from ``penalty_env.bench.granular`` itself, under the
names it had when this package was one module (bench/granular.py): the public names (``__all__``)
and the private helpers (imported ``as`` themselves, for code that reached into the module).

- ``grains``: the units, the contact law's numbers (``Contact``), ``make_world``, random
  non-overlapping positions, settling, the friction arguments and the box of a poured bed.
- ``packing``: ``packing3d``/``packing2d``: the poured bed and its solid fraction.
- ``pile``: ``repose2d``/``repose3d``: the pile released from a tube, its angle of repose, Zhou et
  al.'s correlation.
- ``beverloo``: ``beverloo2d``/``beverloo3d``: the silo's discharge and the fit of Beverloo's law.
- ``silo_vs_lammps``: ``lammps``: the 3D silo discharged here and in LAMMPS.
- ``pile_vs_lammps``: ``lammps_repose``: the 3D pile lifted here and in LAMMPS.
- ``lammps_common``: what both LAMMPS cross-checks share (frozen spheres in the input, running
  LAMMPS).
- ``output``: the figure backend and the CSV writer the cases share.

This module holds the command line (``main``), which runs the cases.
"""

from __future__ import annotations

import argparse
import os
import time

from .beverloo import (
    BEVERLOO_2D,
    BEVERLOO_3D,
    BEVERLOO_CSV,
    Discharge,
    beverloo_fit,
    beverloo_summary,
    beverloo_table,
    bulk_density,
    case_beverloo,
    discharge,
    discharge_rate,
    read_beverloo_csv,
    silo_scene,
    silo_terrain,
)
from .beverloo import _fill_height as _fill_height
from .beverloo import _write_beverloo_csv as _write_beverloo_csv
from .grains import (
    RESTITUTION,
    RHO_S,
    STEPS_PER_CONTACT,
    Contact,
    G,
    box_terrain,
    grain_mass,
    kinetic_per_grain,
    make_world,
    mean_overlap,
    random_sequential,
    settle,
    spin_kwargs,
)
from .lammps_common import _frozen_type_2 as _frozen_type_2
from .lammps_common import _lammps as _lammps
from .lammps_common import _run_lammps as _run_lammps
from .output import _plt as _plt
from .output import _write_csv as _write_csv
from .packing import JAMMING_2D, RCP_3D, Packing, case_packing, pour_bed, solid_fraction
from .pile import (
    REPOSE_2D,
    REPOSE_3D,
    REPOSE_3D_SETUP,
    Repose,
    ReposeFill,
    case_repose,
    lift_steps,
    pile_top,
    profile_angle,
    repose,
    repose_fill,
    repose_lift,
    repose_terrain,
    rough_base,
    zhou,
    zhou_2002_angle,
    zhou_2002_model_a,
)
from .pile import _repose_job as _repose_job
from .pile import _settle_held as _settle_held
from .pile import _step_held as _step_held
from .pile_vs_lammps import (
    LAMMPS_REPOSE,
    PileState,
    case_lammps_repose,
    lammps_pile,
    lammps_pile_fill,
    lammps_repose,
    lammps_repose_script,
    ours_pile,
    plot_lammps_repose,
)
from .pile_vs_lammps import _lammps_repose_job as _lammps_repose_job
from .silo_vs_lammps import (
    LAMMPS_SILO,
    SiloState,
    case_lammps,
    lammps_compare,
    lammps_silo,
    lammps_silo_discharge,
    lammps_silo_fill,
    lammps_silo_final,
    lammps_silo_script,
    lammps_silo_terrain,
    ours_silo_discharge,
    ours_silo_world,
    perturbed,
    plot_lammps,
    rim_centres,
)
from .silo_vs_lammps import _lammps_silo_input as _lammps_silo_input

CASES = ("packing3d", "packing2d", "repose2d", "repose3d", "beverloo2d", "beverloo3d", "lammps", "lammps_repose")
# docs/ (penalty_env/bench/../../docs: the same path as when this package was one module, bench/granular.py)
DOCS = os.path.join(os.path.dirname(os.path.dirname(__file__)), "..", "..", "docs")


__all__ = [
    "main",
    "CASES",
    "DOCS",
    "BEVERLOO_2D",
    "BEVERLOO_3D",
    "BEVERLOO_CSV",
    "Discharge",
    "beverloo_fit",
    "beverloo_summary",
    "beverloo_table",
    "bulk_density",
    "case_beverloo",
    "discharge",
    "discharge_rate",
    "read_beverloo_csv",
    "silo_scene",
    "silo_terrain",
    "RESTITUTION",
    "RHO_S",
    "STEPS_PER_CONTACT",
    "Contact",
    "G",
    "box_terrain",
    "grain_mass",
    "kinetic_per_grain",
    "make_world",
    "mean_overlap",
    "random_sequential",
    "settle",
    "spin_kwargs",
    "JAMMING_2D",
    "RCP_3D",
    "Packing",
    "case_packing",
    "pour_bed",
    "solid_fraction",
    "REPOSE_2D",
    "REPOSE_3D",
    "REPOSE_3D_SETUP",
    "Repose",
    "ReposeFill",
    "case_repose",
    "lift_steps",
    "pile_top",
    "profile_angle",
    "repose",
    "repose_fill",
    "repose_lift",
    "repose_terrain",
    "rough_base",
    "zhou",
    "zhou_2002_angle",
    "zhou_2002_model_a",
    "LAMMPS_REPOSE",
    "PileState",
    "case_lammps_repose",
    "lammps_pile",
    "lammps_pile_fill",
    "lammps_repose",
    "lammps_repose_script",
    "ours_pile",
    "plot_lammps_repose",
    "LAMMPS_SILO",
    "SiloState",
    "case_lammps",
    "lammps_compare",
    "lammps_silo",
    "lammps_silo_discharge",
    "lammps_silo_fill",
    "lammps_silo_final",
    "lammps_silo_script",
    "lammps_silo_terrain",
    "ours_silo_discharge",
    "ours_silo_world",
    "perturbed",
    "plot_lammps",
    "rim_centres",
]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m penalty_env.bench granular", description=__doc__.split("\n")[0])
    parser.add_argument("cases", nargs="*", help=f"any of {', '.join(CASES)} (default: all)")
    parser.add_argument("--out", default=DOCS, help="folder for the CSV and PNG files (default: docs/)")
    args = parser.parse_args(argv)
    cases = args.cases or list(CASES)
    bad = [c for c in cases if c not in CASES]
    if bad:
        parser.error(f"unknown case(s) {bad}; choose from {CASES}")
    runners = {
        "packing3d": lambda: case_packing(3, args.out),
        "packing2d": lambda: case_packing(2, args.out),
        "repose2d": lambda: case_repose(2, args.out),
        "repose3d": lambda: case_repose(3, args.out),
        "beverloo2d": lambda: case_beverloo(2, args.out),
        "beverloo3d": lambda: case_beverloo(3, args.out),
        "lammps": lambda: case_lammps(args.out),
        "lammps_repose": lambda: case_lammps_repose(args.out),
    }
    for case in cases:
        tick = time.time()
        summary = runners[case]()
        print(f"{case} ({time.time() - tick:.0f} s):", flush=True)
        for key, value in summary.items():
            print(f"  {key}: {value}", flush=True)
