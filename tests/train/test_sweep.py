"""train/sweep.py: a small local Ray Tune sweep equals serial train_ppo.py runs, a trial whose
worker is killed is retried and completes, a stopped sweep resumes, and bad specs are refused."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TRAIN = ROOT / "train" / "train_ppo.py"
SWEEP = ROOT / "train" / "sweep.py"

pytest.importorskip("stable_baselines3")

# a few thousand env steps: two evaluations during training, 16 held-out episodes at the end
TINY = {
    "timesteps": 4096,
    "n_envs": 8,
    "n_steps": 256,
    "batch_size": 512,
    "eval_freq": 2048,
    "eval_episodes": 8,
    "final_episodes": 16,
}
RUN_FILES = ("model.zip", "vecnormalize.pkl", "learning_curve.png", "evaluations.csv", "summary.json")
LOCAL_RAY = ["--num-cpus", "2", "--object-store-mb", "100"]


def _load_sweep():
    spec = importlib.util.spec_from_file_location("penalty_env_train_sweep", SWEEP)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _serial(seed: int, out: Path) -> subprocess.Popen:
    """train_ppo.py with the sweep's settings, on one torch thread and one Numba thread (a trial of 1 CPU)."""
    args = [sys.executable, str(TRAIN), "--seed", str(seed), "--out", str(out), "--no-gif", "--no-progress"]
    for key, value in TINY.items():
        args += [f"--{key.replace('_', '-')}", str(value)]
    args += ["--threads", "1", "--numba-threads", "1"]
    return subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _sweep_args(out: Path, *extra: str) -> list[str]:
    args = [sys.executable, str(SWEEP), "--seeds", "0,1", "--no-gif", "--out", str(out), *LOCAL_RAY, *extra]
    for key, value in TINY.items():
        args += ["--set", f"{key}={value}"]
    return args


