"""What every stepping path shares: the status codes, the final finiteness check, the scratch
buffers, and the control inputs (external forces and motors) turned into each step's forces."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..._jit import njit
from ..broadphase.partners import PARTNER_ROWS

__all__ = [
    "STATUS_OK",
    "STATUS_NONFINITE",
    "STATUS_CG",
    "Scratch",
    "new_scratch",
    "final_status",
    "motor_force",
    "step_forces",
]

STATUS_OK, STATUS_NONFINITE, STATUS_CG = 0, 1, 2


class Scratch(NamedTuple):
    """Per-world scratch of the scalar paths: the partners of one ball, and a step's external
    forces (given forces plus motors)."""

    partners: np.ndarray  # (B, max(n, 2 PARTNER_ROWS)) int64: a ball's partner ranges or partners
    ext: np.ndarray  # (B, n, d)


def new_scratch(B: int, n: int, d: int) -> Scratch:
    return Scratch(partners=np.zeros((B, max(n, 2 * PARTNER_ROWS)), dtype=np.int64), ext=np.zeros((B, n, d)))


@njit
def final_status(b, ok, x, v, D):
    """STATUS_NONFINITE if the step said so or any position or velocity of world b is not finite."""
    if not ok:
        return STATUS_NONFINITE
    for i in range(x.shape[1]):
        for k in range(D):
            if not (math.isfinite(x[b, i, k]) and math.isfinite(v[b, i, k])):
                return STATUS_NONFINITE
    return STATUS_OK


@njit(hot=True)
def motor_force(max_force, inv_max_speed, throttle, speed):
    """A DC motor's linear force-speed law along one axis: ``max_force (throttle - v / max_speed)``."""
    return max_force * (throttle - speed * inv_max_speed)


@njit(hot=True)
def step_forces(b, v, control, motors, E, D):
    """World b's external forces for the next step into ``E[b]``: the given forces (when
    ``control.flags[0]``) plus each motor's force on its ball (at the ball's velocity now)."""
    given = control.flags[0] != 0
    for i in range(E.shape[1]):
        for k in range(D):
            E[b, i, k] = control.forces[b, i, k] if given else 0.0
    for q in range(motors.ball.shape[0]):
        i = motors.ball[q]
        for k in range(motors.axes[q]):
            f = motor_force(motors.max_force[q], motors.inv_max_speed[q], control.throttle[b, q, k], v[b, i, k])
            E[b, i, k] = control.forces[b, i, k] + f if given else f
