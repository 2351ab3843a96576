"""Scaling of the physics core: ``python -m penalty_env.bench scale [--quick] [--max-n N] [--no-lammps]``.

Prints, writes (``docs/scale.csv``) and plots (``docs/scale.png``, log-log):
  (1) one settled world of N = 10^3 .. 10^6 frictionless balls in a bowl (the core benchmark's
      section (b) scene, ``packed_bowl`` scaled, settled with a drag: see ``settled_bed``):
      particle-substeps per second on 1 and 2 threads (``numba.set_num_threads``), and LAMMPS on
      the same state in the same run (``-pk omp 1`` and ``2``), interleaved in rounds;
  (2) the cost per particle-substep against N (flat within 1.5x from 10^3 to 10^6 is the target),
      the bytes per grain of the largest world (its arrays and neighbour list, and the growth of the
      process's resident memory), and whether it fits in memory;
  (3) batches: B worlds of n balls (each a small settled bed), stepped in one call of one World, on
      the path ``stepping="auto"`` picks and on the other paths that apply (target: 256 x 500
      within 1.5x of the 100,000-ball world's cost per particle-substep);
  (4) the 100,000-ball world of the core's own section (b) (slumped from its lattice for 6 s
      simulated, still sloshing): ours against LAMMPS, the "about 3x" figure, to tie (1) to it.
The settled states are cached (``--cache-dir``, default ``~/.cache/penalty_env/scale``), keyed by N;
the first run settles them (the 10^6 one takes a few minutes).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np

from .._jit import njit
from ..physics import World
from ..physics.stepping.large import _slab_forces
from ..physics.stepping.runner import thread_count
from ..physics.world import NEIGHBOUR_SKIN
from ..scenarios import packed_bowl, scene_params
from .core import _time_large
from .peer_lammps import Lammps, LammpsRun, Rates, find_lammps, run_lammps

RADIUS, MASS = 0.5, 1.0  # the core's (b) balls
SPACING = 2.0  # lattice pitch in radii: touching (the core's 2.02 leaves gaps that collapse)
DRAG = 2.0  # 1/s: settling drag, -DRAG m v (applied as an external force, refreshed every DRAG_EVERY steps)
DRAG_EVERY = 10
SETTLE_S = 4.0  # simulated seconds of settling under the drag
CACHE_VERSION = 1
SIZES = (1_000, 10_000, 100_000, 1_000_000)
BATCHES = ((64, 2000), (256, 500), (1024, 100), (256, 2000))
THREADS = (1, 2)
WORK = 1.0e7  # particle-substeps per timed measurement (split into BLOCKS blocks)
BLOCKS = 3
ROUNDS = 2
DOCS = Path(__file__).resolve().parents[2] / "docs"


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
    lists = w._runner.lists
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


def write_csv(rows: list[Row], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        out = csv.DictWriter(f, fieldnames=list(Row("", "", 0, 0, 0, "").csv()))
        out.writeheader()
        for r in rows:
            out.writerow(r.csv())


def plot(rows: list[Row], path: Path) -> None:
    """Log-log: particle-substeps/s against N (ours and LAMMPS, 1 and 2 threads), and ns per
    particle-substep against particles per call, with the batches."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8))
    single = [r for r in rows if r.section == "single" and r.rates]
    for code, marker in (("penalty_env", "o"), ("lammps", "s")):
        for t, style in ((1, "--"), (2, "-")):
            pts = sorted((r.n_balls, r.best) for r in single if r.code == code and r.threads == t)
            if not pts:
                continue
            xs, ys = zip(*pts, strict=True)
            label = f"{code}, {t} thread{'s' if t > 1 else ''}"
            a.loglog(xs, ys, style, marker=marker, label=label)
            b.loglog(xs, [1e9 / y for y in ys], style, marker=marker, label=label)
    for r in rows:
        if r.section == "batch" and r.rates:
            mk = "^" if r.note == "auto" else "v"
            b.loglog([r.n_worlds * r.n_balls], [r.ns], mk, color="tab:purple" if r.note == "auto" else "tab:gray")
            b.annotate(
                f"{r.n_worlds}x{r.n_balls} {r.path}{' (auto)' if r.note == 'auto' else ''}",
                (r.n_worlds * r.n_balls, r.ns),
                fontsize=7,
                xytext=(4, 2),
                textcoords="offset points",
            )
    a.set_xlabel("balls in the world (N)")
    a.set_ylabel("particle-substeps per second")
    a.set_title("one settled world in a bowl")
    b.set_xlabel("particles per step call (N, or B x n for a batch)")
    b.set_ylabel("ns per particle-substep")
    b.set_title("cost per particle-substep (batches: triangles, 2 threads)")
    for ax in (a, b):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


