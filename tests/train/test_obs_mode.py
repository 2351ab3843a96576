"""``train_ppo.py --obs-mode``: the observation mode picks the policy and what VecNormalize
normalises; bad modes are refused naming the setting; a short run from pixels completes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TRAIN = ROOT / "train" / "train_ppo.py"

pytest.importorskip("stable_baselines3")


def _train_module():
    sys.path.insert(0, str(ROOT / "train"))
    import train_ppo as T

    return T


def test_obs_mode_picks_the_policy_and_the_normalisation():
    T = _train_module()
    parse = T.build_parser().parse_args
    s = T.check_settings(T.settings_from_args(parse([])))
    assert s["obs_mode"] == "state" and T.policy_for(s["obs_mode"]) == ("MlpPolicy", {"norm_obs": True})
    s = T.check_settings(T.settings_from_args(parse(["--obs-mode", "rgb"])))
    assert T.policy_for(s["obs_mode"]) == ("CnnPolicy", {"norm_obs": False})  # uint8 pixels as they are
    s = T.check_settings(T.settings_from_args(parse(["--obs-mode", "state, heightmap,rgb"])))
    assert s["obs_mode"] == ("state", "heightmap", "rgb")
    assert T.policy_for(s["obs_mode"]) == (
        "MultiInputPolicy",
        {"norm_obs": True, "norm_obs_keys": ["state", "heightmap"]},
    )
    assert T.policy_for(("rgb",)) == ("MultiInputPolicy", {"norm_obs": False})
    with pytest.raises(ValueError, match=r"setting 'obs_mode'.*'pixels'"):
        T.check_settings({"obs_mode": "pixels"})
    with pytest.raises(ValueError, match="'obs_mode'.*not in env_kwargs"):
        T.check_settings({"env_kwargs": {"obs_mode": "rgb"}})


@pytest.mark.slow
def test_a_short_run_from_pixels_saves_a_cnn_policy(tmp_path):
    out = tmp_path / "rgb"
    args = ["--obs-mode", "rgb", "--env-kwarg", "rgb_size=36", "--timesteps", 1024, "--n-envs", 8, "--n-steps", 64]
    args += ["--batch-size", 128, "--eval-freq", 512, "--eval-episodes", 4, "--final-episodes", 4, "--quiet"]
    res = subprocess.run(
        [sys.executable, str(TRAIN), *map(str, args), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=ROOT,
    )
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-4000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["obs_mode"] == "rgb" and summary["timesteps"] == 1024
    from stable_baselines3 import PPO

    model = PPO.load(out / "model.zip", device="cpu")
    assert type(model.policy).__name__ == "ActorCriticCnnPolicy"  # (SB3's CnnPolicy)
    assert model.observation_space.shape == (3, 36, 36)  # (SB3 stores the transposed image space)
