"""The penalty contact laws (the course notes' section 2) and the helpers they share.

A contact is a spring plus a dashpot along the contact normal, acting while two bodies overlap:

* ball i against ball j (rest length l0 = r_i + r_j, unit normal n = (x_j - x_i) / |x_j - x_i|),
  force on i, minus that on j: ``f = [ks (|x_j - x_i| - l0) + kd ((v_j - v_i) . n)] n``;
* ball i against a terrain shape of signed distance phi (outward normal grad phi, overlap
  pen = r_i - phi(c_i) > 0, the surface moving at v_s at the contact point, 0 for a static shape):
  ``f = ks pen grad phi - kd ((v_i - v_s) . grad phi) grad phi``, one law for every shape
  (:func:`terrain_law`).

Options: ``no_tension`` clips the normal force at zero (the linear dashpot pulls at separation;
LAMMPS ``limit_damping``), and regularised Coulomb friction (as NVIDIA Warp) adds
``|f_t| = min(kf |v_t|, mu |f_n|)`` against the sliding velocity v_t. Where the normal is undefined
(coincident centres, a ball at a shape's centre) it falls back to the last axis ("up"), which keeps
every force finite.

Every implementation of each law
--------------------------------
The reference implementation is this module's: :func:`pair_contact` and :func:`terrain_contact`
(all integrators, the energy and penetration diagnostics, the implicit solver's matrix-vector
product, both broad phases and the event location call them, with a ``mode``). The terrain law
itself is :func:`terrain_law`: :func:`terrain_contact` applies it to the static spheres and bowls
and, through :func:`.geometry.general_terrain`, to every other shape (whose phi and normal come
from :mod:`.geometry`). Fast twins repeat the law for speed, named after it:

=====================================  =====================================================  ==============================================
twin                                   what it varies                                         pinned to the reference by
=====================================  =====================================================  ==============================================
``contact_lanes.pair_contact_lanes``   one world per SIMD lane, the contact test a mask       ``tests/physics/test_stepping_paths.py``: bit for bit
``contact_lanes.terrain_contact_lanes`` the same for the terrain                              ``tests/physics/test_stepping_paths.py``: bit for bit
``contact_listed.pair_contact_listed`` a neighbour-list pass, branch-free, Newton's third law ``tests/physics/test_neighbour_list.py``: to round-off
``rotation.spin_pair``                 with rotation: the normal law, then slip, torque       ``tests/physics/test_rotation.py``: bit for bit at mu = 0
``rotation.spin_terrain_contact``      with rotation: :func:`terrain_law`, then the same      ``tests/physics/test_rotation.py``: bit for bit at mu = 0
=====================================  =====================================================  ==============================================

The neighbour-list twin without friction evaluates the same operations in another order (it sums
in registers), hence round-off; with friction, or for coincident centres, it calls
:func:`pair_contact` itself. The general shapes have no twin: the lanes path calls
:func:`.geometry.general_terrain` one lane at a time (``contact_lanes.general_terrain_lanes``, bit for
bit: ``tests/physics/test_geometry.py``), and the neighbour-list path calls :func:`general_terrain_row`
in a serial pass (to round-off: the same file).

Modes of the contact functions
------------------------------
FORCE   add the contact force (plus optional friction) to ``out``
ENERGY  return the penalty spring's potential 1/2 ks overlap^2
LINEAR  add ``coef * n (n . (p_i - p_j))`` to ``out`` with ``p`` passed as ``v``: the frozen-contact
        Jacobian product of the linearised backward Euler step
DIAG    add ``coef * n*n`` (per component) to ``out``: the Jacobi preconditioner of that solve
MAXPEN  return overlap / radius (max over contacts), the penetration diagnostic

State arrays are ``(B, n, D)``; ``g`` (gravity) is a tuple of length D, a compile-time constant, so
every ``for k in range(D)`` loop is unrolled. ``friction`` is None when off (its branches are then
compiled away) or ``(mu, kf)``.
"""

from __future__ import annotations

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit
from .geometry import general_terrain, model_geometry_type
from .shapes import BOWL, SPHERE  # terrain shape kinds

