"""Contacts of spinning balls: the normal law, then slip, the tangential force, its torque and
rolling resistance (docs/physics.md, "Rotation").

With ``World(rotation=True)`` each ball carries an angular velocity (3 components in 3D, 1 in 2D,
about the axis out of the plane) and the moment of inertia of a solid sphere, I = 2/5 m r^2, or of
a disk, I = 1/2 m r^2. For a contact of unit normal n (from ball i towards the other body) at the
middle of the overlap (lever arms l_i = r_i - overlap/2, :func:`.law.lever`):

* the normal force is the law's (:func:`.law.normal_force`);
* the slip velocity of ball i's surface against the other's at the contact,
  ``s = (v_i + w_i x l_i n) - (v_j + w_j x (-l_j n))``, tangential part (a moving terrain shape's
  surface velocity in place of ball j's);
* the tangential force on i, against the slip: regularised Coulomb (``tangential="coulomb"``,
  :func:`.law.regularised_ratio`) or the spring with history (``tangential="history"``,
  :func:`.law.history_spring`), capped at mu |f_n|;
* the torque on i, ``l_i n x f_t`` (on j: ``l_j n x f_t``, with -f_t its force);
* rolling resistance (``mu_r > 0``): ``|M_r| = min(kr |w_r|, mu_r R* |f_n|)`` against the
  tangential part w_r of w_i - w_j (the twist about n is left free), R* = r_i r_j / (r_i + r_j)
  (r_i at the terrain): the law's regularised ratio again.

The history lives in :attr:`.model.Spin.hist`, addressed by a row and a slot. On the scalar path
that is one slot per ball pair (i < j, at ``[b, i, j]``) and per ball and terrain shape (at
``[b, i, n + s]``, s the shape's row in the table); the neighbour-list path keeps a
:class:`~.model.Spin` of its own whose rows are its storage slots and whose slots are the list's
(``[0, i, m]`` for i's m-th listed partner, ``[0, i, cap + s]`` for shape s; an escaped ball's pairs
that the list does not hold have a table of their own: :mod:`..broadphase.history`). The same
functions serve both: only the address differs. Each slot has a stamp: a slot written in the step
before is a continuing contact, any other is a new one (xi starts at zero). The step counter is
per world, so the history does not depend on the thread count or on which worlds share a batch.
"""

from __future__ import annotations

from ..._jit import njit
from ..broadphase.partners import partner, partners
from ..geometry.evaluate import is_direct, is_moving, shape_miss, shape_sdf, surface_velocity
from .law import cross, history_spring, lever, normal_force, regularised_ratio, turn_into_plane
from .pair import pair_geometry
from .terrain import terrain_law

__all__ = [
    "spin_pair",
    "spin_pair_law",
    "tangential_law",
    "spin_terrain",
    "spin_terrain_contact",
    "spin_shapes",
    "spin_forces",
    "tangential_force",
    "rolling_torque",
]


@njit(hot=True)
def tangential_law(h0, h1, h2, fn, s0, s1, s2, n0, n1, n2, mu, kf, kt, kd_t, dt, select):
    """The tangential force (f0, f1, f2) on a ball whose surface slips at s (tangential) against
    the other body, in contact along n with normal force fn, and the spring after the step (x0, x1,
    x2): with ``kt`` > 0 the spring with history (h the contact's spring from the step before, turned
    into the tangent plane; zero for a new contact), else regularised Coulomb (x zero).
    The branch on ``kt`` is the same for every contact of a world (so the scalar path skips the
    spring it does not have, and the block pass of :mod:`.listed_spin` still vectorises: a loop
    invariant); ``select``: as :func:`.law.regularised_ratio`'s (True in the block pass)."""
    if kt > 0.0:
        x0, x1, x2 = turn_into_plane(h0, h1, h2, n0, n1, n2, select)
        return history_spring(x0, x1, x2, s0, s1, s2, fn, kt, kd_t, mu, dt, select)
    st2 = s0 * s0 + s1 * s1 + s2 * s2
    k = regularised_ratio(kf, mu, fn, st2, select)
    slips = st2 > 0.0
    return (-k * s0 if slips else 0.0), (-k * s1 if slips else 0.0), (-k * s2 if slips else 0.0), 0.0, 0.0, 0.0


