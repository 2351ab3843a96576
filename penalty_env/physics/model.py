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

from typing import Any, NamedTuple

import numpy as np

__all__ = ["Model", "SlimModel", "State"]


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
    # every terrain shape but the static spheres and bowls (:class:`.geometry.Geometry`), or None:
    # then the step compiles to the spheres' and bowls' code alone
    geometry: Any = None

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


class SlimModel(NamedTuple):
    """The fields of a :class:`Model` that the neighbour list's parallel passes read (no friction,
    gravity or general shapes: those reach them as separate arguments or run in serial passes).
    Numba passes a named tuple by value, every field a live value in the loops that use it: the
    full Model held enough more of them in the list's per-ball loops to spill registers (callgrind:
    the same instructions less 7%, but 4% more loads and 17% more stores per step, and 4 to 6% slower)."""

    radii: np.ndarray
    inv_mass: np.ndarray
    shape_kind: np.ndarray
    shape_center: np.ndarray
    shape_radius: np.ndarray
    ks: float
    kd: float
    ks_terrain: float
    kd_terrain: float
    no_tension: bool
    cell_size: float
    # r_i + r_j of every pair when all the radii are equal (the list pass then reads no partner's
    # radius: one stream of random loads fewer per pair), else 0.0
    diameter: float

    @classmethod
    def of(cls, model: Model, **changes: Any) -> SlimModel:
        """The slim view of ``model`` (arrays shared), with ``changes`` applied; ``diameter`` is
        computed from the radii unless given."""
        fields = {name: getattr(model, name) for name in cls._fields if name != "diameter"}
        fields.update(changes)
        if "diameter" not in fields:
            radii = np.asarray(fields["radii"])
            same = radii.size > 0 and bool(np.all(radii == radii.flat[0]))
            fields["diameter"] = float(radii.flat[0] + radii.flat[0]) if same else 0.0
        return cls(**fields)


class State(NamedTuple):
    """Positions and velocities, ``(B, n, d)`` float64 each."""

    positions: np.ndarray
    velocities: np.ndarray
