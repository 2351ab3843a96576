"""What other libraries read from the envs: frame rates, video recorders, info dtypes; what a fresh
process can make."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401

INFO_DTYPES = {
    "reward_goal": np.float64,
    "reward_reach": np.float64,
    "reward_success": np.float64,
    "distance": np.float64,
    "pusher_distance": np.float64,
    "max_overlap": np.float64,
    "is_success": bool,
}


def test_single_env_info_values_are_numpy_scalars_of_their_declared_dtype():
    """float64 values, and ``is_success`` a Python bool: Gymnasium's ``SyncVectorEnv`` batches a numpy
    bool into an object array (it makes typed arrays only for Python scalars and numpy numbers)."""
    env = gym.make("PenaltyBalls-v0")
    _, info = env.reset(seed=0)
    for value in (info, env.step(np.zeros(2, np.float32))[4]):
        assert {k: type(v) for k, v in value.items()} == INFO_DTYPES


def test_vector_env_infos_are_arrays_of_their_declared_dtype():
    venv = gym.make_vec("PenaltyBalls-v0", num_envs=3)
    venv.reset(seed=0)
    info = venv.step(np.zeros((3, 2), np.float32))[4]
    for key, dtype in INFO_DTYPES.items():
        assert info[key].dtype == np.dtype(dtype) and info[key].shape == (3,)
        assert info["_" + key].dtype == np.bool_


def test_sb3_infos_are_numpy_scalars_and_its_metadata_has_the_frame_rate(tmp_path):
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from penalty_env.sb3 import make_vec_env

    venv = make_vec_env("PenaltyBalls-v0", n_envs=2, seed=0, render_mode="rgb_array")
    venv.reset()
    infos = venv.step(np.zeros((2, 2), np.float32))[3]
    assert {k: type(v) for k, v in infos[0].items() if k in INFO_DTYPES} == INFO_DTYPES
    fps = gym.make("PenaltyBalls-v0").metadata["render_fps"]
    assert venv.metadata["render_fps"] == fps == 25  # 1 / control_period
    rec = VecVideoRecorder(venv, str(tmp_path), record_video_trigger=lambda step: step == 0, video_length=4)
    assert rec.frames_per_sec == 25  # SB3 falls back to 30 without it
    rec.reset()
    for _ in range(5):
        rec.step(np.zeros((2, 2), np.float32))
    rec.close()
    assert list(tmp_path.glob("*.mp4"))


def test_gymnasium_vector_record_video_records_the_native_vector_env(tmp_path):
    pytest.importorskip("moviepy")
    from gymnasium.wrappers.vector import RecordVideo

    venv = gym.make_vec("PenaltyBalls-v0", num_envs=3, render_mode="rgb_array")
    frames = venv.render()
    assert len(frames) == 3 and frames[0].shape == (256, 256, 3)
    folder = tmp_path / "videos"  # (a new folder: Gymnasium warns of overwriting an existing one)
    rec = RecordVideo(venv, str(folder), episode_trigger=lambda e: e == 0, video_length=5)
    rec.reset(seed=0)
    for _ in range(6):
        rec.step(np.zeros((3, 2), np.float32))
    rec.close()
    assert list(folder.glob("*.mp4"))


FRESH = """
import pickle, sys
import gymnasium as gym
try:
    gym.make("PenaltyBalls-v0")
    print("plain id: made")
except gym.error.NameNotFound:
    print("plain id: NameNotFound")
assert "penalty_env" not in sys.modules
print("spec:", gym.make(pickle.loads(bytes.fromhex(sys.argv[1]))).spec.id)  # imports the entry point's module
print("prefixed id:", gym.make("penalty_env:PenaltyBalls-v0").spec.id)
"""


def test_a_fresh_process_needs_the_prefixed_id_or_the_spec(tmp_path):
    """What docs/interop.md says of fresh worker processes: Gymnasium loads no plugins, so a plain
    id is unknown in a process that did not import penalty_env; the module-prefixed id and a
    pickled spec (what ``make_vec(..., vectorization_mode="async")`` and rl-zoo3 send) both work.
    If a Gymnasium release loads plugins again, the first line changes and the page must too."""
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=str(root))
    spec = pickle.dumps(gym.spec("PenaltyBalls-v0")).hex()
    res = subprocess.run(
        [sys.executable, "-c", FRESH, spec], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.split("\n")[:3] == [
        "plain id: NameNotFound",
        "spec: PenaltyBalls-v0",
        "prefixed id: PenaltyBalls-v0",
    ]
