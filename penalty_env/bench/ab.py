"""Same-run A/B of this tree against another commit: ``python -m penalty_env.bench ab --baseline REV``.

A refactor must keep the speed (docs/performance.md): this times the same scenes in two long-lived
processes, one importing this tree and one a ``git worktree`` of ``REV``, in alternating short
windows (a shared, noisy machine slows both alike), and prints the median ratio per scene with its
spread over rounds. The scenes use only the public API (``World``, ``gymnasium.make``), so any
commit can be the baseline.

Scenes: ``lanes`` (1,024 worlds of 6 balls in a bowl, the SIMD path), ``scalar`` (64 worlds of 40
balls, the grid, one world per thread), ``list`` (one world of 10,000 balls settled in a bowl, the
neighbour list), ``env`` (the single env's step), ``vec`` (the native vector env, 1,024 worlds).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

SCENES = ("lanes", "scalar", "list", "env", "vec")

# the worker: builds the scenes with the public API of whichever tree is on its path, then answers
# "scene seconds" lines with the rate it measured over that window
_WORKER = textwrap.dedent(
    r"""
    import json, sys, time, warnings
    import numpy as np
    warnings.simplefilter("ignore")
    import gymnasium as gym
    import penalty_env  # noqa: F401
    from penalty_env.physics import Bowl, World

    def packed(n, R_ball, seed=0):
        rng = np.random.default_rng(seed)
        a = 2.02 * R_ball
        side = int(np.ceil(n ** (1 / 3))) + 4
        g = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3) * a
        g = g - g.mean(0)
        R = a * side
        g[:, 2] += R
        inside = np.linalg.norm(g - np.array([0, 0, R]), axis=1) < R - 1.5 * R_ball
        g = g[inside]
        g = g[np.argsort(g[:, 2], kind="stable")][:n]
        return g + rng.uniform(-0.005, 0.005, g.shape) * R_ball, Bowl((0.0, 0.0, R), R)

    def world(B, n, settle, **kw):
        x, bowl = packed(n, 0.5)
        x = np.repeat(x[None], B, 0) + np.random.default_rng(1).uniform(-0.01, 0.01, (B, n, 3))
        w = World(x if B > 1 else x[0], np.full(n, 0.5), np.ones(n), terrain=bowl, ks=2e4, kd=40.0, dt=2e-3, **kw)
        w.step(settle)
        return w

    scenes = {}
    def make(name):
        if name == "lanes":
            w = world(1024, 6, 500, broadphase="all_pairs")
            return lambda k: w.step(k), 1024 * 6
        if name == "scalar":
            w = world(64, 40, 500, broadphase="grid")
            return lambda k: w.step(k), 64 * 40
        if name == "list":
            w = world(1, 10000, 2000)
            return lambda k: w.step(k), 10000
        if name == "env":
            env = gym.make("PenaltyBalls-v0")
            env.reset(seed=0)
            a = np.zeros(env.action_space.shape, dtype=np.float32)
            def run(k):
                for _ in range(k):
                    _, _, te, tr, _ = env.step(a)
                    if te or tr:
                        env.reset()
            return run, 1
        if name == "vec":
            venv = gym.make_vec("PenaltyBalls-v0", num_envs=1024)
            venv.reset(seed=0)
            a = np.zeros((1024,) + venv.single_action_space.shape, dtype=np.float32)
            def run(k):
                for _ in range(k):
                    venv.step(a)
            return run, 1024
        raise ValueError(name)

    print("ready", flush=True)
    for line in sys.stdin:
        name, seconds = line.split()
        seconds = float(seconds)
        if name not in scenes:
            run, per = make(name)
            run(2)
            k = 1
            while True:  # a call count that takes about a tenth of the window
                t = time.perf_counter(); run(k); el = time.perf_counter() - t
                if el > seconds / 10 or k > 1 << 24:
                    break
                k *= 2
            scenes[name] = (run, per, k)
        run, per, k = scenes[name]
        calls = 0
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            run(k); calls += k
        print(json.dumps(per * calls / (time.perf_counter() - t0)), flush=True)
    """
)


class _Worker:
    def __init__(self, tree: str, threads: int) -> None:
        env = dict(os.environ, PYTHONPATH=tree, NUMBA_NUM_THREADS=str(threads), PYTHONHASHSEED="0")
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _WORKER],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
            cwd=tree,
        )
        assert self.proc.stdout is not None
        if self.proc.stdout.readline().strip() != "ready":
            raise RuntimeError(f"the benchmark worker for {tree} did not start")

    def time(self, scene: str, seconds: float) -> float:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(f"{scene} {seconds}\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the benchmark worker stopped on scene {scene!r}")
        return float(json.loads(line))

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait(timeout=60)


def _worktree(rev: str) -> tuple[str, str]:
    """A detached worktree of ``rev`` of this repository (path, toplevel)."""
    top = subprocess.run(
        ["git", "rev-parse", "--show-toplevel"], capture_output=True, text=True, check=True, cwd=Path(__file__).parent
    ).stdout.strip()
    path = tempfile.mkdtemp(prefix="penalty_env-ab-")
    subprocess.run(["git", "worktree", "add", "--detach", "-f", path, rev], check=True, capture_output=True, cwd=top)
    return path, top


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench ab", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--baseline", required=True, help="the commit to compare with (e.g. HEAD~1, a hash)")
    ap.add_argument("--scenes", default=",".join(SCENES), help=f"comma-separated, of {', '.join(SCENES)}")
    ap.add_argument("--rounds", type=int, default=20, help="alternating windows per scene and side (default 20)")
    ap.add_argument("--window", type=float, default=0.2, help="seconds per window (default 0.2)")
    ap.add_argument("--threads", type=int, default=1, help="Numba threads of both sides (default 1)")
    ap.add_argument("--this", default=None, help="the tree to measure (default: this package's working tree)")
    args = ap.parse_args(argv)
    scenes = [s for s in args.scenes.split(",") if s]
    for s in scenes:
        if s not in SCENES:
            ap.error(f"--scenes: unknown scene {s!r} (allowed: {', '.join(SCENES)})")
    if args.rounds < 1:
        ap.error(f"--rounds must be >= 1, got {args.rounds}")
    here = args.this or str(Path(__file__).resolve().parents[2])
    base, top = _worktree(args.baseline)
    print(f"A/B: this tree ({here}) against {args.baseline} ({base}); {args.threads} thread(s), {args.rounds} rounds")
    a = b = None
    try:
        a, b = _Worker(here, args.threads), _Worker(base, args.threads)
        print(f"{'scene':>8}  {'this':>12}  {'baseline':>12}  {'ratio':>6}  (median over rounds; spread: 10-90%)")
        for scene in scenes:
            a.time(scene, args.window)  # builds, compiles and warms the scene on both sides
            b.time(scene, args.window)
            ratios, ra, rb = [], [], []
            for k in range(args.rounds):
                first, second = (a, b) if k % 2 == 0 else (b, a)
                x = first.time(scene, args.window)
                y = second.time(scene, args.window)
                this, other = (x, y) if first is a else (y, x)
                ra.append(this)
                rb.append(other)
                ratios.append(this / other)
            q = statistics.quantiles(ratios, n=10) if len(ratios) > 1 else [ratios[0]] * 9
            print(
                f"{scene:>8}  {statistics.median(ra):12.4g}  {statistics.median(rb):12.4g}  "
                f"{statistics.median(ratios):6.3f}  ({q[0]:.3f} to {q[-1]:.3f})",
                flush=True,
            )
    finally:
        for w in (a, b):
            if w is not None:
                w.close()
        subprocess.run(["git", "worktree", "remove", "--force", base], capture_output=True, cwd=top)


if __name__ == "__main__":
    main()
