"""General implicit geometry, kernel side: every terrain shape other than a static Sphere or Bowl.

A scene's general shapes are packed into one :class:`Geometry` (``Model.geometry``), a tuple of
*groups*, one per kind of shape, each ``None`` when the scene has no shape of that kind. Numba
compiles a step for the group types it is given, so a scene runs code for exactly the kinds it
has (a group that is None compiles to nothing), and a scene without general shapes
(``Model.geometry`` None) compiles to the code of spheres and bowls alone.

Every shape is a signed distance function ``phi`` in its own *local frame* (its axis the last
axis), placed in the world by a pose per world: ``q = R^T (x - c)``, ``grad phi = R n_local``. The
local functions (``sdf_*``) are the one implementation of each primitive: the contact pass, the
CSG trees' leaves, the Python-side ``Shape.phi`` and the renderer all call them.

=============  ======================================================  =====================================
kind           local phi (q: local coordinates; rho the distance to     parameters ``par``
               the axis, |q0| in 2D; z = q_last)
=============  ======================================================  =====================================
plane          z (solid below)                                          -
round          |q| - R (a Sphere; a Bowl is its inside, sign -1)        R
box            |max(u, 0)| + min(max_k u_k, 0), u = |q| - h             h (d half extents)
capsule        |q - clamp(z, -h, h) e_z| - r                            h, r
cylinder       the 2D box of (rho, z), half extents (r, h)              r, h
cone           distance to the trapezoid (rho, z) of radii r0 at        r0, r1, h
               z = -h and r1 at z = +h (a frustum)
torus          |(rho - R, z)| - r                                       R, r
height field   (z - h(q)) / sqrt(1 + |grad h|^2), h bilinear            grid (see :func:`sdf_height`)
=============  ======================================================  =====================================

A shape's ``sign`` is -1 for the complement (``Inside(shape)``: the shape's interior is free space).
CSG trees (``Union``, ``Intersection``, ``Difference``, ``Inside``) are typed trees of leaves, so
each tree compiles to straight-line code (min / max of its leaves); user SDFs are Numba functions
called by the step. Moving shapes (``Geometry.motion`` not None) advance their pose after every
step, and the dashpot and friction see the ball's velocity relative to the surface point.
"""

from __future__ import annotations

from collections import namedtuple
from typing import Any

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit

__all__ = [
    "Geometry",
    "PRIMITIVE_KINDS",
    "GROUP_CLASSES",
    "GROUP_ORDER",
    "HeightGroup",
    "CSGGroup",
    "UserShape",
    "N_PAR",
    "SIGN",
    "BOUND",
    "INNER",
    "PAR",
    "pose_size",
    "pose_columns",
    "general_terrain",
    "advance_geometry",
    "geometry_clearance",
    "model_geometry_type",
    "shape_sdf",
    "csg_sdf",
    "evaluate",
    "columns",
    "world_slice",
    "geometry_shape_count",
]

N_PAR = 4  # parameters per primitive (the local size; unused ones are 0)

# ---------------------------------------------------------------------------------------------
# The primitives in their local frame. Each returns (phi, n0, n1, n2): the signed distance and the
# outward unit normal (n2 = 0 in 2D). Where the normal is undefined (a point on a capsule's axis, at
# a sphere's centre, exactly on a boundary) a fixed axis is used: every force stays finite.
# ---------------------------------------------------------------------------------------------


@njit(inline="always")
def sdf_plane(q0, q1, q2, a, b, c, e, D):
    """Half-space below the local z = 0 plane: phi = z."""
    if D == 3:
        return q2, 0.0, 0.0, 1.0
    return q1, 0.0, 1.0, 0.0


@njit(inline="always")
def sdf_round(q0, q1, q2, R, b, c, e, D):
    """Solid ball of radius R: phi = |q| - R (the last axis at the centre)."""
    d2 = q0 * q0 + q1 * q1
    if D == 3:
        d2 += q2 * q2
    dist = np.sqrt(d2)
    if dist > 0.0:
        inv = 1.0 / dist
        return dist - R, q0 * inv, q1 * inv, (q2 * inv if D == 3 else 0.0)
    return dist - R, 0.0, (1.0 if D == 2 else 0.0), (1.0 if D == 3 else 0.0)


@njit(inline="always")
def _sign(x):
    return -1.0 if x < 0.0 else 1.0


@njit(inline="always")
def _box2(a, z, ha, hz):
    """Exact distance to the 2D box |a| <= ha, |z| <= hz: (phi, na, nz)."""
    ua = abs(a) - ha
    uz = abs(z) - hz
    oa = max(ua, 0.0)
    oz = max(uz, 0.0)
    o2 = oa * oa + oz * oz
    if o2 > 0.0:
        o = np.sqrt(o2)
        return o, _sign(a) * oa / o, _sign(z) * oz / o
    if ua >= uz:
        return ua, _sign(a), 0.0
    return uz, 0.0, _sign(z)


