"""Broad phases, batching and threads change how the work is done, never the physics.

* grid vs all pairs: the same contacts, summed in a different order, so the trajectories agree to
  round-off over a horizon short enough (and a scene damped enough) that chaos does not amplify it;
* B worlds in one World: each world is stepped serially with its own buffers, so a batch is
  bit-identical to each world run alone, whether the batch is split over threads or not;
* the thread count (NUMBA_NUM_THREADS) changes nothing, bit for bit.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from penalty_env.physics import Bowl, World
from penalty_env.physics.world import GRID_MIN_BALLS

ALL_INTEGRATORS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler")


def _bowl_scene(n, d, seed, scatter, radius=None, spacing=0.002):
    rng = np.random.default_rng(seed)
    R = 1.0
    r = radius if radius is not None else (0.06 if d == 3 else 0.05)
    center = np.zeros(d)
    center[-1] = R
    x = scatter(n, d, r, center, R, rng, spacing=spacing)
    v = rng.normal(0.0, 0.5, x.shape)
    return x, v, np.full(n, r), rng.uniform(0.5, 1.5, n), Bowl(tuple(center), R)


@pytest.mark.parametrize("d,n", [(2, 80), (3, 120)])
def test_grid_and_all_pairs_broad_phases_give_the_same_trajectories(scatter, d, n, contact_kwargs):
    x, v, radii, masses, bowl = _bowl_scene(n, d, seed=3, scatter=scatter)
    kw = contact_kwargs(masses)
    worlds = {bp: World(x, radii, masses, v, terrain=bowl, mu=0.3, broadphase=bp, **kw)
              for bp in ("all_pairs", "grid", "auto")}
    assert n >= GRID_MIN_BALLS  # so "auto" chooses the grid
    in_contact = 0
    for _ in range(5):
        for w in worlds.values():
            w.step(200)
        a, g = worlds["all_pairs"], worlds["grid"]
        np.testing.assert_allclose(g.positions, a.positions, rtol=0, atol=1e-10)
        np.testing.assert_allclose(g.velocities, a.velocities, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(worlds["auto"].positions, g.positions)
        assert g.energy() == pytest.approx(a.energy(), rel=1e-12)
        in_contact += g.max_penetration() > 0.0
    assert in_contact == 5, "the scene must be full of contacts for the comparison to mean anything"


def _batched_states(B, n, d, seed, scatter):
    xs, vs = [], []
    radii = masses = bowl = None
    for b in range(B):
        x, v, radii, masses, bowl = _bowl_scene(n, d, seed=seed + b, scatter=scatter, radius=0.12, spacing=0.005)
        xs.append(x)
        vs.append(v)
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.5, 1.5, n)  # shared by the batch
    return np.array(xs), np.array(vs), radii, masses, bowl


@pytest.mark.parametrize(
    "variant",
    [
        pytest.param(dict(broadphase="all_pairs"), id="all_pairs"),
        pytest.param(dict(broadphase="grid", mu=0.3, forces=True), id="grid+friction+forces"),
    ],
)
@pytest.mark.parametrize("integrator", ALL_INTEGRATORS)
def test_batched_worlds_are_bit_identical_to_each_world_alone(scatter, integrator, variant, contact_kwargs):
    variant = dict(variant)
    use_forces = variant.pop("forces", False)
    B, n, d = 5, 12, 3
    x, v, radii, masses, bowl = _batched_states(B, n, d, seed=10, scatter=scatter)
    kw = contact_kwargs(masses, zeta=0.3, omega_dt=0.1)  # explicit Euler needs omega dt <= 2 zeta
    rng = np.random.default_rng(4)
    forces = rng.normal(0.0, 2.0, (B, n, d)) if use_forces else None
    batch = World(x, radii, masses, v, terrain=bowl, integrator=integrator, **variant, **kw)
    singles = [World(x[b], radii, masses, v[b], terrain=bowl, integrator=integrator, **variant, **kw) for b in range(B)]
    # 5 x 12 balls x 400 steps is above World's threshold for spreading worlds over threads
    touched = np.zeros(B, dtype=bool)
    for chunk in (400, 1, 99) + (50,) * 8:
        batch.step(chunk, forces=forces)
        for b, w in enumerate(singles):
            w.step(chunk, forces=None if forces is None else forces[b])
        touched |= batch.max_penetration() > 0.0
    assert touched.all(), "every world must have had contacts"
    for b, w in enumerate(singles):
        np.testing.assert_array_equal(batch.positions[b], w.positions)
        np.testing.assert_array_equal(batch.velocities[b], w.velocities)
        assert batch.energy()[b] == w.energy()


def test_resetting_one_world_of_a_batch_leaves_the_others_untouched(scatter, contact_kwargs):
    B, n, d = 3, 10, 2
    x, v, radii, masses, bowl = _batched_states(B, n, d, seed=20, scatter=scatter)
    kw = contact_kwargs(masses)
    batch = World(x, radii, masses, v, terrain=bowl, integrator="velocity_verlet", **kw)
    batch.step(50)
    before = batch.positions.copy()
    batch.set_state(positions=x[1:2], velocities=v[1:2], worlds=[1])
    np.testing.assert_array_equal(batch.positions[[0, 2]], before[[0, 2]])
    batch.step(50)
    fresh = World(x[1], radii, masses, v[1], terrain=bowl, integrator="velocity_verlet", **kw)
    fresh.step(50)
    np.testing.assert_array_equal(batch.positions[1], fresh.positions)  # Verlet's cached force was reset


_THREAD_SCRIPT = textwrap.dedent(
    """
    import hashlib, math, sys
    import numpy as np
    import numba
    from penalty_env.physics import Bowl, Sphere, World

    out = [str(numba.config.NUMBA_NUM_THREADS)]
    rng = np.random.default_rng(0)
    # a batch: B worlds spread over the thread pool, on the SIMD-lanes path (3 blocks of 64)
    B, n, d = 133, 24, 3
    side = np.arange(3) * 0.25
    lattice = np.array([[a, b, c] for a in side for b in side for c in side])[:n] + [-0.25, -0.25, 0.2]
    x = lattice[None] + rng.normal(0, 0.01, (B, n, d))
    v = rng.normal(0, 0.5, (B, n, d))
    kw = dict(ks=1e4, kd=2 * 0.2 * math.sqrt(1e4 * 0.5), dt=0.2 / math.sqrt(2e4))
    w = World(x, np.full(n, 0.11), np.ones(n), v, terrain=Bowl((0, 0, 1.0), 1.0), mu=0.3, **kw)
    w.step(300)
    out.append(hashlib.sha256(w.positions.tobytes() + w.velocities.tobytes()).hexdigest())
    # a large world: its force loop runs in parallel over balls
    k = 16
    g = np.arange(k) * 0.196
    big = np.array([[a, b, c] for a in g for b in g for c in g]) - [1.47, 1.47, -0.11]
    big = big + rng.normal(0, 0.005, big.shape)
    wl = World(big, np.full(k**3, 0.1), np.ones(k**3), terrain=Bowl((0, 0, 3.0), 3.0), broadphase="grid", **kw)
    for _ in range(3):  # past a re-sort of its storage
        wl.step(20)
    out.append(hashlib.sha256(wl.positions.tobytes() + wl.velocities.tobytes()).hexdigest())
    print(" ".join(out))
    """
)


def test_results_do_not_depend_on_the_thread_count():
    digests = {}
    for threads in (1, 2):
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
        res = subprocess.run([sys.executable, "-c", _THREAD_SCRIPT], env=env, capture_output=True, text=True, timeout=600)
        assert res.returncode == 0, res.stderr[-3000:]
        seen, *hashes = res.stdout.split()
        assert seen == str(threads)
        digests[threads] = hashes
    assert digests[1] == digests[2]
