"""Shapes at a point, kernel side: phi and its normal of any row of a :class:`.table.ShapeTable`.

:func:`shape_sdf` places a shape in the world: ``q = R^T (x - c)`` into its local frame, its kind's
function there (:mod:`.sdf`; a CSG program over such leaves, a height field's grid, or a user's
compiled function called through its address), and the normal back, ``R n``; times the shape's
sign (-1 for a complement). One function for every kind, dispatching on the row's kind at run
time: a new scene, terrain or combination of shapes compiles nothing new.

Also here: the miss test that skips a square root for a ball far from a bounded shape, the
velocity of a moving shape's surface, the advance of kinematic poses after each step, the
clearance bound of the neighbour list, and :func:`evaluate` (phi and normals at points, for the
Python side).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from ..._jit import njit
from .sdf import CSG, HEIGHTS, ROUND, USER, primitive_sdf, sdf_height, sdf_round
from .table import (
    BOUND,
    DIRECT,
    INDEX,
    INNER,
    MOVING,
    OP_INTERSECTION,
    OP_NEGATE,
    OP_UNION,
    P0,
    SIGN,
)

__all__ = [
    "to_local",
    "to_parent",
    "csg_sdf",
    "user_sdf",
    "local_sdf",
    "shape_sdf",
    "shape_miss",
    "surface_velocity",
    "advance_shapes",
    "terrain_clearance",
    "evaluate",
    "evaluate_shape",
    "USER_FD_STEP",
]

USER_FD_STEP = 6e-6  # central differences' step, relative to max(1, |q|_inf): ~ eps^(1/3)


# ---------------------------------------------------------------------------------------------
# Frames: a centre at row[:D] and a rotation row-major at row[D:]
# ---------------------------------------------------------------------------------------------


@njit(hot=True)
def to_local(row, x0, x1, x2, D):
    """q = R^T (x - centre), the frame's centre at row[:D] and its rotation (row-major) after it."""
    d0 = x0 - row[0]
    d1 = x1 - row[1]
    R = D
    if D == 3:
        d2 = x2 - row[2]
        return (
            row[R] * d0 + row[R + 3] * d1 + row[R + 6] * d2,
            row[R + 1] * d0 + row[R + 4] * d1 + row[R + 7] * d2,
            row[R + 2] * d0 + row[R + 5] * d1 + row[R + 8] * d2,
        )
    return row[R] * d0 + row[R + 2] * d1, row[R + 1] * d0 + row[R + 3] * d1, 0.0


@njit(hot=True)
def to_parent(row, n0, n1, n2, D):
    """R n: a local direction in the parent frame (the frame as :func:`to_local`'s)."""
    R = D
    if D == 3:
        return (
            row[R] * n0 + row[R + 1] * n1 + row[R + 2] * n2,
            row[R + 3] * n0 + row[R + 4] * n1 + row[R + 5] * n2,
            row[R + 6] * n0 + row[R + 7] * n1 + row[R + 8] * n2,
        )
    return row[R] * n0 + row[R + 1] * n1, row[R + 2] * n0 + row[R + 3] * n1, 0.0


# ---------------------------------------------------------------------------------------------
# CSG programs: a postfix program over the shape's leaves, evaluated on a small stack held in
# registers (s0 the top)
# ---------------------------------------------------------------------------------------------


@njit
def _combine(op, t0, t1, t2, t3, u0, u1, u2, u3):
    """The binary operation ``op`` of the two topmost operands (t the top, u the one under it)."""
    if op == OP_UNION:
        if t0 < u0:  # min; a tie keeps the first operand
            return t0, t1, t2, t3
        return u0, u1, u2, u3
    if op == OP_INTERSECTION:
        if t0 > u0:  # max
            return t0, t1, t2, t3
        return u0, u1, u2, u3
    if -t0 > u0:  # difference: max(phi_a, -phi_b)
        return -t0, -t1, -t2, -t3
    return u0, u1, u2, u3


