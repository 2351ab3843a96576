"""``--threads auto``: torch's thread count from what else runs on the machine (train/_threads.py),
on a scripted probe: 2 while nothing else runs, 1 while something does, each change recorded."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "train"))

import _threads as TH  # noqa: E402


def _policy(samples, requested="auto", n_cpus=2):
    feed = iter(samples)
    calls = []
    policy = TH.TorchThreads(requested, probe=lambda: next(feed), set_threads=calls.append, n_cpus=n_cpus)
    return policy, calls


def test_auto_takes_two_threads_on_an_idle_machine_and_keeps_them():
    policy, calls = _policy([0.0] * TH.START_SAMPLES + [0.0] * 20)
    assert policy.start() == 2
    for _ in range(20):
        policy.before_update()
    assert calls == [2] and policy.record() == {
        "torch": 2,
        "torch_setting": "auto",
        "torch_init": 2,
        "torch_schedule": [[0, 2]],
        "others_runnable_at_start": 0.0,
    }


@pytest.mark.parametrize("others", [1.0, 2.0])
def test_auto_takes_one_thread_beside_other_work(others):
    """A second run started at the same time (one other task), or two busy loops."""
    policy, calls = _policy([others] * (TH.START_SAMPLES + 5))
    assert policy.start() == 1
    for _ in range(5):
        policy.before_update()
    assert calls == [1]


def test_auto_steps_down_when_work_arrives_and_up_when_it_has_gone():
    quiet, busy = [0.0] * TH.START_SAMPLES + [0.0] * 4, [1.0] * 6
    policy, calls = _policy(quiet + busy + [0.0] * 12)
    policy.start()
    for _ in range(4 + 6 + 12):
        policy.before_update()
    schedule = policy.record()["torch_schedule"]
    assert calls == [2, 1, 2] and [t for _, t in schedule] == [2, 1, 2]
    down, up = schedule[1][0], schedule[2][0]
    assert 4 < down <= 4 + TH.DOWN_WINDOW  # within a window of the first busy sample
    assert 4 + 6 + TH.UP_WINDOW - 1 <= up <= 4 + 6 + TH.UP_WINDOW  # after a whole quiet window
    assert policy.record()["torch"] == [2, 1, 2]


def test_a_brief_blip_does_not_step_down():
    policy, calls = _policy([0.0] * TH.START_SAMPLES + [0.0, 1.0, 0.0, 0.0, 0.0])
    policy.start()
    for _ in range(5):
        policy.before_update()
    assert calls == [2]


def test_a_count_is_fixed_whatever_the_load_and_one_cpu_means_one_thread():
    policy, calls = _policy([5.0] * 10, requested=2)
    policy.start()
    for _ in range(5):
        policy.before_update()
    assert calls == [2] and policy.record() == {"torch": 2, "torch_setting": 2, "torch_init": 2}
    policy, calls = _policy([0.0] * (TH.START_SAMPLES + 3), n_cpus=1)
    assert policy.start() == 1


def test_runnable_others_reads_this_machine():
    value = TH.runnable_others()
    assert value is None or value >= 0.0
    assert TH.parse("auto") == "auto" and TH.parse("3") == 3 and TH.parse(1) == 1
    for bad in ("x", 0, True, -2):
        with pytest.raises(ValueError):
            TH.parse(bad)


@pytest.mark.parametrize("requested, run, init", [("auto", 1, 2), (1, 1, 1), (3, 3, 3)])
def test_the_policy_is_built_on_the_settings_threads_not_the_runs(requested, run, init):
    """The initial weights depend on torch's threads: ``auto`` builds on 2 whatever it runs on
    (so it equals ``--threads 2``), a count on itself."""
    policy, calls = _policy([2.0] * (TH.START_SAMPLES + 2), requested=requested, n_cpus=2)
    assert policy.start() == run
    with policy.building():
        assert calls[-1] == init
    assert calls[-1] == run and policy.record()["torch_init"] == init
