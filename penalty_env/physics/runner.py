"""The runner: the one place that owns threads and decides how a batch of worlds is stepped.

``World.step`` and the environments' fused step both come here. It holds

* the thread pool (one per process, rebuilt in a forked child: a pool inherited across ``fork``
  has no worker threads, and work submitted to it would wait forever), sized by Numba's thread
  count (``NUMBA_NUM_THREADS``, default the CPU count);
* the one work threshold, :data:`PARALLEL_MIN_WORK` ball-substeps per call, below which threads
  cost more than they save;
* the choice of stepping path for a World (:data:`PATHS`): ``scalar`` (one world at a time per
  thread, :func:`.integrators.run_worlds`, or the event-located :func:`.events.run_worlds`),
  ``lanes`` (a block of worlds per SIMD vector, :mod:`.lanes`) and ``neighbour_list`` (a Verlet
  list per world, :mod:`.neighbour_list`: a batch a share of its worlds per thread, each serial; a
  single large world parallel over its balls).

Every world is stepped serially within its range, so what a world computes does not depend on how
the batch is split: the split only decides the speed.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba
import numpy as np

from .._jit import entry_point
from . import events as _events
from . import integrators as _integrators
from . import lanes as _lanes
from .neighbour_list import EXPLICIT_EULER, SERIAL_MAX_BALLS, SYMPLECTIC_EULER, NeighbourLists

__all__ = ["PATHS", "PARALLEL_MIN_WORK", "thread_count", "pool", "split", "dispatch", "entry_point", "Runner"]

PATHS = ("scalar", "lanes", "neighbour_list")

# Below this many ball-substeps per call, threads cost more than they save (measured with
# ``python -m penalty_env.bench env``: a thread hand-off costs about as much as ~2,000 of them on
# the SIMD path, and far fewer on the scalar path, whose ball-steps cost more).
PARALLEL_MIN_WORK = 2_000

_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()
# held while a kernel runs on Numba's threading layer (the neighbour-list path): the fork-safe
# ``workqueue`` layer aborts if two threads launch parallel kernels at once
PARALLEL_LOCK = threading.Lock()


def thread_count() -> int:
    """Worker threads: Numba's ``NUMBA_NUM_THREADS`` (default: the CPU count)."""
    return max(1, int(numba.config.NUMBA_NUM_THREADS))