@njit(inline="always")
def sdf_box(q0, q1, q2, h0, h1, h2, e, D):
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
        o = np.sqrt(s2)
        return o, _sign(q0) * o0 / o, _sign(q1) * o1 / o, _sign(q2) * o2 / o
    if u0 >= u1 and u0 >= u2:
        return u0, _sign(q0), 0.0, 0.0
    if u1 >= u2:
        return u1, 0.0, _sign(q1), 0.0
    return u2, 0.0, 0.0, _sign(q2)


@njit(inline="always")
def sdf_capsule(q0, q1, q2, h, r, c, e, D):
    """Capsule of the segment z in [-h, h] on the axis and radius r (a stadium in 2D)."""
    if D == 3:
        w2 = q2 - min(max(q2, -h), h)
        d2 = q0 * q0 + q1 * q1 + w2 * w2
        dist = np.sqrt(d2)
        if dist > 0.0:
            return dist - r, q0 / dist, q1 / dist, w2 / dist
        return dist - r, 1.0, 0.0, 0.0
    w1 = q1 - min(max(q1, -h), h)
    dist = np.sqrt(q0 * q0 + w1 * w1)
    if dist > 0.0:
        return dist - r, q0 / dist, w1 / dist, 0.0
    return dist - r, 1.0, 0.0, 0.0


@njit(inline="always")
def _radial(q0, q1, D):
    """(rho, e0, e1): the distance to the axis and the unit radial direction (the first axis on it)."""
    if D == 3:
        rho = np.sqrt(q0 * q0 + q1 * q1)
        if rho > 0.0:
            return rho, q0 / rho, q1 / rho
        return rho, 1.0, 0.0
    return abs(q0), _sign(q0), 0.0


@njit(inline="always")
def _from_meridian(phi, nr, nz, e0, e1, D):
    """A normal (nr, nz) of the meridian plane back to the local frame."""
    if D == 3:
        return phi, nr * e0, nr * e1, nz
    return phi, nr * e0, nz, 0.0


@njit(inline="always")
def sdf_cylinder(q0, q1, q2, r, h, c, e, D):
    """Finite cylinder of radius r and half height h with flat caps (a rectangle in 2D): exact."""
    z = q2 if D == 3 else q1
    rho, e0, e1 = _radial(q0, q1, D)
    phi, nr, nz = _box2(rho, z, r, h)
    return _from_meridian(phi, nr, nz, e0, e1, D)


@njit(inline="always")
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


@njit(inline="always")
def sdf_cone(q0, q1, q2, r0, r1, h, e, D):
    """Frustum of radius r0 at z = -h and r1 at z = +h, with flat caps (a trapezoid in 2D): the
    exact distance to the meridian trapezoid (its caps and its slanted side)."""
    z = q2 if D == 3 else q1
    rho, e0, e1 = _radial(q0, q1, D)
    best, cr, cz = _segment(rho, z, 0.0, -h, r0, -h)  # bottom cap
    fr, fz = 0.0, -1.0
    d2, tr, tz = _segment(rho, z, r0, -h, r1, h)  # side
    if d2 < best:
        best, cr, cz = d2, tr, tz
        sl = np.sqrt(4.0 * h * h + (r1 - r0) * (r1 - r0))
        fr, fz = 2.0 * h / sl, (r0 - r1) / sl
    d2, tr, tz = _segment(rho, z, 0.0, h, r1, h)  # top cap
    if d2 < best:
        best, cr, cz = d2, tr, tz
        fr, fz = 0.0, 1.0
    dist = np.sqrt(best)
    inside = abs(z) <= h and rho <= r0 + (r1 - r0) * (z + h) / (2.0 * h)
    if dist > 0.0:
        s = -1.0 if inside else 1.0
        return _from_meridian(s * dist, s * (rho - cr) / dist, s * (z - cz) / dist, e0, e1, D)
    return _from_meridian(0.0, fr, fz, e0, e1, D)


@njit(inline="always")
def sdf_torus(q0, q1, q2, R, r, c, e, D):
    """Torus of major radius R (about the axis) and minor radius r: phi = |(rho - R, z)| - r
    (in 2D its meridian slice: two discs)."""
    z = q2 if D == 3 else q1
    rho, e0, e1 = _radial(q0, q1, D)
    w = rho - R
    L = np.sqrt(w * w + z * z)
    if L > 0.0:
        return _from_meridian(L - r, w / L, z / L, e0, e1, D)
    return _from_meridian(L - r, 1.0, 0.0, e0, e1, D)


