"""Speed of the sand-shaping task: ``python -m penalty_env.bench level [--seconds S]``.

Measures, in one run on this machine, env-steps/s with uniformly random actions (resets on
episode end) of ``gymnasium.make("PenaltySandLevel-v0")`` and of the 2D id, of their native vector
envs at 8 worlds, and of ``PenaltyBallsSand-v1`` (the pushing task through 300 grains) as the
peer in the same run, and prints each as a ratio to the peer's single env. Each figure is the best
of three interleaved timed windows (after a warm-up that compiles the kernels and settles the
heap), so a burst of load from another process does not set a figure.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import penalty_env  # noqa: F401  (registers the ids)

PEER = "make PenaltyBallsSand-v1"


def _single(env_id: str):
    env = gym.make(env_id)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1.0, 1.0, (256,) + env.action_space.shape).astype(np.float32)

    def run(steps: int) -> int:
        for k in range(steps):
            _, _, term, trunc, _ = env.step(acts[k % 256])
            if term or trunc:
                env.reset()
        return steps

    return run


def _vector(env_id: str, n: int):
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1.0, 1.0, (64,) + venv.action_space.shape).astype(np.float32)

    def run(steps: int) -> int:
        for k in range(steps):
            venv.step(acts[k % 64])
        return steps * n

    return run


def main(argv=None) -> dict[str, float]:
    parser = argparse.ArgumentParser(prog="python -m penalty_env.bench level", description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="length of one timed window")
    args = parser.parse_args(argv)
    cases = {
        PEER: _single("PenaltyBallsSand-v1"),
        "make PenaltySandLevel-v0": _single("PenaltySandLevel-v0"),
        "make_vec PenaltySandLevel-v0 x 8": _vector("PenaltySandLevel-v0", 8),
        "make PenaltySandLevel2D-v0": _single("PenaltySandLevel2D-v0"),
        "make_vec PenaltySandLevel2D-v0 x 8": _vector("PenaltySandLevel2D-v0", 8),
    }
    calls = {}
    for label, run in cases.items():  # warm-up, then calls of about ``seconds``
        run(2)
        t = time.perf_counter()
        run(5)
        calls[label] = max(1, int(5 * args.seconds / max(time.perf_counter() - t, 1e-9)))
    rates = dict.fromkeys(cases, 0.0)
    for _ in range(3):
        for label, run in cases.items():
            t = time.perf_counter()
            done = run(calls[label])
            rates[label] = max(rates[label], done / (time.perf_counter() - t))
    for id_ in ("PenaltySandLevel-v0", "PenaltySandLevel2D-v0"):
        print(f"{id_}: {gym.make(id_).unwrapped.scene.describe()}")
    print(f"{'case':40s} {'env-steps/s':>12s} {'/ ' + PEER:>30s}")
    for label, rate in rates.items():
        print(f"{label:40s} {rate:12.1f} {rate / rates[PEER]:30.2f}")
    return rates


if __name__ == "__main__":
    main()