@njit(hot=True)
def tangential_force(spin, b, row, slot, fn, s0, s1, s2, n0, n1, n2, mu, kf, D):
    """:func:`tangential_law` with the spring's store: ``spin.hist[b, row, slot]`` read and written
    (``spin.kt`` > 0), continuing when its stamp is the world's clock."""
    if spin.kt > 0.0:
        h = spin.hist
        continuing = spin.stamp[b, row, slot] == spin.clock[b]
        h0 = h[b, row, slot, 0] if continuing else 0.0
        h1 = h[b, row, slot, 1] if continuing else 0.0
        h2 = h[b, row, slot, 2] if continuing and D == 3 else 0.0
        f0, f1, f2, x0, x1, x2 = tangential_law(
            h0, h1, h2, fn, s0, s1, s2, n0, n1, n2, mu, kf, spin.kt, spin.kd_t, spin.dt, False
        )
        h[b, row, slot, 0] = x0
        h[b, row, slot, 1] = x1
        h[b, row, slot, 2] = x2
        spin.stamp[b, row, slot] = spin.clock[b] + 1
        return f0, f1, f2
    f0, f1, f2, _, _, _ = tangential_law(0.0, 0.0, 0.0, fn, s0, s1, s2, n0, n1, n2, mu, kf, 0.0, 0.0, 0.0, False)
    return f0, f1, f2


@njit(hot=True)
def rolling_torque(spin, fn, reff, r0, r1, r2, select):
    """The rolling-resistance torque on a ball whose rolling angular velocity (relative to the
    other body, tangential part) is w_r."""
    wr2 = r0 * r0 + r1 * r1 + r2 * r2
    k = regularised_ratio(spin.kr, spin.mu_r * reff, fn, wr2, select)
    rolls = wr2 > 0.0
    return (-k * r0 if rolls else 0.0), (-k * r1 if rolls else 0.0), (-k * r2 if rolls else 0.0)


@njit(hot=True)
def _omega(spin, b, i, D):
    """Ball i's angular velocity as a 3-vector (2D: about the out-of-plane axis)."""
    if D == 3:
        return spin.w[b, i, 0], spin.w[b, i, 1], spin.w[b, i, 2]
    return 0.0, 0.0, spin.w[b, i, 0]


@njit(hot=True)
def _add_torque(spin, b, i, t0, t1, t2, D):
    if D == 3:
        spin.alpha[b, i, 0] += t0
        spin.alpha[b, i, 1] += t1
        spin.alpha[b, i, 2] += t2
    else:
        spin.alpha[b, i, 0] += t2


@njit(hot=True)
def spin_pair_law(overlap, n0, n1, n2, u0, u1, u2, wi0, wi1, wi2, wj0, wj1, wj2, ri, rj, h, model, spin, D, select):
    """The law of two touching spinning balls i and j: overlap, unit normal n (i to j), relative
    velocity u = v_j - v_i, angular velocities w_i, w_j (3-vectors), radii; ``h`` the pair's spring
    from the step before (3 numbers, from i's side; zeros for a new contact). Select-style, so the
    block pass of :mod:`.listed_spin` vectorises it (and the same values as branches). Returns the force on i (f; -f on j), n x f_t
    (q: the torque on i is l_i q, on j l_j q), the levers l_i, l_j, the rolling-resistance torque on
    i (m; -m on j) and the spring after the step (x; zero without history)."""
    vn = u0 * n0 + u1 * n1 + u2 * n2
    fn = -normal_force(model.ks, model.kd, overlap, vn, model.no_tension)  # along +n on i
    li = lever(ri, overlap)
    lj = lever(rj, overlap)
    # slip of i's surface against j's: -(v_j - v_i) + (l_i w_i + l_j w_j) x n, tangential part
    c0, c1, c2 = cross(li * wi0 + lj * wj0, li * wi1 + lj * wj1, li * wi2 + lj * wj2, n0, n1, n2)
    s0 = c0 - u0
    s1 = c1 - u1
    s2 = c2 - u2 if D == 3 else 0.0
    sn = s0 * n0 + s1 * n1 + s2 * n2
    s0 -= sn * n0
    s1 -= sn * n1
    s2 -= sn * n2
    t0 = t1 = t2 = x0 = x1 = x2 = 0.0
    q0 = q1 = q2 = m0 = m1 = m2 = 0.0
    if model.mu > 0.0:
        t0, t1, t2, x0, x1, x2 = tangential_law(
            h[0], h[1], h[2], fn, s0, s1, s2, n0, n1, n2, model.mu, model.kf, spin.kt, spin.kd_t, spin.dt, select
        )
        q0, q1, q2 = cross(n0, n1, n2, t0, t1, t2)  # n x f_t: times l_i on i, l_j on j
    if spin.mu_r > 0.0:
        r0 = wi0 - wj0
        r1 = wi1 - wj1
        r2 = wi2 - wj2
        rn = r0 * n0 + r1 * n1 + r2 * n2  # the twist about n is not resisted
        m0, m1, m2 = rolling_torque(spin, fn, ri * rj / (ri + rj), r0 - rn * n0, r1 - rn * n1, r2 - rn * n2, select)
    f0 = fn * n0 + t0
    f1 = fn * n1 + t1
    f2 = fn * n2 + t2
    return f0, f1, f2, q0, q1, q2, li, lj, m0, m1, m2, x0, x1, x2


