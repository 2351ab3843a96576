"""Rotation: balls that spin, tangential contact models with torque, and rolling resistance.

With ``World(rotation=True)`` each ball carries an angular velocity (3 components in 3D, 1 in 2D,
about the axis out of the plane) and the moment of inertia of a solid sphere, I = 2/5 m r^2, or of
a disk, I = 1/2 m r^2. The kernels then take a :class:`Spin` where they take ``friction`` when
balls do not spin (None or ``(mu, kf)``): every function that differs dispatches on that type when
Numba compiles the step, so a scene without rotation compiles to exactly the code it ran before
(no branch, no argument more), and a rotating scene runs :func:`spin_contact_forces` instead of
:func:`.broadphase.contact_forces`.

The law (docs/physics.md, "Rotation"), for a contact of unit normal n (from ball i towards the
other body) at the middle of the overlap: lever arms l_i = r_i - overlap/2 (LAMMPS
``gran/hooke/history`` takes the radii; the difference is of the order overlap / r, and the
middle makes l_i + l_j the centres' distance, so a pair's forces and torques conserve angular
momentum exactly):

* the normal force is the seed's (:func:`.contact.terrain_law` for the terrain, the pair law's
  arithmetic for pairs);
* the slip velocity of ball i's surface against the other's at the contact,
  ``s = (v_i + w_i x l_i n) - (v_j + w_j x (-l_j n))``, tangential part (a moving terrain shape's
  surface velocity in place of ball j's);
* the tangential force on i, against the slip: regularised Coulomb,
  ``f_t = -min(kf |s_t|, mu |f_n|) s_t / |s_t|`` (``tangential="coulomb"``, as without rotation),
  or a spring with history, Cundall and Strack (1979), as LAMMPS ``gran/hooke/history``
  (``tangential="history"``): a per-contact displacement xi, carried from step to step (turned
  into the current tangent plane, its length kept), ``xi += s_t dt``,
  ``f_t = -kt xi - kd_t s_t``, capped at ``mu |f_n|`` (then xi = -(f_t + kd_t s_t) / kt: the
  spring holds what the cap allows), and dropped when the contact ends;
* the torque on i, ``l_i n x f_t`` (on j: ``l_j n x f_t``, with -f_t its force);
* rolling resistance (``mu_r > 0``): the constant directional torque of Ai, Chen, Rotter and
  Ooi (2011, Powder Technology 206, "model A"), ``M_r = -mu_r R* |f_n| w_r / |w_r|``, with
  ``w_r`` the tangential part of w_i - w_j (the twist about n is left free) and
  ``R* = r_i r_j / (r_i + r_j)`` (r_i at the terrain), regularised as the friction is:
  ``|M_r| = min(kr |w_r|, mu_r R* |f_n|)``, so a ball at rest stays at rest instead of chattering.

The history lives in :attr:`Spin.hist`, one slot per ball pair (i < j, at ``[b, i, j]``) and per
ball and terrain shape (at ``[b, i, n + s]``, the shapes in World order of their kernel slots), with
a stamp per slot: a slot written in the step before is a continuing contact, any other is a new one
(xi starts at zero). The step counter is per world, so the history does not depend on the thread
count or on which worlds share a batch.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit
from .broadphase import neighbour_rows
from .contact import FORCE, fallback_axis, shape_dist2, terrain_law, terrain_normal
from .geometry import _count, _is_tuple, _miss, _present, _rows, model_geometry_type, shape_sdf, surface_velocity

__all__ = ["Spin", "TANGENTIAL", "new_spin", "is_spin", "spin_contact_forces", "inertia_factor"]

TANGENTIAL = ("coulomb", "history")


class Spin(NamedTuple):
    """What a rotating scene's kernels take in place of ``friction`` (its first two fields are
    ``mu`` and ``kf``, as ``friction[0]`` and ``friction[1]``)."""

    mu: float  # Coulomb coefficient (0: no tangential force)
    kf: float  # regularised Coulomb's slope, force / sliding speed (tangential="coulomb")
    kt: float  # history spring, force / length (0: regularised Coulomb)
    kd_t: float  # history dashpot, force / sliding speed
    mu_r: float  # rolling resistance coefficient (0: off)
    kr: float  # rolling resistance's regularising slope, torque / angular speed
    dt: float  # the step, for the history's displacement
    w: np.ndarray  # (B, n, R) angular velocities, R = 3 (3D) or 1 (2D)
    alpha: np.ndarray  # (B, n, R) torque, then angular acceleration, of the last force pass
    inv_inertia: np.ndarray  # (n,)
    w0: np.ndarray  # (B, n, R) integrator scratch: the angular velocity at the step's start
    sw: np.ndarray  # (B, n, R) integrator scratch: RK4's weighted sum; velocity Verlet's cached alpha
    hist: np.ndarray  # (B, n, n + S, 3) the tangential springs' displacements ((1, 1, 1, 3) unused)
    stamp: np.ndarray  # (B, n, n + S) int64: the step count at which each slot is current
    clock: np.ndarray  # (B,) int64: steps taken per world


def inertia_factor(d: int) -> float:
    """I / (m r^2): 2/5 for a solid sphere (3D), 1/2 for a disk (2D)."""
    return 0.4 if d == 3 else 0.5


def new_spin(
    B: int,
    n: int,
    d: int,
    masses: np.ndarray,
    radii: np.ndarray,
    slots: int,
    *,
    rotation: bool = True,
    mu: float,
    kf: float,
    kt: float,
    kd_t: float,
    mu_r: float,
    kr: float,
    dt: float,
) -> Spin:
    """The buffers of a rotating scene: B worlds of n balls, ``slots`` terrain history slots per
    ball (history storage only when ``kt > 0``). ``rotation=False``: the tangential spring on balls
    that do not spin (1 / I = 0: the torque turns nothing)."""
    R = 3 if d == 3 else 1
    inertia = inertia_factor(d) * masses * radii * radii
    hist_shape = (B, n, n + slots) if kt > 0.0 else (1, 1, 1)
    return Spin(
        mu=float(mu),
        kf=float(kf),
        kt=float(kt),
        kd_t=float(kd_t),
        mu_r=float(mu_r),
        kr=float(kr),
        dt=float(dt),
        w=np.zeros((B, n, R)),
        alpha=np.zeros((B, n, R)),
        inv_inertia=1.0 / inertia if rotation else np.zeros(n),
        w0=np.zeros((B, n, R)),
        sw=np.zeros((B, n, R)),
        hist=np.zeros(hist_shape + (3,)),
        stamp=np.full(hist_shape, -1, dtype=np.int64),
        clock=np.zeros(B, dtype=np.int64),
    )


def is_spin(t) -> bool:
    """At compile time: is this Numba type a :class:`Spin`?"""
    return isinstance(t, types.BaseNamedTuple) and t.instance_class is Spin


# --------------------------------------------------------------------------------------------
# The tangential models and rolling resistance (one contact)
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def tangential_force(spin, b, i, slot, fn, s0, s1, s2, n0, n1, n2, D):
    """The tangential force on a ball whose surface slips at s (tangential) against the other
    body, in contact along n with normal force fn (see the module docstring)."""
    cap = spin.mu * abs(fn)
    if spin.kt > 0.0:
        h = spin.hist
        if spin.stamp[b, i, slot] == spin.clock[b]:  # a continuing contact: its spring, turned
            x0 = h[b, i, slot, 0]
            x1 = h[b, i, slot, 1]
            x2 = h[b, i, slot, 2] if D == 3 else 0.0
            old = x0 * x0 + x1 * x1 + x2 * x2
            xn = x0 * n0 + x1 * n1 + x2 * n2
            x0 -= xn * n0
            x1 -= xn * n1
            x2 -= xn * n2
            new = x0 * x0 + x1 * x1 + x2 * x2
            if new > 0.0:
                scale = np.sqrt(old / new)
                x0 *= scale
                x1 *= scale
                x2 *= scale
        else:
            x0 = 0.0
            x1 = 0.0
            x2 = 0.0
        dt = spin.dt
        x0 += s0 * dt
        x1 += s1 * dt
        x2 += s2 * dt
        f0 = -spin.kt * x0 - spin.kd_t * s0
        f1 = -spin.kt * x1 - spin.kd_t * s1
        f2 = -spin.kt * x2 - spin.kd_t * s2
        f2n = f0 * f0 + f1 * f1 + f2 * f2
        if f2n > cap * cap:  # sliding: the force at the cap, the spring at what the cap allows
            scale = cap / np.sqrt(f2n)
            f0 *= scale
            f1 *= scale
            f2 *= scale
            x0 = -(f0 + spin.kd_t * s0) / spin.kt
            x1 = -(f1 + spin.kd_t * s1) / spin.kt
            x2 = -(f2 + spin.kd_t * s2) / spin.kt
        h[b, i, slot, 0] = x0
        h[b, i, slot, 1] = x1
        h[b, i, slot, 2] = x2
        spin.stamp[b, i, slot] = spin.clock[b] + 1
        return f0, f1, f2
    st2 = s0 * s0 + s1 * s1 + s2 * s2
    if not st2 > 0.0:
        return 0.0, 0.0, 0.0
    st = np.sqrt(st2)
    k = min(spin.kf * st, cap) / st
    return -k * s0, -k * s1, -k * s2


@njit(inline="always")
def rolling_torque(spin, fn, reff, r0, r1, r2):
    """The rolling-resistance torque on a ball whose rolling angular velocity (relative to the
    other body, tangential part) is w_r (see the module docstring)."""
    wr2 = r0 * r0 + r1 * r1 + r2 * r2
    if not wr2 > 0.0:
        return 0.0, 0.0, 0.0
    wr = np.sqrt(wr2)
    k = min(spin.kr * wr, spin.mu_r * reff * abs(fn)) / wr
    return -k * r0, -k * r1, -k * r2


@njit(inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(inline="always")
def _omega(spin, b, i, D):
    """Ball i's angular velocity as a 3-vector (2D: about the out-of-plane axis)."""
    if D == 3:
        return spin.w[b, i, 0], spin.w[b, i, 1], spin.w[b, i, 2]
    return 0.0, 0.0, spin.w[b, i, 0]


