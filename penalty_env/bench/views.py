"""Speed of the observation modes: ``python -m penalty_env.bench views [--worlds N] [--seconds S] [--quick]``.

Measures, in one run on this machine, at ``--worlds`` worlds (default 1,024) of ``PenaltyBalls-v0``
(and the 2D id) in the native vector env, with uniformly random actions:
  - observations/s of the ``"rgb"`` mode (64x64 images) and of the ``"heightmap"`` mode (16 x 16
    cells), the views alone (``Views.observe`` of the whole batch, after a step);
  - env-steps/s of ``gymnasium.make_vec`` with ``obs_mode="state"`` (the default), ``"heightmap"``,
    ``"rgb"`` and ``("state", "rgb")``, each as a ratio to the state mode's steps/s of the same run;
  - the rgb mode on the bumpy terrain, whose terrain image is redrawn per world after each reset.
The target: at least 100,000 rgb observations/s at 1,024 worlds. Each figure is the best of three
timed windows, taken in interleaved rounds (a burst of load from another process hits every case
alike).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable

import gymnasium as gym
import numba
import numpy as np

import penalty_env  # noqa: F401  (registers the ids)

TARGET_RGB_OBS_PER_S = 100_000


def _observe_case(env_id: str, worlds: int, mode: str, **kwargs) -> Callable[[int], None]:
    """``calls`` whole-batch observations of one mode, the worlds stepped once before."""
    env = gym.make_vec(env_id, num_envs=worlds, vectorization_mode="vector_entry_point", obs_mode=mode, **kwargs)
    env.reset(seed=0)
    env.step(np.random.default_rng(0).uniform(-1, 1, env.action_space.shape))
    views = env.unwrapped.views

    def run(calls: int) -> None:
        for _ in range(calls):
            views.observe()

    return run


def _step_case(env_id: str, worlds: int, mode, **kwargs) -> Callable[[int], None]:
    """``calls`` steps of the vector env in ``mode`` (random actions drawn beforehand)."""
    env = gym.make_vec(env_id, num_envs=worlds, vectorization_mode="vector_entry_point", obs_mode=mode, **kwargs)
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (16,) + env.action_space.shape)

    def run(calls: int) -> None:
        for k in range(calls):
            env.step(actions[k % 16])

    return run


def _rate(run: Callable[[int], None], calls: int) -> float:
    t = time.perf_counter()
    run(calls)
    return calls / (time.perf_counter() - t)


def _calibrate(run: Callable[[int], None], seconds: float) -> int:
    run(2)  # compiles, draws the terrain images
    calls = 1
    while True:
        t = time.perf_counter()
        run(calls)
        dt = time.perf_counter() - t
        if dt > 0.05:
            return max(1, int(calls * seconds / dt))
        calls *= 4


def main(argv=None) -> dict[str, float]:
    parser = argparse.ArgumentParser(prog="python -m penalty_env.bench views", description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", type=int, default=1024, help="worlds of the vector env (default: %(default)s)")
    parser.add_argument("--seconds", type=float, default=None, help="length of one timed window (default 1)")
    parser.add_argument("--quick", action="store_true", help="short windows (a smoke run, noisy figures)")
    args = parser.parse_args(argv)
    seconds = args.seconds or (0.1 if args.quick else 1.0)
    N = args.worlds
    print(
        f"PenaltyBalls observation modes: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
        f"numba threads {numba.config.NUMBA_NUM_THREADS}, {N:,} worlds, best of 3 x {seconds:g} s"
    )
    cases: list[tuple[str, Callable[[int], None], int]] = [
        ("observe rgb 64x64, PenaltyBalls-v0", _observe_case("PenaltyBalls-v0", N, "rgb"), N),
        ("observe rgb 64x64, PenaltyBalls2D-v0", _observe_case("PenaltyBalls2D-v0", N, "rgb"), N),
        ("observe heightmap 16x16, PenaltyBalls-v0", _observe_case("PenaltyBalls-v0", N, "heightmap"), N),
        ("step state, PenaltyBalls-v0", _step_case("PenaltyBalls-v0", N, "state"), N),
        ("step heightmap, PenaltyBalls-v0", _step_case("PenaltyBalls-v0", N, "heightmap"), N),
        ("step rgb, PenaltyBalls-v0", _step_case("PenaltyBalls-v0", N, "rgb"), N),
        ("step (state, rgb), PenaltyBalls-v0", _step_case("PenaltyBalls-v0", N, ("state", "rgb")), N),
        ("step state, PenaltyBalls-v0, bumpy", _step_case("PenaltyBalls-v0", N, "state", terrain="bumpy"), N),
        ("step rgb, PenaltyBalls-v0, bumpy", _step_case("PenaltyBalls-v0", N, "rgb", terrain="bumpy"), N),
    ]
    calls = [_calibrate(run, seconds) for _, run, _ in cases]
    best = [0.0] * len(cases)
    for _ in range(3):  # interleaved rounds
        for k, (_, run, per_call) in enumerate(cases):
            best[k] = max(best[k], _rate(run, calls[k]) * per_call)
    rates = {label: rate for (label, _, _), rate in zip(cases, best)}
    state = rates["step state, PenaltyBalls-v0"]
    state_bumpy = rates["step state, PenaltyBalls-v0, bumpy"]
    for label, rate in rates.items():
        unit = "observations/s" if label.startswith("observe") else "env-steps/s"
        ref = state_bumpy if label.endswith("bumpy") else state
        ratio = "" if label.startswith("observe") else f"  ({rate / ref:.2f}x the state mode's)"
        print(f"  {label:45s} {rate:>13,.0f} {unit}{ratio}")
    rgb = rates["observe rgb 64x64, PenaltyBalls-v0"]
    verdict = "holds" if rgb >= TARGET_RGB_OBS_PER_S else "DOES NOT HOLD"
    print(f"target: >= {TARGET_RGB_OBS_PER_S:,} rgb observations/s at {N:,} worlds: {rgb:,.0f} ({verdict})")
    return rates


if __name__ == "__main__":
    main()