@njit(hot=True)
def spin_pair(b, i, j, row, slot, x, v, a, model, spin, D):
    """Ball i against ball j (:func:`spin_pair_law`), the spring at ``spin.hist[b, row, slot]``
    (kept from i's side); forces added to ``a``, torques to ``spin.alpha``. The law is
    antisymmetric to the bit: evaluated as (j, i), every force, torque and spring is the negative of
    (i, j)'s."""
    touching, overlap, n0, n1, n2 = pair_geometry(b, i, j, x, model, D)
    if not touching:
        return
    wi0, wi1, wi2 = _omega(spin, b, i, D)
    wj0, wj1, wj2 = _omega(spin, b, j, D)
    history = model.mu > 0.0 and spin.kt > 0.0
    continuing = history and spin.stamp[b, row, slot] == spin.clock[b]
    hh = spin.hist
    h = (
        hh[b, row, slot, 0] if continuing else 0.0,
        hh[b, row, slot, 1] if continuing else 0.0,
        hh[b, row, slot, 2] if continuing and D == 3 else 0.0,
    )
    f0, f1, f2, q0, q1, q2, li, lj, m0, m1, m2, x0, x1, x2 = spin_pair_law(
        overlap,
        n0,
        n1,
        n2,
        v[b, j, 0] - v[b, i, 0],
        v[b, j, 1] - v[b, i, 1],
        v[b, j, 2] - v[b, i, 2] if D == 3 else 0.0,
        wi0,
        wi1,
        wi2,
        wj0,
        wj1,
        wj2,
        model.radii[i],
        model.radii[j],
        h,
        model,
        spin,
        D,
        False,
    )
    if history:
        hh[b, row, slot, 0] = x0
        hh[b, row, slot, 1] = x1
        hh[b, row, slot, 2] = x2
        spin.stamp[b, row, slot] = spin.clock[b] + 1
    a[b, i, 0] += f0
    a[b, i, 1] += f1
    a[b, j, 0] -= f0
    a[b, j, 1] -= f1
    if D == 3:
        a[b, i, 2] += f2
        a[b, j, 2] -= f2
    if model.mu > 0.0:
        _add_torque(spin, b, i, li * q0, li * q1, li * q2, D)
        _add_torque(spin, b, j, lj * q0, lj * q1, lj * q2, D)
    if spin.mu_r > 0.0:
        _add_torque(spin, b, i, m0, m1, m2, D)
        _add_torque(spin, b, j, -m0, -m1, -m2, D)


