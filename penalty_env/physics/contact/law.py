"""The contact law, once: every stepping path evaluates a contact with these functions.

A contact is a spring plus a dashpot along the contact normal, acting while two bodies overlap
(the course notes, section 2), with the options of the DEM codes:

* :func:`normal_force`: ``f_n = ks pen - kd v_n`` along the outward normal of the body pushed
  (pen > 0 the overlap, v_n the rate at which the gap opens), and with ``no_tension`` never a pull
  (LAMMPS ``limit_damping``: the linear dashpot pulls the bodies together as they separate);
* :func:`regularised_ratio`: regularised Coulomb friction (as NVIDIA Warp),
  ``|f_t| = min(kf |v_t|, mu |f_n|)`` against the sliding velocity v_t; with the rolling angular
  velocity, the torque lever R* and ``kr``, ``mu_r`` in their place, the same function is rolling
  resistance (Ai, Chen, Rotter and Ooi 2011, model A, regularised);
* :func:`history_spring`: the tangential spring with history of Cundall and Strack (1979), as LAMMPS
  ``gran/hooke/history``: a displacement xi carried from step to step (turned into the current
  tangent plane, its length kept), ``xi += s_t dt``, ``f_t = -kt xi - kd_t s_t``, capped at
  ``mu |f_n|`` (the spring then holds what the cap allows);
* :func:`lever`: the lever arm from a ball's centre to the contact point, the middle of the overlap.

Units are the caller's: ``ks`` force per length, ``kd`` force per speed, ``kf`` force per sliding
speed, ``kr`` torque per angular speed. Sign conventions: an overlap is a positive length; a normal
points out of the body that pushes.

Every caller, and the test that pins it to the law
--------------------------------------------------
The law is called where each path has its geometry ready; the paths differ in how they find the
contacts and where they add the forces, never in the law.

=====================================  ==========================================  =============================================
caller                                 what it is                                  pinned by
=====================================  ==========================================  =============================================
``contact.pair.pair_force``            a ball pair, scalar (every integrator)      ``tests/physics/test_validation.py`` etc.: closed forms
``contact.terrain.terrain_force``      a ball and every terrain shape, scalar      ``tests/physics/test_geometry.py``: closed forms
``contact.lanes.pair_lanes``           the pair, one world per SIMD lane           ``tests/physics/test_stepping_paths.py``: bit for bit
``contact.lanes.terrain_lanes``        the terrain, one world per SIMD lane        ``tests/physics/test_stepping_paths.py``: bit for bit
``contact.listed.block_law``           neighbour-list pairs, a block at a time     ``tests/physics/test_neighbour_list.py``: round-off
``contact.spin.spin_pair``             a pair of spinning balls                    ``tests/physics/test_rotation.py``: bit for bit at mu = 0
``contact.spin.spin_terrain``          a spinning ball and the terrain             ``tests/physics/test_rotation.py``: bit for bit at mu = 0
=====================================  ==========================================  =============================================

The functions are written select-style (a value chosen by a comparison, not a branch around
work), so LLVM vectorises the SIMD and neighbour-list loops that call them.
"""

from __future__ import annotations

import math

from ..._jit import njit

__all__ = ["normal_force", "regularised_ratio", "history_spring", "turn_into_plane", "lever", "cross"]


@njit(hot=True)
def normal_force(ks, kd, pen, vn, no_tension):
    """The normal force along the outward normal of the pushing body: ``ks pen - kd vn`` for an
    overlap ``pen`` and a separation rate ``vn`` (> 0 opening); 0 instead of a pull when
    ``no_tension``."""
    fn = ks * pen - kd * vn
    if no_tension:
        fn = 0.0 if fn < 0.0 else fn
    return fn