@njit(inline="always")
def sdf_height(heights, b, s, nx, ny, cx, cy, ox, oy, q0, q1, q2, D):
    """Height field: the solid below z = h(x, y), h interpolated bilinearly (linearly in 2D) from
    ``heights[b, s]`` (nodes at origin + index x cell) and held at its edge value beyond the grid.

    phi = (z - h) / sqrt(1 + |grad h|^2): the distance to the tangent plane at the point's foot,
    exact for a tilted plane; for a surface of curvature K it is within K delta^2 / 2 of the true
    distance, delta = z - h (docs/physics.md section 1). The normal is the surface's at the foot."""
    fx = (q0 - ox) / cx
    fx = min(max(fx, 0.0), nx - 1.0)
    i = min(int(fx), nx - 2)
    tx = fx - i
    inside_x = q0 > ox and q0 < ox + (nx - 1.0) * cx
    if D == 2:
        h0 = heights[b, s, i, 0]
        h1 = heights[b, s, i + 1, 0]
        hv = h0 + tx * (h1 - h0)
        hx = (h1 - h0) / cx if inside_x else 0.0
        norm = np.sqrt(1.0 + hx * hx)
        return (q1 - hv) / norm, -hx / norm, 1.0 / norm, 0.0
    fy = (q1 - oy) / cy
    fy = min(max(fy, 0.0), ny - 1.0)
    j = min(int(fy), ny - 2)
    ty = fy - j
    inside_y = q1 > oy and q1 < oy + (ny - 1.0) * cy
    h00 = heights[b, s, i, j]
    h10 = heights[b, s, i + 1, j]
    h01 = heights[b, s, i, j + 1]
    h11 = heights[b, s, i + 1, j + 1]
    hv = (h00 * (1.0 - tx) + h10 * tx) * (1.0 - ty) + (h01 * (1.0 - tx) + h11 * tx) * ty
    hx = ((h10 - h00) * (1.0 - ty) + (h11 - h01) * ty) / cx if inside_x else 0.0
    hy = ((h01 - h00) * (1.0 - tx) + (h11 - h10) * tx) / cy if inside_y else 0.0
    norm = np.sqrt(1.0 + hx * hx + hy * hy)
    return (q2 - hv) / norm, -hx / norm, -hy / norm, 1.0 / norm


# kind name -> the local function (the table above); the order is the groups' order in Geometry
PRIMITIVE_KINDS = {
    "planes": sdf_plane,
    "rounds": sdf_round,
    "boxes": sdf_box,
    "capsules": sdf_capsule,
    "cylinders": sdf_cylinder,
    "cones": sdf_cone,
    "tori": sdf_torus,
}
KIND_CODES = {name: k for k, name in enumerate(PRIMITIVE_KINDS)}  # a CSG leaf's kind
GROUP_ORDER = (*PRIMITIVE_KINDS, "heights", "csg", "user")  # the Geometry's groups, in order

# ---------------------------------------------------------------------------------------------
# Packed shapes: flat float arrays, few per group. A function Numba does not inline receives a
# named tuple's every field, and every array's shape and strides, as arguments: a group of eight
# arrays cost more to pass than its contact costs to compute (measured), so a group is two arrays.
#
#   pose  (B, S, P): per world and shape, P = 2 d + d^2 + 3 columns: the centre (d), the rotation
#         (d x d, row-major), the velocity (d) and the angular velocity (3; the z one in 2D)
#   shape (S, Q): per shape, Q = 3 + its parameters: sign (+1 the shape, -1 its complement), bound
#         (a radius about the centre enclosing the shape; inf if unbounded), inner (a radius about
#         the centre inside the shape; 0 if none), then the parameters (N_PAR for a primitive)
# ---------------------------------------------------------------------------------------------
SIGN, BOUND, INNER, PAR = 0, 1, 2, 3  # columns of ``shape``


def pose_size(d: int) -> int:
    """Columns of a pose row in d dimensions."""
    return 2 * d + d * d + 3


def pose_columns(d: int) -> dict[str, slice]:
    """Where the centre, rotation, velocity and angular velocity sit in a pose row."""
    return {
        "position": slice(0, d),
        "rotation": slice(d, d + d * d),
        "velocity": slice(d + d * d, 2 * d + d * d),
        "angular_velocity": slice(2 * d + d * d, 2 * d + d * d + 3),
    }


GROUP_CLASSES = {name: namedtuple(name.capitalize() + "Group", ["pose", "shape"]) for name in PRIMITIVE_KINDS}
# each class also a module attribute of its own name: pickle (Numba's cache index keys its entries by
# the argument types) then stores it by reference, and a new process finds the cached kernels. As
# dict values only, the classes were pickled by value, each process's types differed from the
# cache's, and every scene with general shapes compiled again in every process (60 s and more).
globals().update({cls.__name__: cls for cls in GROUP_CLASSES.values()})
# a height field group: shape's parameters nx, ny, cell x, cell y, origin x, origin y; heights (B, S, NX, NY)
HeightGroup = namedtuple("HeightGroup", ["pose", "shape", "heights"])
# CSG shapes (:func:`csg_sdf`): prog (S, 1 + L) int64, each row its length then its postfix program
# (a leaf index, or an OP_ code); leaves (S, M, 1 + d + d^2 + N_PAR), each row a leaf: its kind code,
# centre, rotation (row-major) and parameters
CSGGroup = namedtuple("CSGGroup", ["pose", "shape", "prog", "leaves"])
# a user SDF: pose (B, P), shape (3,), phi, grad (or None) and dim (a tuple of d zeros: the
# dimension in the type)
UserShape = namedtuple("UserShape", ["pose", "shape", "phi", "grad", "dim"])

