"""The integrators' side of rotation: advancing the angular velocities w (each a no-op, compiled to
nothing, when ``spin`` is None: a scene whose balls do not spin)."""

from __future__ import annotations

from ..._jit import njit

__all__ = ["spin_cache", "spin_predict", "spin_correct", "spin_rk4", "spin_tick"]


@njit(hot=True)
def spin_cache(spin, b):
    """Velocity Verlet's first force pass: cache alpha (as a0)."""
    if spin is None:
        return
    sw, al = spin.sw, spin.alpha
    for i in range(sw.shape[1]):
        for k in range(sw.shape[2]):
            sw[b, i, k] = al[b, i, k]


@njit(hot=True)
def spin_predict(spin, b, dt):
    """Velocity Verlet: keep w in w0, then w = w0 + dt alpha0 (the predicted end-of-step spin the
    second force pass sees, as it sees the predicted velocity)."""
    if spin is None:
        return
    w, w0, a0 = spin.w, spin.w0, spin.sw
    for i in range(w.shape[1]):
        for k in range(w.shape[2]):
            w0[b, i, k] = w[b, i, k]
            w[b, i, k] += dt * a0[b, i, k]


@njit(hot=True)
def spin_correct(spin, b, dt):
    """Velocity Verlet: w = w0 + dt/2 (alpha0 + alpha1); alpha1 cached as the next alpha0."""
    if spin is None:
        return
    w, w0, a0, al = spin.w, spin.w0, spin.sw, spin.alpha
    for i in range(w.shape[1]):
        for k in range(w.shape[2]):
            w[b, i, k] = w0[b, i, k] + 0.5 * dt * (a0[b, i, k] + al[b, i, k])
            a0[b, i, k] = al[b, i, k]


@njit
def spin_rk4(spin, b, stage, h):
    """RK4 with w as one more velocity: stage 0 keeps w0 and starts the sum with k1; stages 1 to
    3 add 2 k2, 2 k3, k4; each stage but the last sets w = w0 + h alpha for the next force pass.
    ``h`` < 0 ends the step: w = w0 + (-h) sum (h = -dt / 6)."""
    if spin is None:
        return
    w, w0, sw, al = spin.w, spin.w0, spin.sw, spin.alpha
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


@njit(hot=True)
def spin_tick(spin, b):
    """One step of world b is done: advance its clock (the history's stamps)."""
    if spin is None:
        return
    spin.clock[b] += 1
