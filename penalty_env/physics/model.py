"""The scene's static description (the *model*) and its dynamic *state*, as Warp's ``sim`` keeps them.

:class:`Model` holds everything that does not change while stepping: the balls' radii and inverse
masses, the terrain shapes, every contact parameter (the spring ``ks`` and dashpot ``kd`` of ball
pairs and of ball-terrain contacts, the damping mode, the regularised Coulomb friction ``mu`` and
``kf``), gravity and the grid's cell size. It is the one place these live: ``World`` builds it once,
the integrators, the environments' fused step and the diagnostics all read it.

:class:`State` holds the positions and velocities, ``(B, n, d)`` float64: B independent worlds of
n balls in d = 2 or 3 dimensions.

Units are the caller's, used consistently (SI in the examples): ``ks`` force per length, ``kd``
force per speed, ``kf`` force per sliding speed. Sign conventions: phi < 0 inside a solid,
grad phi is the solid's outward normal, an overlap is a positive length.

The kernels take ``model`` together with ``model.friction`` and ``model.gravity`` as separate
arguments: Numba compiles a branch on an *argument* that is None away, so a scene without friction
runs friction-free machine code, and gravity's tuple length makes a 2D scene run 2D code.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Model", "State"]


class Model(NamedTuple):
    """What a scene is made of (see the module docstring). Arrays are read by the kernels only."""

    radii: np.ndarray  # (n,) ball radii
    inv_mass: np.ndarray  # (n,) 1 / mass
    shape_kind: np.ndarray  # (S,) int64: shapes.SPHERE or shapes.BOWL
    shape_center: np.ndarray  # (S, d)
    shape_radius: np.ndarray  # (S,)
    ks: float  # ball-ball spring, force / length
    kd: float  # ball-ball dashpot, force / speed
    ks_terrain: float  # ball-terrain spring
    kd_terrain: float  # ball-terrain dashpot
    no_tension: bool  # clip the normal force at zero (no dashpot pull at separation)
    cell_size: float  # grid cell edge >= the largest diameter
    mu: float = 0.0  # Coulomb friction coefficient (0: friction off)
    kf: float = 0.0  # regularised friction's viscous slope, force / sliding speed
    # (d,) acceleration (an array: Numba's parallel kernels take no tuple inside a tuple argument)
    gravity_vector: np.ndarray = np.zeros(0)

    @property
    def friction(self) -> tuple[float, float] | None:
        """``(mu, kf)`` as the kernels take it, or None when friction is off."""
        return (self.mu, self.kf) if self.mu > 0.0 else None

    @property
    def gravity(self) -> tuple[float, ...]:
        """Gravity as the kernels take it: a tuple of length d (a compile-time constant)."""
        return tuple(float(c) for c in self.gravity_vector)

    @property
    def dim(self) -> int:
        return len(self.gravity_vector)


class State(NamedTuple):
    """Positions and velocities, ``(B, n, d)`` float64 each."""

    positions: np.ndarray
    velocities: np.ndarray