@njit(inline="always")
def _add_torque(spin, b, i, t0, t1, t2, D):
    if D == 3:
        spin.alpha[b, i, 0] += t0
        spin.alpha[b, i, 1] += t1
        spin.alpha[b, i, 2] += t2
    else:
        spin.alpha[b, i, 0] += t2


# --------------------------------------------------------------------------------------------
# Contacts
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def spin_pair(b, i, j, x, v, a, model, spin, D):
    """Ball i against ball j (i < j): the normal law of :func:`.contact.pair_contact`, then the
    tangential force, the torques and rolling resistance; forces added to ``a``, torques to
    ``spin.alpha``."""
    ri = model.radii[i]
    rj = model.radii[j]
    l0 = ri + rj
    d0 = x[b, j, 0] - x[b, i, 0]
    d1 = x[b, j, 1] - x[b, i, 1]
    d2 = x[b, j, 2] - x[b, i, 2] if D == 3 else 0.0
    dist2 = d0 * d0 + d1 * d1 + d2 * d2
    if not dist2 < l0 * l0:
        return
    dist = np.sqrt(dist2)
    overlap = l0 - dist
    if dist > 0.0:
        inv = 1.0 / dist
        n0 = d0 * inv
        n1 = d1 * inv
        n2 = d2 * inv
    else:
        n0 = fallback_axis(0, D)
        n1 = fallback_axis(1, D)
        n2 = fallback_axis(2, D) if D == 3 else 0.0
    u0 = v[b, j, 0] - v[b, i, 0]
    u1 = v[b, j, 1] - v[b, i, 1]
    u2 = v[b, j, 2] - v[b, i, 2] if D == 3 else 0.0
    vn = u0 * n0 + u1 * n1 + u2 * n2
    fn = -model.ks * overlap + model.kd * vn  # along +n on i; < 0 pushes i away from j
    if model.no_tension and fn > 0.0:
        fn = 0.0
    wi0, wi1, wi2 = _omega(spin, b, i, D)
    wj0, wj1, wj2 = _omega(spin, b, j, D)
    li = ri - 0.5 * overlap  # lever arms to the middle of the overlap: li + lj = dist
    lj = rj - 0.5 * overlap
    # slip of i's surface against j's: -(v_j - v_i) + (l_i w_i + l_j w_j) x n, tangential part
    c0, c1, c2 = _cross(li * wi0 + lj * wj0, li * wi1 + lj * wj1, li * wi2 + lj * wj2, n0, n1, n2)
    s0 = c0 - u0
    s1 = c1 - u1
    s2 = c2 - u2 if D == 3 else 0.0
    sn = s0 * n0 + s1 * n1 + s2 * n2
    s0 -= sn * n0
    s1 -= sn * n1
    s2 -= sn * n2
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    if spin.mu > 0.0:
        t0, t1, t2 = tangential_force(spin, b, i, j, fn, s0, s1, s2, n0, n1, n2, D)
    f0 = fn * n0 + t0
    f1 = fn * n1 + t1
    a[b, i, 0] += f0
    a[b, i, 1] += f1
    a[b, j, 0] -= f0
    a[b, j, 1] -= f1
    if D == 3:
        f2 = fn * n2 + t2
        a[b, i, 2] += f2
        a[b, j, 2] -= f2
    if spin.mu > 0.0:
        q0, q1, q2 = _cross(n0, n1, n2, t0, t1, t2)  # n x f_t: times l_i on i, l_j on j
        _add_torque(spin, b, i, li * q0, li * q1, li * q2, D)
        _add_torque(spin, b, j, lj * q0, lj * q1, lj * q2, D)
    if spin.mu_r > 0.0:
        r0 = wi0 - wj0
        r1 = wi1 - wj1
        r2 = wi2 - wj2
        rn = r0 * n0 + r1 * n1 + r2 * n2  # the twist about n is not resisted
        m0, m1, m2 = rolling_torque(spin, fn, ri * rj / l0, r0 - rn * n0, r1 - rn * n1, r2 - rn * n2)
        _add_torque(spin, b, i, m0, m1, m2, D)
        _add_torque(spin, b, j, -m0, -m1, -m2, D)


