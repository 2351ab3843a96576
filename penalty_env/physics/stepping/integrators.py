"""Time integrators: one step function per method (world b, serial).

Each integrator is identified by the type of its scratch buffers (its *work*, allocated once per
``World`` by :func:`allocate_work`): :func:`integrate` picks the method's step from that type when
Numba compiles a driver, so a scene compiles only the integrator it uses.

=====================  ===============================================  ===============================
method                 one step of dt                                   angular velocity w (rotation)
=====================  ===============================================  ===============================
explicit Euler         x += dt v; v += dt a(x, v)                        w += dt alpha(x, v, w)
symplectic Euler       v += dt a(x, v); x += dt v (the course's)         w += dt alpha(x, v, w)
velocity Verlet        x1 = x + dt v + dt^2/2 a0; a1 = a(x1, v + dt a0);  w1 = w + dt/2 (alpha0 + alpha1),
                       v1 = v + dt/2 (a0 + a1) (damping at the          alpha1 at w + dt alpha0 (cached
                       predicted end-of-step velocity; a1 cached)        as a1 is)
RK4                    classical fourth order, four force passes        w as one more velocity
implicit Euler         linearised backward Euler, frozen contacts,      w += dt alpha(x, v, w): explicit,
                       Jacobi-preconditioned conjugate gradients        as friction is
=====================  ===============================================  ===============================

``a(x, v) = (contact forces + ext) / m + g``: :func:`.forces.accelerations`. Each step returns
False if a position is not finite. ``ext`` is the external force (read when ``has_ext``), held
over the step.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import types

from ..._jit import njit, overload_kernel
from .forces import accelerations, contact_jacobian, spin_kick
from .spin_steps import spin_cache, spin_correct, spin_predict, spin_rk4

__all__ = [
    "INTEGRATORS",
    "ExplicitEulerWork",
    "SymplecticEulerWork",
    "VelocityVerletWork",
    "RK4Work",
    "ImplicitEulerWork",
    "allocate_work",
    "integrate",
    "is_work",
    "symplectic_euler_into",
]

INTEGRATORS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler")
# full contact passes per step (implicit Euler: one, plus its CG iterations' products)


class ExplicitEulerWork(NamedTuple):
    a: np.ndarray  # (B, n, D) accelerations


class SymplecticEulerWork(NamedTuple):
    a: np.ndarray


class VelocityVerletWork(NamedTuple):
    a: np.ndarray
    a0: np.ndarray  # the cached acceleration (contact + gravity) of the current state
    vp: np.ndarray  # the predicted end-of-step velocity
    a0_valid: np.ndarray  # (B,) bool: a0 belongs to the current state


class RK4Work(NamedTuple):
    a: np.ndarray
    xe: np.ndarray
    ve: np.ndarray
    sx: np.ndarray
    sv: np.ndarray


class ImplicitEulerWork(NamedTuple):
    f0: np.ndarray
    rhs: np.ndarray
    r: np.ndarray
    p: np.ndarray
    q: np.ndarray
    z: np.ndarray
    cg: np.ndarray  # (2,) [tolerance (relative residual), largest iteration count]
    cg_failed: np.ndarray  # (B,) bool: some step of the last call did not converge


_WORK = {
    "explicit_euler": (ExplicitEulerWork, 1),
    "symplectic_euler": (SymplecticEulerWork, 1),
    "velocity_verlet": (VelocityVerletWork, 3),
    "rk4": (RK4Work, 5),
    "implicit_euler": (ImplicitEulerWork, 6),
}


def allocate_work(integrator: str, B: int, n: int, d: int):
    """The scratch buffers of ``integrator`` for B worlds of n balls in d dimensions."""
    cls, arrays = _WORK[integrator]
    fields = [np.zeros((B, n, d)) for _ in range(arrays)]
    if cls is VelocityVerletWork:
        fields.append(np.zeros(B, dtype=np.bool_))
    elif cls is ImplicitEulerWork:
        fields += [np.array([1e-10, float(max(50, 4 * n * d))]), np.zeros(B, dtype=np.bool_)]
    return cls(*fields)


@njit
def _dot(b, p, q, D):
    s = 0.0
    for i in range(p.shape[1]):
        for k in range(D):
            s += p[b, i, k] * q[b, i, k]
    return s


@njit(hot=True)
def symplectic_euler_into(a, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """v += dt a(x, v); x += dt v, with ``a`` as scratch (also the event location's crossing step)."""
    D = len(g)
    ok = accelerations(b, x, v, a, ext, has_ext, grid, buf, model, spin, g)
    for i in range(x.shape[1]):
        for k in range(D):
            v[b, i, k] += dt * a[b, i, k]
            x[b, i, k] += dt * v[b, i, k]
    spin_kick(spin, b, dt)
    return ok


@njit(hot=True)
def explicit_euler_step(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """x += dt v; v += dt a(x, v), both from the old state."""
    D = len(g)
    a = work.a
    ok = accelerations(b, x, v, a, ext, has_ext, grid, buf, model, spin, g)
    for i in range(x.shape[1]):
        for k in range(D):
            x[b, i, k] += dt * v[b, i, k]
            v[b, i, k] += dt * a[b, i, k]
    spin_kick(spin, b, dt)
    return ok


@njit(hot=True)
def symplectic_euler_step(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """v += dt a(x, v); x += dt v (the course's integrator)."""
    return symplectic_euler_into(work.a, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g)


@njit(hot=True)
def velocity_verlet_step(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """x1 = x + dt v + dt^2/2 a0; a1 = a(x1, v + dt a0); v1 = v + dt/2 (a0 + a1).

    The damping in a1 sees the predicted end-of-step velocity v + dt a0. ``work.a0`` caches the
    contact + gravity part of a1 as the next step's a0 (one force evaluation per step); the external
    force is added on use, so it may change between calls.
    """
    D = len(g)
    n = x.shape[1]
    a, a0, vp, a0_valid = work.a, work.a0, work.vp, work.a0_valid
    ok = True
    if not a0_valid[b]:
        ok = accelerations(b, x, v, a0, ext, False, grid, buf, model, spin, g)
        spin_cache(spin, b)
        a0_valid[b] = True
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            ak = a0[b, i, k] + (ext[b, i, k] * im if has_ext else 0.0)
            x[b, i, k] += dt * v[b, i, k] + 0.5 * dt * dt * ak
            vp[b, i, k] = v[b, i, k] + dt * ak
    spin_predict(spin, b, dt)
    ok = accelerations(b, x, vp, a, ext, False, grid, buf, model, spin, g) and ok
    spin_correct(spin, b, dt)
    for i in range(n):
        im = model.inv_mass[i]
        for k in range(D):
            e = ext[b, i, k] * im if has_ext else 0.0
            v[b, i, k] += 0.5 * dt * (a0[b, i, k] + a[b, i, k] + 2.0 * e)
            a0[b, i, k] = a[b, i, k]
    return ok


@njit
def rk4_step(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """Classical fourth-order Runge-Kutta: four full contact passes per step."""
    D = len(g)
    n = x.shape[1]
    a, xe, ve, sx, sv = work.a, work.xe, work.ve, work.sx, work.sv
    ok = accelerations(b, x, v, a, ext, has_ext, grid, buf, model, spin, g)
    h2 = 0.5 * dt
    spin_rk4(spin, b, 0, h2)
    for i in range(n):
        for k in range(D):
            sx[b, i, k] = v[b, i, k]
            sv[b, i, k] = a[b, i, k]
            xe[b, i, k] = x[b, i, k] + h2 * v[b, i, k]
            ve[b, i, k] = v[b, i, k] + h2 * a[b, i, k]
    for stage in range(1, 4):
        ok = accelerations(b, xe, ve, a, ext, has_ext, grid, buf, model, spin, g) and ok
        w = 2.0 if stage < 3 else 1.0
        hs = h2 if stage == 1 else dt
        spin_rk4(spin, b, stage, hs)
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
    spin_rk4(spin, b, 4, -h6)
    return ok


@njit
def _cg_solve(work, b, x, grid, buf, model, c_p, c_t, D):
    """Jacobi-preconditioned conjugate gradients for (M - dt D - dt^2 K) dv = rhs, from dv = 0
    (dv in f0's slot, f0 consumed). Returns whether the relative residual reached the tolerance."""
    n = x.shape[1]
    dv, rhs, r, p, q, z = work.f0, work.rhs, work.r, work.p, work.q, work.z
    cg_tol = work.cg[0]
    cg_max_iter = work.cg[1]
    for i in range(n):
        for k in range(D):
            r[b, i, k] = rhs[b, i, k]
            dv[b, i, k] = 0.0
            p[b, i, k] = z[b, i, k] * r[b, i, k]
    rz = 0.0
    for i in range(n):
        for k in range(D):
            rz += r[b, i, k] * z[b, i, k] * r[b, i, k]
    r0 = math.sqrt(_dot(b, rhs, rhs, D))
    converged = r0 == 0.0
    it = 0
    while not converged and it < cg_max_iter:
        for i in range(n):
            m = 1.0 / model.inv_mass[i]
            for k in range(D):
                q[b, i, k] = m * p[b, i, k]
        contact_jacobian(b, x, p, q, c_p, c_t, False, grid, buf[b], model, D)
        pq = _dot(b, p, q, D)
        if not pq > 0.0:
            break
        alpha = rz / pq
        for i in range(n):
            for k in range(D):
                dv[b, i, k] += alpha * p[b, i, k]
                r[b, i, k] -= alpha * q[b, i, k]
        it += 1
        if math.sqrt(_dot(b, r, r, D)) <= cg_tol * r0:
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
    return converged


@njit
def implicit_euler_step(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """Linearised backward Euler (Baraff & Witkin 1998), one Newton step with frozen contacts.

    Solves (M - dt D - dt^2 K) dv = dt (f0 + dt K v) by Jacobi-preconditioned conjugate gradients,
    then v += dv, x += dt v. K and D keep only the normal (n n^T) part of each contact's Jacobian,
    which is negative semidefinite, so the system matrix is symmetric positive definite and the
    step is stable at any dt. Friction and the no-tension clip stay explicit (in f0 only). A step
    whose solve does not converge sets ``work.cg_failed[b]``.
    """
    D = len(g)
    n = x.shape[1]
    f0, rhs, z = work.f0, work.rhs, work.z
    finite = accelerations(b, x, v, f0, ext, has_ext, grid, buf, model, spin, g)  # grid built here
    c_sp = dt * dt * model.ks
    c_st = dt * dt * model.ks_terrain
    c_p = dt * model.kd + c_sp
    c_t = dt * model.kd_terrain + c_st
    # rhs = dt M a0 + dt^2 K v, with (K v)_i = -ks n (n . (v_i - v_j)): a Jacobian pass with -coef
    for i in range(n):
        for k in range(D):
            rhs[b, i, k] = 0.0
            z[b, i, k] = 0.0
    contact_jacobian(b, x, v, rhs, -c_sp, -c_st, False, grid, buf[b], model, D)
    for i in range(n):
        m = 1.0 / model.inv_mass[i]
        for k in range(D):
            rhs[b, i, k] += dt * m * f0[b, i, k]
    # Jacobi preconditioner: diag(M + c n n^T)
    contact_jacobian(b, x, v, z, c_p, c_t, True, grid, buf[b], model, D)
    for i in range(n):
        m = 1.0 / model.inv_mass[i]
        for k in range(D):
            z[b, i, k] = 1.0 / (z[b, i, k] + m)  # z now holds the inverse diagonal
    converged = _cg_solve(work, b, x, grid, buf, model, c_p, c_t, D)
    dv = work.f0
    for i in range(n):
        for k in range(D):
            v[b, i, k] += dv[b, i, k]
            x[b, i, k] += dt * v[b, i, k]
    spin_kick(spin, b, dt)  # the torque stays explicit, as friction does
    if not converged:
        work.cg_failed[b] = True
    return finite


# --------------------------------------------------------------------------------------------
# Dispatch on the work type (resolved when a driver compiles: nothing is decided per step)
# --------------------------------------------------------------------------------------------


def is_work(work, cls) -> bool:
    """At compile time: are these Numba-typed work buffers the integrator ``cls``'s?"""
    return isinstance(work, types.BaseNamedTuple) and work.instance_class is cls


def integrate(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    """One step of world b with the integrator whose work buffers these are (jitted code only)."""
    raise NotImplementedError("integrate is called from jitted code")


_STEPS = (
    (ExplicitEulerWork, explicit_euler_step),
    (SymplecticEulerWork, symplectic_euler_step),
    (VelocityVerletWork, velocity_verlet_step),
    (RK4Work, rk4_step),
    (ImplicitEulerWork, implicit_euler_step),
)


@overload_kernel(integrate, hot=True)
def _integrate(work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g):
    for cls, step in _STEPS:
        if is_work(work, cls):
            return lambda work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g: step(
                work, b, dt, x, v, ext, has_ext, grid, buf, model, spin, g
            )
    return None
