"""The measurements of ``python -m penalty_env.bench scale`` (:mod:`penalty_env.bench.scale`): the
settled beds (made once, cached), and the timed figures of its sections (1) to (4): one settled
world against LAMMPS, the bytes per grain, batches of settled beds, the core's own (b) pile.
"""

from __future__ import annotations

import math
import os
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np

from ..physics import World
from ..physics.stepping.runner import thread_count
from ..physics.world import NEIGHBOUR_SKIN
from ..scenarios import packed_bowl, scene_params
from .core import _time_large
from .peer_lammps import Lammps, LammpsRun, Rates, run_lammps

RADIUS, MASS = 0.5, 1.0  # the core's (b) balls
SPACING = 2.0  # lattice pitch in radii: touching (the core's 2.02 leaves gaps that collapse)
DRAG = 2.0  # 1/s: settling drag, -DRAG m v (applied as an external force, refreshed every DRAG_EVERY steps)
DRAG_EVERY = 10
SETTLE_S = 4.0  # simulated seconds of settling under the drag
CACHE_VERSION = 1
THREADS = (1, 2)
WORK = 1.0e7  # particle-substeps per timed measurement (split into BLOCKS blocks)
BLOCKS = 3
ROUNDS = 2


def default_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "penalty_env" / "scale"


@dataclass
class Bed:
    """A settled bed: positions and velocities (n, 3), its bowl, and the scene's constants."""

    x: np.ndarray
    v: np.ndarray
    bowl: Any  # the Bowl
    ks: float
    kd: float
    dt: float
    settle_wall_s: float = 0.0  # wall seconds it took to settle (0: from the cache)

    @property
    def n(self) -> int:
        return self.x.shape[0]

    @property
    def ke_per_ball(self) -> float:
        return float(0.5 * MASS * np.sum(self.v**2) / self.n)

    def world(self, worlds: int = 1, **kw: Any) -> World:
        """A World of this bed (``worlds`` copies of it, batched when more than one)."""
        x = self.x if worlds == 1 else np.repeat(self.x[None], worlds, 0)
        v = self.v if worlds == 1 else np.repeat(self.v[None], worlds, 0)
        kw.setdefault("broadphase", "grid")
        return World(
            x,
            np.full(self.n, RADIUS),
            np.full(self.n, MASS),
            v,
            terrain=(self.bowl,),
            ks=self.ks,
            kd=self.kd,
            dt=self.dt,
            **kw,
        )


def _scene(n: int) -> tuple[np.ndarray, Any, float, float, float]:
    """The core's (b) scene for n balls, on a touching lattice: positions, bowl, ks, kd, dt."""
    pos, bowl = packed_bowl(n, 3, RADIUS, spacing=SPACING)
    ks, kd = scene_params(RADIUS, MASS)
    probe = World(pos[:2], [RADIUS] * 2, [MASS] * 2, terrain=(bowl,), ks=ks, kd=kd, dt=1.0, allow_unstable=True)
    return pos, bowl, ks, kd, probe.stability_limit()


def _settle(w: World, seconds: float) -> int:
    """``seconds`` simulated under the settling drag; returns the steps taken."""
    steps = int(round(seconds / w.dt))
    for k in range(0, steps, DRAG_EVERY):
        w.step(min(DRAG_EVERY, steps - k), forces=-DRAG * MASS * w.velocities)
    return steps


def _bed_path(cache_dir: Path, n: int) -> Path:
    tag = f"s{SPACING:g}-d{DRAG:g}-t{SETTLE_S:g}-v{CACHE_VERSION}"
    return Path(cache_dir) / f"bed-{n}-{tag}.npz"


def settled_bed(n: int, cache_dir: Path | None = None, verbose: bool = False) -> Bed:
    """n balls settled in the core's bowl. Cheap to make: the balls start on ``packed_bowl``'s
    close-packed lattice at touching pitch (so the pile does not collapse by the lattice's gaps),
    filling the bowl lowest first (so its top is already flat), and settle for ``SETTLE_S``
    simulated seconds under the World's own contact law plus a drag -DRAG m v (an external force,
    refreshed every DRAG_EVERY steps) that kills the slosh a frictionless pile keeps for tens of
    seconds otherwise (what is left: the kinetic energy per ball, printed and in the CSV; the
    larger piles keep more of it). The result is cached (``cache_dir``/bed-<n>-<settings>.npz)."""
    pos, bowl, ks, kd, dt = _scene(n)
    path = None
    if cache_dir is not None:
        path = _bed_path(cache_dir, n)
        if path.exists():
            with np.load(path) as f:
                return Bed(f["x"], f["v"], bowl, ks, kd, dt)
    t0 = time.perf_counter()
    w = Bed(pos, np.zeros_like(pos), bowl, ks, kd, dt).world()
    steps = _settle(w, SETTLE_S)
    bed = Bed(w.positions.copy(), w.velocities.copy(), bowl, ks, kd, dt, time.perf_counter() - t0)
    if verbose:
        print(
            f"    settled {n:,} balls in {bed.settle_wall_s:.0f} s ({steps} steps, {SETTLE_S:g} s simulated), "
            f"KE {bed.ke_per_ball:.2e} J/ball"
        )
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, x=bed.x, v=bed.v)
        os.replace(tmp, path)
    return bed


