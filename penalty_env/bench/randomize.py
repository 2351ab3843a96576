"""Cost of per-world domain randomisation: ``python -m penalty_env.bench randomize [--seconds S]
[--worlds N] [--no-compile]``.

Measures, in one run on this machine, the env-steps/s of the native vector env
(``PenaltyBallsVectorEnv``, random actions, resets on episode end) at 1,024 worlds, fixed and
randomised (``randomize=RANGES``), for ``PenaltyBalls-v0`` (slide, the SIMD-lanes path) and
``PenaltyBalls-v1`` (roll, the scalar path), in interleaved rounds (best of six windows each, the order
swapped every round, so a burst of load from another process hits every case alike), and prints the ratio randomised /
fixed (the target: >= 0.9). Twice: with the worlds' episodes in step (all worlds reset together
at the time limit, as a freshly reset vector env runs) and staggered (each world's step count
starts at a random point, so about N / max_episode_steps worlds reset at every step, as in a long
training run: this prices the per-reset cost of drawing and deriving the physics). Then (unless ``--no-compile``) the first make's compile time of each,
each in a fresh process with an empty Numba cache: make, reset and one step.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np

from penalty_env.envs.penalty_balls import PenaltyBallsVectorEnv

# the example ranges (its restitution floor raised into the allowed range)
# plus the motor and the radii: ranges whose corners the fixed scene's substep already covers
RANGES: dict[str, tuple[float, float]] = {
    "ball_mass": (0.5, 2.0),
    "friction": (0.2, 0.8),
    "restitution": (0.3, 0.6),
    "max_force": (15.0, 20.0),
    "ball_radius": (0.15, 0.2),
}
TARGET = 0.9
ROUNDS = 6  # timed windows per case (best of them), fixed and randomised alternating, the first of each pair swapped
CASES = (("v0", "sliding"), ("v1", "rolling"))
MODES = ("in step", "staggered")


def _env(physics: str, worlds: int, randomize: dict | None) -> PenaltyBallsVectorEnv:
    return PenaltyBallsVectorEnv(worlds, physics=physics, randomize=randomize)


def _rate(env: PenaltyBallsVectorEnv, calls: int, rng: np.random.Generator) -> float:
    actions = rng.uniform(-1, 1, (calls,) + env.action_space.shape)
    t = time.perf_counter()
    for a in actions:
        env.step(a)
    return calls * env.num_envs / (time.perf_counter() - t)


def _compile_seconds(physics: str, randomize: bool) -> float:
    """Seconds Numba compiles for a first make, reset and step in a fresh process (empty cache)."""
    code = (
        "import time, json\n"
        "from penalty_env._jit import _CompileWatch\n"
        "from numba.core import event\n"
        "w = _CompileWatch(); event.register('numba:compile', w)\n"
        "from penalty_env.envs.penalty_balls import PenaltyBallsVectorEnv\n"
        "import numpy as np\n"
        f"env = PenaltyBallsVectorEnv(1024, physics={physics!r}, randomize={RANGES if randomize else None!r})\n"
        "env.reset(seed=0); env.step(np.zeros((1024,) + env.single_action_space.shape))\n"
        "print(json.dumps(w.seconds))\n"
    )
    with tempfile.TemporaryDirectory(prefix="penalty_env-bench-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def main(argv: Any = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m penalty_env.bench randomize", description=__doc__)
    ap.add_argument("--seconds", type=float, default=2.0, help="length of each timed window")
    ap.add_argument("--worlds", type=int, default=1024)
    ap.add_argument("--no-compile", action="store_true", help="skip the first-make compile times")
    args = ap.parse_args(argv)
    print(f"randomize={RANGES}")
    rng = np.random.default_rng(0)
    rows = []
    for (version, physics), mode in ((c, m) for c in CASES for m in MODES):
        fixed, rand = _env(physics, args.worlds, None), _env(physics, args.worlds, RANGES)
        for env in (fixed, rand):
            env.reset(seed=0)
            if mode == "staggered":  # (the same step counts in both)
                env.batch.steps[:] = np.random.default_rng(1).integers(0, env.batch.max_episode_steps, env.num_envs)
            _rate(env, 5, rng)  # warm-up (compiles)
        t = time.perf_counter()
        _rate(fixed, 5, rng)
        calls = max(5, int(args.seconds / max((time.perf_counter() - t) / 5, 1e-9)))
        best = {"fixed": 0.0, "randomised": 0.0}
        for r in range(ROUNDS):  # interleaved windows, the order swapped every round
            for kind in ("fixed", "randomised")[:: 1 if r % 2 == 0 else -1]:
                best[kind] = max(best[kind], _rate(fixed if kind == "fixed" else rand, calls, rng))
        ratio = best["randomised"] / best["fixed"]
        subs = (fixed.scene.substeps, rand.scene.substeps)
        rows.append((version, best, ratio, subs))
        print(
            f"PenaltyBalls-{version} x {args.worlds}, episodes {mode}: fixed {best['fixed']:,.0f} env-steps/s, randomised "
            f"{best['randomised']:,.0f} env-steps/s (substeps {subs[0]} / {subs[1]}): ratio {ratio:.3f} "
            f"({'meets' if ratio >= TARGET else 'misses'} the target >= {TARGET})"
        )
    if not args.no_compile:
        for version, physics in CASES:
            cold = {kind: _compile_seconds(physics, kind == "randomised") for kind in ("fixed", "randomised")}
            print(
                f"PenaltyBalls-{version}: first make's compile (empty cache): fixed {cold['fixed']:.1f} s, "
                f"randomised {cold['randomised']:.1f} s"
            )


if __name__ == "__main__":
    main()