def pool() -> ThreadPoolExecutor:
    """The process's thread pool (made on first use; a forked child makes its own)."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max_workers=thread_count(), thread_name_prefix="penalty_env")
        return _POOL


def _forget_pool_in_child() -> None:
    # the parent's pool object came across fork without its threads: drop it (never shut it down,
    # that would wait for threads that do not exist) and start afresh on first use; the locks may
    # have been held by a parent thread that does not exist here
    global _POOL, _POOL_LOCK, PARALLEL_LOCK
    _POOL = None
    _POOL_LOCK = threading.Lock()
    PARALLEL_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool_in_child)


def split(items: int | np.ndarray, work_per_item: int, align: int = 1) -> list:
    """Split ``items`` (a count of worlds, or an array of world indices) into at most
    ``thread_count()`` parts when the work, ``len(items) x work_per_item`` ball-substeps, reaches
    :data:`PARALLEL_MIN_WORK`; else one part. A count gives ``(start, stop)`` ranges in whole blocks
    of ``align`` worlds, an array gives index arrays."""
    count = items if isinstance(items, (int, np.integer)) else len(items)
    threads = thread_count()
    parts = 1 if threads < 2 or count < 2 or count * work_per_item < PARALLEL_MIN_WORK else min(threads, count)
    if not isinstance(items, (int, np.integer)):
        return list(np.array_split(items, parts)) if parts > 1 else [items]
    blocks = -(-count // align)
    parts = max(1, min(parts, blocks))
    bounds = np.minimum(np.linspace(0, blocks, parts + 1).astype(int) * align, count)
    return [(int(b0), int(b1)) for b0, b1 in zip(bounds[:-1], bounds[1:])]


def dispatch(fn: Callable, arg_lists: Sequence[tuple]) -> list:
    """Call ``fn(*args)`` for each entry: inline when there is one, else on the pool (the kernels
    release the GIL). Returns the results in order."""
    if len(arg_lists) == 1:
        return [fn(*arg_lists[0])]
    futures = [pool().submit(fn, *a) for a in arg_lists]
    return [f.result() for f in futures]


class Runner:
    """How one World is stepped: its path, its buffers, and the calls that advance it.

    Made by :class:`~penalty_env.physics.World`; ``step`` is what ``World.step`` calls after
    validating its arguments.
    """

    def __init__(
        self,
        path: str,
        integrator: str,
        events: bool,
        model: Any,
        state: Any,
        work: Any,
        grid: Any,
        status: np.ndarray,
        dt: float,
        friction: Any = None,
    ) -> None:
        B, n, d = state.positions.shape
        self.path = path
        self.integrator = integrator
        self.events = events
        self.model = model
        self.state = state
        self.work = work
        self.grid = grid
        self.status = status
        self.dt = dt
        self.event_buffers = _events.allocate(B, n, d) if events else None
        self.lane_scratch = np.zeros((thread_count(), 5, n, d, _lanes.LANES)) if path == "lanes" else None
        self.lists = NeighbourLists(model, B, n, d, thread_count()) if path == "neighbour_list" else None
        # as the kernels take them: ``friction`` a rotating scene's Spin, else the model's (mu, kf) or None
        self.friction = model.friction if friction is None else friction
        self.g = model.gravity
        self._entries: dict[bool, Callable] = {}  # compiled step kernels, by whether ext is None

    def forget(self, worlds: Any = slice(None)) -> None:
        """Drop what was derived from the state of ``worlds`` (velocity Verlet's cached acceleration,
        a neighbour list and its storage order), after the state was written."""
        if isinstance(self.work, _integrators.VelocityVerletWork):
            self.work.a0_valid[worlds] = False
        if self.lists is not None:
            self.lists.reset(worlds)

    def step(self, n: int, ext: np.ndarray | None) -> None:
        """Advance every world by n steps of dt (``ext``: the external force per ball, or None)."""
        x, v = self.state
        model = self.model
        friction, g = self.friction, self.g
        B, balls = x.shape[0], x.shape[1]
        if self.path == "neighbour_list":
            integ = SYMPLECTIC_EULER if self.integrator == "symplectic_euler" else EXPLICIT_EULER
            args = (integ, n, self.dt, x, v, ext, friction, g, self.status)
            threads = thread_count()
            if B >= threads and B > 1:
                # a batch: a share of the worlds per thread, each world serial on its own list (no
                # parallel region; round robin, so a batch of equal worlds splits evenly)
                parts = [range(t, B, threads) for t in range(min(threads, B))]
                dispatch(lambda part: self.lists.step(*args, worlds=part, serial=True), [(p,) for p in parts])
            elif threads == 1 or balls < SERIAL_MAX_BALLS or numba.get_num_threads() == 1:
                # no parallel region: its launch costs more than it saves (and with
                # numba.set_num_threads(1) it saves nothing: 75 against 86 ns a ball-step at 10^4, measured)
                self.lists.step(*args, serial=True)
            else:
                with PARALLEL_LOCK:
                    self.lists.step(*args)
            return
        if self.path == "lanes":
            sym = self.integrator == "symplectic_euler"
            ranges = split(B, balls * n, align=_lanes.LANES)
            calls = [
                (sym, b0, b1, n, self.dt, x, v, self.lane_scratch[i], ext, model, friction, g, self.status)
                for i, (b0, b1) in enumerate(ranges)
            ]
            fn = _lanes.run_lanes
        else:
            ranges = split(B, balls * n)
            if self.events:
                tail = (self.work, ext, self.grid, model, friction, g, self.event_buffers, self.status)
                fn = _events.run_worlds
            else:
                tail = (self.work, ext, self.grid, model, friction, g, self.status)
                fn = _integrators.run_worlds
            calls = [(b0, b1, n, self.dt, x, v) + tail for b0, b1 in ranges]
        # the argument types are fixed by the World (only the external force may be None or not):
        # call the compiled kernel without Numba's per-call type resolution
        entry = self._entries.get(ext is None)
        if entry is None:
            entry = self._entries[ext is None] = entry_point(fn, calls[0])
        dispatch(entry, calls)
