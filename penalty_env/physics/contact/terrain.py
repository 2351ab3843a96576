"""Ball i against every terrain shape in world b (scalar): the force, the overlaps, and the
implicit solver's products.

Each shape is a row of the scene's :class:`~..geometry.table.ShapeTable`: at the ball's centre
its signed distance phi and outward normal n (:func:`..geometry.evaluate.shape_sdf`), the overlap
pen = r_i - phi, in contact while pen > 0; the force on the ball is ``f_n n`` (+ friction) with the
law's f_n (:func:`.law.normal_force`) of the overlap and the rate (u - w) . n at which the ball
leaves the surface (w the surface's velocity there: 0 for a static shape, the seed's case). A
ball touching several shapes gets a force from each: the static spheres and bowls add theirs as
they go, the other shapes' are summed and added once (the table's order, :mod:`..geometry.table`).
"""

from __future__ import annotations

from ..._jit import njit
from ..geometry.evaluate import is_direct, is_moving, shape_miss, shape_sdf, surface_velocity
from ..geometry.sdf import sdf_round
from ..geometry.table import P0, SIGN
from .law import normal_force, regularised_ratio

__all__ = [
    "terrain_law",
    "round_force",
    "terrain_force",
    "summed_terrain",
    "terrain_measure",
    "terrain_jacobian",
    "has_summed_shapes",
]


@njit(hot=True)
def terrain_law(pen, n0, n1, n2, r0, r1, r2, ks, kd, no_tension, mu, kf, D):
    """The force (f0, f1, f2) on a ball overlapping a solid by pen > 0 along its outward normal n,
    moving at r relative to the surface: ``f_n n`` with f_n = ks pen - kd (r . n) (clipped at 0
    with ``no_tension``), and regularised Coulomb friction against the sliding part of r."""
    vn = r0 * n0 + r1 * n1
    if D == 3:
        vn += r2 * n2
    fn = normal_force(ks, kd, pen, vn, no_tension)  # along +n; > 0 pushes out
    f0 = fn * n0
    f1 = fn * n1
    f2 = fn * n2 if D == 3 else 0.0
    if mu > 0.0:
        t0 = r0 - vn * n0
        t1 = r1 - vn * n1
        t2 = r2 - vn * n2 if D == 3 else 0.0
        vt2 = t0 * t0 + t1 * t1
        if D == 3:
            vt2 += t2 * t2
        ratio = regularised_ratio(kf, mu, fn, vt2, False)
        f0 -= ratio * t0  # opposes sliding
        f1 -= ratio * t1
        f2 -= ratio * t2
    return f0, f1, f2


@njit(hot=True)
def has_summed_shapes(table):
    """Whether the table holds a shape whose force is summed (not a static sphere or bowl)."""
    for s in range(table.kind.shape[0]):
        if not is_direct(table, s):
            return True
    return False


@njit(hot=True)
def _ball(b, i, u, D):
    return u[b, i, 0], u[b, i, 1], (u[b, i, 2] if D == 3 else 0.0)


@njit(hot=True)
def shape_force(table, b, s, p0, p1, p2, u0, u1, u2, r, model, D):
    """(touching, f0, f1, f2): shape s's force on a ball of radius r at p moving at u."""
    if shape_miss(table, b, s, p0, p1, p2, r, D):
        return False, 0.0, 0.0, 0.0
    phi, n0, n1, n2 = shape_sdf(table, b, s, p0, p1, p2, D)
    pen = r - phi
    if not pen > 0.0:
        return False, 0.0, 0.0, 0.0
    r0, r1, r2 = u0, u1, u2
    if is_moving(table, s):
        w0, w1, w2 = surface_velocity(table.pose[b, s], p0, p1, p2, phi, n0, n1, n2, D)
        r0 = u0 - w0
        r1 = u1 - w1
        r2 = u2 - w2
    f0, f1, f2 = terrain_law(
        pen, n0, n1, n2, r0, r1, r2, model.ks_terrain, model.kd_terrain, model.no_tension, model.mu, model.kf, D
    )
    return True, f0, f1, f2


@njit(hot=True)
def summed_terrain(table, b, p0, p1, p2, u0, u1, u2, r, model, D):
    """The summed force (f0, f1, f2) of every shape but the static spheres and bowls on a ball of
    radius r at p moving at u (world b), in the table's order."""
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    for s in range(table.kind.shape[0]):
        if is_direct(table, s):
            continue
        touching, f0, f1, f2 = shape_force(table, b, s, p0, p1, p2, u0, u1, u2, r, model, D)
        if touching:
            g0 += f0
            g1 += f1
            g2 += f2
    return g0, g1, g2


