"""The runner: the one place that owns threads and decides how a batch of worlds is stepped.

``World.step`` and the environments' step both come here. It holds

* the thread pool (one per process, rebuilt in a forked child: a pool inherited across ``fork``
  has no worker threads, and work submitted to it would wait forever), sized by Numba's thread
  count (``NUMBA_NUM_THREADS``, default the CPU count; :func:`set_thread_count` uses fewer);
* the hand-off (:func:`dispatch`): the calling thread works on the parts too, and takes any part no
  helper has started, so a helper that the operating system does not run (a machine shared with
  other jobs) delays nothing: the batch then runs serially on the caller;
* the one work threshold, :data:`PARALLEL_MIN_WORK` ball-substeps per call, below which threads
  cost more than they save;
* a World's stepping path (:data:`PATHS`) and its buffers: ``scalar`` (one world at a time per
  thread, :func:`.scalar.run_worlds`, or the event-located :func:`.events.run_worlds`), ``lanes``
  (a block of worlds per SIMD vector, :func:`.lanes.run_lanes`) and ``neighbour_list`` (a Verlet
  list per world, :class:`.neighbour_lists.NeighbourLists`).

The scalar and lanes paths are also reached from other kernels through :func:`advance`, on the
runner's own :class:`Physics` bundle: the environments step their worlds inside their own kernel
(motor, physics, observation and reward in one call) with exactly the path, buffers and code that
``World.step`` uses.

Every world is stepped serially within its range, so what a world computes does not depend on how
the batch is split: the split only decides the speed.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any, NamedTuple

import numba
import numpy as np

from ..._jit import compile_notice, entry_point, njit, overload_kernel
from ..model import Control, Model, Spin, State
from . import events as _events
from . import lanes as _lanes
from . import scalar as _scalar
from .common import Scratch, new_scratch
from .large import EXPLICIT_EULER, SERIAL_MAX_BALLS, SYMPLECTIC_EULER
from .large_spin import SERIAL_MAX_SPIN_BALLS
from .neighbour_lists import NeighbourLists

__all__ = [
    "PATHS",
    "PARALLEL_MIN_WORK",
    "thread_count",
    "max_threads",
    "set_thread_count",
    "pool",
    "split",
    "dispatch",
    "Runner",
    "Physics",
    "LanesPhysics",
    "advance",
]

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


_THREADS: int | None = None  # set_thread_count's limit (None: max_threads())


def max_threads() -> int:
    """Numba's ``NUMBA_NUM_THREADS`` (default: the CPU count): the most threads a call may use."""
    return max(1, int(numba.config.NUMBA_NUM_THREADS))


def thread_count() -> int:
    """The threads a batch is split over: :func:`max_threads`, or fewer after
    :func:`set_thread_count`."""
    top = max_threads()
    return top if _THREADS is None else min(_THREADS, top)


def set_thread_count(threads: int | None) -> None:
    """Split the batches of later calls over at most ``threads`` threads (1: every call runs on
    the calling thread); None: :func:`max_threads` again. Results do not depend on it (each world
    is stepped serially within its part); a vector env made before keeps its split, which
    :func:`dispatch` runs on the caller alone when no helper is free."""
    global _THREADS
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise ValueError(f"the thread count must be None or an integer >= 1, got {threads!r}")
    _THREADS = threads


def buffer_threads() -> int:
    """How many per-thread buffers a World or env allocates: enough for any split
    (:func:`thread_count` may be raised up to :func:`max_threads` after it was made)."""
    return max(thread_count(), max_threads())


