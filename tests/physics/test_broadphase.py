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


@pytest.mark.parametrize("d,n", [pytest.param(2, 80, marks=pytest.mark.slow), (3, 120)])
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


@pytest.mark.parametrize(
    "d,rotation",
    # each case compiles its own force kernel: the sand env's (3D, rotating) in the default run
    [(3, True), pytest.param(3, False, marks=pytest.mark.slow), pytest.param(2, True, marks=pytest.mark.slow)],
)
def test_lead_balls_meet_every_ball_directly_and_small_cells_still_find_every_contact(d, rotation, contact_kwargs):
    """``World(grid_lead=k)``: the first k balls (here two large ones among small grains) stay out
    of the grid and meet every ball directly; the grid's cells are sized for the small balls only.
    A step is that of all pairs, to round-off (velocities and spins): no contact is lost."""
    n = 60 if d == 2 else 120
    x, v, radii, _, bowl = balls_in_bowl(n, d, seed=5, radius=0.05, spacing=0.002, speed=0.8)
    radii = radii.copy()
    radii[:2] = 0.2  # two large balls first, sunk into the small ones
    x = x.copy()
    x[0, 0, :] = x[0, n // 3, :] + 0.1
    x[0, 1, :] = x[0, 2 * n // 3, :] - 0.1
    masses = np.random.default_rng(5).uniform(0.5, 1.5, n)
    kw = contact_kwargs(masses)
    common = dict(terrain=bowl, mu=0.3, rotation=rotation, allow_unstable=True, stepping="scalar", **kw)
    every = World(x[0], radii, masses, v[0], broadphase="all_pairs", **common)
    lead = World(x[0], radii, masses, v[0], broadphase="grid", grid_lead=2, **common)
    assert lead.model.cell_size == 2.0 * float(radii[2:].max())  # cells of the grains' size
    contacts_large = np.sum(np.linalg.norm(x[0, :2, None] - x[0, None, 2:], axis=-1) < radii[:2, None] + 0.05)
    assert contacts_large >= 4, "the large balls must touch grains for the comparison to mean anything"
    every.step(1)
    lead.step(1)
    dv = every.velocities - v[0]
    np.testing.assert_allclose(lead.velocities - v[0], dv, rtol=0, atol=1e-12 * np.abs(dv).max())
    if rotation:
        w = every.angular_velocities
        np.testing.assert_allclose(lead.angular_velocities, w, rtol=0, atol=1e-12 * np.abs(w).max())