@njit(entry=True)
def _force_pass(slabs, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf):  # type: ignore[no-untyped-def]
    """The neighbour list's force pass alone (every slab in storage order, serially: the work of
    ``run_large``'s even and odd slab passes, without the advance)."""
    for s in range(slabs):
        _slab_forces(s, layer, start, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf)


def listed_world(bed: Bed) -> tuple[World, Any, Any, Any]:
    """A World of ``bed`` stepped twice (its list built): the World, its ``NeighbourLists``, and
    the one world's list state and Model. Raises when the World does not step the list path."""
    w = bed.world()
    w.step(2)
    lists = w._runner.lists
    if lists is None:
        raise ValueError(f"{bed.n} balls: this World steps {w.stepping!r}, not the neighbour-list path")
    lw, sm = lists.worlds[0]
    return w, lists, lw, sm


def phase_profile(bed: Bed, steps: int = 20, reps: int = 5) -> dict:
    """Wall-clock shares of a settled world's step on one thread, measured alternately (best of
    ``reps``): the whole step (``World.step(steps)``), the force pass alone (``_force_pass`` on the
    list's state, into a scratch array: pairs and the terrain of the balls near it), and one list
    build (a step after ``NeighbourLists.reset``, which re-sorts the storage and rebuilds, less a
    plain step). The advance (symplectic Euler, the escape check) and the passes' overheads are the
    step less the force pass."""
    w, lists, lw, sm = listed_world(bed)
    grid = lw.grid
    layer = int(grid.dims[0, 0] * grid.dims[0, 1])
    slabs = int(grid.dims[0, 2])
    scratch = np.zeros_like(lw.a)
    fargs = (slabs, layer, grid.start[0], lw.x, lw.v, scratch, lw.nbr, lw.count, lw.near, sm)
    g = w._runner.g
    saved = numba.get_num_threads()
    t_step = t_force = t_build = math.inf
    numba.set_num_threads(1)
    try:
        _force_pass(*fargs, g, lw.escaped, int(lw.state[3]), lw.pairs[0])  # compile
        for _ in range(reps):
            t = time.perf_counter()
            w.step(steps)
            t_step = min(t_step, (time.perf_counter() - t) / steps)
            t = time.perf_counter()
            for _ in range(steps):
                _force_pass(*fargs, g, lw.escaped, int(lw.state[3]), lw.pairs[0])
            t_force = min(t_force, (time.perf_counter() - t) / steps)
            t = time.perf_counter()
            for _ in range(steps // 4 or 1):
                lists.reset()
                w.step(1)
            t_build = min(t_build, (time.perf_counter() - t) / (steps // 4 or 1))
    finally:
        numba.set_num_threads(saved)
    stats = w.neighbour_list_stats()
    lw = lists.worlds[0][0]
    return {
        "n": bed.n,
        "step_s": t_step,
        "force_s": t_force,
        "build_s": max(t_build - t_step, 0.0),
        "near_terrain": float(np.mean(stats["near_terrain"])),
        "listed_per_ball": stats["listed_per_ball"],
        "capacity": stats["capacity"],
    }


def profile_run(n: int, steps: int, rebuild: bool = False, cache_dir: Path | None = None) -> None:
    """The profiled workload (docs/scale.md): the settled bed of n balls, one step (the list built),
    then ``steps`` more, each after forcing a rebuild with ``rebuild`` (the list's cost is the
    difference). Run it twice under callgrind with two step counts and difference the counts."""
    w = settled_bed(n, cache_dir).world()
    w.step(1)
    lists = w._runner.lists
    for _ in range(steps):
        if rebuild and lists is not None:
            lists.reset()
        w.step(1)
    print(f"profile_run: {n} balls, {steps} steps, builds {_list_stats(w)[0]}")


def _parse_batch(s: str) -> tuple[int, int]:
    b, n = s.lower().split("x")
    return int(b), int(n)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench scale",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="N up to 10^4, small batches, short timings")
    ap.add_argument("--max-n", type=int, default=None, help="largest N of (1) (default 10^6; 10^4 with --quick)")
    ap.add_argument("--batches", nargs="*", default=None, help="batch shapes BxN (default 64x2000 256x500 ...)")
    ap.add_argument("--no-lammps", action="store_true", help="do not run LAMMPS")
    ap.add_argument("--no-core-b", action="store_true", help="skip (4), the core's own slumped 10^5 pile")
    ap.add_argument("--work", type=float, default=None, help="particle-substeps per timed measurement")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 2; 1 with --quick)")
    ap.add_argument("--cache-dir", default=str(default_cache_dir()), help="where settled beds are kept")
    ap.add_argument("--out-dir", default=str(DOCS), help="where scale.csv and scale.png go")
    ap.add_argument(
        "--profile-run",
        nargs=2,
        type=int,
        metavar=("N", "STEPS"),
        help="only the profiled workload (for callgrind): the settled N-ball bed, 1 + STEPS steps",
    )
    ap.add_argument("--rebuild", action="store_true", help="with --profile-run: rebuild the list every step")
    args = ap.parse_args(argv)
    if args.profile_run:
        profile_run(args.profile_run[0], args.profile_run[1], args.rebuild, Path(args.cache_dir))
        return
    quick = args.quick
    max_n = args.max_n if args.max_n is not None else (10_000 if quick else SIZES[-1])
    sizes = [n for n in SIZES if n <= max_n] or [max_n]
    batches = [_parse_batch(s) for s in args.batches] if args.batches is not None else None
    if batches is None:
        batches = [(16, 500), (64, 100)] if quick else list(BATCHES)
    work = args.work if args.work is not None else (2e6 if quick else WORK)
    rounds = args.rounds if args.rounds is not None else (1 if quick else ROUNDS)
    threads = tuple(t for t in THREADS if t <= thread_count())
    cache = Path(args.cache_dir) if args.cache_dir else None
    out = Path(args.out_dir)

    peer: Lammps | None = None
    print(
        f"penalty_env scale benchmark: symplectic Euler, {thread_count()} threads, "
        f"numba {numba.__version__}; settled beds from {cache}"
    )
    if not args.no_lammps:
        found = find_lammps()
        if isinstance(found, str):
            print(f"    peer: {found}")
        else:
            peer = found
            print(f"    peer: LAMMPS {found.version} (gran/hooke, wall/gran/region, nve; OPENMP, -pk omp T)")
    rows: list[Row] = []
    print(
        f"(1) one settled world in a bowl: {rounds} interleaved round(s) of [ours on {threads} threads, "
        f"LAMMPS on each], {BLOCKS} blocks of ~{work / BLOCKS:.2g} particle-substeps each"
    )
    beds = {}
    for n in sizes:
        bed = beds[n] = settled_bed(n, cache, verbose=True)
        got = measure_single(bed, threads, work, BLOCKS, rounds, peer)
        rows += got
        ours = {r.threads: r for r in got if r.code == "penalty_env"}
        lmp = {r.threads: r for r in got if r.code == "lammps"}
        for t, r in ours.items():
            line = (
                f"    {n:>9,} balls, {t} thr: {r.best / 1e6:7.2f} M/s (median {r.median / 1e6:6.2f}), "
                f"{r.ns:6.1f} ns/particle-step, list every {r.steps_per_build:6.1f} steps, {r.listed_per_ball:4.1f} listed/ball"
            )
            if t in lmp and lmp[t].rates:
                line += f" | LAMMPS {lmp[t].best / 1e6:6.2f} M/s, ours {r.best / lmp[t].best:5.2f}x"
            elif t in lmp:
                line += f" | LAMMPS {lmp[t].note}"
            print(line, flush=True)
        write_csv(rows, out / "scale.csv")

    print("(2) cost per particle-substep against N (best block; target: flat within 1.5x)")
    for t in threads:
        ns = {r.n_balls: r.ns for r in rows if r.section == "single" and r.code == "penalty_env" and r.threads == t}
        lo, hi = min(ns.values()), max(ns.values())
        print(
            f"    {t} thread{'s' if t > 1 else ' '}: "
            + ", ".join(f"{n:,}: {v:.1f} ns" for n, v in sorted(ns.items()))
            + f"; largest / smallest N {ns[max(ns)] / ns[min(ns)]:.2f}x, max / min {hi / lo:.2f}x "
            f"({'flat' if hi / lo <= 1.5 else 'NOT flat'} within 1.5x)"
        )
    mem = measure_memory(beds[sizes[-1]])
    print(
        f"    memory at {mem['n']:,} balls: arrays {mem['arrays_per_grain']:.0f} B/grain (neighbour list "
        f"{mem['list_per_grain']:.0f} of it, {mem['capacity']} slots per ball); resident memory grew "
        f"{mem['rss_per_grain']:.0f} B/grain ({mem['rss_make_per_grain']:.0f} at World(), the rest at the first "
        f"step); process RSS {mem['rss_total'] / 2**30:.2f} GiB, {mem['available'] / 2**30:.1f} GiB still available"
    )
    mrow = Row("memory", "penalty_env", 1, mem["n"], numba.get_num_threads(), "neighbour_list")
    mrow.note = (
        f"arrays_B_per_grain={mem['arrays_per_grain']:.0f};list_B_per_grain={mem['list_per_grain']:.0f};"
        f"rss_growth_B_per_grain={mem['rss_per_grain']:.0f};rss_GiB={mem['rss_total'] / 2**30:.2f}"
    )
    rows.append(mrow)
    del beds

    print(
        f"(3) batches of settled beds, one World, {numba.get_num_threads()} threads: every path that applies "
        "(auto's pick marked)"
    )
    ref = {r.threads: r for r in rows if r.section == "single" and r.code == "penalty_env" and r.n_balls == 100_000}
    ref2 = ref.get(max(threads))
    for worlds, n in batches:
        bed = settled_bed(n, cache)
        try:
            got = measure_batch(worlds, n, bed, work, BLOCKS, rounds)
        except MemoryError as exc:
            print(f"    {worlds} x {n}: out of memory ({exc})")
            continue
        rows += got
        for r in got:
            vs = f", {r.ns / ref2.ns:4.2f}x the 100,000-ball world's" if ref2 is not None else ""
            print(
                f"    {worlds:>5} x {n:>5}: {r.path:>14}{' (auto)' if r.note == 'auto' else '       '} "
                f"{r.best / 1e6:7.2f} M/s (median {r.median / 1e6:6.2f}), {r.ns:6.1f} ns/particle-step{vs}",
                flush=True,
            )
        write_csv(rows, out / "scale.csv")
    if ref2 is not None:
        print(
            "    target: 256 x 500 within 1.5x of the 100,000-ball world's ns/particle-step (best path and auto above)"
        )

    if not args.no_core_b and not quick:
        print("(4) the core's (b) pile, 100,000 balls slumped from its lattice (6 s simulated), with LAMMPS")
        got = core_b_check(peer, threads)
        rows += got
        ours = {r.threads: r for r in got if r.code == "penalty_env"}
        for r in got:
            line = f"    {r.code:>11}, {r.threads} thr: {r.best / 1e6:7.2f} M/s (median {r.median / 1e6:6.2f})"
            if r.code == "lammps" and r.rates and r.threads in ours:
                line += f": ours {ours[r.threads].best / r.best:5.2f}x"
            print(line + (f" {r.note}" if r.note else ""))
    prof_n = max(n for n in sizes if n <= 100_000)
    prof = phase_profile(settled_bed(prof_n, cache), 20 if not quick else 5, 3)
    step, force, build = prof["step_s"], prof["force_s"], prof["build_s"]
    print(
        f"(5) where the time goes, the settled {prof_n:,}-ball world on 1 thread (best of 3, alternating): step "
        f"{1e9 * step / prof_n:.1f} ns/particle, force pass alone {100 * force / step:.0f}% of it (pairs, "
        f"{prof['listed_per_ball']:.2f} listed per ball, and the terrain of the {100 * prof['near_terrain']:.1f}% "
        f"of balls near it), advance and overheads {100 * (1 - force / step):.0f}%; one list build costs "
        f"{build / step:.1f} steps"
    )
    prow = Row("profile", "penalty_env", 1, prof_n, 1, "neighbour_list", [prof_n / step])
    prow.listed_per_ball = prof["listed_per_ball"]
    prow.note = (
        f"force_share={force / step:.3f};build_in_steps={build / step:.2f};near_terrain={prof['near_terrain']:.4f}"
    )
    rows.append(prow)
    write_csv(rows, out / "scale.csv")
    plot(rows, out / "scale.png")
    print(f"wrote {out / 'scale.csv'} and {out / 'scale.png'}")


if __name__ == "__main__":
    main()
