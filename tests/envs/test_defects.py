"""The defects outside users and an independent probe found in the envs (one test each; each
failed before its fix)."""

from __future__ import annotations

import gc
import pickle
import re
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import tomllib
from numba.core.registry import CPUDispatcher

import penalty_env  # noqa: F401
from penalty_env import sb3
from penalty_env.envs.scripted import RasterSweep, ScriptedPusher, scripted_policy

ROOT = Path(__file__).resolve().parents[2]
TOML = tomllib.loads((ROOT / "pyproject.toml").read_text())


# 1 -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("env_id", ["PenaltyBallsGoal-v0", "PenaltyBallsGoal2D-v1"])
def test_goal_vector_observations_are_copies(env_id):
    """A stored observation of the goal vector env keeps its values after later steps (they were
    views of the scene's buffer)."""
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    obs, _ = vec.reset(seed=0)
    kept = {k: v.copy() for k, v in obs.items()}
    for _ in range(3):
        vec.step(np.ones(vec.action_space.shape, dtype=np.float32))
    for key in kept:
        np.testing.assert_array_equal(obs[key], kept[key])
    vec.close()


# 2 -----------------------------------------------------------------------------------------------
HUGE = 10**400  # an int no float holds: float(HUGE) raises OverflowError


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: gym.make("PenaltyBalls-v0", randomize={"ball_mass": (1, HUGE)}), "ball_mass"),
        (lambda: gym.make("PenaltyBalls-v0", obs_mode="heightmap", heightmap_cell=HUGE), "heightmap_cell"),
        (lambda: gym.make("PenaltyBallsGoal-v0", goal_tolerance=HUGE), "goal_tolerance"),
        (lambda: gym.make("PenaltySandLevel2D-v0", blade_speed=HUGE), "blade_speed"),
    ],
)
def test_a_number_too_large_for_a_float_is_a_value_error_naming_the_argument(make, name):
    with pytest.raises(ValueError, match=name):
        make()


# 3 -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", ["abc", [1, 2], 1.5, -1, True])
def test_sb3_make_vec_env_validates_the_seed(seed):
    with pytest.raises(ValueError, match="seed"):
        sb3.make_vec_env("PenaltyBalls2D-v0", n_envs=2, seed=seed)


def test_sb3_make_vec_env_takes_a_numpy_integer_seed():
    a = sb3.make_vec_env("PenaltyBalls2D-v0", n_envs=2, seed=np.int64(3))
    b = sb3.make_vec_env("PenaltyBalls2D-v0", n_envs=2, seed=3)
    np.testing.assert_array_equal(a.reset(), b.reset())


# 4 -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("env_id", ["PenaltyBalls2D-v0", "PenaltyBallsGoal2D-v0", "PenaltySandLevel2D-v0"])
def test_a_complex_action_is_refused(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    action = np.full(env.action_space.shape, 0.5 + 0.5j)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not NumPy's ComplexWarning and a step on the real part
        with pytest.raises(ValueError, match="action"):
            env.unwrapped.step(action)


# 5 -----------------------------------------------------------------------------------------------
def test_each_task_records_its_own_scripted_policy_or_is_refused_by_id():
    assert isinstance(scripted_policy(gym.make("PenaltyBalls2D-v0")), ScriptedPusher)
    assert isinstance(scripted_policy(gym.make("PenaltySandLevel2D-v0")), RasterSweep)
    with pytest.raises(ValueError, match="PenaltyBallsGoal-v0"):
        scripted_policy(gym.make("PenaltyBallsGoal-v0"))  # a Dict observation
    with pytest.raises(ValueError, match="PenaltyBalls-v0"):
        scripted_policy(gym.make("PenaltyBalls-v0", obs_mode="rgb"))
    with pytest.raises(ValueError, match="CartPole-v1"):
        scripted_policy(gym.make("CartPole-v1"))


def test_the_level_tasks_scripted_policy_levels_sand():
    """The recorded level policy is the raster sweep, which moves the blade (the pusher's
    actions on a level observation were nonsense)."""
    env = gym.make("PenaltySandLevel2D-v0")
    policy = scripted_policy(env)
    obs, info = env.reset(seed=0)
    start = info["flatness"] if "flatness" in info else None
    for _ in range(20):
        obs, _, _, _, info = env.step(policy(obs))
    assert np.abs(env.unwrapped.scene.obs[0]).sum() > 0
    if start is not None:
        assert info["flatness"] != start


# 6 -----------------------------------------------------------------------------------------------
def _signatures() -> dict[int, int]:
    with warnings.catch_warnings():  # (isinstance on every live object wakes torch's deprecated names)
        warnings.simplefilter("ignore")
        return {id(d): len(d.signatures) for d in gc.get_objects() if isinstance(d, CPUDispatcher)}


@pytest.mark.parametrize("env_id", ["PenaltyBalls2D-v0", "PenaltyBallsSand2D-v1", "PenaltySandLevel2D-v0"])
def test_an_unpickled_env_steps_without_compiling(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    copy = pickle.loads(pickle.dumps(env))
    before = _signatures()
    copy.step(copy.action_space.sample())
    copy.reset(seed=1)
    copy.step(copy.action_space.sample())
    after = _signatures()
    assert {k: after[k] for k in before} == before  # no kernel gained a signature (a new type)


# 7 -----------------------------------------------------------------------------------------------
def _lowest_gymnasium() -> str:
    (req,) = [r for r in TOML["project"]["dependencies"] if r.startswith("gymnasium")]
    return re.search(r">=\s*([\d.]+)", req).group(1)


@pytest.mark.slow  # (20 s from a cold cache: .ci/run runs it beside the default run)
def test_the_lowest_declared_gymnasium_runs_the_envs(tmp_path):
    """Gymnasium at the lowest version pyproject.toml allows (installed alone into a folder put
    first on the path) makes, checks and steps a single and a vector env of each task. (1.0
    lacks ``AutoresetMode``: 1.1 is the lowest that works.)"""
    version = _lowest_gymnasium()
    pip = [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(tmp_path)]
    subprocess.run([*pip, f"gymnasium=={version}"], check=True, capture_output=True)
    script = f"""
import gymnasium as gym, penalty_env
from gymnasium.utils.env_checker import check_env
from packaging.version import Version
assert Version(gym.__version__) == Version({version!r}), gym.__version__
for eid in ["PenaltyBalls2D-v0", "PenaltyBallsGoal2D-v1", "PenaltySandLevel2D-v0"]:
    env = gym.make(eid)
    check_env(env.unwrapped, skip_render_check=True)
    env.reset(seed=0); env.step(env.action_space.sample())
    vec = gym.make_vec(eid, num_envs=2, vectorization_mode="vector_entry_point")
    vec.reset(seed=0); vec.step(vec.action_space.sample())
print("ok")
"""
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}"}
    import os

    out = subprocess.run([sys.executable, "-c", script], env={**os.environ, **env}, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-2000:]


# 8 -----------------------------------------------------------------------------------------------
def test_the_minari_extra_has_pillow():
    """Minari 0.5.4's hdf5 storage imports PIL."""
    extra = TOML["project"]["optional-dependencies"]["minari"]
    assert any(r.lower().startswith("pillow") for r in extra), extra