@njit(inline="always")
def spin_terrain_contact(b, i, slot, pen, n0, n1, n2, ws, v, a, model, spin, D):
    """Ball i against one terrain shape, overlapping it by pen along its outward normal n, its
    surface moving at ``ws`` there (None: static): the normal law of :func:`.contact.terrain_law`,
    then the tangential force, the torque and rolling resistance."""
    r = model.radii[i]
    u0 = v[b, i, 0]
    u1 = v[b, i, 1]
    u2 = v[b, i, 2] if D == 3 else 0.0
    _, f0, f1, f2 = terrain_law(
        FORCE, pen, n0, n1, n2, ws, u0, u1, u2, r, 0.0, model.ks_terrain, model.kd_terrain, model.no_tension, None, D
    )
    fn = f0 * n0 + f1 * n1 + f2 * n2
    w0, w1, w2 = _omega(spin, b, i, D)
    lev = r - 0.5 * pen  # lever arm to the middle of the overlap
    # slip of the ball's surface at the contact (lever -l n) against the shape's
    c0, c1, c2 = _cross(w0, w1, w2, n0, n1, n2)
    s0 = u0 - lev * c0
    s1 = u1 - lev * c1
    s2 = u2 - lev * c2 if D == 3 else 0.0
    if ws is not None:
        s0 -= ws[0]
        s1 -= ws[1]
        s2 -= ws[2]
    sn = s0 * n0 + s1 * n1 + s2 * n2
    s0 -= sn * n0
    s1 -= sn * n1
    s2 -= sn * n2
    if spin.mu > 0.0:
        t0, t1, t2 = tangential_force(spin, b, i, slot, fn, s0, s1, s2, n0, n1, n2, D)
        f0 += t0
        f1 += t1
        f2 += t2
        q0, q1, q2 = _cross(n0, n1, n2, t0, t1, t2)  # (-l n) x f_t
        _add_torque(spin, b, i, -lev * q0, -lev * q1, -lev * q2, D)
    a[b, i, 0] += f0
    a[b, i, 1] += f1
    if D == 3:
        a[b, i, 2] += f2
    if spin.mu_r > 0.0:
        rn = w0 * n0 + w1 * n1 + w2 * n2
        m0, m1, m2 = rolling_torque(spin, fn, r, w0 - rn * n0, w1 - rn * n1, w2 - rn * n2)
        _add_torque(spin, b, i, m0, m1, m2, D)


