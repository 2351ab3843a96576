"""The primitives' signed distance functions in their local frame (kernel side).

Each returns ``(phi, n0, n1, n2)``: the signed distance (< 0 inside the solid) and the outward unit
normal (n2 = 0 in 2D) at a local point q (its axis the last axis). They are the one implementation
of each primitive: the contact passes (scalar, SIMD lanes, neighbour list), the CSG programs'
leaves, the Python side's ``Shape.phi`` and the renderer all reach them through
:func:`.evaluate.shape_sdf` (or :mod:`.lanes`). Where the normal is undefined (a point on a
capsule's axis, at a sphere's centre, exactly on a box's diagonal) a fixed axis is used: every
force stays finite.

=============  ======================================================  =====================================
kind           local phi (q: local coordinates; rho the distance to     parameters ``a, b, c``
               the axis, |q0| in 2D; z = q_last)
=============  ======================================================  =====================================
plane          z (solid below)                                          -
round          |q| - R (a Sphere; a Bowl is its complement)              R
box            |max(u, 0)| + min(max_k u_k, 0), u = |q| - h             h (d half extents)
capsule        |q - clamp(z, -h, h) e_z| - r                            h, r
cylinder       the 2D box of (rho, z), half extents (r, h)              r, h
cone           distance to the trapezoid (rho, z) of radii r0 at        r0, r1, h
               z = -h and r1 at z = +h (a frustum)
torus          |(rho - R, z)| - r                                       R, r
height field   (z - h(q)) / sqrt(1 + |grad h|^2), h bilinear            the grid (:func:`sdf_height`)
=============  ======================================================  =====================================

``D`` is the dimension, passed as a value: each function compiles once and LLVM folds the branches
on D where it inlines it into a caller of known dimension.
"""

from __future__ import annotations

import math

from ..._jit import njit

__all__ = [
    "PLANE",
    "ROUND",
    "BOX",
    "CAPSULE",
    "CYLINDER",
    "CONE",
    "TORUS",
    "HEIGHTS",
    "CSG",
    "USER",
    "KIND_NAMES",
    "sdf_plane",
    "sdf_round",
    "sdf_box",
    "sdf_capsule",
    "sdf_cylinder",
    "sdf_cone",
    "sdf_torus",
    "sdf_height",
    "primitive_sdf",
]

# Shape kinds: the shape table's ``kind`` column (and a CSG leaf's code for the primitives)
PLANE, ROUND, BOX, CAPSULE, CYLINDER, CONE, TORUS, HEIGHTS, CSG, USER = range(10)
KIND_NAMES = ("plane", "round", "box", "capsule", "cylinder", "cone", "torus", "heights", "csg", "user")


@njit(hot=True)
def sdf_plane(q0, q1, q2, a, b, c, D):
    """Half-space below the local z = 0 plane: phi = z."""
    if D == 3:
        return q2, 0.0, 0.0, 1.0
    return q1, 0.0, 1.0, 0.0


@njit
def sdf_round(q0, q1, q2, R, b, c, D):
    """Solid ball of radius R: phi = |q| - R (the last axis at the centre)."""
    d2 = q0 * q0 + q1 * q1
    if D == 3:
        d2 += q2 * q2
    dist = math.sqrt(d2)
    if dist > 0.0:
        inv = 1.0 / dist
        return dist - R, q0 * inv, q1 * inv, (q2 * inv if D == 3 else 0.0)
    return dist - R, 0.0, (1.0 if D == 2 else 0.0), (1.0 if D == 3 else 0.0)


@njit(hot=True)
def _sign(x):
    return -1.0 if x < 0.0 else 1.0


@njit(hot=True)
def _box2(a, z, ha, hz):
    """Exact distance to the 2D box |a| <= ha, |z| <= hz: (phi, na, nz)."""
    ua = abs(a) - ha
    uz = abs(z) - hz
    oa = max(ua, 0.0)
    oz = max(uz, 0.0)
    o2 = oa * oa + oz * oz
    if o2 > 0.0:
        o = math.sqrt(o2)
        return o, _sign(a) * oa / o, _sign(z) * oz / o
    if ua >= uz:
        return ua, _sign(a), 0.0
    return uz, 0.0, _sign(z)