@njit(hot=True)
def regularised_ratio(slope, mu, fn, speed2, select):
    """``|f| / |u|`` of a regularised Coulomb law, ``|f| = min(slope |u|, mu |f_n|)`` against a
    relative motion u of squared size ``speed2`` (0 when at rest). Friction: u the sliding
    velocity, ``slope`` kf; rolling resistance: u the rolling angular velocity, ``slope`` kr and
    ``mu`` mu_r R*.

    ``select`` (a constant at each call site, folded once inlined): True for the block passes that
    vectorise (both outcomes computed, one selected), False for the scalar paths (a branch skips
    what a case does not need). The same values either way, to the bit; likewise in
    :func:`turn_into_plane` and :func:`history_spring`."""
    if select:
        speed = math.sqrt(speed2)
        ratio = min(slope * speed, mu * abs(fn)) / speed
        return ratio if speed2 > 0.0 else 0.0  # (at rest 0, the ratio's 0 / 0 unused)
    if not speed2 > 0.0:
        return 0.0
    speed = math.sqrt(speed2)
    return min(slope * speed, mu * abs(fn)) / speed


@njit(hot=True)
def turn_into_plane(x0, x1, x2, n0, n1, n2, select):
    """A continuing contact's spring displacement turned into the current tangent plane (normal
    n), its length kept (a new contact's zero spring stays zero). ``select``: as
    :func:`regularised_ratio`'s."""
    old = x0 * x0 + x1 * x1 + x2 * x2
    xn = x0 * n0 + x1 * n1 + x2 * n2
    x0 -= xn * n0
    x1 -= xn * n1
    x2 -= xn * n2
    new = x0 * x0 + x1 * x1 + x2 * x2
    if not select:
        if new > 0.0:
            scale = math.sqrt(old / new)
            return x0 * scale, x1 * scale, x2 * scale
        return x0, x1, x2
    scale = math.sqrt(old / new)
    turned = new > 0.0  # (selects: along n, or zero, the spring is left as it is)
    return (x0 * scale if turned else x0), (x1 * scale if turned else x1), (x2 * scale if turned else x2)


@njit(hot=True)
def history_spring(x0, x1, x2, s0, s1, s2, fn, kt, kd_t, mu, dt, select):
    """One step of the tangential spring with history: the displacement xi (already in the tangent
    plane; zero for a new contact) grows by the slip s dt, the force is ``-kt xi - kd_t s``, capped
    at ``mu |fn|`` (then xi = -(f + kd_t s) / kt). Returns the force and the new displacement.
    ``select``: as :func:`regularised_ratio`'s."""
    cap = mu * abs(fn)
    x0 += s0 * dt
    x1 += s1 * dt
    x2 += s2 * dt
    f0 = -kt * x0 - kd_t * s0
    f1 = -kt * x1 - kd_t * s1
    f2 = -kt * x2 - kd_t * s2
    f2n = f0 * f0 + f1 * f1 + f2 * f2
    if not select:
        if f2n > cap * cap:  # sliding: the force at the cap, the spring at what the cap allows
            scale = cap / math.sqrt(f2n)
            f0 *= scale
            f1 *= scale
            f2 *= scale
            x0 = -(f0 + kd_t * s0) / kt
            x1 = -(f1 + kd_t * s1) / kt
            x2 = -(f2 + kd_t * s2) / kt
        return f0, f1, f2, x0, x1, x2
    # (selects: both are computed)
    sliding = f2n > cap * cap
    scale = cap / math.sqrt(f2n)
    g0 = f0 * scale
    g1 = f1 * scale
    g2 = f2 * scale
    y0 = -(g0 + kd_t * s0) / kt
    y1 = -(g1 + kd_t * s1) / kt
    y2 = -(g2 + kd_t * s2) / kt
    return (
        g0 if sliding else f0,
        g1 if sliding else f1,
        g2 if sliding else f2,
        y0 if sliding else x0,
        y1 if sliding else x1,
        y2 if sliding else x2,
    )


@njit(hot=True)
def lever(radius, overlap):
    """The lever arm from a ball's centre to the contact point, the middle of the overlap (a pair's
    two levers add up to the centres' distance, so its torques conserve angular momentum)."""
    return radius - 0.5 * overlap


@njit(hot=True)
def cross(a0, a1, a2, b0, b1, b2):
    """a x b."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