Geometry = namedtuple("Geometry", [*PRIMITIVE_KINDS, "heights", "csg", "user", "motion", "dim"])
"""Every general shape of a scene: one group per primitive kind (None if absent), ``heights`` (a
HeightGroup or None), ``csg`` (a CSGGroup or None), ``user`` (a tuple of UserShape, or None),
``motion`` (None when no shape moves: then poses are never advanced and the surface velocity is
never computed; else a (1,) array) and ``dim`` (a tuple of d zeros)."""


def geometry_shape_count(geom) -> int:
    """How many shapes a Geometry holds."""
    if geom is None:
        return 0
    n = sum(0 if getattr(geom, k) is None else getattr(geom, k).shape.shape[0] for k in GROUP_ORDER[:-1])
    return n + (0 if geom.user is None else len(geom.user))


def columns(where: list[tuple[str, int]]) -> list[int]:
    """For shapes packed with ``where`` (``shapes.pack_geometry``): each shape's column in
    :func:`evaluate`'s output (which lists the shapes group by group)."""
    order = sorted(range(len(where)), key=lambda k: (GROUP_ORDER.index(where[k][0]), where[k][1]))
    col = [0] * len(where)
    for c, k in enumerate(order):
        col[k] = c
    return col


# ---------------------------------------------------------------------------------------------
# Frames: a centre at row[c:c + D] and a rotation row-major at row[c + D:]
# ---------------------------------------------------------------------------------------------


@njit(inline="always")
def to_local(row, c, x0, x1, x2, D):
    """q = R^T (x - centre)."""
    d0 = x0 - row[c]
    d1 = x1 - row[c + 1]
    R = c + D
    if D == 3:
        d2 = x2 - row[c + 2]
        return (
            row[R] * d0 + row[R + 3] * d1 + row[R + 6] * d2,
            row[R + 1] * d0 + row[R + 4] * d1 + row[R + 7] * d2,
            row[R + 2] * d0 + row[R + 5] * d1 + row[R + 8] * d2,
        )
    return row[R] * d0 + row[R + 2] * d1, row[R + 1] * d0 + row[R + 3] * d1, 0.0


@njit(inline="always")
def to_parent(row, c, n0, n1, n2, D):
    """R n: a local direction in the parent frame."""
    R = c + D
    if D == 3:
        return (
            row[R] * n0 + row[R + 1] * n1 + row[R + 2] * n2,
            row[R + 3] * n0 + row[R + 4] * n1 + row[R + 5] * n2,
            row[R + 6] * n0 + row[R + 7] * n1 + row[R + 8] * n2,
        )
    return row[R] * n0 + row[R + 1] * n1, row[R + 2] * n0 + row[R + 3] * n1, 0.0


# ---------------------------------------------------------------------------------------------
# CSG programs: each CSG shape is a postfix program over its leaves, evaluated on a small stack held
# in registers. Data, not types: a CSG shape as a typed tree of named tuples is passed by value, its
# every array an argument, at every call of every level (measured 10x slower).
# ---------------------------------------------------------------------------------------------
OP_UNION, OP_INTERSECTION, OP_DIFFERENCE, OP_NEGATE = -1, -2, -3, -4  # a leaf is its index >= 0


@njit(inline="always")
def primitive_sdf(kind, q0, q1, q2, a, b, c, e, D):
    """The primitive of code ``kind`` (KIND_CODES) in its local frame."""
    if kind == 0:
        return sdf_plane(q0, q1, q2, a, b, c, e, D)
    if kind == 1:
        return sdf_round(q0, q1, q2, a, b, c, e, D)
    if kind == 2:
        return sdf_box(q0, q1, q2, a, b, c, e, D)
    if kind == 3:
        return sdf_capsule(q0, q1, q2, a, b, c, e, D)
    if kind == 4:
        return sdf_cylinder(q0, q1, q2, a, b, c, e, D)
    if kind == 5:
        return sdf_cone(q0, q1, q2, a, b, c, e, D)
    return sdf_torus(q0, q1, q2, a, b, c, e, D)


CSG_MAX_DEPTH = 4  # operands a CSG program may hold pending at once (its stack lives in registers)


@njit(inline="always")
def _combine(op, top, under):
    """The binary operation ``op`` of the two topmost operands (``under`` the first)."""
    if op == OP_UNION:
        return top if top[0] < under[0] else under  # min; a tie keeps the first operand
    if op == OP_INTERSECTION:
        return top if top[0] > under[0] else under  # max
    if -top[0] > under[0]:  # difference: max(phi_a, -phi_b)
        return -top[0], -top[1], -top[2], -top[3]
    return under


@njit
def csg_sdf(prog, leaves, q0, q1, q2, D):
    """A CSG shape at a point q of its frame: its postfix program ``prog`` (prog[0] its length,
    then its ops) over its ``leaves`` (rows [kind, c, R, par]), on a stack of CSG_MAX_DEPTH entries
    held in registers (s0 the top). Takes two arrays, not the group: a function that is not inlined
    receives a named tuple's every field as an argument."""
    z = (0.0, 0.0, 0.0, 0.0)
    s0 = s1 = s2 = s3 = z
    P = 1 + D + D * D  # where the parameters start
    for t in range(1, prog[0] + 1):
        op = prog[t]
        if op >= 0:
            leaf = leaves[op]
            t0, t1, t2 = to_local(leaf, 1, q0, q1, q2, D)
            phi, n0, n1, n2 = primitive_sdf(int(leaf[0]), t0, t1, t2, leaf[P], leaf[P + 1], leaf[P + 2], leaf[P + 3], D)
            m0, m1, m2 = to_parent(leaf, 1, n0, n1, n2, D)
            s3 = s2
            s2 = s1
            s1 = s0
            s0 = (phi, m0, m1, m2)
        elif op == OP_NEGATE:
            s0 = (-s0[0], -s0[1], -s0[2], -s0[3])
        else:
            s0 = _combine(op, s0, s1)
            s1 = s2
            s2 = s3
    return s0