@njit(hot=True)
def sdf_box(q0, q1, q2, h0, h1, h2, D):
    """Box of half extents h: phi = |max(u, 0)| + min(max_k u_k, 0), u = |q| - h (exact)."""
    if D == 2:
        phi, n0, n1 = _box2(q0, q1, h0, h1)
        return phi, n0, n1, 0.0
    u0 = abs(q0) - h0
    u1 = abs(q1) - h1
    u2 = abs(q2) - h2
    o0 = max(u0, 0.0)
    o1 = max(u1, 0.0)
    o2 = max(u2, 0.0)
    s2 = o0 * o0 + o1 * o1 + o2 * o2
    if s2 > 0.0:
        o = math.sqrt(s2)
        return o, _sign(q0) * o0 / o, _sign(q1) * o1 / o, _sign(q2) * o2 / o
    if u0 >= u1 and u0 >= u2:
        return u0, _sign(q0), 0.0, 0.0
    if u1 >= u2:
        return u1, 0.0, _sign(q1), 0.0
    return u2, 0.0, 0.0, _sign(q2)


@njit
def sdf_capsule(q0, q1, q2, h, r, c, D):
    """Capsule of the segment z in [-h, h] on the axis and radius r (a stadium in 2D)."""
    if D == 3:
        w2 = q2 - min(max(q2, -h), h)
        dist = math.sqrt(q0 * q0 + q1 * q1 + w2 * w2)
        if dist > 0.0:
            return dist - r, q0 / dist, q1 / dist, w2 / dist
        return dist - r, 1.0, 0.0, 0.0
    w1 = q1 - min(max(q1, -h), h)
    dist = math.sqrt(q0 * q0 + w1 * w1)
    if dist > 0.0:
        return dist - r, q0 / dist, w1 / dist, 0.0
    return dist - r, 1.0, 0.0, 0.0


@njit
def _radial(q0, q1, D):
    """(rho, e0, e1): the distance to the axis and the unit radial direction (the first axis on it)."""
    if D == 3:
        rho = math.sqrt(q0 * q0 + q1 * q1)
        if rho > 0.0:
            return rho, q0 / rho, q1 / rho
        return rho, 1.0, 0.0
    return abs(q0), _sign(q0), 0.0


@njit
def _from_meridian(phi, nr, nz, e0, e1, D):
    """A normal (nr, nz) of the meridian plane back to the local frame."""
    if D == 3:
        return phi, nr * e0, nr * e1, nz
    return phi, nr * e0, nz, 0.0


@njit
def sdf_cylinder(q0, q1, q2, r, h, c, D):
    """Finite cylinder of radius r and half height h with flat caps (a rectangle in 2D): exact."""
    z = q2 if D == 3 else q1
    rho, e0, e1 = _radial(q0, q1, D)
    phi, nr, nz = _box2(rho, z, r, h)
    return _from_meridian(phi, nr, nz, e0, e1, D)


@njit
def _segment(pr, pz, ar, az, br, bz):
    """Squared distance from (pr, pz) to the segment a-b, and the closest point."""
    dr = br - ar
    dz = bz - az
    len2 = dr * dr + dz * dz
    t = ((pr - ar) * dr + (pz - az) * dz) / len2 if len2 > 0.0 else 0.0
    t = min(max(t, 0.0), 1.0)
    cr = ar + t * dr
    cz = az + t * dz
    return (pr - cr) * (pr - cr) + (pz - cz) * (pz - cz), cr, cz


@njit
def sdf_cone(q0, q1, q2, r0, r1, h, D):
    """Frustum of radius r0 at z = -h and r1 at z = +h, with flat caps (a trapezoid in 2D): the
    exact distance to the meridian trapezoid (its caps and its slanted side)."""
    z = q2 if D == 3 else q1
    rho, e0, e1 = _radial(q0, q1, D)
    best, cr, cz = _segment(rho, z, 0.0, -h, r0, -h)  # bottom cap
    fr, fz = 0.0, -1.0
    d2, tr, tz = _segment(rho, z, r0, -h, r1, h)  # side
    if d2 < best:
        best, cr, cz = d2, tr, tz
        sl = math.sqrt(4.0 * h * h + (r1 - r0) * (r1 - r0))
        fr, fz = 2.0 * h / sl, (r0 - r1) / sl
    d2, tr, tz = _segment(rho, z, 0.0, h, r1, h)  # top cap
    if d2 < best:
        best, cr, cz = d2, tr, tz
        fr, fz = 0.0, 1.0
    dist = math.sqrt(best)
    inside = abs(z) <= h and rho <= r0 + (r1 - r0) * (z + h) / (2.0 * h)
    if dist > 0.0:
        s = -1.0 if inside else 1.0
        return _from_meridian(s * dist, s * (rho - cr) / dist, s * (z - cz) / dist, e0, e1, D)
    return _from_meridian(0.0, fr, fz, e0, e1, D)


