"""The broad phase changes how contacts are found, never the physics.

Grid vs all pairs: the same contacts, summed in a different order, so the trajectories agree to
round-off over a horizon short enough (and a scene damped enough) that chaos does not amplify it.
(Batching, stepping paths and threads: ``test_stepping_paths.py``.)
"""

from __future__ import annotations

import numpy as np
import pytest

from penalty_env.physics import World
from penalty_env.physics.world import GRID_MIN_BALLS
from penalty_env.scenarios import balls_in_bowl


@pytest.mark.parametrize("d,n", [(2, 80), (3, 120)])
def test_grid_and_all_pairs_broad_phases_give_the_same_trajectories(d, n, contact_kwargs):
    x, v, radii, _, bowl = balls_in_bowl(n, d, seed=3, radius=0.06 if d == 3 else 0.05, spacing=0.002, speed=0.8)
    x, v = x[0], v[0]
    masses = np.random.default_rng(3).uniform(0.5, 1.5, n)
    kw = contact_kwargs(masses)
    worlds = {
        bp: World(x, radii, masses, v, terrain=bowl, mu=0.3, broadphase=bp, **kw)
        for bp in ("all_pairs", "grid", "auto")
    }
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
