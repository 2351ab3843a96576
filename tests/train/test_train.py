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
# the sand run after its PenaltyBalls-v1 run (docs/granular.md, "PPO through sand")
V1_SEEDS = (0, 1, 2)  # the sand curriculum: the best of these v1 runs starts the sand run
SAND_ARGS = ["--gamma", 0.99, "--learning-rate", 3e-4, "--timesteps", 2_000_000, "--eval-freq", 100_000]


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
    for opt in (
        "--env-id",
        "--timesteps",
        "--n-envs",
        "--seed",
        "--out",
        "--tensorboard",
        "--env-kwarg",
        "--init-from",
    ):
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


def test_init_from_starts_where_the_earlier_run_left_off_and_refuses_what_does_not_fit(tmp_path):
    """``--init-from``: the sand env's policy starts as the earlier (v1) run's policy acts on the
    21 entries they share, whatever its height map says (the extra inputs' weights start at
    zero); the shared normalisation statistics are carried over with a weight of
    INIT_STATS_COUNT samples; a 2D run cannot start a 3D one, nor a missing folder anything."""
    import numpy as np
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    sys.path.insert(0, str(ROOT / "train"))
    import _common as C
    import train_ppo as T

    def model_on(env_id, seed):
        venv = VecNormalize(C.make_env(env_id, 2, seed, {}), gamma=0.99)
        return PPO("MlpPolicy", venv, n_steps=8, batch_size=16, seed=seed, device="cpu"), venv

    old, old_norm = model_on("PenaltyBalls-v1", 0)
    rng = np.random.default_rng(0)
    old_norm.obs_rms.mean[:] = rng.normal(size=21)
    old_norm.obs_rms.var[:] = rng.uniform(0.5, 2.0, 21)
    src = tmp_path / "v1"
    src.mkdir()
    old.save(src / "model.zip")
    old_norm.save(str(src / "vecnormalize.pkl"))

    new, new_norm = model_on("PenaltyBallsSand-v1", 1)
    obs = rng.normal(size=(5, 21 + 25)).astype(np.float32)
    with torch.no_grad():
        before = new.policy.get_distribution(torch.as_tensor(obs)).distribution.mean.numpy()
    T.init_from(new, new_norm, src)
    with torch.no_grad():
        after = new.policy.get_distribution(torch.as_tensor(obs)).distribution.mean.numpy()
        other = obs.copy()
        other[:, 21:] = rng.normal(size=(5, 25))  # another height map: the same action
        after2 = new.policy.get_distribution(torch.as_tensor(other)).distribution.mean.numpy()
        ref = old.policy.get_distribution(torch.as_tensor(obs[:, :21])).distribution.mean.numpy()
        v_new = new.policy.predict_values(torch.as_tensor(obs)).numpy()
        v_ref = old.policy.predict_values(torch.as_tensor(obs[:, :21])).numpy()
    assert not np.allclose(before, ref)
    np.testing.assert_allclose(after, ref, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(after, after2)
    np.testing.assert_allclose(v_new, v_ref, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(new_norm.obs_rms.mean[:21], old_norm.obs_rms.mean)
    np.testing.assert_array_equal(new_norm.obs_rms.var[:21], old_norm.obs_rms.var)
    assert not new_norm.obs_rms.mean[21:].any() and (new_norm.obs_rms.var[21:] == 1.0).all()
    assert new_norm.obs_rms.count == new_norm.ret_rms.count == T.INIT_STATS_COUNT

    flat, _ = model_on("PenaltyBalls2D-v1", 2)
    with pytest.raises(ValueError, match=r"init_from=.*action space"):
        T.init_from(flat, None, src)
    raw, _ = model_on("PenaltyBallsSand-v1", 3)
    with pytest.raises(ValueError, match=r"init_from=.*with VecNormalize, this one without"):
        T.init_from(raw, None, src)
    with pytest.raises(ValueError, match=r"'init_from'.*model\.zip.*nowhere"):
        T.check_settings({"init_from": str(tmp_path / "nowhere")})


@pytest.mark.slow
def test_the_sand_curriculum_reaches_80_percent_within_30_minutes(tmp_path):
    """docs/granular.md's sand run: PPO on PenaltyBalls-v1 (the default settings) with seeds 0, 1 and 2,
    then PPO on PenaltyBallsSand-v1 from the one that succeeded most on its own held-out v1
    episodes: at least 80% of 100 held-out sand episodes, all four runs together within 30
    minutes of training on 2 cores, where a random policy fails."""
    firsts = []
    for seed in V1_SEEDS:
        out = tmp_path / f"v1-seed{seed}"
        _run(
            [TRAIN, "--env-id", "PenaltyBalls-v1", "--seed", seed, "--no-progress", "--no-gif", "--out", out],
            timeout=15 * 60,
        )
        firsts.append((json.loads((out / "summary.json").read_text()), out))
    best = max(firsts, key=lambda f: f[0]["success_rate"])[1]
    sand = tmp_path / "sand"
    _run(
        [
            TRAIN,
            "--env-id",
            "PenaltyBallsSand-v1",
            "--init-from",
            best,
            *SAND_ARGS,
            "--no-progress",
            "--no-gif",
            "--out",
            sand,
        ],
        timeout=40 * 60,
    )
    second = json.loads((sand / "summary.json").read_text())
    assert second["init_from"] == str(best)
    assert sum(f[0]["wall_time_s"] for f in firsts) + second["wall_time_s"] <= 30 * 60
    assert second["eval_episodes"] == 100
    assert second["success_rate"] >= 0.8, second
    assert second["random_success_rate"] <= 0.2, second
