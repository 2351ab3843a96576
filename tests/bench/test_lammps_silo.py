"""The LAMMPS cross-check of the 3D silo (docs/granular.md section 4; ``python -m penalty_env.bench
granular lammps``): the walls are the same in both codes, the rim's contact law is the same, and the
discharge rates agree. The LAMMPS tests are skipped where LAMMPS is not installed (the ``bench``
extra)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from penalty_env.bench import granular as gr
from penalty_env.bench.peer_lammps import find_lammps

LAMMPS = find_lammps()
needs_lammps = pytest.mark.skipif(isinstance(LAMMPS, str), reason=str(LAMMPS))
CFG = gr.LAMMPS_SILO


def _plate_and_rim():
    D, plate, rr = CFG["D"], CFG["plate"], CFG["rim_radius"]
    rim = gr.rim_centres(D, plate, rr, CFG["rim_spacing"])
    terrain = gr.lammps_silo_terrain(CFG["width"], D, 20.0, CFG["catch"], plate, rr, rim)
    return terrain[0], rim, D / 2 + rr, plate, rr


def _rim_overlap(p, rim, r, rr):
    """The deepest overlap of a grain of radius r centred at each of ``p`` with the rim's spheres."""
    d = np.linalg.norm(p[:, None, :] - rim[None], axis=-1).min(axis=1)
    return r + rr - d


def test_the_rim_keeps_the_grains_off_the_plates_edges():
    """Our plate is Difference(Box, Cylinder), a bound of the distance within a grain radius of the
    hole's edges, where LAMMPS's union of regions has no contact at all: the rim must keep every
    grain out of there. A grain (r = 0.5) whose centre lies anywhere within r of either edge of the
    hole, or against the hole's lateral face, overlaps a rim sphere by at least 0.2 d (measured
    0.21; a grain's overlaps in the silo are about 0.01 d). The rim spheres stand at most
    ``rim_spacing`` apart, so this holds between them too."""
    plate, rim, a, t, rr = _plate_and_rim()
    r = 0.5
    rng = np.random.default_rng(0)
    m = 100_000
    rho = a - r * rng.random(m)
    phi = 2.0 * np.pi * rng.random(m)
    for lo, hi in ((0.0, r), (-t - r, -t), (-t, 0.0)):  # over the top edge, under the bottom one, the face
        z = lo + (hi - lo) * rng.random(m)
        p = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=-1)
        assert _rim_overlap(p, rim, r, rr).min() > 0.2


def test_the_plate_touches_a_grain_the_rim_lets_through_only_on_its_top_face():
    """Everywhere a grain can be (its overlap with the rim under 0.05 d), our plate's contact is the
    one LAMMPS's regions give: none over or in the hole (phi >= r there: no phantom surface from
    the hole cylinder's caps, which reach 2 d past the plate), and elsewhere above the plate the
    top face's exact distance, phi = z."""
    plate, rim, a, t, rr = _plate_and_rim()
    r = 0.5
    rng = np.random.default_rng(1)
    m = 200_000
    p = np.stack([rng.uniform(-6.0, 6.0, m), rng.uniform(-6.0, 6.0, m), rng.uniform(-3.0, 3.0, m)], axis=-1)
    rho = np.hypot(p[:, 0], p[:, 1])
    reachable = _rim_overlap(p, rim, r, rr) < 0.05
    phi = plate.phi(p)
    hole = reachable & (rho < a)
    assert hole.sum() > 10_000
    assert phi[hole].min() >= r
    above = reachable & (rho >= a) & (p[:, 2] > 0.0) & (rho < 6.0)
    assert above.sum() > 10_000
    near = above & (phi < r)  # in contact with the plate
    assert near.sum() > 100
    np.testing.assert_allclose(phi[near], p[near, 2], atol=1e-12)