__all__ = [
    "FORCE",
    "ENERGY",
    "LINEAR",
    "DIAG",
    "MAXPEN",
    "SPHERE",
    "BOWL",
    "pair_contact",
    "terrain_contact",
    "terrain_law",
    "general_terrain_row",
    "pair_gap",
    "terrain_gap",
    "pair_normal",
    "terrain_normal",
    "fallback_axis",
    "shape_sign",
    "shape_dist2",
    "combine",
]

FORCE, ENERGY, LINEAR, DIAG, MAXPEN = 0, 1, 2, 3, 4


# --------------------------------------------------------------------------------------------
# Shared helpers: normal with its fallback, shape sign, gaps. Plain functions, not inline="always":
# LLVM inlines them into the laws anyway (measured: the same speed), while Numba's own inlining of
# each call site copies its IR and made the laws 1.7x slower to compile.
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def combine(mode, acc, val):
    """Accumulate a contact's return value: max for MAXPEN, sum otherwise."""
    if mode == MAXPEN:
        return max(acc, val)
    return acc + val


@njit
def fallback_axis(k, D):
    """Component k of the normal used where the true one is undefined: the last axis ("up")."""
    return 1.0 if k == D - 1 else 0.0


@njit
def pair_normal(b, i, j, k, x, inv, dist, D):
    """Component k of the unit normal i -> j (``inv`` = 1 / dist); coincident centres: the last axis."""
    return (x[b, j, k] - x[b, i, k]) * inv if dist > 0.0 else fallback_axis(k, D)


@njit
def shape_sign(model, s):
    """phi = sign (|x - c| - R): +1 for a Sphere, -1 for a Bowl (the inside of a sphere)."""
    return 1.0 if model.shape_kind[s] == SPHERE else -1.0


@njit
def shape_dist2(b, i, x, model, s, D):
    """The sign of terrain shape s's phi about |x - c| and ball i's squared distance to its centre."""
    dist2 = 0.0
    for k in range(D):
        dx = x[b, i, k] - model.shape_center[s, k]
        dist2 += dx * dx
    return shape_sign(model, s), dist2


@njit
def terrain_normal(b, i, s, k, x, model, inv, dist, D):
    """Component k of grad phi of shape s at ball i (``inv`` = sign / dist); at the centre: the last axis."""
    return (x[b, i, k] - model.shape_center[s, k]) * inv if dist > 0.0 else fallback_axis(k, D)


@njit
def pair_gap(b, i, j, x, model, D):
    """Signed gap of a pair: |x_j - x_i| - (r_i + r_j), < 0 in contact."""
    d2 = 0.0
    for k in range(D):
        dx = x[b, j, k] - x[b, i, k]
        d2 += dx * dx
    return np.sqrt(d2) - (model.radii[i] + model.radii[j])


@njit
def terrain_gap(b, i, s, x, model, D):
    """Signed gap of ball i to terrain shape s: phi(c_i) - r_i, < 0 in contact."""
    sign, d2 = shape_dist2(b, i, x, model, s, D)
    return sign * (np.sqrt(d2) - model.shape_radius[s]) - model.radii[i]


