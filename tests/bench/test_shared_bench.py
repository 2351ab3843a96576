"""bench shared's orchestration, on a stand-in training script (no torch, no kernels: a second):
the three situations of a round, the busy loops started and stopped, the runs on the checkout's own
package, the ratios and the files. Its timing targets are the benchmark's to check, not a test's."""

from __future__ import annotations

import json
import os
import textwrap

import pytest

from penalty_env.bench import shared as B

# a stand-in train/train_ppo.py: its "training time" says how many processes ran beside it (the
# busy loops and the other run of the pair), read from the files the runs and the spinners leave
_SCRIPT = textwrap.dedent(
    """
    import argparse, json, os, sys, time
    from pathlib import Path

    p = argparse.ArgumentParser()
    p.add_argument("--out", type=Path)
    p.add_argument("--seed", type=int)
    p.add_argument("--marker")
    args, _ = p.parse_known_args()
    args.out.mkdir(parents=True, exist_ok=True)
    import probe_pkg  # the checkout's own package: PYTHONPATH holds the checkout first
    summary = {
        "train_time_s": 1.0 + args.seed,
        "time_split": {"env_step_s": 0.1},
        "threads": {"torch": 1},
        "argv": sys.argv[1:],
        "package": probe_pkg.__file__,
    }
    (args.out / "summary.json").write_text(json.dumps(summary))
    """
)


def test_shared_bench_runs_the_three_situations_and_reports_the_ratios(tmp_path, capsys):
    checkout = tmp_path / "tree"
    (checkout / "train").mkdir(parents=True)
    (checkout / "train" / "train_ppo.py").write_text(_SCRIPT)
    (checkout / "probe_pkg").mkdir()
    (checkout / "probe_pkg" / "__init__.py").write_text("")
    out = tmp_path / "out"
    B.main(
        ["--checkout", str(checkout), "--out", str(out), "--rounds", "2", "--timesteps", "128"]
        + ["--train-args=--marker x"]
    )
    record = json.loads((out / "shared.json").read_text())
    assert len(record["rounds"]) == 2 and record["timesteps"] == 128
    for found in record["rounds"]:
        assert set(found) == {"alone", "two", "busy"}
        assert found["alone"]["train_time_s"] == [1.0] and found["busy"]["train_time_s"] == [1.0]
        assert found["two"]["train_time_s"] == [1.0, 2.0]  # seeds 0 and 1
        assert "load1" in found["alone"]["load_at_start"]
    assert record["ratios"] == {"two": [2.0, 2.0], "busy": [1.0, 1.0]}
    summary = json.loads((out / "round0" / "two" / "seed1" / "summary.json").read_text())
    assert summary["package"] == str(checkout / "probe_pkg" / "__init__.py")
    argv = summary["argv"]
    assert argv[argv.index("--timesteps") + 1] == "128" and argv[-2:] == ["--marker", "x"]
    text = capsys.readouterr().out
    assert "two runs together: median 2.00x one run alone (target <= 2.5x): met" in text
    assert "one run beside 2 busy loops: median 1.00x alone (target <= 3.0x): met" in text
    assert (out / "shared.md").read_text() in text


def test_the_busy_loops_are_stopped(tmp_path, monkeypatch):
    """The spinners end with the run, also when the run fails."""
    seen = []
    original = B.subprocess.Popen

    def popen(cmd, *args, **kwargs):
        proc = original(cmd, *args, **kwargs)
        if cmd[-1] == "while True: pass":
            seen.append(proc)
        return proc

    monkeypatch.setattr(B.subprocess, "Popen", popen)
    fail = [B.sys.executable, "-c", "import sys; sys.exit(3)", "--out", str(tmp_path)]
    with pytest.raises(SystemExit, match="failed"):
        B.run_together([fail], dict(os.environ), busy=2)
    assert len(seen) == 2 and all(p.poll() is not None for p in seen)


def test_ratios_are_per_round_against_that_rounds_run_alone():
    rounds = [
        {"alone": {"train_time_s": [2.0]}, "two": {"train_time_s": [3.0, 5.0]}, "busy": {"train_time_s": [4.0]}},
        {"alone": {"train_time_s": [4.0]}, "two": {"train_time_s": [4.0, 4.0]}, "busy": {"train_time_s": [14.0]}},
    ]
    assert B.ratios(rounds) == {"two": [2.5, 1.0], "busy": [2.0, 3.5]}


def test_torch_threads_as_recorded():
    assert B.torch_threads({"torch": 2}) == "2" and B.torch_threads({"torch": [2, 1, 2]}) == "2>1>2"
    assert B.torch_threads(None) == "?"  # a tree that does not record them