@njit
def csg_sdf(prog, leaves, q0, q1, q2, D):
    """A CSG shape at a point q of its frame: its postfix program ``prog`` (prog[0] its length,
    then its ops) over its ``leaves`` (rows [kind, centre, rotation, parameters])."""
    z = (0.0, 0.0, 0.0, 0.0)
    s0 = s1 = s2 = s3 = z
    P = 1 + D + D * D  # where a leaf's parameters start
    for t in range(1, prog[0] + 1):
        op = prog[t]
        if op >= 0:
            leaf = leaves[op]
            frame = leaf[1:]
            t0, t1, t2 = to_local(frame, q0, q1, q2, D)
            phi, n0, n1, n2 = primitive_sdf(int(leaf[0]), t0, t1, t2, leaf[P], leaf[P + 1], leaf[P + 2], D)
            m0, m1, m2 = to_parent(frame, n0, n1, n2, D)
            s3 = s2
            s2 = s1
            s1 = s0
            s0 = (phi, m0, m1, m2)
        elif op == OP_NEGATE:
            s0 = (-s0[0], -s0[1], -s0[2], -s0[3])
        else:
            s0 = _combine(op, s0[0], s0[1], s0[2], s0[3], s1[0], s1[1], s1[2], s1[3])
            s1 = s2
            s2 = s3
    return s0


# ---------------------------------------------------------------------------------------------
# User SDFs: the user's jitted functions compiled as C callbacks (:mod:`.user`), called through
# their addresses, so the step is compiled (and cached) once for any of them
# ---------------------------------------------------------------------------------------------


@intrinsic
def _call_phi(typingctx, addr, q0, q1, q2):
    """phi of a user SDF: the C function ``double phi(double, double, double)`` at ``addr``."""
    sig = types.float64(types.int64, types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType()] * 3)
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(fn, args[1:])

    return sig, codegen


