"""The runner's hand-off of a batch to its threads (``runner.dispatch``) and its thread limit
(``runner.set_thread_count``): plain Python, no kernel compiled.

* the calling thread works too, and runs any part no helper has started: a helper that never
  starts (a machine whose cores are busy) delays nothing;
* the results come back in order, whoever ran each part; an exception is raised after every part
  ran;
* ``set_thread_count`` lowers the split of later calls, never the buffers (sized for any split).
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

from penalty_env.physics.stepping import runner


class _NeverStarts:
    """A pool whose helpers never get a core: submitted work never runs."""

    def __init__(self) -> None:
        self.submitted = 0

    def submit(self, fn, *args):
        self.submitted += 1


def test_the_caller_runs_every_part_when_no_helper_starts(monkeypatch):
    stuck = _NeverStarts()
    monkeypatch.setattr(runner, "pool", lambda: stuck)
    ran_on = []

    def part(i):
        ran_on.append(threading.get_ident())
        return i * i

    assert runner.dispatch(part, [(i,) for i in range(4)]) == [0, 1, 4, 9]
    assert stuck.submitted == 3 and set(ran_on) == {threading.get_ident()}


def test_helpers_take_parts_and_the_results_keep_their_order():
    started = threading.Barrier(2, timeout=10)

    def part(i):
        if i < 2:
            started.wait()  # the first two parts run at once: on the caller and on a helper
        return threading.get_ident(), i

    out = runner.dispatch(part, [(i,) for i in range(5)])
    assert [i for _, i in out] == list(range(5))
    assert len({ident for ident, _ in out[:2]}) == 2


def test_an_exception_is_raised_after_every_part_ran(monkeypatch):
    monkeypatch.setattr(runner, "pool", lambda: _NeverStarts())
    ran = []

    def part(i):
        ran.append(i)
        if i in (1, 2):
            raise RuntimeError(f"part {i}")
        return i

    with pytest.raises(RuntimeError, match="part 1"):
        runner.dispatch(part, [(i,) for i in range(4)])
    assert ran == [0, 1, 2, 3]


def test_set_thread_count_limits_the_split_not_the_buffers(monkeypatch):
    monkeypatch.setattr(runner, "max_threads", lambda: 2)
    try:
        runner.set_thread_count(1)
        assert runner.thread_count() == 1 and runner.buffer_threads() == 2
        assert len(runner.split(np.arange(64), 10_000)) == 1
        runner.set_thread_count(8)  # above Numba's threads: capped
        assert runner.thread_count() == 2 and len(runner.split(np.arange(64), 10_000)) == 2
        for bad in (0, -1, 1.5, True, "2"):
            with pytest.raises(ValueError, match="thread count"):
                runner.set_thread_count(bad)  # type: ignore[arg-type]
    finally:
        runner.set_thread_count(None)
    assert runner.thread_count() == 2