@njit
def sdf_torus(q0, q1, q2, R, r, c, D):
    """Torus of major radius R (about the axis) and minor radius r: phi = |(rho - R, z)| - r
    (in 2D its meridian slice: two discs)."""
    z = q2 if D == 3 else q1
    rho, e0, e1 = _radial(q0, q1, D)
    w = rho - R
    L = math.sqrt(w * w + z * z)
    if L > 0.0:
        return _from_meridian(L - r, w / L, z / L, e0, e1, D)
    return _from_meridian(L - r, 1.0, 0.0, e0, e1, D)


@njit
def sdf_height(heights, nx, ny, cx, cy, ox, oy, q0, q1, q2, D):
    """Height field: the solid below z = h(x, y), h interpolated bilinearly (linearly in 2D) from
    ``heights`` (nx x ny nodes, row-major, at origin + index x cell) and held at its edge value
    beyond the grid.

    phi = (z - h) / sqrt(1 + |grad h|^2): the distance to the tangent plane at the point's foot,
    exact for a tilted plane; for a surface of curvature K it is within K delta^2 / 2 of the true
    distance, delta = z - h (docs/physics.md section 1). The normal is the surface's at the foot."""
    fx = (q0 - ox) / cx
    fx = min(max(fx, 0.0), nx - 1.0)
    i = min(int(fx), nx - 2)
    tx = fx - i
    inside_x = q0 > ox and q0 < ox + (nx - 1.0) * cx
    if D == 2:
        h0 = heights[i]
        h1 = heights[i + 1]
        hv = h0 + tx * (h1 - h0)
        hx = (h1 - h0) / cx if inside_x else 0.0
        norm = math.sqrt(1.0 + hx * hx)
        return (q1 - hv) / norm, -hx / norm, 1.0 / norm, 0.0
    fy = (q1 - oy) / cy
    fy = min(max(fy, 0.0), ny - 1.0)
    j = min(int(fy), ny - 2)
    ty = fy - j
    inside_y = q1 > oy and q1 < oy + (ny - 1.0) * cy
    h00 = heights[i * ny + j]
    h10 = heights[(i + 1) * ny + j]
    h01 = heights[i * ny + j + 1]
    h11 = heights[(i + 1) * ny + j + 1]
    hv = (h00 * (1.0 - tx) + h10 * tx) * (1.0 - ty) + (h01 * (1.0 - tx) + h11 * tx) * ty
    hx = ((h10 - h00) * (1.0 - ty) + (h11 - h01) * ty) / cx if inside_x else 0.0
    hy = ((h01 - h00) * (1.0 - tx) + (h11 - h10) * tx) / cy if inside_y else 0.0
    norm = math.sqrt(1.0 + hx * hx + hy * hy)
    return (q2 - hv) / norm, -hx / norm, -hy / norm, 1.0 / norm


@njit
def primitive_sdf(kind, q0, q1, q2, a, b, c, D):
    """The primitive of code ``kind`` (PLANE .. TORUS) at local point q, parameters (a, b, c)."""
    if kind == PLANE:
        return sdf_plane(q0, q1, q2, a, b, c, D)
    if kind == ROUND:
        return sdf_round(q0, q1, q2, a, b, c, D)
    if kind == BOX:
        return sdf_box(q0, q1, q2, a, b, c, D)
    if kind == CAPSULE:
        return sdf_capsule(q0, q1, q2, a, b, c, D)
    if kind == CYLINDER:
        return sdf_cylinder(q0, q1, q2, a, b, c, D)
    if kind == CONE:
        return sdf_cone(q0, q1, q2, a, b, c, D)
    return sdf_torus(q0, q1, q2, a, b, c, D)
