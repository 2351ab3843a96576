"""Every registered id's episodes, at default arguments and on each terrain, are the ones the package
gave before its core was rebuilt (shapes as data, one contact law, the env on the World's runner):
a hash of every observation, reward, flag and info value of two seeded single-env runs of
random actions and of one seeded vector-env run, per id and terrain (``data/fingerprints.json``,
recorded by this file's ``record`` at commit 21c709f, the commit before that work).

What this pins is behaviour users rely on (an env whose episodes change gets a new version), not
physics: the physics tests check against closed forms and conserved quantities.

Across machines (README, "Guarantees"): the bowl and the arena are the same on every x86-64 host
with FMA; the bumpy terrain's bumps go through NumPy's ``exp`` (3D) and a BLAS product (2D), whose
last bits depend on the CPU's SIMD paths, so its fingerprints are checked only on a host of the
kind that recorded them (AVX-512 and FMA).
"""

from __future__ import annotations

import hashlib
import json
import pathlib
import warnings

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401 (registers the ids)

DATA = pathlib.Path(__file__).parent / "data" / "fingerprints.json"
IDS = [
    "PenaltyBalls-v0",
    "PenaltyBalls2D-v0",
    "PenaltyBalls-v1",
    "PenaltyBalls2D-v1",
    "PenaltyBallsSand-v0",
    "PenaltyBallsSand2D-v0",
    "PenaltyBallsSand-v1",
    "PenaltyBallsSand2D-v1",
]


def _terrains(env_id: str) -> tuple[str, ...]:
    return ("bowl", "arena") if "Sand" in env_id else ("bowl", "arena", "bumpy")


def _hash(*arrays) -> str:
    m = hashlib.sha256()
    for a in arrays:
        m.update(np.ascontiguousarray(np.asarray(a, dtype=np.float64)).tobytes())
    return m.hexdigest()[:16]


def single(env_id: str, seed: int, kwargs: dict, steps: int) -> str:
    env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(1000 + seed)
    obs, info = env.reset(seed=seed)
    rows, vals = [obs], [list(info.values())]
    for _ in range(steps):
        obs, r, te, tr, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        rows.append(obs)
        vals.append([r, te, tr] + list(info.values()))
        if te or tr:
            obs, info = env.reset()
            rows.append(obs)
            vals.append(list(info.values()))
    flat = np.concatenate([np.asarray(v, dtype=np.float64) for v in vals])
    same_width = len({len(v) for v in vals}) == 1
    return _hash(np.array(rows), np.array(vals, dtype=np.float64) if same_width else flat)


def vector(env_id: str, n: int, seed: int, kwargs: dict, steps: int) -> str:
    venv = gym.make_vec(env_id, num_envs=n, **kwargs)
    rng = np.random.default_rng(7 + seed)
    obs, _ = venv.reset(seed=seed)
    rows, rews = [obs], []
    for _ in range(steps):
        obs, r, te, tr, info = venv.step(rng.uniform(-1, 1, (n,) + venv.single_action_space.shape))
        rows.append(obs)
        rews.append(np.concatenate([r, te, tr, info["distance"], info["max_overlap"]]))
    return _hash(np.array(rows), np.array(rews))


def fingerprints(env_id: str, terrain: str) -> dict[str, str]:
    sand = "Sand" in env_id
    kw = {} if terrain == "bowl" else {"terrain": terrain}
    key = f"{env_id}/{terrain}"
    out = {f"{key}/s{seed}": single(env_id, seed, kw, 200 if sand else 300) for seed in (0, 1)}
    out[f"{key}/vec"] = vector(env_id, 8 if sand else 64, 0, kw, 60 if sand else 200)
    return out


def _recording_host() -> bool:
    """An x86-64 host with AVX-512 and FMA (the kind the fingerprints were recorded on)."""
    try:
        flags = pathlib.Path("/proc/cpuinfo").read_text().split()
    except OSError:
        return False
    return "avx512f" in flags and "fma" in flags


CASES = [(i, t) for i in IDS for t in _terrains(i)]


@pytest.mark.parametrize("env_id,terrain", CASES, ids=[f"{i}-{t}" for i, t in CASES])
def test_episodes_are_bit_identical_to_the_recorded_ones(env_id, terrain):
    if terrain == "bumpy" and not _recording_host():
        pytest.skip("the bumpy terrain's last bits depend on NumPy's SIMD exp and BLAS (see the module docstring)")
    want = json.loads(DATA.read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the -v0 ids' deprecation notice
        got = fingerprints(env_id, terrain)
    assert got == {k: want[k] for k in got}


def test_every_registered_id_is_fingerprinted():
    # (the goal-conditioned ids step the base ids' worlds: tests/envs/test_goal.py checks their
    # observations against the base ids' episodes, bit for bit)
    registered = {k for k in gym.registry if k.startswith("PenaltyBalls") and not k.startswith("PenaltyBallsGoal")}
    assert registered == set(IDS)
    assert {k.rsplit("/", 1)[0] for k in json.loads(DATA.read_text())} == {f"{i}/{t}" for i, t in CASES}


def record(path: pathlib.Path = DATA) -> None:
    """Write the fingerprints of this checkout (``python tests/envs/test_fingerprints.py``): only
    when an env's episodes change on purpose, under a new version."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = {k: v for i, t in CASES for k, v in fingerprints(i, t).items()}
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"recorded {len(out)} fingerprints in {path}")


if __name__ == "__main__":
    record()
