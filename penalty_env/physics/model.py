"""The data protocol of the kernels, as Warp's ``sim`` keeps it: the scene's static description (the
*model*), its dynamic *state*, and the per-step *control*.

:class:`Model` holds everything that does not change while stepping: the balls' radii and inverse
masses, every contact parameter (the spring ``ks`` and dashpot ``kd`` of ball pairs and of
ball-terrain contacts, the damping mode, the regularised Coulomb friction ``mu`` and ``kf``), the
grid's cell size, the terrain as a shape table and the motors. ``World`` builds it once; every
kernel reads it.

:class:`State` holds the positions and velocities, ``(B, n, d)`` float64: B independent worlds of n
balls in d = 2 or 3 dimensions. :class:`Spin` holds what rotating balls add to it.

:class:`Control` holds the inputs of one ``World.step`` call, per world: an external force per ball
and each motor's throttle. A motor drives one ball along its first ``axes`` axes with the force of
a DC motor's linear force-speed law, ``max_force (throttle - v / max_speed)``, evaluated at the
start of every step (a controller running at the physics rate).

Units are the caller's, used consistently (SI in the examples): ``ks`` force per length, ``kd``
force per speed, ``kf`` force per sliding speed. Sign conventions: phi < 0 inside a solid, grad
phi is the solid's outward normal, an overlap is a positive length.

Flags and shapes are data (arrays and scalars of fixed types): a kernel compiles once per
dimension for every scene. The dimension comes to the kernels as gravity, a tuple of d floats,
so a 2D scene runs 2D machine code; rotation comes as a :class:`Spin` or None (a scene whose balls
do not spin compiles none of it).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .geometry.table import ShapeTable, pose_size

__all__ = [
    "Model",
    "State",
    "Control",
    "Motors",
    "Spin",
    "TANGENTIAL",
    "no_motors",
    "new_control",
    "new_spin",
    "inertia_factor",
]


class Motors(NamedTuple):
    """The motors of a scene: motor q drives ball ``ball[q]`` along its first ``axes[q]`` axes."""

    ball: np.ndarray  # (m,) int64
    max_force: np.ndarray  # (m,) stall force
    inv_max_speed: np.ndarray  # (m,) 1 / no-load speed
    axes: np.ndarray  # (m,) int64


def no_motors() -> Motors:
    return Motors(
        ball=np.zeros(0, dtype=np.int64),
        max_force=np.zeros(0),
        inv_max_speed=np.zeros(0),
        axes=np.zeros(0, dtype=np.int64),
    )


class Model(NamedTuple):
    """What a scene is made of (see the module docstring). Arrays are read by the kernels only."""

    radii: np.ndarray  # (n,) ball radii
    inv_mass: np.ndarray  # (n,) 1 / mass
    ks: float  # ball-ball spring, force / length
    kd: float  # ball-ball dashpot, force / speed
    ks_terrain: float  # ball-terrain spring
    kd_terrain: float  # ball-terrain dashpot
    no_tension: bool  # clip the normal force at zero (no dashpot pull at separation)
    mu: float  # Coulomb friction coefficient (0: friction off)
    kf: float  # regularised friction's viscous slope, force / sliding speed
    cell_size: float  # grid cell edge >= the largest diameter
    shapes: ShapeTable  # the terrain
    motors: Motors

    @property
    def dim(self) -> int:
        """d, from the width of a pose row (2 d + d^2 + 3)."""
        return 3 if self.shapes.pose.shape[2] == pose_size(3) else 2


class State(NamedTuple):
    """Positions and velocities, ``(B, n, d)`` float64 each."""

    positions: np.ndarray
    velocities: np.ndarray


class Control(NamedTuple):
    """One step call's inputs per world (see the module docstring)."""

    forces: np.ndarray  # (B, n, d) external force per ball, held over the call
    throttle: np.ndarray  # (B, m, d) each motor's throttle per axis (the first ``axes`` read)
    flags: np.ndarray  # (2,) int64: [external forces given, motors on]


def new_control(B: int, n: int, d: int, motors: int) -> Control:
    return Control(
        forces=np.zeros((B, n, d)),
        throttle=np.zeros((B, motors, d)),
        flags=np.zeros(2, dtype=np.int64),
    )


class Spin(NamedTuple):
    """What rotating balls add to the state, and the parameters of the rotating contact law
    (:mod:`.contact.spin`)."""

    kt: float  # history spring, force / length (0: regularised Coulomb)
    kd_t: float  # history dashpot, force / sliding speed
    mu_r: float  # rolling resistance coefficient (0: off)
    kr: float  # rolling resistance's regularising slope, torque / angular speed
    dt: float  # the step, for the history's displacement
    w: np.ndarray  # (B, n, R) angular velocities, R = 3 (3D) or 1 (2D)
    alpha: np.ndarray  # (B, n, R) torque, then angular acceleration, of the last force pass
    inv_inertia: np.ndarray  # (n,)
    w0: np.ndarray  # (B, n, R) integrator scratch: the angular velocity at the step's start
    sw: np.ndarray  # (B, n, R) integrator scratch: RK4's weighted sum; velocity Verlet's cached alpha
    hist: np.ndarray  # (B, n, n + S, 3) the tangential springs' displacements ((1, 1, 1, 3) unused)
    stamp: np.ndarray  # (B, n, n + S) int64: the step count at which each slot is current
    clock: np.ndarray  # (B,) int64: steps taken per world


TANGENTIAL = ("coulomb", "history")


def inertia_factor(d: int) -> float:
    """I / (m r^2): 2/5 for a solid sphere (3D), 1/2 for a disk (2D)."""
    return 0.4 if d == 3 else 0.5


def new_spin(
    B: int,
    n: int,
    d: int,
    masses: np.ndarray,
    radii: np.ndarray,
    slots: int,
    *,
    rotation: bool = True,
    kt: float,
    kd_t: float,
    mu_r: float,
    kr: float,
    dt: float,
    pair_store: bool = True,
) -> Spin:
    """The buffers of a rotating scene: B worlds of n balls, ``slots`` terrain history slots per
    ball (history storage only when ``kt > 0`` and ``pair_store``: the scalar path's, one slot per
    ball pair; the neighbour-list path keeps its springs per list slot instead). ``rotation=False``:
    the tangential spring on balls that do not spin (1 / I = 0: the torque turns nothing)."""
    R = 3 if d == 3 else 1
    inertia = inertia_factor(d) * masses * radii * radii
    hist_shape = (B, n, n + slots) if kt > 0.0 and pair_store else (1, 1, 1)
    return Spin(
        kt=float(kt),
        kd_t=float(kd_t),
        mu_r=float(mu_r),
        kr=float(kr),
        dt=float(dt),
        w=np.zeros((B, n, R)),
        alpha=np.zeros((B, n, R)),
        inv_inertia=1.0 / inertia if rotation else np.zeros(n),
        w0=np.zeros((B, n, R)),
        sw=np.zeros((B, n, R)),
        hist=np.zeros(hist_shape + (3,)),
        stamp=np.full(hist_shape, -1, dtype=np.int64),
        clock=np.zeros(B, dtype=np.int64),
    )