# ---------------------------------------------------------------------------------------------
# User SDFs
# ---------------------------------------------------------------------------------------------
USER_FD_STEP = 6e-6  # central differences' step, relative to max(1, |q|_inf): ~ eps^(1/3)


@njit(inline="always")
def _normalised(val, g0, g1, g2, D):
    """(val, g / |g|); the last axis where g is zero or not finite."""
    n2 = g0 * g0 + g1 * g1
    if D == 3:
        n2 += g2 * g2
    if n2 > 0.0 and n2 < np.inf:
        inv = 1.0 / np.sqrt(n2)
        return val, g0 * inv, g1 * inv, (g2 * inv if D == 3 else 0.0)
    return val, 0.0, (1.0 if D == 2 else 0.0), (1.0 if D == 3 else 0.0)


def user_sdf(node, q0, q1, q2):
    """A user shape's phi and unit normal at a local point: its ``phi`` (a Numba function of a
    tuple of d floats) and its ``grad``, or central differences where it has none (jitted code
    only). The dimension comes from the node's type, so phi is compiled for d-tuples only."""
    raise NotImplementedError


@overload(user_sdf)
def _user_sdf(node, q0, q1, q2):
    d = _field(node, "dim").count
    if not _none(_field(node, "grad")):
        if d == 3:

            def impl_g3(node, q0, q1, q2):
                g = node.grad((q0, q1, q2))
                return _normalised(node.phi((q0, q1, q2)), float(g[0]), float(g[1]), float(g[2]), 3)

            return impl_g3

        def impl_g2(node, q0, q1, q2):
            g = node.grad((q0, q1))
            return _normalised(node.phi((q0, q1)), float(g[0]), float(g[1]), 0.0, 2)

        return impl_g2
    if d == 3:

        def impl3(node, q0, q1, q2):
            f = node.phi
            h = USER_FD_STEP * max(1.0, abs(q0), abs(q1), abs(q2))
            g0 = f((q0 + h, q1, q2)) - f((q0 - h, q1, q2))
            g1 = f((q0, q1 + h, q2)) - f((q0, q1 - h, q2))
            g2 = f((q0, q1, q2 + h)) - f((q0, q1, q2 - h))
            return _normalised(f((q0, q1, q2)), g0, g1, g2, 3)

        return impl3

    def impl2(node, q0, q1, q2):
        f = node.phi
        h = USER_FD_STEP * max(1.0, abs(q0), abs(q1))
        g0 = f((q0 + h, q1)) - f((q0 - h, q1))
        g1 = f((q0, q1 + h)) - f((q0, q1 - h))
        return _normalised(f((q0, q1)), g0, g1, 0.0, 2)

    return impl2


# ---------------------------------------------------------------------------------------------
# Compile-time dispatch on the group types
# ---------------------------------------------------------------------------------------------


def _is(t, cls) -> bool:
    return isinstance(t, types.BaseNamedTuple) and t.instance_class is cls


def _none(t) -> bool:
    return t is None or isinstance(t, (types.NoneType, types.Omitted))


def _field(t, name):
    """The type of field ``name`` of a named-tuple type (None's type where it has no such field)."""
    return t.types[t.fields.index(name)] if name in t.fields else types.none


def model_geometry_type(model):
    """At compile time: the type of a Model's ``geometry`` (NoneType when it has none)."""
    return _field(model, "geometry")


def _is_tuple(t) -> bool:
    return isinstance(t, types.BaseTuple) and not isinstance(t, types.BaseNamedTuple)


def _present(geo) -> list[str]:
    return [k for k in GROUP_ORDER if not _none(_field(geo, k))]


def _rows(grp, b, s):
    """(pose row, shape row) of shape s of a group in world b (jitted code only)."""
    raise NotImplementedError


@overload(_rows, inline="always")
def _rows_impl(grp, b, s):
    if _is(grp, UserShape):
        return lambda grp, b, s: (grp.pose[b], grp.shape)
    return lambda grp, b, s: (grp.pose[b, s], grp.shape[s])


def _count(grp):
    raise NotImplementedError


@overload(_count, inline="always")
def _count_impl(grp):
    if _is(grp, UserShape):
        return lambda grp: 1
    return lambda grp: grp.shape.shape[0]


def local_sdf(grp, b, s, q0, q1, q2, D):
    """Shape s of a primitive, height or CSG group in its local frame (jitted code only)."""
    raise NotImplementedError