@njit(hot=True)
def spin_terrain_contact(b, i, slot, pen, n0, n1, n2, w0s, w1s, w2s, v, a, model, spin, D):
    """Ball i against one terrain shape, overlapping it by pen along its outward normal n, its
    surface moving at ws there (0 for a static shape): the normal law, then the tangential force
    (its history at ``spin.hist[b, i, slot]``), the torque and rolling resistance."""
    r = model.radii[i]
    u0 = v[b, i, 0]
    u1 = v[b, i, 1]
    u2 = v[b, i, 2] if D == 3 else 0.0
    f0, f1, f2 = terrain_law(
        pen,
        n0,
        n1,
        n2,
        u0 - w0s,
        u1 - w1s,
        u2 - w2s,
        model.ks_terrain,
        model.kd_terrain,
        model.no_tension,
        0.0,
        0.0,
        D,
    )
    fn = f0 * n0 + f1 * n1 + f2 * n2
    w0, w1, w2 = _omega(spin, b, i, D)
    lev = lever(r, pen)
    # slip of the ball's surface at the contact (lever -l n) against the shape's
    c0, c1, c2 = cross(w0, w1, w2, n0, n1, n2)
    s0 = u0 - lev * c0 - w0s
    s1 = u1 - lev * c1 - w1s
    s2 = (u2 - lev * c2 if D == 3 else 0.0) - w2s
    sn = s0 * n0 + s1 * n1 + s2 * n2
    s0 -= sn * n0
    s1 -= sn * n1
    s2 -= sn * n2
    if model.mu > 0.0:
        t0, t1, t2 = tangential_force(spin, b, i, slot, fn, s0, s1, s2, n0, n1, n2, model.mu, model.kf, D)
        f0 += t0
        f1 += t1
        f2 += t2
        q0, q1, q2 = cross(n0, n1, n2, t0, t1, t2)  # (-l n) x f_t
        _add_torque(spin, b, i, -lev * q0, -lev * q1, -lev * q2, D)
    a[b, i, 0] += f0
    a[b, i, 1] += f1
    if D == 3:
        a[b, i, 2] += f2
    if spin.mu_r > 0.0:
        rn = w0 * n0 + w1 * n1 + w2 * n2
        m0, m1, m2 = rolling_torque(spin, fn, r, w0 - rn * n0, w1 - rn * n1, w2 - rn * n2, False)
        _add_torque(spin, b, i, m0, m1, m2, D)


@njit(hot=True)
def spin_shapes(b, i, x, v, a, model, spin, first, others, D):
    """Ball i against the terrain shapes, in the table's order, shape s's history at slot
    ``first + s``: every shape, or with ``others`` every shape but the static spheres and bowls
    (the neighbour-list path meets those in its parallel pass)."""
    table = model.shapes
    r = model.radii[i]
    p0 = x[b, i, 0]
    p1 = x[b, i, 1]
    p2 = x[b, i, 2] if D == 3 else 0.0
    for s in range(table.kind.shape[0]):
        if others and is_direct(table, s):
            continue
        if shape_miss(table, b, s, p0, p1, p2, r, D):
            continue
        phi, n0, n1, n2 = shape_sdf(table, b, s, p0, p1, p2, D)
        pen = r - phi
        if not pen > 0.0:
            continue
        if is_moving(table, s):
            w0, w1, w2 = surface_velocity(table.pose[b, s], p0, p1, p2, phi, n0, n1, n2, D)
            spin_terrain_contact(b, i, first + s, pen, n0, n1, n2, w0, w1, w2, v, a, model, spin, D)
        else:
            spin_terrain_contact(b, i, first + s, pen, n0, n1, n2, 0.0, 0.0, 0.0, v, a, model, spin, D)


@njit(hot=True)
def spin_terrain(b, i, x, v, a, model, spin, D):
    """Ball i against every terrain shape (history slot n + the shape's row)."""
    spin_shapes(b, i, x, v, a, model, spin, x.shape[1], False, D)


@njit(hot=True)
def spin_forces(b, x, v, a, grid, buf, model, spin, D):
    """Every contact of world b with rotation: forces added to ``a``; ``spin.alpha[b]`` set to the
    angular accelerations (torque / I). Pairs in the visiting order of
    :func:`..broadphase.partners.partners` (``buf`` its scratch)."""
    n = x.shape[1]
    R = spin.w.shape[2]
    for i in range(n):
        for k in range(R):
            spin.alpha[b, i, k] = 0.0
    for i in range(n):
        rows, direct = partners(b, i, x, grid, buf, D)
        if direct:  # one range of later balls (all pairs, a lead ball): no test per pair
            for j in range(buf[0], buf[1]):
                spin_pair(b, i, j, i, j, x, v, a, model, spin, D)
        else:
            for r in range(rows):
                for idx in range(buf[2 * r], buf[2 * r + 1]):
                    j = partner(grid, b, idx, direct)
                    if j > i:
                        spin_pair(b, i, j, i, j, x, v, a, model, spin, D)
        spin_terrain(b, i, x, v, a, model, spin, D)
    for i in range(n):
        ii = spin.inv_inertia[i]
        for k in range(R):
            spin.alpha[b, i, k] *= ii
