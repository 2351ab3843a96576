"""rl-zoo3: its hyperparameter file is train/_tuned.py's table (train_ppo.py's defaults), and
rl-zoo3 trains a registered id with it."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

yaml = pytest.importorskip("yaml")
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "train"))

import _tuned  # noqa: E402


def test_zoo_file_is_the_tuned_table():
    assert _tuned.ZOO_FILE.read_text() == _tuned.zoo_yaml(), "run `python train/_tuned.py` to regenerate it"
    entries = yaml.safe_load(_tuned.ZOO_FILE.read_text())
    import gymnasium as gym

    import penalty_env  # noqa: F401

    # one entry per registered id (the goal-conditioned ids train with SAC + HER: train/train_her.py)
    registered = {k for k in gym.registry if k.startswith("Penalty") and not k.startswith("PenaltyBallsGoal")}
    assert set(entries) == registered
    for env_id, entry in entries.items():
        s = _tuned.TUNED[env_id]
        repeat = s["action_repeat"]  # (train_ppo.py counts decisions, rl-zoo3 env steps)
        assert entry["n_envs"] == s["n_envs"] and entry["n_steps"] == s["n_steps"] * repeat
        assert entry["n_timesteps"] == s["timesteps"] * repeat
        assert entry["learning_rate"] == f"lin_{s['learning_rate']!r}"
        assert entry["batch_size"] <= entry["n_envs"] * entry["n_steps"]  # SB3 needs a full minibatch


def test_train_ppo_defaults_are_the_tuned_settings():
    import train_ppo as T

    for env_id in _tuned.TUNED:
        s = T.check_settings({"env_id": env_id})
        for key, value in _tuned.TUNED[env_id].items():
            assert s[key] == value, (env_id, key)
    assert T.check_settings({"env_id": "PenaltyBalls-v1", "n_envs": 8, "n_steps": 256})["n_envs"] == 8  # overrides win


def test_rl_zoo3_trains_with_the_file(tmp_path):
    # (looked up, not imported: importing rl_zoo3 replaces gymnasium's TimeLimit with its own,
    # which adds an info key at truncation, for every later test in this process)
    if importlib.util.find_spec("rl_zoo3") is None:
        pytest.skip("rl_zoo3 is not installed")
    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "ppo",
        "--env",
        "PenaltyBalls-v0",
        "--gym-packages",
        "penalty_env",
        "-conf",
        str(_tuned.ZOO_FILE),
        "-n",
        "8192",
        "--eval-freq",
        "-1",
        "--seed",
        "0",
        "--log-folder",
        str(tmp_path),
    ]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    run = tmp_path / "ppo" / "PenaltyBalls-v0_1"
    assert (run / "PenaltyBalls-v0.zip").stat().st_size > 0
    assert (run / "PenaltyBalls-v0" / "vecnormalize.pkl").is_file()
    config = dict(yaml.unsafe_load((run / "PenaltyBalls-v0" / "config.yml").read_text()))
    tuned = _tuned.TUNED["PenaltyBalls-v0"]
    assert config["n_steps"] == tuned["n_steps"] and config["n_envs"] == tuned["n_envs"]
    assert config["batch_size"] == tuned["batch_size"] and config["n_epochs"] == tuned["n_epochs"]