def _group_impl(fn):
    return lambda grp, b, s, q0, q1, q2, D: fn(
        q0, q1, q2, grp.shape[s, PAR], grp.shape[s, PAR + 1], grp.shape[s, PAR + 2], grp.shape[s, PAR + 3], D
    )


@overload(local_sdf, inline="always")
def _local_sdf(grp, b, s, q0, q1, q2, D):
    for name, fn in PRIMITIVE_KINDS.items():
        if _is(grp, GROUP_CLASSES[name]):
            return _group_impl(fn)
    if _is(grp, HeightGroup):

        def impl(grp, b, s, q0, q1, q2, D):
            p = grp.shape[s]
            nx, ny = int(p[PAR]), int(p[PAR + 1])
            return sdf_height(grp.heights, b, s, nx, ny, p[PAR + 2], p[PAR + 3], p[PAR + 4], p[PAR + 5], q0, q1, q2, D)

        return impl
    if _is(grp, CSGGroup):
        return lambda grp, b, s, q0, q1, q2, D: csg_sdf(grp.prog[s], grp.leaves[s], q0, q1, q2, D)
    if _is(grp, UserShape):
        return lambda grp, b, s, q0, q1, q2, D: user_sdf(grp, q0, q1, q2)
    return None


def shape_sdf(grp, b, s, x0, x1, x2, D):
    """(phi, n0, n1, n2) in the world frame of shape s of a group (a UserShape: s ignored), signed
    by its ``sign``, at world point x of world b (jitted code only)."""
    raise NotImplementedError


@overload(shape_sdf, inline="always")
def _shape_sdf(grp, b, s, x0, x1, x2, D):
    if _is(grp, GROUP_CLASSES["rounds"]):
        # a sphere needs no rotation: the same arithmetic as the static spheres' (bit for bit)
        def impl_round(grp, b, s, x0, x1, x2, D):
            pose, shape = _rows(grp, b, s)
            sg = shape[SIGN]
            q0 = x0 - pose[0]
            q1 = x1 - pose[1]
            q2 = x2 - pose[2] if D == 3 else 0.0
            phi, n0, n1, n2 = sdf_round(q0, q1, q2, shape[PAR], 0.0, 0.0, 0.0, D)
            return sg * phi, sg * n0, sg * n1, sg * n2

        return impl_round

    def impl(grp, b, s, x0, x1, x2, D):
        pose, shape = _rows(grp, b, s)
        q0, q1, q2 = to_local(pose, 0, x0, x1, x2, D)
        phi, n0, n1, n2 = local_sdf(grp, b, s, q0, q1, q2, D)
        m0, m1, m2 = to_parent(pose, 0, n0, n1, n2, D)
        sg = shape[SIGN]
        return sg * phi, sg * m0, sg * m1, sg * m2

    return impl


# ---------------------------------------------------------------------------------------------
# Contacts: every general shape against ball i (the law itself is contact.terrain_law)
# ---------------------------------------------------------------------------------------------


@njit(inline="always")
def _miss(pose, shape, p0, p1, p2, r, D):
    """Early miss test without a square root: a solid is touched only within ``bound`` + r of its
    centre, a complement only outside ``inner`` - r (the static spheres' test)."""
    d0 = p0 - pose[0]
    d1 = p1 - pose[1]
    d2 = d0 * d0 + d1 * d1
    if D == 3:
        d2 += (p2 - pose[2]) * (p2 - pose[2])
    if shape[SIGN] > 0.0:
        bound = shape[BOUND]
        return d2 >= (bound + r) * (bound + r)
    inner = shape[INNER]
    return inner > r and d2 <= (inner - r) * (inner - r)


@njit(inline="always")
def surface_velocity(pose, p0, p1, p2, phi, n0, n1, n2, D):
    """Velocity of the moving surface at the contact point (the ball centre's foot on the
    surface, x - phi grad phi): v_s + w_s x (point - c_s)."""
    V = D + D * D
    W = V + D
    c0 = p0 - phi * n0 - pose[0]
    c1 = p1 - phi * n1 - pose[1]
    if D == 3:
        c2 = p2 - phi * n2 - pose[2]
        return (
            pose[V] + pose[W + 1] * c2 - pose[W + 2] * c1,
            pose[V + 1] + pose[W + 2] * c0 - pose[W] * c2,
            pose[V + 2] + pose[W] * c1 - pose[W + 1] * c0,
        )
    return pose[V] - pose[W + 2] * c1, pose[V + 1] + pose[W + 2] * c0, 0.0


def _group_contacts(mode, grp, motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2):
    raise NotImplementedError