def _group_spin(grp, motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D):
    """Every shape of one general-shape group against ball i (their history slots from ``slot``
    on); returns the next free slot (jitted code only)."""
    raise NotImplementedError


@overload(_group_spin)
def _group_spin_impl(grp, motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D):
    if _is_tuple(grp):  # user shapes: one at a time
        if len(grp) == 0:
            return lambda grp, motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D: slot

        def impl_tuple(grp, motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D):
            slot = _group_spin(grp[0], motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D)
            return _group_spin(grp[1:], motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D)

        return impl_tuple

    def impl(grp, motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D):
        count = _count(grp)
        for s in range(count):
            pose, shape = _rows(grp, b, s)
            if _miss(pose, shape, p0, p1, p2, r, D):
                continue
            phi, n0, n1, n2 = shape_sdf(grp, b, s, p0, p1, p2, D)
            pen = r - phi
            if not pen > 0.0:
                continue
            if motion is None:
                spin_terrain_contact(b, i, slot + s, pen, n0, n1, n2, None, v, a, model, spin, D)
            else:
                ws = surface_velocity(pose, p0, p1, p2, phi, n0, n1, n2, D)
                spin_terrain_contact(b, i, slot + s, pen, n0, n1, n2, ws, v, a, model, spin, D)
        return slot + count

    return impl


