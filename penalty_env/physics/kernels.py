"""Numba kernels: the penalty force laws, broad phases and integrators.

Conventions
-----------
* State arrays are ``(B, n, D)`` float64: B independent worlds of n balls in D = 2 or 3 dimensions.
* ``g`` (gravity) is passed as a tuple of length D. Its length is a compile-time constant, so every
  ``for k in range(D)`` loop is unrolled and a 2D scene runs genuinely 2D machine code.
* Optional features are passed as ``None`` when off (``friction``, ``ext``): Numba prunes the
  ``is not None`` branches at compile time, so a feature that is off costs nothing.
* One force law, one function: :func:`pair_contact` (sphere-sphere) and :func:`terrain_contact`
  (sphere-implicit terrain) are the only places the seed's formulas live. Every integrator, the
  energy, the implicit solver's matrix-vector product and both broad phases call them with a
  ``mode``. The one exception is their SIMD twin in :mod:`.lanes` (the FORCE mode, many worlds per
  vector instruction), which must repeat the same operations in the same order: its results are
  tested to be bit-identical to these (``tests/test_physics_lanes.py``).

Modes of the contact functions
------------------------------
FORCE   add the contact force (seed section 2, plus optional friction) to ``out``
ENERGY  return the penalty spring's potential 1/2 ks overlap^2
LINEAR  add ``coef * n (n . (p_i - p_j))`` to ``out`` with ``p`` passed as ``v``: the frozen-contact
        Jacobian product of the linearised backward Euler step
DIAG    add ``coef * n*n`` (per component) to ``out``: the Jacobi preconditioner of that solve
MAXPEN  return overlap / radius (max over contacts), the penetration diagnostic
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .._jit import njit, prange

FORCE, ENERGY, LINEAR, DIAG, MAXPEN = 0, 1, 2, 3, 4

EXPLICIT_EULER, SYMPLECTIC_EULER, VELOCITY_VERLET, RK4, IMPLICIT_EULER = 0, 1, 2, 3, 4
INTEGRATOR_CODES = {
    "explicit_euler": EXPLICIT_EULER,
    "symplectic_euler": SYMPLECTIC_EULER,
    "velocity_verlet": VELOCITY_VERLET,
    "rk4": RK4,
    "implicit_euler": IMPLICIT_EULER,
}
# scratch (B, n, D) arrays each integrator needs (the ``work`` argument of its step function)
WORK_ARRAYS = {EXPLICIT_EULER: 1, SYMPLECTIC_EULER: 1, VELOCITY_VERLET: 3, RK4: 5, IMPLICIT_EULER: 6}

STATUS_OK, STATUS_NONFINITE, STATUS_CG = 0, 1, 2

# The static description of a scene (Warp's "model"): nothing in it changes while stepping.
Model = namedtuple(
    "Model",
    [
        "radii",  # (n,) ball radii
        "inv_mass",  # (n,) 1 / mass
        "shape_kind",  # (S,) SPHERE or BOWL
        "shape_center",  # (S, D)
        "shape_radius",  # (S,)
        "ks",  # sphere-sphere spring, force / length
        "kd",  # sphere-sphere dashpot, force / speed
        "ks_terrain",
        "kd_terrain",
        "no_tension",  # clip the normal force at zero (no dashpot pull at separation)
        "cell_size",  # grid cell edge >= the largest diameter
    ],
)

# Uniform-grid (cell list) buffers, one grid per world, rebuilt at every force evaluation.
Grid = namedtuple(
    "Grid",
    [
        "start",  # (B, cap + 1) first item of each cell
        "items",  # (B, n) ball indices sorted by cell, ascending within a cell
        "cell",  # (B, n) linear cell index of each ball
        "geom",  # (B, 7) lower corner (3), upper corner (3), cell size
        "dims",  # (B, 4) cells per axis (3) and their product
    ],
)


# One large world's private state (``run_large``): its balls in grid-cell order in memory, its own
# grid, and a Verlet neighbour list (every pair within r_i + r_j + skin at the last build).
LargeWorld = namedtuple(
    "LargeWorld",
    [
        "x", "v", "a", "ext",  # (1, n, D) state, accelerations and external force in storage order
        "grid",  # Grid (one row) of the storage at the last build
        "perm",  # (n,) ball index of each storage slot
        "order", "itmp",  # (n,) int scratch
        "tmp",  # (n, max(D, 2)) float scratch
        "nbr",  # (n, cap) int32 storage slots of each ball's listed neighbours, in grid order
        "count",  # (n,) int32 listed neighbours per ball
        "near",  # (n,) int8: 1 if the ball was within a skin of a terrain shape at the build
        "xref",  # (n, D) positions at the last build
        "escaped",  # (n,) int8: 1 once the slot has moved skin / 2 from xref
        "escapes",  # (max_escapes,) the escaped slots, in the order they escaped
        "moved",  # (threads,) per thread: how many slots escaped in the last step (-1: not finite)
        "skin",  # list reach beyond contact
        "state",  # (4,) int64: [list valid, largest count at the last build, builds so far, escaped]
    ],
)

# --------------------------------------------------------------------------------------------
# Force laws
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _combine(mode, acc, val):
    if mode == MAXPEN:
        return max(acc, val)
    return acc + val


@njit(inline="always")
def pair_contact(mode, b, i, j, x, v, out, coef, scatter, model, friction, g):
    """Sphere i against sphere j in world b (seed section 2).

    n = (x_j - x_i) / |x_j - x_i|, l0 = r_i + r_j; in contact while |x_j - x_i| < l0.
    Force on i: f = [ks (|x_j - x_i| - l0) + kd ((v_j - v_i) . n)] n (+ friction), minus on j when
    ``scatter``. Returns the pair's energy or penetration in those modes, else 0.
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
    # unit normal i -> j; coincident centres get the last axis (keeps the force finite)
    inv = 1.0 / dist if dist > 0.0 else 0.0
    vn = 0.0
    for k in range(D):
        nk = (x[b, j, k] - x[b, i, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
        vn += (v[b, j, k] - v[b, i, k]) * nk
    if mode == DIAG:
        for k in range(D):
            nk = (x[b, j, k] - x[b, i, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
            out[b, i, k] += coef * nk * nk
            if scatter:
                out[b, j, k] += coef * nk * nk
        return 0.0
    if mode == LINEAR:
        # out_i += coef n (n . (p_i - p_j)) = -coef vn n, with p passed as v
        for k in range(D):
            nk = (x[b, j, k] - x[b, i, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
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
            nk = (x[b, j, k] - x[b, i, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
            vtk = (v[b, j, k] - v[b, i, k]) - vn * nk
            vt2 += vtk * vtk
        if vt2 > 0.0:
            vt = np.sqrt(vt2)
            ft_over_vt = min(friction[1] * vt, friction[0] * abs(fn)) / vt
    for k in range(D):
        nk = (x[b, j, k] - x[b, i, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
        fk = fn * nk
        if friction is not None:
            fk += ft_over_vt * ((v[b, j, k] - v[b, i, k]) - vn * nk)
        out[b, i, k] += fk
        if scatter:
            out[b, j, k] -= fk
    return 0.0


@njit(inline="always")
def _shape_dist2(b, i, x, model, s, D):
    """The sign of terrain shape s's phi about |x - c| (SPHERE: phi = |x - c| - R, +1; BOWL:
    phi = R - |x - c|, -1) and ball i's squared distance to the shape's centre."""
    dist2 = 0.0
    for k in range(D):
        dx = x[b, i, k] - model.shape_center[s, k]
        dist2 += dx * dx
    return (1.0 if model.shape_kind[s] == 0 else -1.0), dist2


@njit(inline="always")
def terrain_contact(mode, b, i, x, v, out, coef, model, friction, g):
    """Sphere i against every static terrain shape (seed section 2, zero rest length).

    In contact while phi(c_i) - r_i < 0. With the outward normal grad phi and the overlap
    pen = r_i - phi(c_i) > 0: f = ks pen grad phi - kd (v_i . grad phi) grad phi (+ friction).
    A ball touching several shapes gets a force from each. Returns energy / penetration.
    """
    D = len(g)
    r = model.radii[i]
    acc = 0.0
    for s in range(model.shape_kind.shape[0]):
        sign, dist2 = _shape_dist2(b, i, x, model, s, D)
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
        if mode == ENERGY:
            acc += 0.5 * model.ks_terrain * pen * pen
            continue
        if mode == MAXPEN:
            acc = max(acc, pen / r)
            continue
        inv = sign / dist if dist > 0.0 else 0.0
        vn = 0.0
        for k in range(D):
            gk = (x[b, i, k] - model.shape_center[s, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
            vn += v[b, i, k] * gk
        if mode == DIAG:
            for k in range(D):
                gk = (x[b, i, k] - model.shape_center[s, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
                out[b, i, k] += coef * gk * gk
            continue
        if mode == LINEAR:
            for k in range(D):
                gk = (x[b, i, k] - model.shape_center[s, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
                out[b, i, k] += coef * vn * gk
            continue
        fn = model.ks_terrain * pen - model.kd_terrain * vn  # along +grad phi; > 0 pushes out
        if model.no_tension and fn < 0.0:
            fn = 0.0
        ft_over_vt = 0.0
        if friction is not None:
            vt2 = 0.0
            for k in range(D):
                gk = (x[b, i, k] - model.shape_center[s, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
                vtk = v[b, i, k] - vn * gk
                vt2 += vtk * vtk
            if vt2 > 0.0:
                vt = np.sqrt(vt2)
                ft_over_vt = min(friction[1] * vt, friction[0] * abs(fn)) / vt
        for k in range(D):
            gk = (x[b, i, k] - model.shape_center[s, k]) * inv if dist > 0.0 else (1.0 if k == D - 1 else 0.0)
            fk = fn * gk
            if friction is not None:
                fk -= ft_over_vt * (v[b, i, k] - vn * gk)  # opposes sliding
            out[b, i, k] += fk
    return acc


# --------------------------------------------------------------------------------------------
# Broad phases: all pairs, and a uniform grid (cell list)
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def contacts_all_pairs(mode, b, x, v, out, coef_pair, coef_terrain, model, friction, g):
    """Every pair i < j once (forces scattered to both), then the terrain. O(n^2)."""
    n = x.shape[1]
    acc = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            acc = _combine(mode, acc, pair_contact(mode, b, i, j, x, v, out, coef_pair, True, model, friction, g))
        acc = _combine(mode, acc, terrain_contact(mode, b, i, x, v, out, coef_terrain, model, friction, g))
    return acc


@njit(inline="always")
def _cell_coord(xk, lo, inv_h, nk):
    """Cell index along one axis, clamped to [0, nk); NaN lands in cell 0."""
    q = (xk - lo) * inv_h
    c = int(q) if q >= 0.0 else 0
    return c if c < nk else nk - 1


@njit
def build_grid(b, x, grid, model, g):
    """Counting-sort the balls of world b into cells of edge >= the largest diameter.

    The grid spans the balls' bounding box. If that box would need more cells than the buffer
    holds (a ball flung far away), the cells grow until it fits: slower, never wrong.
    Returns False if a coordinate is not finite (the caller reports the blow-up).
    """
    D = len(g)
    n = x.shape[1]
    cap = grid.start.shape[1] - 1
    finite = True
    for k in range(3):
        grid.geom[b, k] = 0.0  # lower corner
        grid.geom[b, 3 + k] = 0.0  # upper corner
        grid.dims[b, k] = 1
    for k in range(D):
        lo = np.inf
        hi = -np.inf
        for i in range(n):
            xk = x[b, i, k]
            if not np.isfinite(xk):
                finite = False
                continue
            lo = min(lo, xk)
            hi = max(hi, xk)
        if lo <= hi:
            grid.geom[b, k] = lo
            grid.geom[b, 3 + k] = hi
    h = model.cell_size
    while True:  # float arithmetic: a far-flung ball must not overflow the cell count
        total_f = 1.0
        for k in range(D):
            total_f *= np.floor((grid.geom[b, 3 + k] - grid.geom[b, k]) / h) + 1.0
        if total_f <= cap or not h < np.inf:  # cap >= 1 always holds for a real grid
            break
        h *= max(1.26, (total_f / cap) ** (1.0 / D))
    total = 1
    for k in range(D):
        nk = int((grid.geom[b, 3 + k] - grid.geom[b, k]) / h) + 1
        grid.dims[b, k] = nk
        total *= nk
    grid.geom[b, 6] = h
    grid.dims[b, 3] = total
    inv_h = 1.0 / h
    for c in range(total + 1):
        grid.start[b, c] = 0
    for i in range(n):
        c = 0
        stride = 1
        for k in range(D):
            ck = _cell_coord(x[b, i, k], grid.geom[b, k], inv_h, grid.dims[b, k])
            c += ck * stride
            stride *= grid.dims[b, k]
        grid.cell[b, i] = c
        grid.start[b, c] += 1
    running = 0
    for c in range(total):
        running += grid.start[b, c]
        grid.start[b, c] = running  # inclusive prefix: one past the last item of cell c
    grid.start[b, total] = n
    for i in range(n - 1, -1, -1):  # reverse fill leaves each cell ascending in i
        c = grid.cell[b, i]
        grid.start[b, c] -= 1
        grid.items[b, grid.start[b, c]] = i
    return finite


@njit(inline="always")
def _neighbour_rows(b, i, x, grid, D):
    """The 3^D cell neighbourhood of ball i as rows: cells adjacent along x are adjacent in the
    sorted items, so each (y, z) row is one contiguous range of ``grid.items`` (9 ranges in 3D, 3
    in 2D). Returns x0, x1 (the row's cell span), the y and z spans, and the cells per x and y."""
    nx = grid.dims[b, 0]
    ny = grid.dims[b, 1]
    nz = grid.dims[b, 2]
    # cell coordinates of ball i (as build_grid computed them; no integer division needed)
    inv_h = 1.0 / grid.geom[b, 6]
    cx = _cell_coord(x[b, i, 0], grid.geom[b, 0], inv_h, nx)
    cy = _cell_coord(x[b, i, 1], grid.geom[b, 1], inv_h, ny)
    cz = _cell_coord(x[b, i, 2], grid.geom[b, 2], inv_h, nz) if D == 3 else 0
    return (max(cx - 1, 0), min(cx + 2, nx), max(cy - 1, 0), min(cy + 2, ny), max(cz - 1, 0), min(cz + 2, nz),
            nx, ny)


@njit(inline="always")
def grid_neighbours(mode, b, i, half, x, v, out, coef_pair, grid, model, friction, g):
    """Pair contacts of ball i with the balls in its own and the adjacent cells.

    ``half``: only j > i, forces scattered to j too (each pair once, serial use).
    Otherwise every j != i, force gathered on i only (each ball independent: parallel-safe and,
    because the visiting order is fixed by the grid, independent of the thread count).
    """
    x0, x1, y0, y1, z0, z1, nx, ny = _neighbour_rows(b, i, x, grid, len(g))
    acc = 0.0
    for qz in range(z0, z1):
        for qy in range(y0, y1):
            row = (qz * ny + qy) * nx
            for idx in range(grid.start[b, row + x0], grid.start[b, row + x1]):
                j = grid.items[b, idx]
                if half:
                    if j <= i:
                        continue
                elif j == i:
                    continue
                acc = _combine(mode, acc, pair_contact(mode, b, i, j, x, v, out, coef_pair, half, model, friction, g))
    return acc


@njit(inline="always")
def contacts_grid(mode, b, x, v, out, coef_pair, coef_terrain, grid, model, friction, g):
    """Every pair once through the grid (which must be built for these positions), then terrain."""
    n = x.shape[1]
    acc = 0.0
    for i in range(n):
        acc = _combine(mode, acc, grid_neighbours(mode, b, i, True, x, v, out, coef_pair, grid, model, friction, g))
        acc = _combine(mode, acc, terrain_contact(mode, b, i, x, v, out, coef_terrain, model, friction, g))
    return acc


@njit
def contact_forces(b, x, v, out, grid, model, friction, g):
    """Add every contact force of world b to ``out``: ``contacts`` specialised to FORCE, so the
    other modes' branches are pruned from the hot path."""
    if grid is not None:
        contacts_grid(FORCE, b, x, v, out, 0.0, 0.0, grid, model, friction, g)
    else:
        contacts_all_pairs(FORCE, b, x, v, out, 0.0, 0.0, model, friction, g)


@njit
def contacts(mode, b, x, v, out, coef_pair, coef_terrain, grid, model, friction, g):
    """Every contact of world b once: through the grid (built for these positions), or all pairs
    when ``grid`` is None (pruned at compile time: a scene pays only for its broad phase)."""
    if grid is not None:
        return contacts_grid(mode, b, x, v, out, coef_pair, coef_terrain, grid, model, friction, g)
    return contacts_all_pairs(mode, b, x, v, out, coef_pair, coef_terrain, model, friction, g)


# --------------------------------------------------------------------------------------------
# Accelerations and integrators (one world, serial)
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def accelerations(b, x, v, a, ext, grid, model, friction, g):
    """a = (contact forces + ext) / m + g for world b at state (x, v). False if x is not finite."""
    D = len(g)
    n = x.shape[1]
    finite = True
    for i in range(n):
        for k in range(D):
            a[b, i, k] = 0.0
    if grid is not None:
        finite = build_grid(b, x, grid, model, g)
    contact_forces(b, x, v, a, grid, model, friction, g)
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            if ext is not None:
                a[b, i, k] = (a[b, i, k] + ext[b, i, k]) * im + g[k]
            else:
                a[b, i, k] = a[b, i, k] * im + g[k]
    return finite


@njit
def _dot(b, p, q, D):
    s = 0.0
    for i in range(p.shape[1]):
        for k in range(D):
            s += p[b, i, k] * q[b, i, k]
    return s


@njit
def implicit_euler_step(b, dt, x, v, work, ext, grid, model, friction, g, cg_tol, cg_max_iter):
    """Linearised backward Euler (Baraff & Witkin 1998), one Newton step with frozen contacts.

    Solves (M - dt D - dt^2 K) dv = dt (f0 + dt K v) by Jacobi-preconditioned conjugate gradients,
    then v += dv, x += dt v. K and D keep only the normal (n n^T) part of each contact's Jacobian,
    which is negative semidefinite, so the system matrix is symmetric positive definite and the
    step is stable at any dt. Friction and the no-tension clip stay explicit (in f0 only).
    Returns (finite, converged).
    """
    D = len(g)
    n = x.shape[1]
    f0 = work[0]
    rhs = work[1]
    r = work[2]
    p = work[3]
    q = work[4]
    z = work[5]
    finite = accelerations(b, x, v, f0, ext, grid, model, friction, g)  # grid built here
    c_sp = dt * dt * model.ks
    c_st = dt * dt * model.ks_terrain
    c_p = dt * model.kd + c_sp
    c_t = dt * model.kd_terrain + c_st
    # rhs = dt M a0 + dt^2 K v, with (K v)_i = -ks n (n . (v_i - v_j)): a LINEAR pass with -coef
    for i in range(n):
        for k in range(D):
            rhs[b, i, k] = 0.0
            z[b, i, k] = 0.0
    contacts(LINEAR, b, x, v, rhs, -c_sp, -c_st, grid, model, friction, g)
    for i in range(n):
        m = 1.0 / model.inv_mass[i]
        for k in range(D):
            rhs[b, i, k] += dt * m * f0[b, i, k]
    # Jacobi preconditioner: diag(M + c n n^T)
    contacts(DIAG, b, x, v, z, c_p, c_t, grid, model, friction, g)
    for i in range(n):
        m = 1.0 / model.inv_mass[i]
        for k in range(D):
            z[b, i, k] = 1.0 / (z[b, i, k] + m)  # z now holds the inverse diagonal
    # CG from dv = 0 (dv lives in f0's slot after f0 is consumed: use work[0])
    dv = f0
    for i in range(n):
        for k in range(D):
            r[b, i, k] = rhs[b, i, k]
            dv[b, i, k] = 0.0
            p[b, i, k] = z[b, i, k] * r[b, i, k]
    rz = 0.0
    for i in range(n):
        for k in range(D):
            rz += r[b, i, k] * z[b, i, k] * r[b, i, k]
    r0 = np.sqrt(_dot(b, rhs, rhs, D))
    converged = r0 == 0.0
    it = 0
    while not converged and it < cg_max_iter:
        for i in range(n):
            m = 1.0 / model.inv_mass[i]
            for k in range(D):
                q[b, i, k] = m * p[b, i, k]
        contacts(LINEAR, b, x, p, q, c_p, c_t, grid, model, friction, g)
        pq = _dot(b, p, q, D)
        if not pq > 0.0:
            break
        alpha = rz / pq
        for i in range(n):
            for k in range(D):
                dv[b, i, k] += alpha * p[b, i, k]
                r[b, i, k] -= alpha * q[b, i, k]
        it += 1
        if np.sqrt(_dot(b, r, r, D)) <= cg_tol * r0:
            converged = True
            break
        rz_new = 0.0
        for i in range(n):
            for k in range(D):
                rz_new += r[b, i, k] * z[b, i, k] * r[b, i, k]
        beta = rz_new / rz
        rz = rz_new
        for i in range(n):
            for k in range(D):
                p[b, i, k] = z[b, i, k] * r[b, i, k] + beta * p[b, i, k]
    for i in range(n):
        for k in range(D):
            v[b, i, k] += dv[b, i, k]
            x[b, i, k] += dt * v[b, i, k]
    return finite, converged


@njit(inline="always")
def symplectic_euler_step(b, dt, x, v, work, ext, grid, model, friction, g):
    """v += dt a(x, v); x += dt v (the course's integrator). Returns False if x is not finite."""
    D = len(g)
    a = work[0]
    ok = accelerations(b, x, v, a, ext, grid, model, friction, g)
    for i in range(x.shape[1]):
        for k in range(D):
            v[b, i, k] += dt * a[b, i, k]
            x[b, i, k] += dt * v[b, i, k]
    return ok


@njit(inline="always")
def explicit_euler_step(b, dt, x, v, work, ext, grid, model, friction, g):
    """x += dt v; v += dt a(x, v), both from the old state."""
    D = len(g)
    a = work[0]
    ok = accelerations(b, x, v, a, ext, grid, model, friction, g)
    for i in range(x.shape[1]):
        for k in range(D):
            x[b, i, k] += dt * v[b, i, k]
            v[b, i, k] += dt * a[b, i, k]
    return ok


@njit(inline="always")
def velocity_verlet_step(b, dt, x, v, work, a0_valid, ext, grid, model, friction, g):
    """x1 = x + dt v + dt^2/2 a0; a1 = a(x1, v + dt a0); v1 = v + dt/2 (a0 + a1).

    The damping in a1 sees the predicted end-of-step velocity v + dt a0. ``work[1]`` caches the
    contact + gravity part of a1 as the next step's a0 (one force evaluation per step); the external
    force is added on use, so it may change between calls.
    """
    D = len(g)
    n = x.shape[1]
    a, a0, vp = work[0], work[1], work[2]
    ok = True
    if not a0_valid[b]:
        ok = accelerations(b, x, v, a0, None, grid, model, friction, g)
        a0_valid[b] = True
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            ak = a0[b, i, k] + (ext[b, i, k] * im if ext is not None else 0.0)
            x[b, i, k] += dt * v[b, i, k] + 0.5 * dt * dt * ak
            vp[b, i, k] = v[b, i, k] + dt * ak
    ok = accelerations(b, x, vp, a, None, grid, model, friction, g) and ok
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            e = ext[b, i, k] * im if ext is not None else 0.0
            v[b, i, k] += 0.5 * dt * (a0[b, i, k] + a[b, i, k] + 2.0 * e)
            a0[b, i, k] = a[b, i, k]
    return ok


@njit(inline="always")
def rk4_step(b, dt, x, v, work, ext, grid, model, friction, g):
    """Classical fourth-order Runge-Kutta: four full contact passes per step."""
    D = len(g)
    n = x.shape[1]
    a, xe, ve, sx, sv = work[0], work[1], work[2], work[3], work[4]
    ok = accelerations(b, x, v, a, ext, grid, model, friction, g)
    h2 = 0.5 * dt
    for i in range(n):
        for k in range(D):
            sx[b, i, k] = v[b, i, k]
            sv[b, i, k] = a[b, i, k]
            xe[b, i, k] = x[b, i, k] + h2 * v[b, i, k]
            ve[b, i, k] = v[b, i, k] + h2 * a[b, i, k]
    for stage in range(1, 4):
        ok = accelerations(b, xe, ve, a, ext, grid, model, friction, g) and ok
        w = 2.0 if stage < 3 else 1.0
        hs = h2 if stage == 1 else dt
        for i in range(n):
            for k in range(D):
                sx[b, i, k] += w * ve[b, i, k]
                sv[b, i, k] += w * a[b, i, k]
                if stage < 3:
                    xe[b, i, k] = x[b, i, k] + hs * ve[b, i, k]
                    ve[b, i, k] = v[b, i, k] + hs * a[b, i, k]
    h6 = dt / 6.0
    for i in range(n):
        for k in range(D):
            x[b, i, k] += h6 * sx[b, i, k]
            v[b, i, k] += h6 * sv[b, i, k]
    return ok


@njit
def _final_status(b, ok, x, v, g):
    if not ok:
        return STATUS_NONFINITE
    for i in range(x.shape[1]):
        for k in range(len(g)):
            if not (np.isfinite(x[b, i, k]) and np.isfinite(v[b, i, k])):
                return STATUS_NONFINITE
    return STATUS_OK


# One driver per integrator: worlds b0..b1-1, nsteps each, every world serial (so a world's result
# is bit-identical whatever the thread count and whether it runs alone or in a batch). The Python
# side spreads world ranges over threads (the kernels release the GIL). Separate drivers mean a
# user compiles only the integrator used (a parallel=True driver holding all five took ~50 s).


@njit(nogil=True)
def run_symplectic_euler(b0, b1, nsteps, dt, x, v, work, ext, grid, model, friction, g, status):
    for b in range(b0, b1):
        ok = True
        for _ in range(nsteps):
            ok = symplectic_euler_step(b, dt, x, v, work, ext, grid, model, friction, g)
            if not ok:
                break
        status[b] = _final_status(b, ok, x, v, g)


@njit(nogil=True)
def run_explicit_euler(b0, b1, nsteps, dt, x, v, work, ext, grid, model, friction, g, status):
    for b in range(b0, b1):
        ok = True
        for _ in range(nsteps):
            ok = explicit_euler_step(b, dt, x, v, work, ext, grid, model, friction, g)
            if not ok:
                break
        status[b] = _final_status(b, ok, x, v, g)


@njit(nogil=True)
def run_velocity_verlet(b0, b1, nsteps, dt, x, v, work, a0_valid, ext, grid, model, friction, g, status):
    for b in range(b0, b1):
        ok = True
        for _ in range(nsteps):
            ok = velocity_verlet_step(b, dt, x, v, work, a0_valid, ext, grid, model, friction, g)
            if not ok:
                break
        status[b] = _final_status(b, ok, x, v, g)


@njit(nogil=True)
def run_rk4(b0, b1, nsteps, dt, x, v, work, ext, grid, model, friction, g, status):
    for b in range(b0, b1):
        ok = True
        for _ in range(nsteps):
            ok = rk4_step(b, dt, x, v, work, ext, grid, model, friction, g)
            if not ok:
                break
        status[b] = _final_status(b, ok, x, v, g)


@njit(nogil=True)
def run_implicit_euler(b0, b1, nsteps, dt, x, v, work, ext, grid, model, friction, g,
                       cg_tol, cg_max_iter, status):
    for b in range(b0, b1):
        ok = True
        all_converged = True
        for _ in range(nsteps):
            ok, converged = implicit_euler_step(b, dt, x, v, work, ext, grid, model, friction, g,
                                                cg_tol, cg_max_iter)
            all_converged = all_converged and converged
            if not ok:
                break
        st = _final_status(b, ok, x, v, g)
        status[b] = STATUS_CG if st == STATUS_OK and not all_converged else st


# --------------------------------------------------------------------------------------------
# Large worlds: one world's force loop in parallel over balls
# --------------------------------------------------------------------------------------------


@njit(parallel=True)
def _permute_rows(src, order, tmp):
    """src[0, i] = src[0, order[i]] for every row i (through tmp, (n, D))."""
    n = order.shape[0]
    for i in prange(n):
        for k in range(src.shape[2]):
            tmp[i, k] = src[0, order[i], k]
    for i in prange(n):
        for k in range(src.shape[2]):
            src[0, i, k] = tmp[i, k]


@njit(inline="always")
def _list_neighbours(i, grid, xs, sm, nbr, skin, D):
    """Write ball i's neighbours j > i within r_i + r_j + skin to ``nbr[i]`` in the grid's order (as
    many as fit below its last column, which takes the rejects); return how many there are: each
    pair is listed once, by its lower slot. The storage must be in the grid's cell order (slot =
    item), so a listed j lies in i's layer of cells along the last axis or in the next one.
    Branch-free: every candidate is written and the count advances only for a neighbour."""
    last = nbr.shape[1] - 1
    x0, x1, y0, y1, z0, z1, nx, ny = _neighbour_rows(0, i, xs, grid, D)
    count = 0
    reach = sm.radii[i] + skin
    p0 = xs[0, i, 0]
    p1 = xs[0, i, 1]
    p2 = xs[0, i, 2] if D == 3 else 0.0
    for qz in range(z0, z1):
        for qy in range(y0, y1):
            row = (qz * ny + qy) * nx
            # storage is in cell order: the slots after i are the later cells (rows before i's end
            # before it, and i's own row resumes after it), so only they are scanned
            for j in range(max(grid.start[0, row + x0], i + 1), grid.start[0, row + x1]):
                cut = reach + sm.radii[j]
                d0 = xs[0, j, 0] - p0
                d1 = xs[0, j, 1] - p1
                d2 = xs[0, j, 2] - p2 if D == 3 else 0.0
                near = d0 * d0 + d1 * d1 + d2 * d2 < cut * cut
                nbr[i, min(count, last)] = j
                count += 1 if near else 0
    return count


@njit(inline="always")
def _near_terrain(i, xs, sm, reach, D):
    """1 unless ball i's surface is at least ``reach`` clear of every terrain shape (phi(c_i) - r_i
    >= reach; a position that is not finite counts as near)."""
    r = sm.radii[i]
    for s in range(sm.shape_kind.shape[0]):
        sign, dist2 = _shape_dist2(0, i, xs, sm, s, D)
        if not sign * (np.sqrt(dist2) - sm.shape_radius[s]) - r >= reach:
            return 1
    return 0


@njit(parallel=True)
def _build_list(grid, xs, sm, lw, g):
    """Every pair within r_i + r_j + skin, listed once by its lower slot in the grid's fixed order
    (the list, and so the force sums, do not depend on the thread count), and which balls are
    within a skin of the terrain. Returns the largest count; a count at the list's capacity leaves
    the list invalid (the caller grows it and retries)."""
    D = len(g)
    n = xs.shape[1]
    nbr, cnt, near, xref = lw.nbr, lw.count, lw.near, lw.xref
    skin = lw.skin
    for i in prange(n):
        cnt[i] = _list_neighbours(i, grid, xs, sm, nbr, skin, D)
        # a ball that has not escaped is within skin / 2 of xref, and phi is 1-Lipschitz: a
        # clearance of a skin at the build means no terrain contact until it escapes
        near[i] = _near_terrain(i, xs, sm, skin, D)
        for k in range(D):
            xref[i, k] = xs[0, i, k]
    most = 0
    for i in range(n):
        most = max(most, cnt[i])
    return most


@njit(inline="always")
def _listed_pair_forces(i, xs, vs, a, nbr, cnt, sm, friction, g, escaped, ne):
    """Apply the pair forces of ball i's list (each pair once: added to i, subtracted from j),
    skipping escaped balls.

    Without friction this is :func:`pair_contact`'s FORCE law written for the list: every entry is
    evaluated without a branch and masked by the contact test, and i's share is summed in registers
    (the contact test is a coin flip in a pile, and a mispredicted branch costs more than the
    arithmetic it skips: 2x faster, measured). Same law, operations in a different order: it agrees
    with pair_contact to round-off (``tests/test_physics_broadphase.py``). Coincident centres and
    friction go through pair_contact itself.
    """
    D = len(g)
    if friction is not None:
        for m in range(cnt[i]):
            j = nbr[i, m]
            if ne == 0 or escaped[j] == 0:
                pair_contact(FORCE, 0, i, j, xs, vs, a, 0.0, True, sm, friction, g)
        return
    ks = sm.ks
    kd = sm.kd
    ri = sm.radii[i]
    p0 = xs[0, i, 0]
    p1 = xs[0, i, 1]
    p2 = xs[0, i, 2] if D == 3 else 0.0
    u0 = vs[0, i, 0]
    u1 = vs[0, i, 1]
    u2 = vs[0, i, 2] if D == 3 else 0.0
    f0 = 0.0
    f1 = 0.0
    f2 = 0.0
    for m in range(cnt[i]):
        j = nbr[i, m]
        l0 = ri + sm.radii[j]
        d0 = xs[0, j, 0] - p0
        d1 = xs[0, j, 1] - p1
        d2 = xs[0, j, 2] - p2 if D == 3 else 0.0
        dist2 = d0 * d0 + d1 * d1 + d2 * d2
        if dist2 == 0.0:
            if ne == 0 or escaped[j] == 0:
                pair_contact(FORCE, 0, i, j, xs, vs, a, 0.0, True, sm, friction, g)
            continue
        dist = np.sqrt(dist2)
        inv = 1.0 / dist
        w0 = vs[0, j, 0] - u0
        w1 = vs[0, j, 1] - u1
        w2 = vs[0, j, 2] - u2 if D == 3 else 0.0
        vn = (w0 * d0 + w1 * d1 + w2 * d2) * inv
        fn = -ks * (l0 - dist) + kd * vn  # along +n on i, as in pair_contact
        if sm.no_tension:
            fn = min(fn, 0.0)
        touch = dist2 < l0 * l0 and (ne == 0 or escaped[j] == 0)
        fn = fn * inv if touch else 0.0
        e0 = fn * d0
        e1 = fn * d1
        f0 += e0
        f1 += e1
        a[0, j, 0] -= e0
        a[0, j, 1] -= e1
        if D == 3:
            e2 = fn * d2
            f2 += e2
            a[0, j, 2] -= e2
    a[0, i, 0] += f0
    a[0, i, 1] += f1
    if D == 3:
        a[0, i, 2] += f2


@njit(inline="always")
def _advance(integ, dt, i0, i1, xs, vs, a, es, ext, sm, xref, escaped, half2, g):
    """Symplectic / explicit Euler update of storage slots i0..i1-1 (leaving their forces zeroed for
    the next step); marks each slot that is now skin / 2 or more from where the list was built.
    Returns how many it marked, or -1 (after updating every slot) if a displacement is not finite:
    the caller rebuilds, and the rebuild's grid reports a position that is not finite."""
    D = len(g)
    marked = 0
    blown = False
    for i in range(i0, i1):
        im = sm.inv_mass[i]
        d2 = 0.0
        for k in range(D):
            ak = (a[0, i, k] + (es[0, i, k] if ext is not None else 0.0)) * im + g[k]
            a[0, i, k] = 0.0  # ready for the next step's forces
            if integ == SYMPLECTIC_EULER:
                vs[0, i, k] += dt * ak
                xs[0, i, k] += dt * vs[0, i, k]
            else:
                xs[0, i, k] += dt * vs[0, i, k]
                vs[0, i, k] += dt * ak
            dk = xs[0, i, k] - xref[i, k]
            d2 += dk * dk
        if not d2 < half2:
            blown = blown or not np.isfinite(d2)
            if escaped[i] == 0:
                escaped[i] = 1
                marked += 1
    return -1 if blown else marked


@njit
def _escaped_contacts(xs, vs, a, grid, sm, friction, g, escaped, escapes, ne):
    """Pair forces of the escaped balls (serial, each pair once, applied to both balls; the list
    pass skipped them). An escaped ball meets the others through the grid of the last build: every
    ball that has not escaped is within skin / 2 of where that grid put it, and the grid's cells
    are wider than r_i + r_j + skin, so a ball in reach sits in the 3^D cells around the escaped
    ball's current position. Escaped balls meet each other pair by pair."""
    D = len(g)
    for e in range(ne):
        i = escapes[e]
        x0, x1, y0, y1, z0, z1, nx, ny = _neighbour_rows(0, i, xs, grid, D)
        for qz in range(z0, z1):
            for qy in range(y0, y1):
                row = (qz * ny + qy) * nx
                for j in range(grid.start[0, row + x0], grid.start[0, row + x1]):
                    if escaped[j] == 0:
                        pair_contact(FORCE, 0, i, j, xs, vs, a, 0.0, True, sm, friction, g)
        for f in range(e + 1, ne):
            pair_contact(FORCE, 0, i, escapes[f], xs, vs, a, 0.0, True, sm, friction, g)


@njit
def _slab_forces(s, layer, start, xs, vs, a, nbr, cnt, near, sm, friction, g, escaped, ne):
    """Listed pair forces and terrain contacts of every ball in slab s (serial, storage order). The
    terrain is tested for the balls listed near it and for the escaped ones (which may have come
    near it since the build). A function of its own, not inlined: each inlined call site would
    compile the force law again."""
    for i in range(start[s * layer], start[(s + 1) * layer]):
        escaped_i = ne > 0 and escaped[i] != 0
        if not escaped_i:
            _listed_pair_forces(i, xs, vs, a, nbr, cnt, sm, friction, g, escaped, ne)
        if escaped_i or near[i] != 0:
            terrain_contact(FORCE, 0, i, xs, vs, a, 0.0, sm, friction, g)


@njit(parallel=True)
def run_large(integ, nsteps, dt, x, v, ext, sm, friction, g, status, lw, threads):
    """Symplectic or explicit Euler for a world too large to run one per thread. Returns the number
    of steps taken: fewer than ``nsteps`` when the world blew up (``status``) or when a ball has more
    neighbours than the list holds (``lw.state[1]`` says how many; the caller grows it and goes on).

    A Verlet neighbour list, as LAMMPS and HOOMD keep: every pair within r_i + r_j + skin is listed
    once (by its lower storage slot), found through a grid whose cells are at least that wide.
    Until a ball has moved skin / 2 from where it was at the build, no pair outside the list can
    touch, so a step visits only the list, and each pair's force is computed once and applied to
    both balls (Newton's third law, as LAMMPS's "newton on"; measured at 100,000 balls, 1.3x faster
    than gathering every pair from both sides). The writes stay apart by slabs: with the storage
    sorted by cell, one layer of cells along the last axis is a contiguous range of slots, and its
    listed partners lie in the same layer or the next. So the even layers run in parallel, then the
    odd ones, each layer serially in storage order. A layer's forces are complete once it and the
    layer before it have run, and no later work of the step reads its state: so each odd layer,
    once its forces are in, advances itself and the (even) layer after it while they are still in
    cache. The terrain is tested only for the balls that were within a skin of it at the build (a
    ball that has not escaped has moved less than skin / 2 since) and for the escaped ones.

    A ball that has moved skin / 2 "escapes": the list no longer speaks for it, and its contacts are
    found each step through the build's grid (:func:`_escaped_contacts`, before the layers, while
    every ball is still where the step began). In a pile a few fast balls escape long before the
    rest move; they no longer force the whole list to be rebuilt. Once ``escapes`` is full, the
    next step re-sorts the storage by grid cell (balls that touch sit close in memory) and rebuilds
    the list.

    Nothing depends on the thread count (what each ball receives, and in which order, is fixed by
    the layers and the list; the escaped balls go in a serial pass), and the rebuilds depend only
    on the state, so splitting the steps over calls changes nothing. ``x``, ``v``, ``ext``,
    ``status`` are the world's own ``(1, n, D)`` / ``(1,)`` slices, in ball order: gathered into
    storage order on entry, scattered back on exit. ``sm`` is a Model
    whose radii / inv_mass arrays are the world's own, permuted with the storage. ``threads``: how
    many ways to split the slabs (the thread count, at most ``len(lw.moved)``; the result does not
    depend on it).
    """
    D = len(g)
    n = x.shape[1]
    # (namedtuple fields are bound to locals before the prange loops: Numba 0.68 silently drops
    # stores through ``tuple.field[i] = ...`` inside a parallel loop; reads are fine)
    xs, vs, a, es, grid = lw.x, lw.v, lw.a, lw.ext, lw.grid
    perm, nbr, cnt, near, moved = lw.perm, lw.nbr, lw.count, lw.near, lw.moved
    xref, escaped, escapes = lw.xref, lw.escaped, lw.escapes
    start = grid.start[0]
    threads = max(1, min(threads, moved.shape[0]))
    half2 = 0.25 * lw.skin * lw.skin
    for i in prange(n):
        u = perm[i]
        for k in range(D):
            xs[0, i, k] = x[0, u, k]
            vs[0, i, k] = v[0, u, k]
            a[0, i, k] = 0.0
            if ext is not None:
                es[0, i, k] = ext[0, u, k]
    ok = True
    taken = 0
    while taken < nsteps:
        if lw.state[0] == 0:
            # re-sort the storage by grid cell, then list every pair within reach
            if not build_grid(0, xs, grid, sm, g):
                ok = False
                break
            order = lw.order
            for i in range(n):
                order[i] = grid.items[0, i]
            _permute_rows(xs, order, lw.tmp)
            _permute_rows(vs, order, lw.tmp)
            if ext is not None:
                _permute_rows(es, order, lw.tmp)
            for i in range(n):
                j = order[i]
                lw.tmp[i, 0] = sm.radii[j]
                lw.tmp[i, 1] = sm.inv_mass[j]
                lw.itmp[i] = perm[j]
            for i in range(n):
                sm.radii[i] = lw.tmp[i, 0]
                sm.inv_mass[i] = lw.tmp[i, 1]
                perm[i] = lw.itmp[i]
                escaped[i] = 0
            most = _build_list(grid, xs, sm, lw, g)
            lw.state[1] = most
            lw.state[2] += 1
            lw.state[3] = 0
            if most >= nbr.shape[1]:
                break  # list too small (its last column takes the rejects): the caller grows it
            lw.state[0] = 1
        ne = lw.state[3]
        # the escaped balls' pairs first (serial), then the slabs: each pair once, its force added
        # to both balls; a slab (one layer of cells along the last axis, a contiguous range of the
        # sorted storage) writes only to itself and the next slab, so the even slabs run in
        # parallel, then the odd ones, each advancing itself and the next once its forces are in.
        # What a ball receives, and in which order, depends on the slabs, never on the threads.
        if ne > 0:
            _escaped_contacts(xs, vs, a, grid, sm, friction, g, escaped, escapes, ne)
        # cells in one layer along the last axis (not "layer = 1; layer *= ...": the literal 1 typed
        # one of the two passes' calls of _slab_forces apart, and compiled it twice)
        layer = grid.dims[0, 0] * grid.dims[0, 1] if D == 3 else grid.dims[0, 0]
        slabs = grid.dims[0, D - 1]
        for t in prange(threads):
            for q in range(t, (slabs + 1) // 2, threads):  # round robin: the slabs differ in size
                _slab_forces(2 * q, layer, start, xs, vs, a, nbr, cnt, near, sm, friction, g, escaped, ne)
        for t in prange(threads):
            marked = 0
            # (an int64 copy of t: a prange index may be unsigned, and int64 with uint64 unifies to float)
            q = -1 if t == 0 else np.int64(t)  # thread 0 first advances slab 0: complete after the even pass
            while q < slabs // 2:
                s0 = 0
                s1 = 1
                if q >= 0:
                    s0 = 1 + 2 * q
                    _slab_forces(s0, layer, start, xs, vs, a, nbr, cnt, near, sm, friction, g, escaped, ne)
                    s1 = min(s0 + 2, slabs)  # this slab and the next, contiguous in storage
                m = _advance(integ, dt, start[s0 * layer], start[s1 * layer], xs, vs, a, es, ext, sm, xref, escaped,
                             half2, g)
                marked = -1 if (m < 0 or marked < 0) else marked + m
                q = np.int64(t) if q < 0 else q + threads
            moved[t] = marked
        taken += 1
        # collect the newly escaped slots in storage order; rebuild when they no longer fit, or
        # at once when a position is not finite
        fresh = 0
        for t in range(threads):
            if moved[t] < 0:
                lw.state[0] = 0
            fresh += moved[t]
        if lw.state[0] != 0 and fresh > 0:
            for i in range(n):
                if escaped[i] == 1:
                    escaped[i] = 2
                    if ne < escapes.shape[0]:
                        escapes[ne] = i
                    ne += 1
            if ne > escapes.shape[0]:
                lw.state[0] = 0
        lw.state[3] = ne
    for i in prange(n):
        u = perm[i]
        for k in range(D):
            x[0, u, k] = xs[0, i, k]
            v[0, u, k] = vs[0, i, k]
    status[0] = _final_status(0, ok, x, v, g)
    return taken


# --------------------------------------------------------------------------------------------
# Diagnostics
# --------------------------------------------------------------------------------------------


@njit(nogil=True)
def world_energy(x, v, grid, model, g, out):
    """Per world: kinetic + gravitational (-m g . x) + penalty springs (1/2 ks overlap^2)."""
    D = len(g)
    for b in range(x.shape[0]):
        e = 0.0
        for i in range(x.shape[1]):
            m = 1.0 / model.inv_mass[i]
            for k in range(D):
                e += 0.5 * m * v[b, i, k] * v[b, i, k] - m * g[k] * x[b, i, k]
        if grid is not None:
            build_grid(b, x, grid, model, g)
        e += contacts(ENERGY, b, x, v, x, 0.0, 0.0, grid, model, None, g)
        out[b] = e


@njit(nogil=True)
def world_max_penetration(x, v, grid, model, g, out):
    """Per world: the largest overlap as a fraction of the smaller radius in contact."""
    for b in range(x.shape[0]):
        if grid is not None:
            build_grid(b, x, grid, model, g)
        out[b] = contacts(MAXPEN, b, x, v, x, 0.0, 0.0, grid, model, None, g)