@njit(hot=True)
def round_force(p0, p1, p2, u0, u1, u2, r, sign, c0, c1, c2, R, model, D):
    """(touching, f0, f1, f2): a static sphere (sign +1) or bowl (-1) of centre c and radius R on a
    ball of radius r at p moving at u (the table's rows of kind ``ROUND`` and the neighbour list's
    flat copy of them: one arithmetic)."""
    d0 = p0 - c0
    d1 = p1 - c1
    q2 = p2 - c2 if D == 3 else 0.0
    d2 = d0 * d0 + d1 * d1
    if D == 3:
        d2 += q2 * q2
    # the miss test without a square root: a Sphere is touched inside R + r, a Bowl outside R - r
    if sign > 0.0:
        if d2 >= (R + r) * (R + r):
            return False, 0.0, 0.0, 0.0
    elif R > r and d2 <= (R - r) * (R - r):
        return False, 0.0, 0.0, 0.0
    phi, n0, n1, n2 = sdf_round(d0, d1, q2, R, 0.0, 0.0, D)
    pen = r - sign * phi
    if not pen > 0.0:
        return False, 0.0, 0.0, 0.0
    f0, f1, f2 = terrain_law(
        pen,
        sign * n0,
        sign * n1,
        sign * n2,
        u0,
        u1,
        u2,
        model.ks_terrain,
        model.kd_terrain,
        model.no_tension,
        model.mu,
        model.kf,
        D,
    )
    return True, f0, f1, f2


@njit(hot=True)
def terrain_force(b, i, x, v, out, model, D):
    """Add ball i's contact forces with every terrain shape to ``out``: each static sphere or bowl
    as it comes, then the others' sum."""
    table = model.shapes
    r = model.radii[i]
    p0, p1, p2 = _ball(b, i, x, D)
    u0, u1, u2 = _ball(b, i, v, D)
    for s in range(table.kind.shape[0]):
        if not is_direct(table, s):
            continue
        c = table.pose[b, s]
        touching, f0, f1, f2 = round_force(
            p0,
            p1,
            p2,
            u0,
            u1,
            u2,
            r,
            table.shape[s, SIGN],
            c[0],
            c[1],
            (c[2] if D == 3 else 0.0),
            table.shape[s, P0],
            model,
            D,
        )
        if touching:
            out[b, i, 0] += f0
            out[b, i, 1] += f1
            if D == 3:
                out[b, i, 2] += f2
    if has_summed_shapes(table):
        g0, g1, g2 = summed_terrain(table, b, p0, p1, p2, u0, u1, u2, r, model, D)
        out[b, i, 0] += g0
        out[b, i, 1] += g1
        if D == 3:
            out[b, i, 2] += g2


@njit(hot=True)
def terrain_measure(b, i, x, model, D):
    """Ball i's terrain contacts: (their spring energy, sum of 1/2 ks_terrain pen^2; the largest
    overlap as a fraction of the ball's radius, 0 without contact)."""
    table = model.shapes
    r = model.radii[i]
    p0, p1, p2 = _ball(b, i, x, D)
    energy = 0.0
    deepest = 0.0
    for s in range(table.kind.shape[0]):
        if shape_miss(table, b, s, p0, p1, p2, r, D):
            continue
        pen = r - shape_sdf(table, b, s, p0, p1, p2, D)[0]
        if not pen > 0.0:
            continue
        energy += 0.5 * model.ks_terrain * pen * pen
        deepest = max(deepest, pen / r)
    return energy, deepest


@njit(hot=True)
def terrain_jacobian(b, i, x, p, out, coef, diag, model, D):
    """The linearised backward Euler step's products for ball i's terrain contacts (as
    :func:`.pair.pair_jacobian`): ``coef n*n`` with ``diag``, else ``coef n (n . p)``."""
    table = model.shapes
    r = model.radii[i]
    p0, p1, p2 = _ball(b, i, x, D)
    u0, u1, u2 = _ball(b, i, p, D)
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    for s in range(table.kind.shape[0]):
        if shape_miss(table, b, s, p0, p1, p2, r, D):
            continue
        phi, n0, n1, n2 = shape_sdf(table, b, s, p0, p1, p2, D)
        if not r - phi > 0.0:
            continue
        if diag:
            f0 = coef * n0 * n0
            f1 = coef * n1 * n1
            f2 = coef * n2 * n2 if D == 3 else 0.0
        else:
            r0, r1, r2 = u0, u1, u2
            if is_moving(table, s):  # (as the force law sees the surface)
                w0, w1, w2 = surface_velocity(table.pose[b, s], p0, p1, p2, phi, n0, n1, n2, D)
                r0 = u0 - w0
                r1 = u1 - w1
                r2 = u2 - w2
            vn = r0 * n0 + r1 * n1
            if D == 3:
                vn += r2 * n2
            f0 = coef * vn * n0
            f1 = coef * vn * n1
            f2 = coef * vn * n2 if D == 3 else 0.0
        if is_direct(table, s):
            out[b, i, 0] += f0
            out[b, i, 1] += f1
            if D == 3:
                out[b, i, 2] += f2
        else:
            g0 += f0
            g1 += f1
            g2 += f2
    if has_summed_shapes(table):
        out[b, i, 0] += g0
        out[b, i, 1] += g1
        if D == 3:
            out[b, i, 2] += g2