def time_blocks(world: World, steps: int, blocks: int) -> list[float]:
    """Particle-substeps per second of each of ``blocks`` consecutive calls ``world.step(steps)``."""
    rates = []
    for _ in range(blocks):
        t = time.perf_counter()
        world.step(steps)
        rates.append(world.n_worlds * world.n_balls * steps / (time.perf_counter() - t))
    return rates


def _steps_per_block(particles: int, work: float, blocks: int) -> int:
    return max(3, math.ceil(work / (particles * blocks)))


def _list_stats(world: World) -> tuple[int, float]:
    if world.stepping != "neighbour_list":
        return 0, float("nan")
    s = world.neighbour_list_stats()
    return s["builds"], s["listed_per_ball"]


@dataclass
class Row:
    """One measured figure: a CSV row."""

    section: str  # single | batch | core_b | memory
    code: str  # penalty_env | lammps
    n_worlds: int
    n_balls: int
    threads: int
    path: str
    rates: list = field(default_factory=list)
    steps_per_build: float = float("nan")
    listed_per_ball: float = float("nan")
    ke_per_ball: float = float("nan")
    note: str = ""

    @property
    def best(self) -> float:
        return Rates(self.rates).best if self.rates else float("nan")

    @property
    def median(self) -> float:
        return Rates(self.rates).median if self.rates else float("nan")

    @property
    def ns(self) -> float:
        return 1e9 / self.best if self.rates else float("nan")

    def csv(self) -> dict:
        return {
            "section": self.section,
            "code": self.code,
            "n_worlds": self.n_worlds,
            "n_balls": self.n_balls,
            "particles": self.n_worlds * self.n_balls,
            "threads": self.threads,
            "path": self.path,
            "best_per_s": f"{self.best:.6g}",
            "median_per_s": f"{self.median:.6g}",
            "ns_per_particle_step": f"{self.ns:.4g}",
            "blocks": len(self.rates),
            "steps_per_build": f"{self.steps_per_build:.4g}",
            "listed_per_ball": f"{self.listed_per_ball:.4g}",
            "ke_per_ball": f"{self.ke_per_ball:.3g}",
            "note": self.note,
        }


def _lammps_state(bed: Bed, steps: int) -> tuple[Any, ...]:
    """run_lammps's positional scene arguments for the bed."""
    b = bed.bowl
    skin = NEIGHBOUR_SKIN * 2.0 * RADIUS
    return (
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
        skin,
    )


def _run_peer(peer: Lammps, state: tuple[Any, ...], threads: int, blocks: int) -> LammpsRun:
    """LAMMPS on a scene (``run_lammps``'s positional arguments) on ``threads`` threads, in blocks."""
    return run_lammps(peer, *state, threads=threads, blocks=blocks)  # type: ignore[misc]


def measure_single(
    bed: Bed,
    threads: tuple[int, ...] = THREADS,
    work: float = WORK,
    blocks: int = BLOCKS,
    rounds: int = ROUNDS,
    peer: Lammps | None = None,
) -> list[Row]:
    """(1) for one bed: ours on each thread count and LAMMPS (``peer``, or None) on each, in
    ``rounds`` interleaved rounds; every block of every round counts (best and median)."""
    n = bed.n
    steps = _steps_per_block(n, work, blocks)
    w = bed.world()
    w.step(1)  # compile, and the first list build
    builds0, _ = _list_stats(w)
    ours = {t: Row("single", "penalty_env", 1, n, t, w.stepping, ke_per_ball=bed.ke_per_ball) for t in threads}
    peers = {t: Row("single", "lammps", 1, n, t, "gran/hooke omp", ke_per_ball=bed.ke_per_ball) for t in threads}
    lmp_steps: list[float] = []
    total_steps = 0
    saved = numba.get_num_threads()
    try:
        for _ in range(rounds):
            for t in threads:
                numba.set_num_threads(min(t, thread_count()))
                ours[t].rates += time_blocks(w, steps, blocks)
                total_steps += steps * blocks
            numba.set_num_threads(saved)
            if peer is None:
                continue
            for t in threads:
                try:
                    run = _run_peer(peer, _lammps_state(bed, steps * blocks), t, blocks)
                except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
                    peers[t].note = f"failed: {str(exc)[-200:]}".replace("\n", " ")
                    continue
                peers[t].rates += list(run.rates)
                lmp_steps.append(run.steps_per_build)
    finally:
        numba.set_num_threads(saved)
    builds, listed = _list_stats(w)
    for r in ours.values():
        r.steps_per_build = total_steps / max(builds - builds0, 1) if builds > builds0 else float("inf")
        r.listed_per_ball = listed
    for r in peers.values():
        r.steps_per_build = float(np.nanmean(lmp_steps)) if lmp_steps else float("nan")
    return list(ours.values()) + ([r for r in peers.values() if r.rates or r.note] if peer is not None else [])


