"""Worker processes: a forked or spawned child steps every path after its parent used them all.

The parent first uses each parallel path the package has: the thread pool (a batched World over
the scalar and SIMD-lanes paths, and ``make_vec`` with enough worlds to split), and Numba's threading
layer (a large World, parallel over its balls; and a batch of them on the pool, each world serial
on its own list). Then a child made by ``fork`` and one made by
``spawn`` do the same. Each must finish (a pool inherited across fork has no threads: work sent to
it would wait forever; GNU OpenMP kills a forked child that uses it after its parent did) and
compute the same trajectories, bit for bit, as the parent.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    import hashlib, multiprocessing as mp, sys
    import numpy as np
    import gymnasium as gym
    import numba
    import penalty_env
    from penalty_env.physics import Bowl, World
    from penalty_env.physics.stepping import runner

    serial_max = runner.SERIAL_MAX_BALLS

    def use_everything():
        out = []
        rng = np.random.default_rng(0)
        x = np.zeros((256, 6, 3))
        x[..., 2] = 0.2 + 0.4 * np.arange(6)
        x[..., 0] = rng.uniform(-1, 1, (256, 6))
        for stepping in ("scalar", "lanes"):
            w = World(x, np.full(6, 0.15), np.full(6, 0.5), terrain=Bowl((0, 0, 8.0), 8.0), ks=2e4, kd=20.0, dt=1e-3,
                      mu=0.3, stepping=stepping)
            w.step(60)
            out.append(hashlib.sha256(w.positions.tobytes()).hexdigest()[:16])
        k = np.arange(6)
        g = np.stack(np.meshgrid(k, k, k, indexing="ij"), -1).reshape(-1, 3).astype(float)
        big = (g - [2.5, 2.5, 0]) * 0.22 + [0, 0, 0.12]
        w = World(big, np.full(len(big), 0.1), np.full(len(big), 1e-3), terrain=Bowl((0, 0, 8.0), 8.0), ks=780.4,
                  kd=0.269, dt=8.58e-5, broadphase="grid")
        assert w.stepping == "neighbour_list"
        w.step(40)  # a world this small steps serially on the list
        out.append(hashlib.sha256(w.positions.tobytes()).hexdigest()[:16])
        runner.SERIAL_MAX_BALLS = 0  # ... and now parallel over its balls, on Numba's threading layer
        w = World(big, np.full(len(big), 0.1), np.full(len(big), 1e-3), terrain=Bowl((0, 0, 8.0), 8.0), ks=780.4,
                  kd=0.269, dt=8.58e-5, broadphase="grid")
        w.step(40)
        out.append(hashlib.sha256(w.positions.tobytes()).hexdigest()[:16])
        runner.SERIAL_MAX_BALLS = serial_max
        pair = np.repeat(big[None], 3, 0)  # a batch on the lists: a share of the worlds per pool thread
        w = World(pair, np.full(len(big), 0.1), np.full(len(big), 1e-3), terrain=Bowl((0, 0, 8.0), 8.0), ks=780.4,
                  kd=0.269, dt=8.58e-5, broadphase="grid")
        w.step(40)
        out.append(hashlib.sha256(w.positions[2].tobytes()).hexdigest()[:16])
        assert out[-1] == out[-2] == out[-3], out  # one algorithm, however it is stepped
        venv = gym.make_vec("PenaltyBalls-v0", num_envs=256)
        obs, _ = venv.reset(seed=0)
        for t in range(5):
            obs = venv.step(np.full((256, 2), 0.5 * (-1) ** t, np.float32))[0]
        out.append(hashlib.sha256(obs.tobytes()).hexdigest()[:16])
        out.append(numba.threading_layer())
        return out

    def child(q):
        q.put(use_everything())

    if __name__ == "__main__":
        parent = use_everything()
        print("parent", parent)
        for method in ("fork", "spawn"):
            ctx = mp.get_context(method)
            q = ctx.Queue()
            p = ctx.Process(target=child, args=(q,))
            p.start()
            p.join(240)
            if p.is_alive():
                p.kill()
                print(method, "HANG")
                sys.exit(3)
            if p.exitcode != 0:
                print(method, "DIED", p.exitcode)
                sys.exit(4)
            got = q.get(timeout=10)
            print(method, got)
            if got[:-1] != parent[:-1]:
                print(method, "DIFFERENT")
                sys.exit(5)
        print("OK")
    """
)


def test_forked_and_spawned_children_step_every_path_after_the_parent(tmp_path):
    script = tmp_path / "children.py"
    script.write_text(SCRIPT)
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=900)
    assert res.returncode == 0 and res.stdout.strip().endswith("OK"), res.stdout[-2000:] + res.stderr[-3000:]
    # the layer the package asks for is fork-safe (GNU OpenMP is not)
    assert "'omp'" not in res.stdout, res.stdout