# --------------------------------------------------------------------------------------------
# The laws
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def pair_contact(mode, b, i, j, x, v, out, coef, scatter, model, friction, g):
    """Sphere i against sphere j in world b (see the module docstring).

    In contact while |x_j - x_i| < l0. Force on i: f = [ks (|x_j - x_i| - l0) + kd ((v_j - v_i) . n)] n
    (+ friction), minus on j when ``scatter``. Returns the pair's energy or penetration in those
    modes, else 0.
    """
    D = len(g)
    l0 = model.radii[i] + model.radii[j]
    dist2 = 0.0
    for k in range(D):
        dx = x[b, j, k] - x[b, i, k]
        dist2 += dx * dx
    if not dist2 < l0 * l0:
        return 0.0
    dist = np.sqrt(dist2)
    overlap = l0 - dist
    if mode == ENERGY:
        return 0.5 * model.ks * overlap * overlap
    if mode == MAXPEN:
        return overlap / min(model.radii[i], model.radii[j])
    inv = 1.0 / dist if dist > 0.0 else 0.0
    vn = 0.0
    for k in range(D):
        vn += (v[b, j, k] - v[b, i, k]) * pair_normal(b, i, j, k, x, inv, dist, D)
    if mode == DIAG:
        for k in range(D):
            nk = pair_normal(b, i, j, k, x, inv, dist, D)
            out[b, i, k] += coef * nk * nk
            if scatter:
                out[b, j, k] += coef * nk * nk
        return 0.0
    if mode == LINEAR:
        # out_i += coef n (n . (p_i - p_j)) = -coef vn n, with p passed as v
        for k in range(D):
            nk = pair_normal(b, i, j, k, x, inv, dist, D)
            out[b, i, k] -= coef * vn * nk
            if scatter:
                out[b, j, k] += coef * vn * nk
        return 0.0
    fn = -model.ks * overlap + model.kd * vn  # along +n on i; < 0 pushes i away from j
    if model.no_tension and fn > 0.0:
        fn = 0.0  # the dashpot may not pull the balls together as they separate
    ft_over_vt = 0.0
    if friction is not None:
        # regularised Coulomb (as NVIDIA Warp): |f_t| = min(kf |v_t|, mu |f_n|), along v_t
        # (the tangential velocity of j relative to i: friction drags i along with j)
        vt2 = 0.0
        for k in range(D):
            vtk = (v[b, j, k] - v[b, i, k]) - vn * pair_normal(b, i, j, k, x, inv, dist, D)
            vt2 += vtk * vtk
        if vt2 > 0.0:
            vt = np.sqrt(vt2)
            ft_over_vt = min(friction[1] * vt, friction[0] * abs(fn)) / vt
    for k in range(D):
        nk = pair_normal(b, i, j, k, x, inv, dist, D)
        fk = fn * nk
        if friction is not None:
            fk += ft_over_vt * ((v[b, j, k] - v[b, i, k]) - vn * nk)
        out[b, i, k] += fk
        if scatter:
            out[b, j, k] -= fk
    return 0.0


@njit
def terrain_law(mode, pen, n0, n1, n2, w, u0, u1, u2, r, coef, ks, kd, no_tension, friction, D):
    """The terrain law, once for every shape: a ball of radius r and velocity u overlapping a
    solid by pen > 0, whose outward unit normal at the ball is n, and whose surface moves at w
    there (None: a static shape, the seed's case); ``ks``, ``kd``, ``no_tension``: the terrain's
    spring, dashpot and clip (scalars, not the Model: Numba passes a named tuple by value, and a
    Model with CSG trees is large).

    FORCE: f = ks pen n - kd ((u - w) . n) n (+ friction against the sliding velocity u - w),
    clipped at zero with ``no_tension``. Returns (val, f0, f1, f2): ``val`` the energy 1/2 ks pen^2
    (ENERGY) or pen / r (MAXPEN), else 0; f what to add to the ball's row of ``out`` (FORCE; LINEAR:
    coef n (n . u) with p passed as u; DIAG: coef n*n), else 0."""
    if mode == ENERGY:
        return 0.5 * ks * pen * pen, 0.0, 0.0, 0.0
    if mode == MAXPEN:
        return pen / r, 0.0, 0.0, 0.0
    if w is None:
        r0 = u0
        r1 = u1
        r2 = u2
    else:
        r0 = u0 - w[0]
        r1 = u1 - w[1]
        r2 = u2 - w[2]
    vn = r0 * n0 + r1 * n1
    if D == 3:
        vn += r2 * n2
    if mode == DIAG:
        return 0.0, coef * n0 * n0, coef * n1 * n1, (coef * n2 * n2 if D == 3 else 0.0)
    if mode == LINEAR:
        return 0.0, coef * vn * n0, coef * vn * n1, (coef * vn * n2 if D == 3 else 0.0)
    fn = ks * pen - kd * vn  # along +n; > 0 pushes out
    if no_tension and fn < 0.0:
        fn = 0.0
    f0 = fn * n0
    f1 = fn * n1
    f2 = fn * n2 if D == 3 else 0.0
    if friction is not None:
        t0 = r0 - vn * n0
        t1 = r1 - vn * n1
        t2 = r2 - vn * n2 if D == 3 else 0.0
        vt2 = t0 * t0 + t1 * t1
        if D == 3:
            vt2 += t2 * t2
        ft_over_vt = 0.0
        if vt2 > 0.0:
            vt = np.sqrt(vt2)
            ft_over_vt = min(friction[1] * vt, friction[0] * abs(fn)) / vt
        f0 -= ft_over_vt * t0  # opposes sliding
        f1 -= ft_over_vt * t1
        f2 -= ft_over_vt * t2
    return 0.0, f0, f1, f2