@overload(_group_contacts)
def _group_contacts_impl(
    mode, grp, motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2
):
    """The contact loop over one group (a tuple of user shapes: each in turn): the miss test, phi
    and its normal, the surface velocity where shapes move, then the law. Not inlined (each
    group's code is compiled once), so its arguments are few and small."""
    from .contact import combine, terrain_law  # (contact imports this module)

    if _is_tuple(grp):
        if len(grp) == 0:
            return (
                lambda mode, grp, motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2: (
                    acc,
                    f0,
                    f1,
                    f2,
                )
            )

        def impl_tuple(
            mode, grp, motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2
        ):
            acc, f0, f1, f2 = _group_contacts(
                mode, grp[0], motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2
            )
            return _group_contacts(
                mode, grp[1:], motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2
            )

        return impl_tuple

    def impl(mode, grp, motion, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D, acc, f0, f1, f2):
        for s in range(_count(grp)):
            pose, shape = _rows(grp, b, s)
            if _miss(pose, shape, p0, p1, p2, r, D):
                continue
            phi, n0, n1, n2 = shape_sdf(grp, b, s, p0, p1, p2, D)
            pen = r - phi
            if not pen > 0.0:
                continue
            if motion is None:
                val, e0, e1, e2 = terrain_law(
                    mode, pen, n0, n1, n2, None, u0, u1, u2, r, coef, ks, kd, clip, friction, D
                )
            else:
                w = surface_velocity(pose, p0, p1, p2, phi, n0, n1, n2, D)
                val, e0, e1, e2 = terrain_law(mode, pen, n0, n1, n2, w, u0, u1, u2, r, coef, ks, kd, clip, friction, D)
            acc = combine(mode, acc, val)
            f0 += e0
            f1 += e1
            f2 += e2
        return acc, f0, f1, f2

    return impl


def general_terrain(mode, geo, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D):
    """Sum over every general shape of the terrain law at ball (p, u) of radius r in world b:
    (acc, f0, f1, f2), acc combined by max for MAXPEN and by sum otherwise (jitted code only)."""
    raise NotImplementedError


@overload(general_terrain, inline="always")
def _general_terrain(mode, geo, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D):
    # one call per present group, unrolled at compile time
    src = ["def impl(mode, geo, b, p0, p1, p2, u0, u1, u2, r, coef, ks, kd, clip, friction, D):"]
    src.append("    acc = 0.0; f0 = 0.0; f1 = 0.0; f2 = 0.0")
    for k in _present(geo):
        src.append(
            f"    acc, f0, f1, f2 = _group_contacts(mode, geo.{k}, geo.motion, b, p0, p1, p2, u0, u1, u2, r, coef, "
            "ks, kd, clip, friction, D, acc, f0, f1, f2)"
        )
    src.append("    return acc, f0, f1, f2")
    scope = {"_group_contacts": _group_contacts}
    exec("\n".join(src), scope)  # noqa: S102 - fixed template, group names from this module
    return scope["impl"]


# ---------------------------------------------------------------------------------------------
# Kinematic shapes: advance every pose of world b by dt (after each step)
# ---------------------------------------------------------------------------------------------


@njit(inline="always")
def _rotate(row, R, w0, w1, w2, dt, D):
    """The rotation stored row-major at row[R:] <- exp(dt [w]x) times it (Rodrigues' formula:
    exact for a constant angular velocity)."""
    if D == 2:
        th = w2 * dt
        if th == 0.0:
            return
        c = np.cos(th)
        s = np.sin(th)
        for j in range(2):
            a = row[R + j]
            e = row[R + 2 + j]
            row[R + j] = c * a - s * e
            row[R + 2 + j] = s * a + c * e
        return
    wn = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    th = wn * dt
    if th == 0.0:
        return
    k0 = w0 / wn
    k1 = w1 / wn
    k2 = w2 / wn
    s = np.sin(th)
    c1 = 1.0 - np.cos(th)
    # R_inc = I + s K + c1 K^2, K the cross-product matrix of k
    r00 = 1.0 - c1 * (k1 * k1 + k2 * k2)
    r11 = 1.0 - c1 * (k0 * k0 + k2 * k2)
    r22 = 1.0 - c1 * (k0 * k0 + k1 * k1)
    r01 = -s * k2 + c1 * k0 * k1
    r10 = s * k2 + c1 * k0 * k1
    r02 = s * k1 + c1 * k0 * k2
    r20 = -s * k1 + c1 * k0 * k2
    r12 = -s * k0 + c1 * k1 * k2
    r21 = s * k0 + c1 * k1 * k2
    for j in range(3):
        a = row[R + j]
        e = row[R + 3 + j]
        f = row[R + 6 + j]
        row[R + j] = r00 * a + r01 * e + r02 * f
        row[R + 3 + j] = r10 * a + r11 * e + r12 * f
        row[R + 6 + j] = r20 * a + r21 * e + r22 * f


def _advance(grp, b, dt, D):
    raise NotImplementedError


@overload(_advance)
def _advance_impl(grp, b, dt, D):
    if _is_tuple(grp):
        if len(grp) == 0:
            return lambda grp, b, dt, D: None

        def impl_tuple(grp, b, dt, D):
            _advance(grp[0], b, dt, D)
            _advance(grp[1:], b, dt, D)

        return impl_tuple

    def impl(grp, b, dt, D):
        V = D + D * D
        for s in range(_count(grp)):
            pose, _ = _rows(grp, b, s)
            for k in range(D):
                pose[k] += dt * pose[V + k]
            W = V + D
            _rotate(pose, D, pose[W], pose[W + 1], pose[W + 2], dt, D)

    return impl


