"""Torch's threads during a training run: ``--threads auto`` (the default), or a fixed count.

Why it matters (docs/training.md, "On a shared machine"). Torch runs its operations on OpenMP
threads, and each operation waits for all of them at its end. On an idle machine two threads make
the PPO update 21% (PenaltyBalls-v0) to 40% (v1) faster than one. When another process holds a
core, the waiting thread spins (OpenMP's default) while the one it waits for is not running, until
the scheduler runs it: beside two busy loops on 2 cores, 83% of a 2-thread run's CPU samples were
in libgomp's spin-wait, and 131,072 steps took 40 to 226 s against 4 to 11 s on one thread.
Letting the threads sleep instead (``OMP_WAIT_POLICY=PASSIVE``, ``GOMP_SPINCOUNT``) made the idle
run up to 45% slower and still did not keep two threads fast beside other jobs.

So ``auto`` uses :data:`IDLE_THREADS` (2) while nothing else runs on the machine, and 1 while
something does. It looks before the run (:data:`START_SAMPLES` samples) and again before every
PPO update (one sample each): the number of runnable tasks of the whole machine
(``/proc/loadavg``) less this process's own running threads. It steps down when the last
:data:`DOWN_WINDOW` samples average half a task or more, and back up when the last
:data:`UP_WINDOW` were all but free (:func:`decide`). Each change is recorded (``schedule``).

Numerics. Torch's thread count changes one thing in a run: the policy's initial weights (SB3's
orthogonal initialisation is a QR factorisation, which LAPACK rounds differently on 1 and 2
threads). The rollouts, the updates and the evaluations gave the same bits at 1 and 2 threads in
every configuration tried (v0; v1; 256 x 256 with minibatches of 4,096; 10 epochs), and
``tests/train/test_train.py`` checks it on every run of the tests. So the policy is built on
:meth:`TorchThreads.building`'s count: the setting's own for a count, :data:`IDLE_THREADS` for
``auto``. A run under ``auto`` then gives the same result bit for bit whatever the load and
whenever it changed threads: that of ``--threads 2``, the default before ``auto``. ``--threads 1``
gives another (equally good) result for the same seed, as it did before.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections import deque
from collections.abc import Callable, Iterator
from typing import Any

IDLE_THREADS = 2  # auto's threads on an idle machine (more were not measured)
START_SAMPLES = 10  # samples before the run, START_INTERVAL_S apart
START_INTERVAL_S = 0.01
DOWN_WINDOW = 3  # step down when the last this many samples average >= DOWN_AT other tasks
DOWN_AT = 0.6  # (2 of 3 samples with another task: a lone sample of one is a blip, 6% of them on an idle machine)
UP_WINDOW = 8  # step up when the last this many samples average < UP_BELOW
UP_BELOW = 0.1


def parse(value: Any) -> int | str:
    """A ``threads`` setting: ``"auto"`` or an integer >= 1 (ValueError otherwise)."""
    if value == "auto":
        return "auto"
    if isinstance(value, str) and value.strip().isdigit():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"setting 'threads' must be 'auto' or an integer >= 1, got {value!r}")
    return value


def cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _own_running() -> int:
    """This process's threads that are running or runnable right now."""
    own = 0
    for task in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{task}/stat") as f:
                stat = f.read()
        except OSError:  # the thread ended meanwhile
            continue
        own += stat[stat.rindex(")") + 2] == "R"
    return own


def runnable_others() -> float | None:
    """Tasks of other processes that are runnable right now: the machine's runnable tasks
    (``/proc/loadavg``'s fourth field) less this process's running threads, counted just before
    and just after (the larger count: one of its threads that starts or stops meanwhile is still
    its own). None where ``/proc`` is not there."""
    try:
        before = _own_running()
        with open("/proc/loadavg") as f:
            running = int(f.read().split()[3].split("/")[0])
        own = max(before, _own_running())
    except (OSError, IndexError, ValueError):
        return None
    return float(max(0, running - own))


def decide(threads: int, samples: list[float], most: int) -> int:
    """The thread count after ``samples`` (other runnable tasks, latest last) at ``threads``:
    down to what the others leave free (at least 1) when the last :data:`DOWN_WINDOW` average
    :data:`DOWN_AT` or more; up to ``most`` when the last :data:`UP_WINDOW` average below
    :data:`UP_BELOW`; else unchanged."""
    if threads > 1 and len(samples) >= DOWN_WINDOW:
        recent = sum(samples[-DOWN_WINDOW:]) / DOWN_WINDOW
        if recent >= DOWN_AT:
            return max(1, min(threads - 1, most - int(recent + 0.5)))
    if threads < most and len(samples) >= UP_WINDOW and sum(samples[-UP_WINDOW:]) / UP_WINDOW < UP_BELOW:
        return most
    return threads