def spin_general_terrain(b, i, slot, x, v, a, model, spin, D):
    """Every general shape against ball i (nothing when the model has none; jitted code only)."""
    raise NotImplementedError


@overload(spin_general_terrain, inline="always")
def _spin_general_terrain(b, i, slot, x, v, a, model, spin, D):
    geo = model_geometry_type(model)
    if isinstance(geo, types.NoneType):
        return lambda b, i, slot, x, v, a, model, spin, D: None
    src = ["def impl(b, i, slot, x, v, a, model, spin, D):"]
    src.append("    g = model.geometry; r = model.radii[i]")
    src.append("    p0 = x[b, i, 0]; p1 = x[b, i, 1]; p2 = x[b, i, 2] if D == 3 else 0.0")
    for k in _present(geo):
        src.append(f"    slot = _group_spin(g.{k}, g.motion, b, i, slot, p0, p1, p2, r, v, a, model, spin, D)")
    src.append("    return None")
    scope = {"_group_spin": _group_spin}
    exec("\n".join(src), scope)  # noqa: S102 - fixed template, group names from geometry
    return scope["impl"]


@njit(inline="always")
def spin_terrain(b, i, x, v, a, model, spin, D):
    """Ball i against every terrain shape: the static spheres and bowls (history slots n + s),
    then the general shapes (the slots after them)."""
    n = x.shape[1]
    r = model.radii[i]
    S = model.shape_kind.shape[0]
    for s in range(S):
        sign, dist2 = shape_dist2(b, i, x, model, s, D)
        R = model.shape_radius[s]
        if sign > 0.0:
            if dist2 >= (R + r) * (R + r):
                continue
        elif R > r and dist2 <= (R - r) * (R - r):
            continue
        dist = np.sqrt(dist2)
        pen = r - sign * (dist - R)
        if not pen > 0.0:
            continue
        inv = sign / dist if dist > 0.0 else 0.0
        n0 = terrain_normal(b, i, s, 0, x, model, inv, dist, D)
        n1 = terrain_normal(b, i, s, 1, x, model, inv, dist, D)
        n2 = terrain_normal(b, i, s, 2, x, model, inv, dist, D) if D == 3 else 0.0
        spin_terrain_contact(b, i, n + s, pen, n0, n1, n2, None, v, a, model, spin, D)
    spin_general_terrain(b, i, n + S, x, v, a, model, spin, D)


@njit
def spin_contact_forces(b, x, v, a, grid, model, spin, g):
    """Every contact of world b with rotation: forces added to ``a``; ``spin.alpha[b]`` set to the
    angular accelerations (torque / I). Pairs in the order of :func:`.broadphase.contacts`."""
    D = len(g)
    n = x.shape[1]
    R = spin.w.shape[2]
    for i in range(n):
        for k in range(R):
            spin.alpha[b, i, k] = 0.0
    for i in range(n):
        if grid is None:
            for j in range(i + 1, n):
                spin_pair(b, i, j, x, v, a, model, spin, D)
        elif i < grid.lead[0]:  # a lead ball meets every later ball directly (:func:`.broadphase.new_grid`)
            for j in range(i + 1, n):
                spin_pair(b, i, j, x, v, a, model, spin, D)
        else:
            x0, x1, y0, y1, z0, z1, nx, ny = neighbour_rows(b, i, x, grid, D)
            for qz in range(z0, z1):
                for qy in range(y0, y1):
                    row = (qz * ny + qy) * nx
                    for idx in range(grid.start[b, row + x0], grid.start[b, row + x1]):
                        j = grid.items[b, idx]
                        if j > i:
                            spin_pair(b, i, j, x, v, a, model, spin, D)
        spin_terrain(b, i, x, v, a, model, spin, D)
    for i in range(n):
        ii = spin.inv_inertia[i]
        for k in range(R):
            spin.alpha[b, i, k] *= ii


