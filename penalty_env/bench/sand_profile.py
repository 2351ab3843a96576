"""Where a sand env's physics step goes: ``python -m penalty_env.bench sand_profile [--env-id ID]``.

One world of ``PenaltyBallsSand-v1`` (or ``--env-id``), 30 steps into an episode of random actions,
its contact pass taken apart on one thread: the grid's counting sort, the pair scan (every candidate
pair's distance test, no force), the terrain pass alone, and the whole rotating contact pass
(scan, pair law and terrain: :func:`~penalty_env.physics.contact.spin.spin_forces`); the pair law's
share is the whole pass less the scan and the terrain. Beside them, the env's step (its substeps,
the integration, the observation and Python) timed through ``env.step``. Each figure is the best
of three windows, in microseconds per physics substep. Last, how many grains of a bed left alone
for 5 s still move (regularised Coulomb friction has no static friction: the bed creeps).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numba
import numpy as np

import penalty_env  # noqa: F401 (registers the ids)

from .._jit import njit
from ..physics.broadphase.grid import build_grid
from ..physics.broadphase.partners import partner, partners
from ..physics.contact.pair import pair_geometry
from ..physics.contact.spin import spin_forces, spin_terrain


@njit(entry=True)
def _grid(N, x, grid, cell_size):  # type: ignore[no-untyped-def]
    for _ in range(N):
        build_grid(0, x, grid, cell_size, 3)


@njit(entry=True)
def _scan(N, x, grid, buf, model):  # type: ignore[no-untyped-def]
    """The pair scan alone: (contacts, distance tests) of one pass."""
    touching = tests = 0
    for _ in range(N):
        touching = tests = 0
        for i in range(x.shape[1]):
            rows, direct = partners(0, i, x, grid, buf, 3)
            for r in range(rows):
                for idx in range(buf[2 * r], buf[2 * r + 1]):
                    j = partner(grid, 0, idx, direct)
                    if j > i:
                        touching += pair_geometry(0, i, j, x, model, 3)[0]
                        tests += 1
    return touching, tests


@njit(entry=True)
def _terrain(N, x, v, a, model, spin):  # type: ignore[no-untyped-def]
    for _ in range(N):
        for i in range(x.shape[1]):
            spin_terrain(0, i, x, v, a, model, spin, 3)


@njit(entry=True)
def _forces(N, x, v, a, grid, buf, model, spin):  # type: ignore[no-untyped-def]
    for _ in range(N):
        spin_forces(0, x, v, a, grid, buf, model, spin, 3)


def _best_us(f, args: tuple, n: int) -> tuple[float, object]:
    """Best of three windows of ``f(n, *args)``, microseconds per pass, and its result."""
    f(1, *args)
    best, out = np.inf, None
    for _ in range(3):
        t = time.perf_counter()
        out = f(n, *args)
        best = min(best, (time.perf_counter() - t) / n * 1e6)
    return best, out


def profile(env_id: str = "PenaltyBallsSand-v1", passes: int = 2000) -> dict[str, float]:
    """The parts' microseconds per substep (see the module docstring), and the counts."""
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(30):
        env.step(env.action_space.sample())
    scene = env.unwrapped.scene
    world = scene.world
    if world.dim != 3 or world.spin is None or world.stepping != "scalar":
        raise ValueError(f"--env-id {env_id!r}: profiles a 3D scene of rolling balls on the scalar path")
    model, spin, grid = world.model, world.spin, world.runner.grid
    x = world.runner.state.positions.copy()  # (1, n, 3)
    v = world.runner.state.velocities.copy()
    a = np.zeros_like(x)
    buf = np.zeros(64, dtype=np.int64)
    fig: dict[str, float] = {}
    fig["grid build"], _ = _best_us(_grid, (x, grid, model.cell_size), passes)
    fig["pair scan"], (contacts, tests) = _best_us(_scan, (x, grid, buf, model), passes)
    fig["terrain"], _ = _best_us(_terrain, (x, v, a, model, spin), passes)
    fig["contact pass"], _ = _best_us(_forces, (x, v, a, grid, buf, model, spin), passes)
    fig["pair law"] = fig["contact pass"] - fig["pair scan"] - fig["terrain"]
    steps, t = 0, time.perf_counter()
    while time.perf_counter() - t < 2.0:
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        steps += 1
        if term or trunc:
            env.reset()
    fig["env step"] = (time.perf_counter() - t) / steps / scene.substeps * 1e6
    fig.update(contacts=float(contacts), tests=float(tests), balls=float(x.shape[1]), substeps=float(scene.substeps))
    # the bed left alone: how many grains still move (what sleeping grains would have to wait for)
    env.reset(seed=1)
    for _ in range(50):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    speed = np.linalg.norm(world.velocities.reshape(-1, 3)[scene.n_bodies :], axis=1)
    fig["creeping 3 mm/s"] = float(np.mean(speed > 3e-3))
    fig["creeping 1 cm/s"] = float(np.mean(speed > 1e-2))
    return fig


def main(argv=None) -> dict[str, float]:
    ap = argparse.ArgumentParser(prog="python -m penalty_env.bench sand_profile", description=__doc__.split("\n")[0])
    ap.add_argument("--env-id", default="PenaltyBallsSand-v1", help="a 3D sand id (default: %(default)s)")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    f = profile(args.env_id)
    step = f["env step"]
    print(
        f"{args.env_id}: {int(f['balls'])} balls, {int(f['substeps'])} substeps per step, "
        f"{int(f['contacts'])} ball pairs touching of {int(f['tests'])} tested; one thread, us per substep"
    )
    for part in ("grid build", "pair scan", "terrain", "pair law", "contact pass", "env step"):
        print(f"  {part:<13} {f[part]:8.1f}   {100 * f[part] / step:5.1f}% of the env step")
    print(f"  pair law per touching pair: {1e3 * f['pair law'] / max(f['contacts'], 1):.0f} ns")
    print(
        f"the bed after 5 s with the pusher still: {f['creeping 3 mm/s']:.0%} of the grains move faster than "
        f"3 mm/s, {f['creeping 1 cm/s']:.0%} faster than 1 cm/s"
    )
    return f


if __name__ == "__main__":
    main()