class TorchThreads:
    """Sets torch's thread count for a run: fixed (``requested`` an integer) or ``"auto"`` (the
    module docstring). ``start()`` before the run, ``before_update()`` before each PPO update;
    ``record()`` is summary.json's entry. ``probe`` (default :func:`runnable_others`) and
    ``set_threads`` (default ``torch.set_num_threads``) are for tests."""

    def __init__(
        self,
        requested: int | str,
        probe: Callable[[], float | None] | None = None,
        set_threads: Callable[[int], None] | None = None,
        n_cpus: int | None = None,
    ) -> None:
        self.requested = parse(requested)
        self.auto = self.requested == "auto"
        self.cpus = cpus() if n_cpus is None else n_cpus
        self.most = max(1, min(IDLE_THREADS, self.cpus))
        self.probe = probe or runnable_others
        self._set = set_threads
        self.threads = 0
        self.samples: deque[float] = deque(maxlen=max(DOWN_WINDOW, UP_WINDOW))
        self.updates = 0
        self.schedule: list[list[int]] = []  # [update index, threads from that update on]
        self.others_at_start: float | None = None

    def _apply(self, threads: int) -> None:
        if threads != self.threads:
            self._set_torch(threads)
            self.threads = threads
            self.schedule.append([self.updates, threads])

    @property
    def init_threads(self) -> int:
        """The threads the policy is built on (its initial weights depend on them; the module
        docstring): the setting's own count, or :data:`IDLE_THREADS` under ``auto``."""
        return self.requested if isinstance(self.requested, int) else IDLE_THREADS

    @contextlib.contextmanager
    def building(self) -> Iterator[None]:
        """Build the policy inside: torch on :attr:`init_threads`, then back to the run's count."""
        run = self.threads
        self._set_torch(self.init_threads)
        try:
            yield
        finally:
            self._set_torch(run)

    def _set_torch(self, threads: int) -> None:
        if self._set is None:
            import torch

            torch.set_num_threads(threads)
        else:
            self._set(threads)

    def start(self) -> int:
        if not self.auto:
            assert isinstance(self.requested, int)
            self._apply(self.requested)
            return self.threads
        seen = []
        for i in range(START_SAMPLES):
            if i:
                time.sleep(START_INTERVAL_S)
            value = self.probe()
            if value is None:  # no /proc: the load average stands in (less sharp)
                load = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
                value = max(0.0, load - 1.0)
            seen.append(value)
        self.others_at_start = round(sum(seen) / len(seen), 2)
        free = self.cpus - self.others_at_start
        self._apply(self.most if free >= self.most - 0.25 else max(1, min(self.most - 1, int(free + 0.5))))
        self.samples.extend([self.others_at_start] * DOWN_WINDOW)
        return self.threads

    def before_update(self) -> None:
        if self.auto:
            value = self.probe()
            if value is not None:
                self.samples.append(value)
                self._apply(decide(self.threads, list(self.samples), self.most))
        self.updates += 1

    def record(self) -> dict[str, Any]:
        used = [t for _, t in self.schedule]
        out: dict[str, Any] = {
            "torch": used[0] if len(used) == 1 else used,
            "torch_setting": self.requested,
            "torch_init": self.init_threads,
        }
        if self.auto:
            out["torch_schedule"] = self.schedule
            out["others_runnable_at_start"] = self.others_at_start
        return out


def note(threads: int | str, n_cpus: int, load: float) -> str | None:
    """A warning for a fixed count of several torch threads where they will wait for each other:
    other jobs on the machine (a load average of at least 0.5 at the start) or fewer CPUs than
    threads. None when there is nothing to say."""
    if threads == "auto" or not isinstance(threads, int) or threads <= 1 or (load < 0.5 and threads <= n_cpus):
        return None
    return (
        f"note: torch on {threads} threads (--threads {threads}), with a load average of {load:.1f} on {n_cpus} CPUs: "
        "on a machine shared with other jobs each torch call waits for all its threads, and the run can take 10 to "
        "50 times as long; --threads auto (the default) steps down to 1 while others run"
    )