def pool() -> ThreadPoolExecutor:
    """The process's thread pool (made on first use; a forked child makes its own)."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max_workers=max_threads(), thread_name_prefix="penalty_env")
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
    """Call ``fn(*args)`` for each entry and return the results in order: inline when there is
    one; else the calling thread and ``len(arg_lists) - 1`` helpers of the pool take the entries
    one by one (the kernels release the GIL).

    The caller does not wait for a helper to start: an entry no helper has taken by the time the
    caller is free, the caller runs itself. On an idle machine the helpers start within
    microseconds and the entries run in parallel; on a machine whose cores are busy with other
    jobs a woken helper may wait a whole scheduler time slice (milliseconds) for a core, and the
    caller then runs the batch serially instead of waiting for it (measured in training: the
    physics 5x slower than alone beside two busy loops when every entry went to the pool and the
    caller waited). The caller waits only for entries a helper has started. An exception is raised
    after every entry has run (the first entry's, in order)."""
    n = len(arg_lists)
    if n == 1:
        return [fn(*arg_lists[0])]
    results: list = [None] * n
    errors: list[BaseException | None] = [None] * n
    lock = threading.Lock()
    finished = threading.Condition(lock)
    state = [0, 0]  # the next entry to take; entries a helper has taken and not finished

    def work(helper: bool) -> None:
        while True:
            with lock:
                i = state[0]
                if i >= n:
                    return
                state[0] = i + 1
                state[1] += helper
            try:
                results[i] = fn(*arg_lists[i])
            except BaseException as exc:  # raised by the caller, after every entry ran
                errors[i] = exc
            finally:
                if helper:
                    with lock:
                        state[1] -= 1
                        if not state[1]:
                            finished.notify_all()

    helpers = pool()
    for _ in range(n - 1):
        helpers.submit(work, True)
    work(False)
    with lock:
        while state[1]:
            finished.wait()
    for exc in errors:
        if exc is not None:
            raise exc
    return results


class Physics(NamedTuple):
    """What the scalar path steps (the runner's buffers): state, integrator scratch, control,
    broad phase, model, rotation (a :class:`~..model.Spin` or None), gravity (a tuple: the
    dimension), the step and the per-world status."""

    x: np.ndarray
    v: np.ndarray
    work: Any
    control: Control
    grid: Any
    scratch: Scratch
    model: Model
    spin: Any
    g: tuple
    dt: float
    status: np.ndarray


class LanesPhysics(NamedTuple):
    """What the SIMD-lanes path steps (symplectic or explicit Euler, all pairs), and the scratch of
    the world's scalar passes (its diagnostics; ``grid`` is None: every pair is tested)."""

    x: np.ndarray
    v: np.ndarray
    symplectic: bool
    control: Control
    grid: Any
    scratch: Scratch
    model: Model
    g: tuple
    dt: float
    status: np.ndarray


def advance(phys, worlds, nsteps, lane_scratch):
    """Step the listed worlds ``nsteps`` steps on the runner's path (jitted code only): the lanes
    path with this thread's ``lane_scratch``, or the scalar path. Returns how many blew up."""
    raise NotImplementedError("advance is called from jitted code")


@overload_kernel(advance)
def _advance(phys, worlds, nsteps, lane_scratch):
    if phys.instance_class is LanesPhysics:

        def lanes(phys, worlds, nsteps, lane_scratch):
            p = phys
            return _lanes.run_lanes(
                p.symplectic, worlds, nsteps, p.dt, p.x, p.v, lane_scratch, p.control, p.model, p.g, p.status
            )

        return lanes

    def scalar(phys, worlds, nsteps, lane_scratch):
        p = phys
        return _scalar.run_worlds(
            worlds, nsteps, p.dt, p.x, p.v, p.work, p.control, p.grid, p.scratch, p.model, p.spin, p.g, p.status
        )

    return scalar


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
        model: Model,
        state: State,
        work: Any,
        grid: Any,
        control: Control,
        status: np.ndarray,
        dt: float,
        g: tuple,
        spin: Spin | None = None,
    ) -> None:
        B, n, d = state.positions.shape
        self.path = path
        self.integrator = integrator
        self.events = events
        self.model = model
        self.state = state
        self.work = work
        self.grid = grid
        self.control = control
        self.status = status
        self.dt = dt
        self.g = g
        self.spin = spin
        self.all_worlds = np.arange(B, dtype=np.int64)
        self.scratch = new_scratch(B, n, d)
        self.event_buffers = _events.allocate(B, n, d) if events else None
        per_world = isinstance(model.ks, np.ndarray)  # (then a lanes scratch has parameter rows too)
        motors = model.motors.ball.shape[0] if per_world else None
        threads = buffer_threads()
        self.lane_scratch = _lanes.new_lane_scratch(threads, n, d, motors) if path == "lanes" else None
        self.lists = NeighbourLists(model, B, n, d, threads, spin) if path == "neighbour_list" else None
        if path == "lanes":
            sym = integrator == "symplectic_euler"
            # (no grid: the lanes test every pair, and the diagnostics compile no grid code)
            self.physics: Any = LanesPhysics(
                state.positions, state.velocities, sym, control, None, self.scratch, model, g, dt, status
            )
        else:
            self.physics = Physics(
                state.positions, state.velocities, work, control, grid, self.scratch, model, spin, g, dt, status
            )
        self._entry: Callable | None = None  # the path's compiled step kernel

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_entry"] = None  # compiled code: found again (cached) on first use after unpickling
        return state

    def forget(self, worlds: Any = slice(None), end_history: bool = False) -> None:
        """Drop what was derived from the state of ``worlds`` (velocity Verlet's cached acceleration,
        a neighbour list and its storage order), after the state was written; ``end_history``
        (new positions) also ends the list's tangential springs (the stamped tables end by the
        spin clock)."""
        if hasattr(self.work, "a0_valid"):
            self.work.a0_valid[worlds] = False
        if self.lists is not None:
            self.lists.reset(worlds, end_history)

    def step(self, n: int, worlds: np.ndarray | None = None) -> int:
        """Advance the listed worlds (default: all) by n steps of dt. Returns how many blew up."""
        worlds = self.all_worlds if worlds is None else worlds
        B, balls = self.state.positions.shape[:2]
        if self.path == "neighbour_list":
            self._step_lists(n, worlds)
            return 0
        if self.path == "lanes":
            chunks = [c for c in split(worlds, balls * n) if len(c)]
            if len(worlds) == B and len(chunks) > 1:  # whole blocks of LANES worlds per thread
                chunks = [worlds[b0:b1] for b0, b1 in split(B, balls * n, align=_lanes.LANES)]
            calls = [(self.physics, c, n, self.lane_scratch[t]) for t, c in enumerate(chunks)]
            fn = run_path
        elif self.events:
            calls = [(c, n, self.dt) + self._event_tail() for c in split(worlds, balls * n) if len(c)]
            fn = _events.run_worlds
        else:
            calls = [(self.physics, c, n, self.lane_scratch) for c in split(worlds, balls * n) if len(c)]
            fn = run_path
        if self._entry is None:
            with compile_notice(f"{self.path} {self.integrator} step"):
                self._entry = entry_point(fn, calls[0])
        return sum(dispatch(self._entry, calls))

    def _event_tail(self) -> tuple:
        x, v = self.state
        ev = self.event_buffers
        return (x, v, self.work, self.control, self.grid, self.scratch, self.model, self.spin, self.g, ev, self.status)

    def _step_lists(self, n: int, worlds: np.ndarray) -> None:
        x, v = self.state
        integ = SYMPLECTIC_EULER if self.integrator == "symplectic_euler" else EXPLICIT_EULER
        has_ext = bool(self.control.flags[0])
        args = (integ, n, self.dt, x, v, self.control.forces, has_ext, self.g, self.status)
        lists = self.lists
        assert lists is not None
        threads = thread_count()
        B, balls = x.shape[:2]
        if len(worlds) >= threads and len(worlds) > 1:
            # a batch: a share of the worlds per thread, each world serial on its own list (no
            # parallel region; round robin, so a batch of equal worlds splits evenly)
            parts = [worlds[t::threads] for t in range(min(threads, len(worlds)))]
            dispatch(lambda part: lists.step(*args, worlds=part, serial=True), [(p,) for p in parts])
        elif (
            threads == 1
            or balls < (SERIAL_MAX_SPIN_BALLS if lists.spins else SERIAL_MAX_BALLS)
            or numba.get_num_threads() == 1
        ):
            # no parallel region: its launch costs more than it saves (and with
            # numba.set_num_threads(1) it saves nothing: 75 against 86 ns a ball-step at 10^4, measured)
            lists.step(*args, worlds=worlds, serial=True)
        else:
            with PARALLEL_LOCK:
                lists.step(*args, worlds=worlds)


@njit(entry=True, nogil=True)
def run_path(phys, worlds, nsteps, lane_scratch):
    """:func:`advance` as a kernel of its own: what ``Runner.step`` calls (per thread)."""
    return advance(phys, worlds, nsteps, lane_scratch)