def _alive(pid: int) -> bool:
    """A running process (a zombie, dead but not yet reaped, counts as gone)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        return " Z " not in Path(f"/proc/{pid}/stat").read_text().split(")", 1)[1][:3]
    except OSError:
        return False


def _without_timings(summary: dict) -> dict:
    timings = ("wall_time_s", "train_time_s", "env_steps_per_s", "time_split")
    s = {k: v for k, v in summary.items() if k not in timings}
    s["curve"] = [{k: v for k, v in c.items() if k not in timings} for c in summary["curve"]]
    return s


def _wait(proc: subprocess.Popen, timeout: float) -> str:
    try:
        text, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        text, _ = proc.communicate()
        raise AssertionError(f"timed out:\n{text[-4000:]}") from None
    assert proc.returncode == 0, text[-6000:]
    return text


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """One two-trial sweep (seeds 0 and 1, one CPU each, both at once on a local 2-CPU cluster)
    whose seed-1 trial kills its own worker after its first evaluation, and the two serial runs
    it must reproduce, all started together."""
    pytest.importorskip("ray")
    tmp = tmp_path_factory.mktemp("sweep")
    kill_dir = tmp / "kill"
    kill_dir.mkdir()
    env = {**os.environ, "PENALTY_ENV_SWEEP_KILL_ONCE": f"1@{kill_dir}"}
    sweep = subprocess.Popen(
        _sweep_args(tmp / "out", "--max-failures", "1"),
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    serial = {seed: _serial(seed, tmp / f"serial{seed}") for seed in (0, 1)}
    for proc in serial.values():
        _wait(proc, 600)
    text = _wait(sweep, 600)
    return {"out": tmp / "out", "serial": {s: tmp / f"serial{s}" for s in serial}, "kill": kill_dir, "log": text}


@pytest.mark.slow
def test_two_trial_sweep_equals_serial_train_ppo_runs(swept):
    out = swept["out"]
    for seed in (0, 1):
        run = out / "runs" / f"c0_default_seed{seed}"
        for name in RUN_FILES:  # train_ppo.py's run folder
            assert (run / name).stat().st_size > 0, (seed, name)
        trial = json.loads((run / "summary.json").read_text())
        serial = json.loads((swept["serial"][seed] / "summary.json").read_text())
        assert trial["seed"] == seed and len(trial["curve"]) == 2
        assert _without_timings(trial) == _without_timings(serial), seed
    with open(out / "trials.csv") as f:
        trials = list(csv.DictReader(f))
    assert sorted(int(t["seed"]) for t in trials) == [0, 1]
    with open(out / "summary.csv") as f:
        (row,) = list(csv.DictReader(f))
    serial_success = [json.loads((swept["serial"][s] / "summary.json").read_text())["success_rate"] for s in (0, 1)]
    assert int(row["seeds"]) == 2
    assert float(row["success_mean"]) == pytest.approx(sum(serial_success) / 2, abs=1e-3)
    assert "| default | 2 |" in (out / "summary.md").read_text()
    assert (out / "success_vs_steps.png").stat().st_size > 5_000


@pytest.mark.slow
def test_a_killed_trial_is_retried_and_completes(swept):
    kill = swept["kill"]
    marker = kill / "c0_default_seed1.killed"
    assert marker.exists(), "the seed-1 trial was never killed"
    killed_pid = int(marker.read_text())
    attempts = [int(p) for p in (kill / "c0_default_seed1.attempts").read_text().split()]
    assert len(attempts) == 2 and attempts[0] == killed_pid and attempts[1] != killed_pid, attempts
    assert not _alive(killed_pid)  # the first worker is gone
    assert not (kill / "c0_default_seed0.attempts").exists()  # the other trial was left alone
    assert "ActorDiedError" in swept["log"]  # Tune saw the worker die ...
    assert (swept["out"] / "runs" / "c0_default_seed1" / "summary.json").exists()  # ... and the retry finished


@pytest.mark.slow
def test_a_stopped_sweep_resumes_and_runs_only_the_unfinished_trials(tmp_path):
    """Ctrl+C (SIGINT) after the first of two trials (one at a time) finished; --resume runs the other one only."""
    pytest.importorskip("ray")
    out = tmp_path / "out"
    proc = subprocess.Popen(
        _sweep_args(out, "--max-concurrent", "1"), cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    done = out / "tune" / "sweep" / "c0_default_seed0" / "checkpoint_000000" / "summary.json"
    deadline = time.monotonic() + 300
    while not done.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    assert done.exists(), "the first trial did not finish"
    proc.send_signal(signal.SIGINT)
    text, _ = proc.communicate(timeout=120)
    assert proc.returncode == 1, text[-4000:]  # stopped with a trial unfinished
    assert "--resume" in text
    assert not (out / "runs" / "c0_default_seed1").exists()
    first = (out / "runs" / "c0_default_seed0" / "summary.json").read_text()
    res = subprocess.run(
        [sys.executable, str(SWEEP), "--resume", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stdout[-4000:] + res.stderr[-4000:]
    log = res.stdout + res.stderr
    assert log.count("training PPO") == 1 and "seed 1" in log  # only the unfinished trial ran again
    assert (out / "runs" / "c0_default_seed0" / "summary.json").read_text() == first
    assert (out / "runs" / "c0_default_seed1" / "summary.json").exists()


# --- bad input: refused before Ray starts, naming the entry, its value and what is allowed ---------


@pytest.mark.parametrize(
    "spec, words",
    [
        ({"grid": {"lr": [1e-3]}}, ["unknown setting 'lr'", "[0.001]", "learning_rate"]),
        ({"settings": {"gamma": 1.5}}, ["'gamma'", "(0, 1]", "1.5"]),
        ({"grid": {"n_epochs": 5}}, ["grid", "'n_epochs'", "non-empty list", "5"]),
        ({"grid": {"env_kwargs.restitution_accuracy": [0.9]}}, ["restitution_accuracy", "0.9", "[0.05, 0.5]"]),
        ({"grid": {"env_kwargs.bounciness": [1]}}, ["'bounciness'", "restitution_accuracy"]),
        ({"random": {"learning_rate": {"normal": [0, 1]}}}, ["'normal'", "loguniform"]),
        ({"random": {"learning_rate": {"loguniform": [0, 1]}}}, ["loguniform", "low > 0", "[0, 1]"]),
        ({"seeds": [0, -1]}, ["seeds", "-1", ">= 0"]),
        ({"cpus_per_trial": 0}, ["cpus_per_trial", ">= 1", "0"]),
        ({"trials": 3}, ["unknown sweep key 'trials'", "3", "seeds"]),
    ],
)
def test_bad_specs_are_refused_with_the_entry_its_value_and_the_allowed_range(spec, words):
    sweep = _load_sweep()
    with pytest.raises(ValueError) as err:
        sweep.configurations(sweep.check_spec(spec))
    for word in words:
        assert word in str(err.value), (word, str(err.value))


def test_command_line_and_yaml_specs(tmp_path):
    pytest.importorskip("yaml")
    sweep = _load_sweep()
    path = tmp_path / "lr.yaml"
    path.write_text(
        "seeds: [0, 1, 2]\n"
        "settings: {timesteps: 10000}\n"
        "grid: {env_kwargs.restitution_accuracy: [0.3, 0.1]}\n"
        "random: {learning_rate: {loguniform: [1.0e-4, 1.0e-2]}}\n"
        "num_samples: 2\n"
    )
    args = sweep.build_parser().parse_args(["--config", str(path), "--grid", 'net_arch=["64,64","128"]'])
    spec = sweep.check_spec(sweep.spec_from_args(args))
    assert spec["name"] == "lr" and spec["seeds"] == [0, 1, 2]
    configs = sweep.configurations(spec)
    assert len(configs) == 2 * 2 * 2  # restitution_accuracy x net_arch x two draws of the learning rate
    assert {c["settings"]["net_arch"] for c in configs} == {"64,64", "128"}
    rates = {c["settings"]["learning_rate"] for c in configs}
    assert len(rates) == 2 and all(1e-4 <= r <= 1e-2 for r in rates)
    assert configs == sweep.configurations(spec)  # the draws are seeded (search_seed)
    assert all(c["settings"]["timesteps"] == 10000 for c in configs)
    names = {sweep.trial_name(c, 0) for c in configs}
    assert len(names) == len(configs)
    path.write_text("seeds: [0]\nepochs: 3\n")
    args = sweep.build_parser().parse_args(["--config", str(path)])
    with pytest.raises(ValueError, match="unknown sweep key 'epochs'"):
        sweep.check_spec(sweep.spec_from_args(args))
    for bad, words in (
        (["--grid", "n_epochs"], ["--grid", "KEY=VALUE", "'n_epochs'"]),
        (["--seeds", "0,x"], ["--seeds", "'0,x'"]),
        (["--random", "gamma=0.9"], ["--random", "DISTRIBUTION", "'gamma=0.9'"]),
    ):
        with pytest.raises(ValueError) as err:
            sweep.spec_from_args(sweep.build_parser().parse_args(bad))
        for word in words:
            assert word in str(err.value), (word, str(err.value))