@pytest.mark.slow
@needs_lammps
def test_a_grain_bounces_off_a_rim_sphere_as_off_a_frozen_lammps_grain():
    """The rim's contact law: a spinning grain hits one rim sphere obliquely (gravity on), in our
    World (a static Sphere: ks, kd_terrain = kd, kt, kd_t) and in LAMMPS through the silo's own
    script (a frozen atom: pair granular with gamma_n = kd / m, x_gamma,t = kd_t / kd, m_eff = the
    grain's mass because of fix freeze). The normal rebound agrees to 0.3% (measured 0.12%; pair
    gran/hooke/history's single gamma_n = kd / (m / 2) would double the rim's dashpot, and the
    closed-form restitution of a head-on hit would fall from 0.62 to 0.37), the tangential velocity
    and the spin to 3% (measured 0.3% and 1.8%: LAMMPS's slip velocity takes the radius as the lever
    arm, ours the distance to the overlap's middle, r - overlap / 2; its integrator is velocity
    Verlet)."""
    _, radii, masses, contact, _ = gr.silo_scene(3, int(CFG["n"]), CFG["width"], 2)  # the silo's contact
    rim = np.array([[0.0, 0.0, 8.0]])
    n0, t0 = np.array([-0.6, 0.0, 0.8]), np.array([0.8, 0.0, 0.6])  # the contact normal, a tangent
    start = dict(
        x=rim + 1.01 * n0,
        v=np.array([-1.0 * n0 + 0.4 * t0]),
        w=np.array([[0.0, 3.0, 0.0]]),
    )
    s = gr.SiloState(
        2,
        radii=radii[:1],
        masses=masses[:1],
        contact=contact,
        dt=contact.dt / 4,
        H=12.0,
        rim=rim,
        kt=2.0 / 7.0 * contact.ks,
        kd_t=0.5 * contact.kd,
        **start,
    )
    steps = int(round(0.15 / s.dt))  # the contact lasts t_c = 0.04 (dt = t_c / 60)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        w = gr.ours_silo_world(s)
        w.step(steps)
    lx, lv, lw = gr.lammps_silo_final(s, steps, LAMMPS)
    v, lv, lw, ww = w.velocities[0], lv[0], lw[0], w.angular_velocities[0]
    assert np.linalg.norm(w.positions[0] - rim[0]) > 1.05 and v @ n0 > 0.3  # it bounced and left
    assert lv @ n0 == pytest.approx(v @ n0, rel=3e-3)  # the normal rebound
    assert np.linalg.norm(lv - (lv @ n0) * n0 - (v - (v @ n0) * n0)) < 0.03 * np.linalg.norm(v - (v @ n0) * n0)
    assert np.linalg.norm(lw - ww) < 0.03 * np.linalg.norm(ww)


@needs_lammps
@pytest.mark.slow
def test_silo_discharges_at_the_rate_lammps_gives():
    """One fill of the cross-check's silo (1106 spheres, clear orifice 5 d between the frozen rim
    spheres, mu = 0.5), settled here, discharged from the same state by a World and by LAMMPS: the
    rates over the middle of the discharge agree within 12%. That is three standard deviations of
    one run's ratio: the discharge is chaotic, and one run's rate scatters by about 3% in either
    code (replicas perturbed at 1e-9 d; the outflow's own fluctuations give 3.5%). The issue's 5%
    holds for the mean over fills and replicas, which the bench case measures (``python -m
    penalty_env.bench granular lammps``, docs/granular.md section 4: 0.996 +- 0.017 and 0.982 +-
    0.007); one run cannot resolve it. Measured here 1.042, in 5.6 minutes on the loaded machine."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = gr.lammps_silo(2, verbose=False, lmp=LAMMPS)
    ours, theirs = r["rates"][0], r["rates_lammps"][0]
    assert np.isfinite(ours) and np.isfinite(theirs)  # neither clogged
    assert ours / theirs == pytest.approx(1.0, abs=0.12)
