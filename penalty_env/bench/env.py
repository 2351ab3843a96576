"""Speed of the PenaltyBalls environments: ``python -m penalty_env.bench env [--quick] [--seconds S]``.

Measures, in one run on this machine, with uniformly random actions and resets on episode end:
  - steps/s of ``gymnasium.make("PenaltyBalls-v0")`` (its wrappers included) and of the 2D id,
    and of the ``-v1`` ids (the balls roll) beside them;
  - env-steps/s of the native vector env (``gymnasium.make_vec``) at 1, 64 and 1,024 worlds;
  - Gymnasium's ``SyncVectorEnv`` of the single env at 8, and the SB3 adapter at 1,024 worlds;
  - ``CartPole-v1`` and, when MuJoCo is installed (the ``bench`` extra), ``Pusher-v5``, both
    through ``gymnasium.make``;
  - rgb_array frames per second at 256x256;
and prints the ratios the project targets. Each figure is the best of three timed windows
(after a warm-up that compiles the kernels), taken in interleaved rounds, so a burst of load from
another process does not set a figure or skew a ratio.
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

TARGETS = (
    # (label, numerator, denominator or None for an absolute figure, threshold)
    ("single env / CartPole-v1", "make PenaltyBalls-v0", "make CartPole-v1", 0.7),
    ("single env / Pusher-v5", "make PenaltyBalls-v0", "make Pusher-v5", 5.0),
    ("vector env (1,024 worlds), env-steps/s", "make_vec PenaltyBalls-v0 x 1024", None, 1.0e6),
    ("vector env (1,024 worlds) / Pusher-v5", "make_vec PenaltyBalls-v0 x 1024", "make Pusher-v5", 100.0),
    ("arena / bowl (1,024 worlds)", "make_vec PenaltyBalls-v0 x 1024, arena", "make_vec PenaltyBalls-v0 x 1024", 0.8),
    ("bumpy / bowl (1,024 worlds)", "make_vec PenaltyBalls-v0 x 1024, bumpy", "make_vec PenaltyBalls-v0 x 1024", 0.8),
)


def _calibrate(run: Callable[[int], None], seconds: float) -> int:
    """Calls of ``run`` that take about ``seconds`` (after a warm-up that compiles and resets)."""
    run(1)
    calls = 1
    while True:
        t = time.perf_counter()
        run(calls)
        dt = time.perf_counter() - t
        if dt > 0.05 or calls > 1_000_000:
            break
        calls *= 4
    return max(1, int(calls * seconds / max(dt, 1e-9)))


def _best_rates(cases, seconds: float, rounds: int = 3) -> dict[str, float]:
    """Best rate of each case over ``rounds`` timed windows. The rounds are interleaved (case 1,
    case 2, ..., case 1, ...), so a burst of load from another process hits every case alike
    instead of spoiling the ratios between them."""
    runners = []
    for label, build, per_call, _unit in cases:
        run = build()
        runners.append((label, run, _calibrate(run, seconds), per_call))
    best = {label: 0.0 for label, *_ in runners}
    for _ in range(rounds):
        for label, run, calls, per_call in runners:
            t = time.perf_counter()
            run(calls)
            best[label] = max(best[label], calls * per_call / (time.perf_counter() - t))
    return best


def _single(env_id: str, seed: int = 0, **kwargs) -> Callable[[int], None]:
    env = gym.make(env_id, **kwargs)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(997)]
    env.reset(seed=seed)
    state = {"k": 0}

    def run(n: int) -> None:
        k = state["k"]
        step, reset = env.step, env.reset
        for _ in range(n):
            _, _, terminated, truncated, _ = step(actions[k % 997])
            k += 1
            if terminated or truncated:
                reset()
        state["k"] = k

    return run


def _vector(envs, n: int, seed: int = 0) -> Callable[[int], None]:
    envs.action_space.seed(seed)
    actions = [envs.action_space.sample() for _ in range(17)]
    envs.reset(seed=seed)
    state = {"k": 0}

    def run(calls: int) -> None:
        k = state["k"]
        for _ in range(calls):
            envs.step(actions[k % 17])  # autoreset: no reset call needed
            k += 1
        state["k"] = k

    return run


def _sb3(n: int, seed: int = 0) -> Callable[[int], None]:
    from .. import sb3

    venv = sb3.make_vec_env("PenaltyBalls-v0", n_envs=n, seed=seed, monitor=False)
    rng = np.random.default_rng(seed)
    actions = [rng.uniform(-1, 1, (n, 2)).astype(np.float32) for _ in range(17)]
    venv.reset()
    state = {"k": 0}

    def run(calls: int) -> None:
        k = state["k"]
        for _ in range(calls):
            venv.step(actions[k % 17])
            k += 1
        state["k"] = k

    return run


def _resets(env_id: str) -> Callable[[int], None]:
    """``reset()`` alone (a new start each call: the env's generator moves on)."""
    env = gym.make(env_id)
    env.reset(seed=0)

    def run(n: int) -> None:
        for _ in range(n):
            env.reset()

    return run


def _render(env_id: str) -> Callable[[int], None]:
    env = gym.make(env_id, render_mode="rgb_array", render_width=256, render_height=256)
    env.reset(seed=0)
    raw = env.unwrapped

    def run(n: int) -> None:
        for _ in range(n):
            raw.render()

    return run


def _installed(env_id: str) -> bool:
    try:
        gym.make(env_id).close()
        return True
    except Exception:  # a missing dependency (mujoco) surfaces as several error types
        return False


_Case = tuple[str, Callable[[], Callable[[int], None]], int, str]  # (label, build, per call, unit)


def _cases() -> list[_Case]:
    """Every timed case, in the order they are printed: CartPole (and Pusher when MuJoCo is
    installed), the PenaltyBalls ids single and vectorised, v1 beside v0, sand, SB3 when installed,
    and rendering."""
    cases: list[_Case] = [
        ("make CartPole-v1", lambda: _single("CartPole-v1"), 1, "steps/s"),
    ]
    if _installed("Pusher-v5"):
        cases.append(("make Pusher-v5", lambda: _single("Pusher-v5"), 1, "steps/s"))
    cases += [
        ("make PenaltyBalls-v0", lambda: _single("PenaltyBalls-v0"), 1, "steps/s"),
        ("make PenaltyBalls2D-v0", lambda: _single("PenaltyBalls2D-v0"), 1, "steps/s"),
        ("make PenaltyBalls-v0, 3 obstacles", lambda: _single("PenaltyBalls-v0", n_obstacles=3), 1, "steps/s"),
        (
            "SyncVectorEnv PenaltyBalls-v0 x 8",
            lambda: _vector(gym.make_vec("PenaltyBalls-v0", 8, vectorization_mode="sync"), 8),
            8,
            "env-steps/s",
        ),
    ]
    for n in (1, 64, 1024):
        cases.append(
            (
                f"make_vec PenaltyBalls-v0 x {n}",
                lambda n=n: _vector(gym.make_vec("PenaltyBalls-v0", num_envs=n), n),
                n,
                "env-steps/s",
            )
        )
    for terrain in ("arena", "bumpy"):  # general shapes (planes, boxes; a height field, spheres)
        cases.append(
            (
                f"make_vec PenaltyBalls-v0 x 1024, {terrain}",
                lambda t=terrain: _vector(gym.make_vec("PenaltyBalls-v0", num_envs=1024, terrain=t), 1024),
                1024,
                "env-steps/s",
            )
        )
    cases.append(
        (
            "make_vec PenaltyBalls2D-v0 x 1024",
            lambda: _vector(gym.make_vec("PenaltyBalls2D-v0", num_envs=1024), 1024),
            1024,
            "env-steps/s",
        )
    )
    # v1 (the balls roll: the scalar step with rotation) beside v0
    cases += [
        ("make PenaltyBalls-v1", lambda: _single("PenaltyBalls-v1"), 1, "steps/s"),
        ("make PenaltyBalls2D-v1", lambda: _single("PenaltyBalls2D-v1"), 1, "steps/s"),
        (
            "make_vec PenaltyBalls-v1 x 1024",
            lambda: _vector(gym.make_vec("PenaltyBalls-v1", num_envs=1024), 1024),
            1024,
            "env-steps/s",
        ),
    ]
    # sand (v1's physics with a settled bed: 300 grains in 3D, 40 in 2D; Sand-v1: grains of 0.5 kg,
    # 9 substeps per step instead of 25); reset's target: under 50 ms
    for sand in ("PenaltyBallsSand-v0", "PenaltyBallsSand2D-v0", "PenaltyBallsSand-v1"):
        cases.append((f"make {sand}", lambda sand=sand: _single(sand), 1, "steps/s"))
        if "2D" not in sand:
            vec = lambda sand=sand: _vector(gym.make_vec(sand, num_envs=64), 64)  # noqa: E731
            cases.append((f"make_vec {sand} x 64", vec, 64, "env-steps/s"))
        cases.append((f"reset {sand}", lambda sand=sand: _resets(sand), 1, "resets/s"))
    try:
        import stable_baselines3  # noqa: F401

        cases.append(("SB3 make_vec_env PenaltyBalls-v0 x 1024", lambda: _sb3(1024), 1024, "env-steps/s"))
    except ImportError:
        pass
    cases += [
        ("rgb_array 256x256 PenaltyBalls-v0", lambda: _render("PenaltyBalls-v0"), 1, "frames/s"),
        ("rgb_array 256x256 PenaltyBalls2D-v0", lambda: _render("PenaltyBalls2D-v0"), 1, "frames/s"),
        ("rgb_array 256x256 PenaltyBallsSand-v0", lambda: _render("PenaltyBallsSand-v0"), 1, "frames/s"),
    ]
    return cases


def _print_rates(cases: list[_Case], rates: dict[str, float]) -> None:
    """The table of every case's rate and time per call."""
    width = max(len(c[0]) for c in cases)
    print(f"\n{'':<{width}}  {'rate':>14}  {'us per call':>11}")
    for label, _, per_call, unit in cases:
        rate = rates[label]
        print(f"{label:<{width}}  {rate:>14,.0f}  {1e6 * per_call / rate:>11.2f}  {unit}")


def _print_targets(rates: dict[str, float]) -> None:
    """Each target's ratio or figure, ok or MISSED."""
    print("\ntargets")
    for label, num, den, threshold in TARGETS:
        if num not in rates or (den is not None and den not in rates):
            print(f"  {label:<42} n/a (needs {den})")
            continue
        value = rates[num] / rates[den] if den else rates[num]
        verdict = "ok" if value >= threshold else "MISSED"
        shown = f"{value:,.2f}x" if den else f"{value:,.0f}"
        goal = f"{threshold:g}x" if den else f"{threshold:,.0f}"
        print(f"  {label:<42} {shown:>14}   (target >= {goal}) {verdict}")
    frames = rates.get("rgb_array 256x256 PenaltyBalls-v0", 0.0)
    print(
        f"  {'rgb_array frames/s at 256x256 (3D)':<42} {frames:>14,.0f}   (target >= 200) "
        f"{'ok' if frames >= 200 else 'MISSED'}"
    )
    for env_id in ("PenaltyBallsSand-v0", "PenaltyBallsSand2D-v0", "PenaltyBallsSand-v1"):
        ms = 1e3 / rates[f"reset {env_id}"]
        print(f"  {'reset ' + env_id + ', ms':<42} {ms:>14.2f}   (target <= 50) {'ok' if ms <= 50 else 'MISSED'}")


def main(argv=None) -> dict[str, float]:
    parser = argparse.ArgumentParser(prog="python -m penalty_env.bench env", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="short windows (a smoke run, noisy figures)")
    parser.add_argument("--seconds", type=float, default=None, help="length of one timed window")
    args = parser.parse_args(argv)
    seconds = args.seconds or (0.1 if args.quick else 1.0)

    print(
        f"PenaltyBalls env benchmark: {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} CPUs, numba threads {numba.config.NUMBA_NUM_THREADS}, best of 3 x {seconds:g} s"
    )
    scene = gym.make("PenaltyBalls-v0").unwrapped.scene
    print(f"PenaltyBalls-v0 physics: {scene.describe()}")
    rates: dict[str, float] = {}
    cases = _cases()

    rates.update(_best_rates(cases, seconds))
    _print_rates(cases, rates)
    _print_targets(rates)
    return rates


if __name__ == "__main__":
    main()
