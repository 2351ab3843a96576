"""The training script end to end: a short PPO run saves a run folder that evaluate.py reloads."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TRAIN = ROOT / "train" / "train_ppo.py"
EVALUATE = ROOT / "train" / "evaluate.py"

pytest.importorskip("stable_baselines3")


def _run(args, timeout):
    res = subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-4000:]
    return res.stdout


def test_training_smoke_run_saves_reloads_and_evaluates(tmp_path):
    out = tmp_path / "run"
    _run(
        [
            TRAIN,
            "--timesteps",
            4096,
            "--n-envs",
            8,
            "--n-steps",
            256,
            "--batch-size",
            512,
            "--eval-freq",
            2048,
            "--eval-episodes",
            8,
            "--final-episodes",
            16,
            "--no-progress",
            "--out",
            out,
        ],
        timeout=600,
    )
    for name in (
        "model.zip",
        "vecnormalize.pkl",
        "learning_curve.png",
        "policy.gif",
        "summary.json",
        "evaluations.csv",
    ):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    for key in (
        "timesteps",
        "wall_time_s",
        "env_steps_per_s",
        "success_rate",
        "mean_return",
        "random_success_rate",
        "random_mean_return",
    ):
        assert key in summary, key
    assert summary["timesteps"] >= 4096
    assert summary["eval_episodes"] == 16
    assert 0.0 <= summary["success_rate"] <= 1.0 and 0.0 <= summary["random_success_rate"] <= 1.0
    assert len(summary["curve"]) == 2  # evaluations at 2048 and 4096 steps
    text = _run([EVALUATE, out, "--episodes", 10, "--n-envs", 5], timeout=300)
    assert "success" in text and "random policy" in text


def test_help_documents_the_options():
    text = _run([TRAIN, "--help"], timeout=120)
    for opt in ("--env-id", "--timesteps", "--n-envs", "--seed", "--out", "--tensorboard", "--env-kwarg"):
        assert opt in text


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_default_run_reaches_80_percent_success_on_held_out_seeds(tmp_path, seed):
    """The README's main job: the default run succeeds on >= 80% of 100 held-out episodes
    within 15 minutes, while a random policy mostly fails."""
    out = tmp_path / f"seed{seed}"
    _run([TRAIN, "--seed", seed, "--no-progress", "--no-gif", "--out", out], timeout=15 * 60 + 120)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["wall_time_s"] <= 15 * 60
    assert summary["eval_episodes"] == 100
    assert summary["success_rate"] >= 0.8, summary
    assert summary["random_success_rate"] <= 0.2, summary
