"""The scalar stepping path: each listed world stepped serially with any integrator.

Every world is stepped serially, so a world's result is bit-identical whatever the thread count and
whether it runs alone or in a batch (the runner spreads lists of worlds over threads). Status
codes (``status[b]`` after a call): STATUS_OK, STATUS_NONFINITE (a position or velocity became NaN
or inf), STATUS_CG (implicit Euler: conjugate gradients did not converge in some step of the call;
the step used the last iterate).
"""

from __future__ import annotations

from ..._jit import njit, overload_kernel
from ..geometry.evaluate import advance_shapes
from ..per_world import world_model, world_spin
from .common import STATUS_CG, STATUS_OK, final_status, step_forces
from .integrators import ImplicitEulerWork, integrate, is_work
from .spin_steps import spin_tick

__all__ = ["run_worlds", "begin_world", "world_status", "external"]


def begin_world(work, b):
    """Reset what a driver call reports per world (implicit Euler: the convergence flag)."""
    raise NotImplementedError("begin_world is called from jitted code")


@overload_kernel(begin_world)
def _begin_world(work, b):
    if is_work(work, ImplicitEulerWork):

        def impl(work, b):
            work.cg_failed[b] = False

        return impl
    return lambda work, b: None


def world_status(work, b, ok, x, v, D):
    """World b's status after a driver call (jitted code only)."""
    raise NotImplementedError("world_status is called from jitted code")


@overload_kernel(world_status)
def _world_status(work, b, ok, x, v, D):
    if is_work(work, ImplicitEulerWork):

        def impl(work, b, ok, x, v, D):
            st = final_status(b, ok, x, v, D)
            return STATUS_CG if st == STATUS_OK and work.cg_failed[b] else st

        return impl
    return lambda work, b, ok, x, v, D: final_status(b, ok, x, v, D)


@njit
def external(control, scratch, motors):
    """(the array of each step's external forces, whether there are any): the given forces as they
    are, or with motors the scratch that :func:`.common.step_forces` fills at every step."""
    has_motors = motors.ball.shape[0] > 0
    ext = scratch.ext if has_motors else control.forces
    return ext, has_motors or control.flags[0] != 0


@njit(nogil=True)
def run_worlds(worlds, nsteps, dt, x, v, work, control, grid, scratch, model, spin, g, status):
    """The listed worlds, ``nsteps`` steps each, every world serial; sets ``status[b]``. Returns how
    many blew up."""
    D = len(g)
    ext, has_ext = external(control, scratch, model.motors)
    has_motors = model.motors.ball.shape[0] > 0
    bad = 0
    for t in range(worlds.shape[0]):
        b = worlds[t]
        mb = world_model(model, b)  # world b's parameters (the model itself for a fixed scene)
        sb = world_spin(spin, b)
        begin_world(work, b)
        ok = True
        for _ in range(nsteps):
            if has_motors:
                step_forces(b, v, control, mb.motors, ext, D)
            ok = integrate(work, b, dt, x, v, ext, has_ext, grid, scratch.partners, mb, sb, g)
            spin_tick(sb, b)  # (nothing without rotation)
            advance_shapes(model.shapes, b, dt, D)  # kinematic shapes move on (nothing if none)
            if not ok:
                break
        status[b] = world_status(work, b, ok, x, v, D)
        bad += status[b] != STATUS_OK
    return bad
