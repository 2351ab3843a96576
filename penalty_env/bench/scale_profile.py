"""Where the time of a settled world's step goes (``python -m penalty_env.bench scale``, section
(5), :mod:`penalty_env.bench.scale`): the neighbour list's force pass timed alone against the whole
step and a list build, and the workload ``--profile-run`` hands to callgrind.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numba
import numpy as np

from .._jit import njit
from ..physics import World
from ..physics.stepping.large import _slab_forces
from .scale_measure import Bed, _list_stats, settled_bed


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
    lists = w.runner.lists
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
    g = w.runner.g
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
    lists = w.runner.lists
    for _ in range(steps):
        if rebuild and lists is not None:
            lists.reset()
        w.step(1)
    print(f"profile_run: {n} balls, {steps} steps, builds {_list_stats(w)[0]}")