# --------------------------------------------------------------------------------------------
# The integrators' side: advancing w (each a no-op when the scene does not rotate)
# --------------------------------------------------------------------------------------------


def _noop2(friction, b):
    return None


def _noop3(friction, b, dt):
    return None


def spin_kick(friction, b, dt):
    """w += dt alpha (explicit, symplectic and implicit Euler)."""
    raise NotImplementedError


@overload(spin_kick, inline="always")
def _spin_kick(friction, b, dt):
    if not is_spin(friction):
        return _noop3

    def impl(friction, b, dt):
        w, al = friction.w, friction.alpha
        for i in range(w.shape[1]):
            for k in range(w.shape[2]):
                w[b, i, k] += dt * al[b, i, k]

    return impl


def spin_cache(friction, b):
    """Velocity Verlet's first force pass: cache alpha (as a0)."""
    raise NotImplementedError


@overload(spin_cache, inline="always")
def _spin_cache(friction, b):
    if not is_spin(friction):
        return _noop2

    def impl(friction, b):
        sw, al = friction.sw, friction.alpha
        for i in range(sw.shape[1]):
            for k in range(sw.shape[2]):
                sw[b, i, k] = al[b, i, k]

    return impl


def spin_predict(friction, b, dt):
    """Velocity Verlet: keep w in w0, then w = w0 + dt alpha0 (the predicted end-of-step spin the
    second force pass sees, as it sees the predicted velocity)."""
    raise NotImplementedError


@overload(spin_predict, inline="always")
def _spin_predict(friction, b, dt):
    if not is_spin(friction):
        return _noop3

    def impl(friction, b, dt):
        w, w0, a0 = friction.w, friction.w0, friction.sw
        for i in range(w.shape[1]):
            for k in range(w.shape[2]):
                w0[b, i, k] = w[b, i, k]
                w[b, i, k] += dt * a0[b, i, k]

    return impl


def spin_correct(friction, b, dt):
    """Velocity Verlet: w = w0 + dt/2 (alpha0 + alpha1); alpha1 cached as the next alpha0."""
    raise NotImplementedError


@overload(spin_correct, inline="always")
def _spin_correct(friction, b, dt):
    if not is_spin(friction):
        return _noop3

    def impl(friction, b, dt):
        w, w0, a0, al = friction.w, friction.w0, friction.sw, friction.alpha
        for i in range(w.shape[1]):
            for k in range(w.shape[2]):
                w[b, i, k] = w0[b, i, k] + 0.5 * dt * (a0[b, i, k] + al[b, i, k])
                a0[b, i, k] = al[b, i, k]

    return impl


def spin_rk4(friction, b, stage, h):
    """RK4 with w as one more velocity: stage 0 keeps w0 and starts the sum with k1; stages 1 to
    3 add 2 k2, 2 k3, k4; each stage but the last sets w = w0 + h alpha for the next force pass.
    ``h`` < 0 ends the step: w = w0 + (-h) sum (h = -dt / 6)."""
    raise NotImplementedError


@overload(spin_rk4)  # not inlined: Numba's SSA check trips on its loop when inlined
def _spin_rk4(friction, b, stage, h):
    if not is_spin(friction):
        return lambda friction, b, stage, h: None

    def impl(friction, b, stage, h):
        w, w0, sw, al = friction.w, friction.w0, friction.sw, friction.alpha
        if h < 0.0:
            for i in range(w.shape[1]):
                for k in range(w.shape[2]):
                    w[b, i, k] = w0[b, i, k] - h * sw[b, i, k]
            return
        for i in range(w.shape[1]):
            for k in range(w.shape[2]):
                if stage == 0:
                    w0[b, i, k] = w[b, i, k]
                    sw[b, i, k] = al[b, i, k]
                else:
                    sw[b, i, k] += (2.0 if stage < 3 else 1.0) * al[b, i, k]
                if stage < 3:
                    w[b, i, k] = w0[b, i, k] + h * al[b, i, k]

    return impl


def spin_tick(friction, b):
    """One step of world b is done: advance its clock (the history's stamps)."""
    raise NotImplementedError


@overload(spin_tick, inline="always")
def _spin_tick(friction, b):
    if not is_spin(friction):
        return _noop2

    def impl(friction, b):
        friction.clock[b] += 1

    return impl
