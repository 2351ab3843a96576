"""The episodes of every public face beyond the registered ids' defaults are the ones the package gave
before ``envs/`` was rebuilt on one base (commit bdc8126): the goal-conditioned ids, the level task,
each observation mode, domain randomisation, the three autoreset modes of the native vector env, the
SB3 ``VecEnv`` and the rendered frames. A hash of every observation, reward, flag and info value
(``data/fingerprints_faces.json``, recorded by this file's ``record`` at bdc8126). Two sets were
recorded again since, on purpose: the goal ids' vector observations (bdc8126's were views of the
scene's buffer that later steps changed: the fingerprint now hashes copies, and the values the steps
returned are the same), and the PenaltyBalls frames of ``render()`` (pictures, not episodes: drawn
by the one raster since ``envs/`` was rebuilt, with the observation images' terrain image).

As :mod:`tests.envs.test_fingerprints`, this pins behaviour users rely on, not physics; the bumpy
terrain's cases are checked only on a host of the kind that recorded them (AVX-512 and FMA).
"""

from __future__ import annotations

import copy
import hashlib
import json
import pathlib
import warnings

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401 (registers the ids)

DATA = pathlib.Path(__file__).parent / "data" / "fingerprints_faces.json"


def _update(m, value) -> None:
    """Feed ``value`` (an array, a number, a bool, None, or a dict / list / tuple of them, in order)."""
    if isinstance(value, dict):
        for k in sorted(value):
            m.update(str(k).encode())
            _update(m, value[k])
    elif isinstance(value, (list, tuple)):
        for v in value:
            _update(m, v)
    elif value is None:
        m.update(b"None")
    else:
        a = np.asarray(value)
        if a.dtype == object:
            for v in a.ravel():
                _update(m, v)
        else:
            m.update(str(a.dtype).encode())
            m.update(np.ascontiguousarray(a).tobytes())


def _hash(*values) -> str:
    m = hashlib.sha256()
    for v in values:
        _update(m, v)
    return m.hexdigest()[:16]


def single(env_id: str, seed: int, steps: int, **kwargs) -> str:
    env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(1000 + seed)
    obs, info = env.reset(seed=seed)
    out = [obs, info]
    for _ in range(steps):
        obs, r, te, tr, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        out += [obs, r, te, tr, info]
        if te or tr:
            obs, info = env.reset()
            out += [obs, info]
    return _hash(out)


def vector(env_id: str, n: int, steps: int, **kwargs) -> str:
    venv = gym.make_vec(env_id, num_envs=n, **kwargs)
    rng = np.random.default_rng(7)
    obs, info = venv.reset(seed=0)
    out = [copy.deepcopy(obs), info]  # (copies: what a step returned, as it was then)
    for _ in range(steps):
        obs, r, te, tr, info = venv.step(rng.uniform(-1, 1, (n,) + venv.single_action_space.shape))
        out += [copy.deepcopy(obs), r, te, tr, copy.deepcopy(info)]
    return _hash(out)


def sb3(env_id: str, n: int, steps: int, **kwargs) -> str:
    from penalty_env.sb3 import make_vec_env

    venv = make_vec_env(env_id, n_envs=n, seed=0, monitor=False, **kwargs)
    rng = np.random.default_rng(11)
    out = [venv.reset(), venv.reset_infos]
    for _ in range(steps):
        obs, r, done, infos = venv.step(rng.uniform(-1, 1, (n,) + venv.action_space.shape))
        out += [obs, r, done, infos]
    return _hash(out)


def frames(env_id: str, steps: int, **kwargs) -> str:
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    rng = np.random.default_rng(5)
    env.reset(seed=3)
    out = [env.render()]
    for _ in range(steps):
        env.step(rng.uniform(-1, 1, env.action_space.shape))
        out.append(env.render())
    return _hash(out)


RANDOM = {"ball_mass": (0.5, 2.0), "friction": (0.2, 0.8), "restitution": (0.3, 0.6), "ball_radius": (0.15, 0.2)}

