"""Section (6) of ``python -m penalty_env.bench scale``: a settled bed of spinning grains, the
tangential springs with history and rolling resistance, ours against LAMMPS.

The bed is section (1)'s settled bed of N balls (``scale_measure.settled_bed``) given friction
(``SPIN``: mu = 0.5, the Cundall-Strack spring with its defaults kt = 2/7 ks and kd_t = kd / 2,
rolling resistance mu_r = 0.1 with kr at its explicit limit) and settled again for
``SPIN_SETTLE_S`` simulated seconds under the same drag, at the step the stability guard allows
the tangential spring (it is stiffer than the normal one on the tangential effective mass: 2.81 ms
instead of 3.71); cached beside the frictionless beds (positions, velocities, angular velocities).
Both codes then start from that state, without contact history (LAMMPS keeps none across runs;
ours starts a fresh World), and are timed interleaved in rounds, as section (1).

LAMMPS runs ``pair_style granular`` (``peer_lammps.run_lammps`` with ``mu_r``): ``hooke`` with
``damping mass_velocity`` (Kn = ks, gamma_n = kd / m_eff), ``tangential linear_history`` (Kt = kt,
its damping kd_t, the cap mu |F_n|), ``rolling sds`` with mu_roll = mu_r and gamma_roll = kr / R*^2
(the same cap and the same viscous torque as ours below it) and k_roll = kt (a rolling spring ours
has not: LAMMPS's slider divides by it), ``fix wall/gran/region granular`` with the same law, ``fix
nve/sphere``. ``granular`` has no OPENMP variant in LAMMPS, so LAMMPS runs on one thread; the
comparison is per core: one thread each.
"""

from __future__ import annotations

import os
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np

from ..physics import World
from ..physics.stepping.runner import thread_count
from .peer_lammps import Lammps, run_lammps
from .scale_measure import (
    BLOCKS,
    DRAG,
    DRAG_EVERY,
    MASS,
    RADIUS,
    ROUNDS,
    WORK,
    Row,
    _steps_per_block,
    settled_bed,
    time_blocks,
)

__all__ = ["SPIN", "SPIN_SETTLE_S", "SpinBed", "spin_bed", "measure_spin"]

# the frictional contact: mu, and rolling resistance (kt, kd_t, kr at the World's defaults)
SPIN = dict(mu=0.5, mu_r=0.1)
SPIN_SETTLE_S = 1.0  # simulated seconds of settling with friction, under the drag
SPIN_CACHE_VERSION = 1


@dataclass
class SpinBed:
    """A settled bed of spinning grains: the state, the bowl, and the contact's numbers."""

    x: np.ndarray
    v: np.ndarray
    w: np.ndarray
    bowl: Any
    ks: float
    kd: float
    dt: float

    @property
    def n(self) -> int:
        return self.x.shape[0]

    @property
    def ke_per_ball(self) -> float:
        return float(0.5 * MASS * np.sum(self.v**2) / self.n)

    def world(self, **kw: Any) -> World:
        """A World of this bed: rotation, the tangential springs with history, rolling resistance."""
        w = World(
            self.x,
            np.full(self.n, RADIUS),
            np.full(self.n, MASS),
            self.v,
            terrain=(self.bowl,),
            ks=self.ks,
            kd=self.kd,
            dt=self.dt,
            broadphase="grid",
            rotation=True,
            tangential="history",
            **SPIN,
            **kw,
        )
        w.angular_velocities = self.w
        return w


def _spin_dt(bed: Any) -> float:
    """The guard's step for the frictional scene (its tangential spring sets it), at most the bed's."""
    kw = dict(terrain=(bed.bowl,), ks=bed.ks, kd=bed.kd, rotation=True, tangential="history", **SPIN)
    probe = World(bed.x[:2], [RADIUS] * 2, [MASS] * 2, dt=1.0, allow_unstable=True, **kw)  # type: ignore[arg-type]
    return min(bed.dt, probe.stability_limit())


