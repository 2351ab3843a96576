"""The speed benchmark's peer, LAMMPS, runs the same scene as the World it is compared with
(``penalty_env.bench.peer_lammps``): a ratio of rates means something only if both solve one
problem. Skipped where LAMMPS is not installed (it comes with the ``bench`` extra)."""

from __future__ import annotations

import numpy as np
import pytest

from penalty_env.bench.peer_lammps import find_lammps, run_lammps
from penalty_env.physics import theory
from penalty_env.physics.world import NEIGHBOUR_SKIN
from penalty_env.scenarios import large_world, scene_params

LAMMPS = find_lammps()
pytestmark = pytest.mark.skipif(isinstance(LAMMPS, str), reason=str(LAMMPS))


def test_lammps_collisions_return_the_closed_form_restitution():
    """The benchmark's contact model as LAMMPS gets it (gamma_n = kd / m_eff: m / 2 between two
    balls, m at the Bowl's wall): a head-on pair and a ball flying radially into the wall, gravity
    off, 200 steps per contact, come back with the closed-form restitution of docs/physics.md section 3
    for their m_eff, to 1% (a factor 2 in gamma_n would move e by a factor of about 1.5 or more)."""
    r, m, u, R = 0.5, 1.0, 1.0, 20.0
    ks, kd = scene_params(r, m)
    x = np.array([[-0.51, 0.0, 0.0], [0.51, 0.0, 0.0], [0.0, R - r - 0.01, 0.0]])
    v = np.array([[u / 2, 0.0, 0.0], [-u / 2, 0.0, 0.0], [0.0, u, 0.0]])
    dt = theory.contact_time(ks, kd, m / 2) / 200
    steps = int((0.02 / u + 3.0 * theory.contact_time(ks, kd, m)) / dt)
    run = run_lammps(
        LAMMPS, x, v, [r] * 3, [m] * 3, (0.0, 0.0, 0.0), R, ks, kd, (0.0, 0.0, 0.0), dt, steps, 0.1, final_state=True
    )
    assert (run.v[1, 0] - run.v[0, 0]) / u == pytest.approx(theory.restitution(ks, kd, m / 2), rel=0.01)
    assert -run.v[2, 1] / u == pytest.approx(theory.restitution(ks, kd, m), rel=0.01)


def test_lammps_slumps_the_benchmark_pile_as_the_world_does():
    """400 balls of the benchmark's lattice slump for 1 s under gravity in both codes, from the same
    state with the same ks, kd, dt and skin. The integrators differ (LAMMPS: velocity Verlet; the
    World: symplectic Euler, both first order in the contacts), so the flows differ in detail, but
    the pile's centre of mass falls by the same amount (to 1% of the fall; measured 0.2%, while kd x 3
    or ks x 2 in LAMMPS alone move it by 4% and 2%: the collisions above pin the contact model down
    more sharply) and no ball leaves."""
    w = large_world(400)
    bowl = w.terrain[0]
    x0, v0 = w.positions.copy(), w.velocities.copy()
    steps = int(round(1.0 / w.dt))
    w.step(steps)
    run = run_lammps(
        LAMMPS,
        x0,
        v0,
        w.radii,
        w.masses,
        bowl.center,
        bowl.radius,
        w.ks,
        w.kd,
        w.gravity,
        w.dt,
        steps,
        NEIGHBOUR_SKIN * 2.0 * float(w.radii.max()),
        final_state=True,
    )
    assert run.x.shape == x0.shape and run.steps == steps and run.best > 0.0
    fall_world = x0[:, 2].mean() - w.positions[:, 2].mean()
    fall_lammps = x0[:, 2].mean() - run.x[:, 2].mean()
    assert fall_world > 0.1  # it did slump
    assert fall_lammps == pytest.approx(fall_world, rel=0.01)
    inside = np.linalg.norm(run.x - np.asarray(bowl.center), axis=1) < bowl.radius
    assert inside.all()
