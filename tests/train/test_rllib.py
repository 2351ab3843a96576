"""train/rllib_ppo.py: RLlib's PPO trains on the native vector env (its vector entry point) in a
remote env runner, and is scored on train_ppo.py's held-out seeds."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RLLIB = ROOT / "train" / "rllib_ppo.py"

pytest.importorskip("ray.rllib")
pytest.importorskip("stable_baselines3")


def test_rllib_ppo_trains_two_iterations_on_the_vector_env_and_reports(tmp_path):
    out = tmp_path / "run"
    args = ["--timesteps", "4096", "--num-envs", "8", "--n-steps", "256", "--batch-size", "512"]
    args += ["--num-env-runners", "1", "--final-episodes", "16", "--num-cpus", "2", "--object-store-mb", "100"]
    res = subprocess.run(
        [sys.executable, str(RLLIB), *args, "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-5000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["iterations"] == 2 and summary["timesteps"] == 4096  # 8 worlds x 256 steps per iteration
    assert summary["num_env_runners"] == 1 and summary["env_steps_per_s"] > 0
    assert summary["eval_episodes"] == 16
    assert 0.0 <= summary["success_rate"] <= 1.0 and 0.0 <= summary["random_success_rate"] <= 1.0
    assert summary["eval_seeds"].startswith("2000000..")  # train_ppo.py's held-out seeds
    assert "[iter 2]" in res.stdout and "success" in res.stdout
    assert len((out / "iterations.csv").read_text().splitlines()) == 3
