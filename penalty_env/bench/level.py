"""Speed of the sand-shaping task: ``python -m penalty_env.bench level [--seconds S] [--lammps]``.

Measures, in one run on this machine, env-steps/s with uniformly random actions (resets on
episode end) of ``gymnasium.make("PenaltySandLevel-v0")``, of v0's grains at v1's contact budget
(``version=`` a ``LevelPhysics``: the softer spring alone, same grain count), of
``PenaltySandLevel-v1`` (2,000 grains) and of the 2D id, of their native vector envs, and of
``PenaltyBallsSand-v1`` (the pushing task through 300 grains) as the peer in the same run, and
prints each as a ratio to the peer's single env and to v0's, with its grain-substeps per second.
Each figure is the best of three interleaved timed windows (after a warm-up that compiles the
kernels and settles the heap), so a burst of load from another process does not set a figure.

``--lammps``: v1's settled bed (2,000 grains, the blade lifted out) stepped at v1's dt by ours
(the scalar path and the neighbour-list path, one thread) and by LAMMPS (``pair_style
granular``: hooke, linear_history, rolling sds; the floor and walls ``fix wall/gran`` planes with
the World's terrain spring; ``bench.peer_lammps``, one thread), interleaved in rounds:
grain-steps per second each.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any

import gymnasium as gym
import numba
import numpy as np

import penalty_env  # noqa: F401  (registers the ids)
from penalty_env.envs.level.scene import LEVEL_VERSIONS, SandLevelScene

PEER = "make PenaltyBallsSand-v1"
V0 = "make PenaltySandLevel-v0"
# v0's grains (250 of 0.06 m, its heap) at v1's contact budget: the softer spring alone
V0_AT_V1_BUDGET = dataclasses.replace(
    LEVEL_VERSIONS[0],
    **{k: getattr(LEVEL_VERSIONS[1], k) for k in ("impact", "overlap", "floor_stiffening", "step_margin")},
)


def _single(env_id: str, **kwargs: Any):
    env = gym.make(env_id, **kwargs)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1.0, 1.0, (256,) + env.action_space.shape).astype(np.float32)

    def run(steps: int) -> int:
        for k in range(steps):
            _, _, term, trunc, _ = env.step(acts[k % 256])
            if term or trunc:
                env.reset()
        return steps

    run.scene = env.unwrapped.scene  # type: ignore[attr-defined]
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

    run.scene = venv.unwrapped.scene  # type: ignore[attr-defined]
    return run


def main(argv=None) -> dict[str, float]:
    parser = argparse.ArgumentParser(prog="python -m penalty_env.bench level", description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="length of one timed window")
    parser.add_argument("--lammps", action="store_true", help="also v1's bed against LAMMPS (grain-steps/s)")
    args = parser.parse_args(argv)
    cases = {
        PEER: _single("PenaltyBallsSand-v1"),
        V0: _single("PenaltySandLevel-v0"),
        "make PenaltySandLevel-v0, v1's budget": _single("PenaltySandLevel-v0", version=V0_AT_V1_BUDGET),
        "make_vec PenaltySandLevel-v0 x 8": _vector("PenaltySandLevel-v0", 8),
        "make PenaltySandLevel-v1": _single("PenaltySandLevel-v1"),
        "make_vec PenaltySandLevel-v1 x 2": _vector("PenaltySandLevel-v1", 2),
        "make PenaltySandLevel2D-v0": _single("PenaltySandLevel2D-v0"),
        "make_vec PenaltySandLevel2D-v0 x 8": _vector("PenaltySandLevel2D-v0", 8),
    }
    scenes = {label: run.scene for label, run in cases.items() if "SandLevel" in label}  # type: ignore[attr-defined]
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
    for label, sc in scenes.items():
        if label.startswith("make "):
            print(f"{label}: {sc.describe()}")
    print(f"{'case':40s} {'env-steps/s':>12s} {'/ ' + PEER:>28s} {'/ v0':>6s} {'grain-substeps/s':>17s}")
    for label, rate in rates.items():
        sc = scenes.get(label)
        grain_rate = f"{rate * sc.n_grains * sc.substeps:17.3g}" if sc is not None else ""
        print(f"{label:40s} {rate:12.1f} {rate / rates[PEER]:28.2f} {rate / rates[V0]:6.2f} {grain_rate}")
    if args.lammps:
        rates.update(bed_against_lammps(scenes["make PenaltySandLevel-v1"]))
    return rates


def bed_against_lammps(scene: SandLevelScene, rounds: int = 3, steps: int = 700) -> dict[str, float]:
    """The scene's settled bed without its blade, ``steps`` steps of its dt per block: ours (the
    scalar path and the neighbour list, one thread) and LAMMPS (one thread), in
    ``rounds`` interleaved rounds; grain-steps/s, the best block of each."""
    from penalty_env.bench.peer_lammps import Lammps, find_lammps, run_lammps
    from penalty_env.physics import World

    n = scene.n_grains
    kwargs = dict(scene.world_kwargs, terrain=scene.world_kwargs["terrain"][: scene.blade_shape])
    worlds = {
        path: World(scene.bed, scene.radii, scene.masses, dt=scene.dt, **dict(kwargs, stepping=path))
        for path in ("scalar", "neighbour_list")
    }
    for w in worlds.values():
        w.step(1)  # compile
    peer = find_lammps()
    rates: dict[str, float] = {}
    saved = numba.get_num_threads()
    try:
        for _ in range(rounds):
            for path, w in worlds.items():
                numba.set_num_threads(1)  # (a spinning world this size steps serially on any count)
                t = time.perf_counter()
                w.step(steps)
                key = f"ours, {path}"
                rates[key] = max(rates.get(key, 0.0), n * steps / (time.perf_counter() - t))
            numba.set_num_threads(saved)
            if isinstance(peer, Lammps):
                w = worlds["neighbour_list"]
                run = run_lammps(
                    peer,
                    scene.bed,
                    np.zeros_like(scene.bed),
                    scene.radii,
                    scene.masses,
                    (0.0, 0.0, 0.0),
                    1.0,
                    scene.ks,
                    scene.kd,
                    (0.0, 0.0, -scene.gravity),
                    scene.dt,
                    steps,
                    w.runner.lists.skin,
                    threads=1,
                    kt=w.kt,
                    kd_t=w.kd_t,
                    mu=float(kwargs["mu"]),
                    mu_r=float(kwargs["mu_r"]),
                    kr=w.kr,
                    omega=np.zeros_like(scene.bed),
                    arena=(scene.half_width, 0.0),
                    ks_wall=scene.ks_terrain,
                    kd_wall=scene.kd_terrain,
                )
                rates["LAMMPS granular, 1 thread"] = max(rates.get("LAMMPS granular, 1 thread", 0.0), run.best)
    finally:
        numba.set_num_threads(saved)
    if not isinstance(peer, Lammps):
        print(f"LAMMPS: {peer}")
    print(f"\nv1's settled bed, {n} grains, dt {scene.dt:.4g} s, {steps} steps per block, best of {rounds} rounds")
    ref = rates.get("LAMMPS granular, 1 thread")
    for key, rate in rates.items():
        ratio = f"{rate / ref:8.2f}" if ref else ""
        print(f"{key:40s} {rate:14.4g} grain-steps/s {ratio}")
    return rates


if __name__ == "__main__":
    main()
