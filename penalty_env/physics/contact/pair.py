"""Ball i against ball j in world b (scalar): the force, the overlap, and the implicit solver's
products.

Rest length l0 = r_i + r_j, unit normal n = (x_j - x_i) / |x_j - x_i| (the last axis where the
centres coincide, which keeps every force finite). In contact while |x_j - x_i| < l0; the force on
i, minus that on j, is ``-f_n n`` (+ friction) with f_n the law's (:func:`.law.normal_force` of
the overlap and the rate v_n = (v_j - v_i) . n at which the centres part).

State arrays are ``(B, n, D)``; ``D`` the dimension (its loops unrolled where it is a constant).
"""

from __future__ import annotations

import math

from ..._jit import njit
from .law import normal_force, regularised_ratio

__all__ = ["pair_geometry", "pair_normal", "pair_force", "pair_overlap", "pair_jacobian"]


@njit(hot=True)
def pair_geometry(b, i, j, x, model, D):
    """(touching, overlap, n0, n1, n2) of balls i and j: the overlap l0 - |x_j - x_i| and the unit
    normal i -> j (the last axis for coincident centres); ``touching`` False (and the rest 0) when
    they are apart."""
    l0 = model.radii[i] + model.radii[j]
    d0 = x[b, j, 0] - x[b, i, 0]
    d1 = x[b, j, 1] - x[b, i, 1]
    d2 = x[b, j, 2] - x[b, i, 2] if D == 3 else 0.0
    dist2 = d0 * d0 + d1 * d1
    if D == 3:
        dist2 += d2 * d2
    if not dist2 < l0 * l0:
        return False, 0.0, 0.0, 0.0, 0.0
    overlap, n0, n1, n2 = pair_normal(d0, d1, d2, dist2, l0, D)
    return True, overlap, n0, n1, n2


@njit(hot=True)
def pair_normal(d0, d1, d2, dist2, l0, D):
    """(overlap, n0, n1, n2) of two touching balls whose centres are d apart (|d|^2 = dist2, rest
    length l0): l0 - |d| and the unit normal d / |d| (the last axis for coincident centres)."""
    dist = math.sqrt(dist2)
    inv = 1.0 / dist
    apart = dist > 0.0  # (selects, so the spinning block pass vectorises it)
    n0 = d0 * inv if apart else 0.0
    n1 = d1 * inv if apart else (1.0 if D == 2 else 0.0)
    n2 = d2 * inv if apart else (1.0 if D == 3 else 0.0)
    return l0 - dist, n0, n1, n2


@njit(hot=True)
def _relative(b, i, j, u):
    """u_j - u_i, three components (the third 0 in 2D)."""
    D = u.shape[2]
    return u[b, j, 0] - u[b, i, 0], u[b, j, 1] - u[b, i, 1], (u[b, j, 2] - u[b, i, 2] if D == 3 else 0.0)


@njit(hot=True)
def pair_force(b, i, j, x, v, out, model, D):
    """Add the contact force of balls i and j to ``out`` (on i; minus it on j)."""
    touching, overlap, n0, n1, n2 = pair_geometry(b, i, j, x, model, D)
    if not touching:
        return
    u0, u1, u2 = _relative(b, i, j, v)
    vn = u0 * n0 + u1 * n1
    if D == 3:
        vn += u2 * n2
    fn = -normal_force(model.ks, model.kd, overlap, vn, model.no_tension)  # along +n on i
    f0 = fn * n0
    f1 = fn * n1
    f2 = fn * n2
    if model.mu > 0.0:
        # regularised Coulomb: along the tangential velocity of j relative to i (friction drags i
        # along with j)
        t0 = u0 - vn * n0
        t1 = u1 - vn * n1
        t2 = u2 - vn * n2
        vt2 = t0 * t0 + t1 * t1
        if D == 3:
            vt2 += t2 * t2
        ratio = regularised_ratio(model.kf, model.mu, fn, vt2, False)
        f0 += ratio * t0
        f1 += ratio * t1
        f2 += ratio * t2
    out[b, i, 0] += f0
    out[b, j, 0] -= f0
    out[b, i, 1] += f1
    out[b, j, 1] -= f1
    if D == 3:
        out[b, i, 2] += f2
        out[b, j, 2] -= f2


@njit(hot=True)
def pair_overlap(b, i, j, x, model, D):
    """The overlap of balls i and j (0 when apart)."""
    return pair_geometry(b, i, j, x, model, D)[1]


@njit(hot=True)
def pair_jacobian(b, i, j, x, p, out, coef, diag, model, D):
    """The linearised backward Euler step's products for the pair, at positions x: with ``diag``
    add ``coef n*n`` (per component, to both balls: the Jacobi preconditioner), else add
    ``coef n (n . (p_i - p_j))`` to i and minus it to j (the frozen-contact Jacobian times p)."""
    touching, overlap, n0, n1, n2 = pair_geometry(b, i, j, x, model, D)
    if not touching:
        return
    if diag:
        out[b, i, 0] += coef * n0 * n0
        out[b, j, 0] += coef * n0 * n0
        out[b, i, 1] += coef * n1 * n1
        out[b, j, 1] += coef * n1 * n1
        if D == 3:
            out[b, i, 2] += coef * n2 * n2
            out[b, j, 2] += coef * n2 * n2
        return
    u0, u1, u2 = _relative(b, i, j, p)
    vn = u0 * n0 + u1 * n1
    if D == 3:
        vn += u2 * n2
    out[b, i, 0] -= coef * vn * n0
    out[b, j, 0] += coef * vn * n0
    out[b, i, 1] -= coef * vn * n1
    out[b, j, 1] += coef * vn * n1
    if D == 3:
        out[b, i, 2] -= coef * vn * n2
        out[b, j, 2] += coef * vn * n2