def spin_bed(n: int, cache_dir: Path | None = None, verbose: bool = False) -> SpinBed:
    """Section (1)'s settled bed of n balls given friction and rolling resistance and settled
    again for SPIN_SETTLE_S under the drag (cached as ``spin-bed-<n>-<settings>.npz``)."""
    bed = settled_bed(n, cache_dir, verbose)
    dt = _spin_dt(bed)
    path = None
    if cache_dir is not None:
        tag = f"mu{SPIN['mu']:g}-r{SPIN['mu_r']:g}-t{SPIN_SETTLE_S:g}-v{SPIN_CACHE_VERSION}"
        path = Path(cache_dir) / f"spin-bed-{n}-{tag}.npz"
        if path.exists():
            with np.load(path) as f:
                return SpinBed(f["x"], f["v"], f["w"], bed.bowl, bed.ks, bed.kd, dt)
    t0 = time.perf_counter()
    w = SpinBed(bed.x, bed.v, np.zeros_like(bed.x), bed.bowl, bed.ks, bed.kd, dt).world()
    steps = int(round(SPIN_SETTLE_S / dt))
    for k in range(0, steps, DRAG_EVERY):
        w.step(min(DRAG_EVERY, steps - k), forces=-DRAG * MASS * w.velocities)
    out = SpinBed(w.positions.copy(), w.velocities.copy(), w.angular_velocities.copy(), bed.bowl, bed.ks, bed.kd, dt)
    if verbose:
        print(
            f"    settled {n:,} spinning grains in {time.perf_counter() - t0:.0f} s ({steps} steps), "
            f"KE {out.ke_per_ball:.2e} J/ball, {w.neighbour_list_stats()['springs'] / n:.2f} springs/ball"
        )
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, x=out.x, v=out.v, w=out.w)
        os.replace(tmp, path)
    return out


def _run_peer(peer: Lammps, bed: SpinBed, world: World, steps: int, blocks: int) -> Any:
    """LAMMPS (one thread) on the bed, ``steps`` steps in ``blocks`` blocks."""
    b = bed.bowl
    return run_lammps(
        peer,
        bed.x,
        bed.v,
        np.full(bed.n, RADIUS),
        np.full(bed.n, MASS),
        b.center,
        b.radius,
        bed.ks,
        bed.kd,
        (0.0, 0.0, -9.81),
        bed.dt,
        steps,
        world.runner.lists.skin,
        threads=1,
        blocks=blocks,
        kt=world.kt,
        kd_t=world.kd_t,
        mu=SPIN["mu"],
        mu_r=SPIN["mu_r"],
        kr=world.kr,
        omega=bed.w,
    )


def measure_spin(
    bed: SpinBed,
    threads: tuple[int, ...] = (1, 2),
    work: float = WORK,
    blocks: int = BLOCKS,
    rounds: int = ROUNDS,
    peer: Lammps | None = None,
) -> list[Row]:
    """Ours on each thread count and LAMMPS on one thread, in ``rounds`` interleaved rounds, every
    block of every round counted (best and median), as ``scale_measure.measure_single``."""
    n = bed.n
    steps = _steps_per_block(n, work, blocks)
    w = bed.world()
    w.step(1)  # compile, and the first list build
    builds0 = w.neighbour_list_stats()["builds"]
    note = f"mu={SPIN['mu']:g};mu_r={SPIN['mu_r']:g};history;dt={bed.dt:.4g}"
    ours = {t: Row("spin", "penalty_env", 1, n, t, w.stepping, ke_per_ball=bed.ke_per_ball, note=note) for t in threads}
    lmp = Row("spin", "lammps", 1, n, 1, "granular", ke_per_ball=bed.ke_per_ball, note=note)
    lmp_builds: list[float] = []
    total = 0
    saved = numba.get_num_threads()
    try:
        for _ in range(rounds):
            for t in threads:
                numba.set_num_threads(min(t, thread_count()))
                ours[t].rates += time_blocks(w, steps, blocks)
                total += steps * blocks
            numba.set_num_threads(saved)
            if peer is None:
                continue
            try:
                run = _run_peer(peer, bed, w, steps * blocks, blocks)
            except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
                lmp.note = f"failed: {str(exc)[-200:]}".replace("\n", " ")
                continue
            lmp.rates += list(run.rates)
            lmp_builds.append(run.steps_per_build)
    finally:
        numba.set_num_threads(saved)
    stats = w.neighbour_list_stats()
    for r in ours.values():
        built = stats["builds"] - builds0
        r.steps_per_build = total / built if built else float("inf")
        r.listed_per_ball = stats["listed_per_ball"]
        r.note += f";springs_per_ball={stats['springs'] / n:.2f}"
    lmp.steps_per_build = float(np.nanmean(lmp_builds)) if lmp_builds else float("nan")
    return list(ours.values()) + ([lmp] if peer is not None and (lmp.rates or lmp.note) else [])