@intrinsic
def _call_grad(typingctx, addr, q0, q1, q2):
    """The gradient of a user SDF: the C function ``void grad(double, double, double, double *out)``
    at ``addr`` (writes 3 values), returned as a tuple."""
    ret = types.UniTuple(types.float64, 3)
    sig = ret(types.int64, types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        dbl = ir.DoubleType()
        fnty = ir.FunctionType(ir.VoidType(), [dbl, dbl, dbl, dbl.as_pointer()])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        out = builder.alloca(ir.ArrayType(dbl, 3))
        base = builder.bitcast(out, dbl.as_pointer())
        builder.call(fn, [args[1], args[2], args[3], base])
        vals = [builder.load(builder.gep(base, [ir.Constant(ir.IntType(32), k)])) for k in range(3)]
        return context.make_tuple(builder, ret, vals)

    return sig, codegen


@njit
def _normalised(val, g0, g1, g2, D):
    """(val, g / |g|); the last axis where g is zero or not finite."""
    n2 = g0 * g0 + g1 * g1
    if D == 3:
        n2 += g2 * g2
    if n2 > 0.0 and n2 < np.inf:
        inv = 1.0 / math.sqrt(n2)
        return val, g0 * inv, g1 * inv, (g2 * inv if D == 3 else 0.0)
    return val, 0.0, (1.0 if D == 2 else 0.0), (1.0 if D == 3 else 0.0)


@njit
def user_sdf(phi, grad, q0, q1, q2, D):
    """A user shape's phi and unit normal at a local point: its ``phi`` and its ``grad`` (addresses),
    or central differences where it has no gradient (``grad`` 0)."""
    if grad != 0:
        g0, g1, g2 = _call_grad(grad, q0, q1, q2)
        return _normalised(_call_phi(phi, q0, q1, q2), g0, g1, g2, D)
    if D == 3:
        h = USER_FD_STEP * max(1.0, abs(q0), abs(q1), abs(q2))
        g0 = _call_phi(phi, q0 + h, q1, q2) - _call_phi(phi, q0 - h, q1, q2)
        g1 = _call_phi(phi, q0, q1 + h, q2) - _call_phi(phi, q0, q1 - h, q2)
        g2 = _call_phi(phi, q0, q1, q2 + h) - _call_phi(phi, q0, q1, q2 - h)
        return _normalised(_call_phi(phi, q0, q1, q2), g0, g1, g2, D)
    h = USER_FD_STEP * max(1.0, abs(q0), abs(q1))
    g0 = _call_phi(phi, q0 + h, q1, 0.0) - _call_phi(phi, q0 - h, q1, 0.0)
    g1 = _call_phi(phi, q0, q1 + h, 0.0) - _call_phi(phi, q0, q1 - h, 0.0)
    return _normalised(_call_phi(phi, q0, q1, 0.0), g0, g1, 0.0, D)


# ---------------------------------------------------------------------------------------------
# Any shape of the table
# ---------------------------------------------------------------------------------------------


@njit(hot=True)
def local_sdf(kind, par, heights, prog, leaves, user, q0, q1, q2, D):
    """A shape of the table in its local frame, before its sign: its ``kind``, its ``shape`` row
    ``par``, and the table's buffers it may read (``heights``: its world's row). Inlined; the
    functions it dispatches to are not (each kind's code is large) and take scalars or the one
    array they read: a call passes each array argument field by field."""
    if kind == HEIGHTS:
        nx = int(par[P0])
        ny = int(par[P0 + 1])
        start = int(par[INDEX])
        grid = heights[start : start + nx * ny]
        return sdf_height(grid, nx, ny, par[P0 + 2], par[P0 + 3], par[P0 + 4], par[P0 + 5], q0, q1, q2, D)
    if kind == CSG:
        c = int(par[INDEX])
        return csg_sdf(prog[c], leaves[c], q0, q1, q2, D)
    if kind == USER:
        u = int(par[INDEX])
        return user_sdf(user[u, 0], user[u, 1], q0, q1, q2, D)
    return primitive_sdf(kind, q0, q1, q2, par[P0], par[P0 + 1], par[P0 + 2], D)


@njit(hot=True)
def shape_sdf(table, b, s, x0, x1, x2, D):
    """(phi, n0, n1, n2) of shape s in the world frame of world b, signed, at the world point x."""
    pose = table.pose[b, s]
    sg = table.shape[s, SIGN]
    if table.kind[s] == ROUND:  # a sphere needs no rotation (the same arithmetic as ever)
        q0 = x0 - pose[0]
        q1 = x1 - pose[1]
        q2 = x2 - pose[2] if D == 3 else 0.0
        phi, n0, n1, n2 = sdf_round(q0, q1, q2, table.shape[s, P0], 0.0, 0.0, D)
        return sg * phi, sg * n0, sg * n1, sg * n2
    q0, q1, q2 = to_local(pose, x0, x1, x2, D)
    phi, n0, n1, n2 = local_sdf(
        table.kind[s], table.shape[s], table.heights[b], table.prog, table.leaves, table.user, q0, q1, q2, D
    )
    m0, m1, m2 = to_parent(pose, n0, n1, n2, D)
    return sg * phi, sg * m0, sg * m1, sg * m2


@njit(hot=True)
def shape_miss(table, b, s, p0, p1, p2, r, D):
    """Early miss test without a square root: a solid is touched only within its bound + r of
    its centre, a complement only outside its inner radius - r."""
    return miss_test(table.pose[b, s], table.shape[s], p0, p1, p2, r, D)


@njit(hot=True)
def miss_test(pose, par, p0, p1, p2, r, D):
    """:func:`shape_miss` of the shape whose pose row and ``shape`` row are given."""
    d0 = p0 - pose[0]
    d1 = p1 - pose[1]
    d2 = d0 * d0 + d1 * d1
    if D == 3:
        d2 += (p2 - pose[2]) * (p2 - pose[2])
    if par[SIGN] > 0.0:
        bound = par[BOUND]
        return d2 >= (bound + r) * (bound + r)
    inner = par[INNER]
    return inner > r and d2 <= (inner - r) * (inner - r)


@njit(hot=True)
def surface_velocity(pose, p0, p1, p2, phi, n0, n1, n2, D):
    """Velocity of a moving shape's surface at the contact point (the ball centre's foot on the
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


@njit(hot=True)
def is_direct(table, s):
    """A static sphere or bowl: its force is added to the ball as it is computed."""
    return (table.flags[s] & DIRECT) != 0


@njit(hot=True)
def is_moving(table, s):
    return (table.flags[s] & MOVING) != 0


# ---------------------------------------------------------------------------------------------
# Kinematic shapes: advance every moving pose of world b by dt (after each step)
# ---------------------------------------------------------------------------------------------


@njit
def _rotate(row, R, w0, w1, w2, dt, D):
    """The rotation stored row-major at row[R:] <- exp(dt [w]x) times it (Rodrigues' formula:
    exact for a constant angular velocity)."""
    if D == 2:
        th = w2 * dt
        if th == 0.0:
            return
        c = math.cos(th)
        s = math.sin(th)
        for j in range(2):
            a = row[R + j]
            e = row[R + 2 + j]
            row[R + j] = c * a - s * e
            row[R + 2 + j] = s * a + c * e
        return
    wn = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    th = wn * dt
    if th == 0.0:
        return
    k0 = w0 / wn
    k1 = w1 / wn
    k2 = w2 / wn
    s = math.sin(th)
    c1 = 1.0 - math.cos(th)
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


@njit(hot=True)
def advance_shapes(table, b, dt, D):
    """Move every kinematic shape of world b on by dt: centre += dt v, rotation turned by dt w.
    (Hot: called per world and step, it costs a loop over the flags when nothing moves.)"""
    V = D + D * D
    W = V + D
    for s in range(table.kind.shape[0]):
        if is_moving(table, s):
            pose = table.pose[b, s]
            for k in range(D):
                pose[k] += dt * pose[V + k]
            _rotate(pose, D, pose[W], pose[W + 1], pose[W + 2], dt, D)


# ---------------------------------------------------------------------------------------------
# Clearance (the neighbour list's "near the terrain" test) and evaluation at points
# ---------------------------------------------------------------------------------------------


@njit
def terrain_clearance(table, b, p0, p1, p2, D):
    """A lower bound of the distance from x to every shape but the static spheres and bowls (the
    neighbour list tests those by themselves): phi itself where phi is 1-Lipschitz (exact shapes,
    CSG: min / max of such), -inf where no bound can be given (a moving shape, a height field, a
    user SDF); inf without such shapes."""
    best = np.inf
    for s in range(table.kind.shape[0]):
        if is_direct(table, s):
            continue
        kind = table.kind[s]
        if kind == HEIGHTS or kind == USER or is_moving(table, s):
            return -np.inf
        best = min(best, shape_sdf(table, b, s, p0, p1, p2, D)[0])
    return best


@njit(entry=True, nogil=True)
def evaluate(table, b, points, out, dim):
    """phi and grad phi of every shape of world b at ``points`` (m, d): ``out`` (m, S, 4)
    receives (phi, n0, n1, n2), shapes in the table's order (``dim``: a tuple of d floats, the
    dimension as the kernels take it)."""
    D = len(dim)
    for s in range(table.kind.shape[0]):
        for t in range(points.shape[0]):
            x2 = points[t, 2] if D == 3 else 0.0
            phi, n0, n1, n2 = shape_sdf(table, b, s, points[t, 0], points[t, 1], x2, D)
            out[t, s, 0] = phi
            out[t, s, 1] = n0
            out[t, s, 2] = n1
            out[t, s, 3] = n2


@njit(entry=True, nogil=True)
def evaluate_shape(table, s, worlds, points, out, dim):
    """phi and grad phi of shape s (a table row) of world ``worlds[t]`` at its points
    ``points[t]`` (k, m, d), for every t in one call: ``out`` (k, m, 4) receives
    (phi, n0, n1, n2), as :func:`evaluate` computes them."""
    D = len(dim)
    for t in range(worlds.shape[0]):
        b = worlds[t]
        for p in range(points.shape[1]):
            x2 = points[t, p, 2] if D == 3 else 0.0
            phi, n0, n1, n2 = shape_sdf(table, b, s, points[t, p, 0], points[t, p, 1], x2, D)
            out[t, p, 0] = phi
            out[t, p, 1] = n0
            out[t, p, 2] = n1
            out[t, p, 3] = n2
