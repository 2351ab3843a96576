"""Soak run: ``python -m penalty_env.bench soak [--env-steps N] [--num-envs B]``.

Steps ``gymnasium.make_vec(env, num_envs=B)`` with uniformly random actions (finite values outside
[-1, 1] included: the env clips them) and autoresets, for N environment steps in all (default 10^7),
and reports: resident memory at the start (after a warm-up) and at every tenth of the run, its
growth (flat within 5% is the pass mark), observations or rewards that are not finite, observations
outside the observation space, exceptions, and the rate. Exits non-zero if a check fails.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np


def _rss_mb() -> float:
    """Resident set size of this process, MB (Linux /proc; ru_maxrss elsewhere)."""
    try:
        with open(f"/proc/{os.getpid()}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:  # pragma: no cover - not Linux
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def soak(
    env_id: str = "PenaltyBalls-v0", env_steps: int = 10_000_000, num_envs: int = 1024, seed: int = 0, log=print
) -> dict:
    import gymnasium as gym

    import penalty_env  # noqa: F401  (registers the ids)

    venv = gym.make_vec(env_id, num_envs=num_envs)
    rng = np.random.default_rng(seed)
    shape = (num_envs,) + venv.single_action_space.shape
    space = venv.single_observation_space
    obs, _ = venv.reset(seed=seed)
    for _ in range(200):  # warm-up: compiled code, pools and caches in place before the first reading
        venv.step(rng.uniform(-1.5, 1.5, shape).astype(np.float32))
    calls = max(1, env_steps // num_envs)
    rss = [_rss_mb()]
    bad_obs = bad_reward = outside = errors = episodes = 0
    t0 = time.perf_counter()
    for k in range(calls):
        try:
            obs, reward, terminated, truncated, _ = venv.step(rng.uniform(-1.5, 1.5, shape).astype(np.float32))
        except Exception as exc:  # the soak counts them; one is a failure
            errors += 1
            log(f"step {k}: {type(exc).__name__}: {exc}")
            obs, _ = venv.reset()
            continue
        bad_obs += int(np.count_nonzero(~np.isfinite(obs)))
        bad_reward += int(np.count_nonzero(~np.isfinite(reward)))
        episodes += int(np.count_nonzero(terminated | truncated))
        if k % 97 == 0:  # the space check costs more than a step: a sample of them
            outside += sum(not space.contains(o) for o in obs)
        if (k + 1) % max(1, calls // 10) == 0:
            rss.append(_rss_mb())
    wall = time.perf_counter() - t0
    growth = max(rss) / rss[0] - 1.0
    result = dict(
        env_steps=calls * num_envs,
        episodes=episodes,
        wall_s=wall,
        rate=calls * num_envs / wall,
        rss_mb=rss,
        rss_growth=growth,
        nonfinite_obs=bad_obs,
        nonfinite_rewards=bad_reward,
        obs_outside_space=outside,
        exceptions=errors,
    )
    result["ok"] = growth <= 0.05 and bad_obs == 0 and bad_reward == 0 and outside == 0 and errors == 0
    return result


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench soak",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--env", default="PenaltyBalls-v0")
    ap.add_argument("--env-steps", type=float, default=1e7, help="environment steps in all (default 1e7)")
    ap.add_argument("--num-envs", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    r = soak(args.env, int(args.env_steps), args.num_envs, args.seed)
    print(
        f"{args.env}: {r['env_steps']:,} env-steps ({r['episodes']:,} episodes) in {r['wall_s']:.1f} s, "
        f"{r['rate']:,.0f} env-steps/s"
    )
    print("resident memory (MB) at the start and every tenth: " + ", ".join(f"{m:.1f}" for m in r["rss_mb"]))
    print(
        f"memory growth {100 * r['rss_growth']:.2f}% (limit 5%); non-finite observations {r['nonfinite_obs']}, "
        f"rewards {r['nonfinite_rewards']}; sampled observations outside the space {r['obs_outside_space']}; "
        f"exceptions {r['exceptions']}"
    )
    print("PASSED" if r["ok"] else "FAILED")
    sys.exit(0 if r["ok"] else 1)


if __name__ == "__main__":
    main()