def advance_geometry(model, b, dt, D):
    """Move every kinematic shape of world b on by dt (jitted code only; nothing when no shape moves)."""
    raise NotImplementedError


@overload(advance_geometry)
def _advance_geometry(model, b, dt, D):
    geo = _field(model, "geometry")
    if _none(geo) or _none(_field(geo, "motion")):
        return lambda model, b, dt, D: None
    src = ["def impl(model, b, dt, D):", "    g = model.geometry"]
    src += [f"    _advance(g.{k}, b, dt, D)" for k in _present(geo)]
    src.append("    return None")
    scope = {"_advance": _advance}
    exec("\n".join(src), scope)  # noqa: S102 - fixed template
    return scope["impl"]


# ---------------------------------------------------------------------------------------------
# Clearance (the neighbour list's "near the terrain" test) and evaluation at points
# ---------------------------------------------------------------------------------------------


def _clearance(grp, b, p0, p1, p2, D, best):
    raise NotImplementedError


@overload(_clearance)
def _clearance_impl(grp, b, p0, p1, p2, D, best):
    if _is_tuple(grp) or _is(grp, HeightGroup):
        # phi need not be 1-Lipschitz (the height field's approximation, a user's function): no
        # clearance can be promised
        return lambda grp, b, p0, p1, p2, D, best: -np.inf

    def impl(grp, b, p0, p1, p2, D, best):
        for s in range(_count(grp)):
            best = min(best, shape_sdf(grp, b, s, p0, p1, p2, D)[0])
        return best

    return impl


def geometry_clearance(model, b, p0, p1, p2, D):
    """A lower bound of the distance from x to every general shape (-inf where none can be given:
    moving shapes, height fields, user SDFs); inf without general shapes (jitted code only).
    Exact shapes and CSG (min / max of 1-Lipschitz functions) give phi itself."""
    raise NotImplementedError


@overload(geometry_clearance)
def _geometry_clearance(model, b, p0, p1, p2, D):
    geo = _field(model, "geometry")
    if _none(geo):
        return lambda model, b, p0, p1, p2, D: np.inf
    if not _none(_field(geo, "motion")):
        return lambda model, b, p0, p1, p2, D: -np.inf
    src = ["def impl(model, b, p0, p1, p2, D):", "    g = model.geometry", "    best = np.inf"]
    src += [f"    best = _clearance(g.{k}, b, p0, p1, p2, D, best)" for k in _present(geo)]
    src.append("    return best")
    scope = {"_clearance": _clearance, "np": np}
    exec("\n".join(src), scope)  # noqa: S102 - fixed template
    return scope["impl"]


def _eval_group(grp, b, points, out, col, D):
    raise NotImplementedError


@overload(_eval_group)
def _eval_group_impl(grp, b, points, out, col, D):
    if _is_tuple(grp):
        if len(grp) == 0:
            return lambda grp, b, points, out, col, D: col

        def impl_tuple(grp, b, points, out, col, D):
            return _eval_group(grp[1:], b, points, out, _eval_group(grp[0], b, points, out, col, D), D)

        return impl_tuple

    def impl(grp, b, points, out, col, D):
        S = _count(grp)
        for s in range(S):
            for t in range(points.shape[0]):
                x2 = points[t, 2] if D == 3 else 0.0
                phi, n0, n1, n2 = shape_sdf(grp, b, s, points[t, 0], points[t, 1], x2, D)
                out[t, col + s, 0] = phi
                out[t, col + s, 1] = n0
                out[t, col + s, 2] = n1
                out[t, col + s, 3] = n2
        return col + S

    return impl


def eval_shapes(geo, b, points, out):
    """phi and grad phi of every general shape of world b at ``points`` (m, d): ``out`` (m, S, 4)
    receives (phi, n0, n1, n2), shapes in the Geometry's order (jitted code only)."""
    raise NotImplementedError


@overload(eval_shapes)
def _eval_shapes(geo, b, points, out):
    src = ["def impl(geo, b, points, out):", "    D = len(geo.dim)", "    col = 0"]
    src += [f"    col = _eval_group(geo.{k}, b, points, out, col, D)" for k in _present(geo)]
    src.append("    return col")
    scope = {"_eval_group": _eval_group}
    exec("\n".join(src), scope)  # noqa: S102 - fixed template
    return scope["impl"]


@njit(nogil=True)
def evaluate(geo, b, points, out):
    """:func:`eval_shapes` as a compiled entry point (the Python side of the shapes calls it)."""
    return eval_shapes(geo, b, points, out)


def world_slice(geo: Any, b: int) -> Any:
    """World b of a Geometry as a one-world Geometry whose arrays are views of the original's (what
    the neighbour-list path steps as world 0: a pose set on the World reaches it)."""
    if geo is None:
        return None

    def one(x: Any) -> Any:
        if x is None:
            return None
        if isinstance(x, tuple) and not hasattr(x, "_fields"):
            return tuple(one(e) for e in x)
        return x._replace(**{k: getattr(x, k)[b : b + 1] for k in ("pose", "heights") if k in x._fields})

    return geo._replace(**{k: one(getattr(geo, k)) for k in GROUP_ORDER})