# name -> (the function, its arguments, its keyword arguments)
CASES: dict[str, tuple] = {
    # the goal-conditioned ids, single and vector, each reward
    "goal/v0/s0": (single, ("PenaltyBallsGoal-v0", 0, 200), {}),
    "goal/v0-dense/s1": (single, ("PenaltyBallsGoal-v0", 1, 200), {"reward": "dense", "observe_goal": True}),
    "goal/2D-v0/s0": (single, ("PenaltyBallsGoal2D-v0", 0, 200), {}),
    "goal/v1/s0": (single, ("PenaltyBallsGoal-v1", 0, 150), {}),
    "goal/2D-v1/s0": (single, ("PenaltyBallsGoal2D-v1", 0, 150), {}),
    "goal/v0/vec": (vector, ("PenaltyBallsGoal-v0", 16, 180), {}),
    "goal/v0/vec-same": (vector, ("PenaltyBallsGoal-v0", 16, 180), {"autoreset_mode": "SameStep"}),
    "goal/2D-v1/vec": (vector, ("PenaltyBallsGoal2D-v1", 8, 160), {}),
    # the level task
    "level/3D/s0": (single, ("PenaltySandLevel-v0", 0, 40), {}),
    "level/3D-random/s1": (single, ("PenaltySandLevel-v0", 1, 30), {"target": "random"}),
    "level/2D/s0": (single, ("PenaltySandLevel2D-v0", 0, 170), {}),
    "level/2D-random/s1": (single, ("PenaltySandLevel2D-v0", 1, 170), {"target": "random"}),
    "level/2D/vec": (vector, ("PenaltySandLevel2D-v0", 4, 160), {"max_episode_steps": 50}),
    # the observation modes
    "obs/v0-heightmap/s0": (single, ("PenaltyBalls-v0", 0, 160), {"obs_mode": "heightmap"}),
    "obs/v0-rgb/s0": (single, ("PenaltyBalls-v0", 0, 60), {"obs_mode": "rgb", "rgb_size": 32}),
    "obs/2D-v1-dict/s0": (single, ("PenaltyBalls2D-v1", 0, 160), {"obs_mode": ("state", "heightmap", "rgb")}),
    "obs/v0-arena-dict/vec": (
        vector,
        ("PenaltyBalls-v0", 8, 160),
        {"terrain": "arena", "obs_mode": ["heightmap", "rgb"], "rgb_size": 24, "heightmap_cells": 8},
    ),
    "obs/v0-bumpy-dict/vec": (
        vector,
        ("PenaltyBalls-v0", 8, 160),
        {"terrain": "bumpy", "obs_mode": ("state", "heightmap", "rgb"), "rgb_size": 24},
    ),
    "obs/sand2D-v1-dict/s0": (single, ("PenaltyBallsSand2D-v1", 0, 60), {"obs_mode": ("state", "heightmap", "rgb")}),
    "obs/v0-rgb/vec-same": (
        vector,
        ("PenaltyBalls-v0", 8, 160),
        {"obs_mode": "rgb", "rgb_size": 16, "autoreset_mode": "SameStep"},
    ),
    # domain randomisation
    "random/v0/s0": (single, ("PenaltyBalls-v0", 0, 200), {"randomize": RANDOM}),
    "random/v1/s0": (single, ("PenaltyBalls-v1", 0, 160), {"randomize": RANDOM}),
    "random/2D-v0-obstacles/s1": (
        single,
        ("PenaltyBalls2D-v0", 1, 200),
        {"n_obstacles": 1, "randomize": dict(RANDOM, obstacle_mass=(0.5, 1.5), max_force=(15.0, 20.0))},
    ),
    "random/v0-bumpy/vec": (
        vector,
        ("PenaltyBalls-v0", 16, 170),
        {"terrain": "bumpy", "randomize": dict(RANDOM, roughness=(0.0, 0.1), stiffness=(0.5, 2.0))},
    ),
    "random/v0/vec-same": (vector, ("PenaltyBalls-v0", 16, 170), {"randomize": RANDOM, "autoreset_mode": "SameStep"}),
    # the native vector env's autoreset modes and obstacles
    "vec/v0-same": (vector, ("PenaltyBalls-v0", 32, 200), {"autoreset_mode": "SameStep"}),
    "vec/2D-v1-obstacles": (vector, ("PenaltyBalls2D-v1", 16, 170), {"n_obstacles": 1}),
    "vec/sand2D-v1-same": (
        vector,
        ("PenaltyBallsSand2D-v1", 4, 60),
        {"autoreset_mode": "SameStep", "max_episode_steps": 25},
    ),
    # the SB3 VecEnv
    "sb3/v0": (sb3, ("PenaltyBalls-v0", 16, 200), {}),
    "sb3/2D-v1-heightmap": (sb3, ("PenaltyBalls2D-v1", 8, 170), {"obs_mode": "heightmap"}),
    "sb3/v0-random": (sb3, ("PenaltyBalls-v0", 8, 170), {"randomize": RANDOM}),
    "sb3/sand2D-v1": (sb3, ("PenaltyBallsSand2D-v1", 4, 40), {"max_episode_steps": 15}),
    # the rendered frames
    "render/v0": (frames, ("PenaltyBalls-v0", 3), {"render_width": 96, "render_height": 96}),
    "render/2D-v0": (frames, ("PenaltyBalls2D-v0", 3), {"render_width": 96, "render_height": 96}),
    "render/v0-arena": (frames, ("PenaltyBalls-v0", 2), {"terrain": "arena", "render_width": 64, "render_height": 64}),
    "render/v0-bumpy": (frames, ("PenaltyBalls-v0", 2), {"terrain": "bumpy", "render_width": 64, "render_height": 64}),
    "render/sand2D-v1": (frames, ("PenaltyBallsSand2D-v1", 2), {"render_width": 64, "render_height": 64}),
    "render/level2D": (frames, ("PenaltySandLevel2D-v0", 2), {}),
}


def _run(name: str) -> str:
    fn, args, kwargs = CASES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


def _recording_host() -> bool:
    try:
        flags = pathlib.Path("/proc/cpuinfo").read_text().split()
    except OSError:
        return False
    return "avx512f" in flags and "fma" in flags


@pytest.mark.parametrize("name", list(CASES))
def test_the_face_gives_the_recorded_episodes(name):
    if "bumpy" in name and not _recording_host():
        pytest.skip("the bumpy terrain's last bits depend on NumPy's SIMD exp and BLAS")
    if name.startswith("sb3/"):
        pytest.importorskip("stable_baselines3")
    want = json.loads(DATA.read_text())
    assert _run(name) == want[name]


def record(path: pathlib.Path = DATA) -> None:
    """Write the fingerprints of this checkout (``python tests/envs/test_fingerprints_faces.py``):
    only when a face's episodes change on purpose, under a new version."""
    out = {name: _run(name) for name in CASES}
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"recorded {len(out)} fingerprints in {path}")


if __name__ == "__main__":
    record()