def measure_batch(
    worlds: int, n: int, bed: Bed, work: float = WORK, blocks: int = BLOCKS, rounds: int = ROUNDS
) -> list[Row]:
    """(3): ``worlds`` copies of a settled bed of n balls in one World, on the path ``auto`` picks
    and on each other path that applies (scalar one world per thread on the grid, the neighbour
    list), interleaved in rounds, on the default thread count."""
    auto = bed.world(worlds)
    paths = [auto.stepping] + [p for p in ("scalar", "neighbour_list") if p != auto.stepping]
    made = {auto.stepping: auto}
    for p in paths[1:]:
        made[p] = bed.world(worlds, stepping=p)
    steps = _steps_per_block(worlds * n, work, blocks)
    rows = {}
    for p, w in made.items():
        w.step(1)
        note = "auto" if p == auto.stepping else ""
        rows[p] = Row("batch", "penalty_env", worlds, n, numba.get_num_threads(), p, note=note)
        rows[p].ke_per_ball = bed.ke_per_ball
    for _ in range(rounds):
        for p, w in made.items():
            rows[p].rates += time_blocks(w, steps, blocks)
    for p, w in made.items():
        builds, listed = _list_stats(w)
        if p == "neighbour_list":
            rows[p].steps_per_build = (1 + rounds * blocks * steps) / max(builds, 1)
            rows[p].listed_per_ball = listed
    return list(rows.values())


def _rss_bytes() -> int:
    """The process's resident memory now (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _available_bytes() -> int:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def array_bytes(obj: Any, seen: set[int] | None = None, depth: int = 0) -> int:
    """Bytes of every distinct numpy array reachable from ``obj`` through attributes, tuples, lists
    and dicts (each buffer once: a view counts its base)."""
    seen = set() if seen is None else seen
    if depth > 12 or id(obj) in seen:
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        base = obj
        while isinstance(base.base, np.ndarray):
            base = base.base
        if base is not obj:
            return array_bytes(base, seen, depth + 1)
        return obj.nbytes
    if isinstance(obj, (str, bytes, int, float, complex, bool, type(None))):
        return 0
    if isinstance(obj, dict):
        return sum(array_bytes(v, seen, depth + 1) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return sum(array_bytes(v, seen, depth + 1) for v in obj)
    if type(obj).__module__.startswith("penalty_env") and hasattr(obj, "__dict__"):
        return sum(array_bytes(v, seen, depth + 1) for v in vars(obj).values())
    return 0


def measure_memory(bed: Bed) -> dict:
    """(2): bytes per grain of a World of the bed: its arrays (state, buffers, grid), its neighbour
    list's, and the growth of the process's resident memory from before the World was made to
    after its first step (the list built)."""
    rss0 = _rss_bytes()
    w = bed.world()
    rss1 = _rss_bytes()
    w.step(2)
    rss2 = _rss_bytes()
    lists = w.runner.lists
    list_bytes = array_bytes(lists) if lists is not None else 0
    total = array_bytes(w)
    n = bed.n
    return {
        "n": n,
        "arrays_per_grain": total / n,
        "list_per_grain": list_bytes / n,
        "capacity": lists.stats()["capacity"] if lists is not None else 0,
        "rss_make_per_grain": (rss1 - rss0) / n,
        "rss_per_grain": (rss2 - rss0) / n,
        "rss_total": rss2,
        "available": _available_bytes(),
    }


def core_b_check(peer: Lammps | None, threads: tuple[int, ...] = THREADS) -> list[Row]:
    """(4): the core's own (b) pile of 100,000 balls (``core._time_large``: slumped from the lattice
    for 6 s simulated, then timed), with LAMMPS on its state: the "about 3x" figure in this run."""
    phases, mode = _time_large(100_000)
    ph = phases[1]
    rows = [
        Row("core_b", "penalty_env", 1, 100_000, numba.get_num_threads(), "neighbour_list", list(ph.rates)),
        Row("core_b", "penalty_env", 1, 100_000, 1, "neighbour_list", list(ph.rates_1thread)),
    ]
    for r in rows:
        r.steps_per_build, r.listed_per_ball = ph.steps_per_build, ph.listed
        r.ke_per_ball = float(0.5 * MASS * np.sum(ph.state[1] ** 2) / 100_000)
    if peer is None:
        return rows
    for t in threads:
        row = Row("core_b", "lammps", 1, 100_000, t, "gran/hooke omp", ke_per_ball=rows[0].ke_per_ball)
        try:
            run = _run_peer(peer, ph.state, t, len(ph.rates))
            row.rates, row.steps_per_build = list(run.rates), run.steps_per_build
        except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
            row.note = f"failed: {str(exc)[-200:]}".replace("\n", " ")
        rows.append(row)
    return rows