@njit(inline="always")
def add_terrain_row(mode, b, i, out, f0, f1, f2, D):
    """Add a terrain law's row to ``out`` (nothing in the ENERGY and MAXPEN modes, where ``out`` is
    a dummy)."""
    if mode != ENERGY and mode != MAXPEN:
        out[b, i, 0] += f0
        out[b, i, 1] += f1
        if D == 3:
            out[b, i, 2] += f2


def general_terrain_row(mode, b, i, x, v, out, coef, model, friction, g, acc):
    """Every general shape (:mod:`.geometry`) against ball i, added to ``out`` and combined into
    ``acc``; nothing at all (compiled away) when the model has none (jitted code only)."""
    raise NotImplementedError


@overload(general_terrain_row, inline="always")
def _general_terrain_row(mode, b, i, x, v, out, coef, model, friction, g, acc):
    if isinstance(model_geometry_type(model), types.NoneType):
        return lambda mode, b, i, x, v, out, coef, model, friction, g, acc: acc

    def impl(mode, b, i, x, v, out, coef, model, friction, g, acc):
        D = len(g)
        val, f0, f1, f2 = general_terrain(
            mode,
            model.geometry,
            b,
            x[b, i, 0],
            x[b, i, 1],
            x[b, i, 2] if D == 3 else 0.0,
            v[b, i, 0],
            v[b, i, 1],
            v[b, i, 2] if D == 3 else 0.0,
            model.radii[i],
            coef,
            model.ks_terrain,
            model.kd_terrain,
            model.no_tension,
            friction,
            D,
        )
        add_terrain_row(mode, b, i, out, f0, f1, f2, D)
        return combine(mode, acc, val)

    return impl


@njit(inline="always")
def terrain_contact(mode, b, i, x, v, out, coef, model, friction, g):
    """Sphere i against every terrain shape (zero rest length; see the module docstring): the
    static spheres and bowls here, then every general shape (:mod:`.geometry`), each through
    :func:`terrain_law`.

    In contact while phi(c_i) - r_i < 0. With the outward normal grad phi and the overlap
    pen = r_i - phi(c_i) > 0: f = ks pen grad phi - kd (v_i . grad phi) grad phi (+ friction).
    A ball touching several shapes gets a force from each. Returns energy / penetration.
    """
    D = len(g)
    r = model.radii[i]
    acc = 0.0
    for s in range(model.shape_kind.shape[0]):
        sign, dist2 = shape_dist2(b, i, x, model, s, D)
        # miss test without a square root: a Sphere is touched inside radius R + r, a Bowl
        # outside R - r (NaN compares False and falls through to the exact test)
        R = model.shape_radius[s]
        if sign > 0.0:
            if dist2 >= (R + r) * (R + r):
                continue
        elif R > r and dist2 <= (R - r) * (R - r):
            continue
        dist = np.sqrt(dist2)
        phi = sign * (dist - R)
        pen = r - phi
        if not pen > 0.0:
            continue
        inv = sign / dist if dist > 0.0 else 0.0
        n0 = terrain_normal(b, i, s, 0, x, model, inv, dist, D)
        n1 = terrain_normal(b, i, s, 1, x, model, inv, dist, D)
        n2 = terrain_normal(b, i, s, 2, x, model, inv, dist, D) if D == 3 else 0.0
        u2 = v[b, i, 2] if D == 3 else 0.0
        ks, kd, clip = model.ks_terrain, model.kd_terrain, model.no_tension
        val, f0, f1, f2 = terrain_law(
            mode, pen, n0, n1, n2, None, v[b, i, 0], v[b, i, 1], u2, r, coef, ks, kd, clip, friction, D
        )
        acc = combine(mode, acc, val)
        add_terrain_row(mode, b, i, out, f0, f1, f2, D)
    return general_terrain_row(mode, b, i, x, v, out, coef, model, friction, g, acc)
