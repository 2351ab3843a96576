"""Terrain shapes: signed distance functions (phi < 0 inside the solid, > 0 outside).

``grad_phi`` is the solid's outward unit normal. Every shape exists in 2D and 3D (a 2D shape is the
3D one's slice through its axis: a cylinder's is a rectangle, a cone's a trapezoid, a torus's two
discs), has a rigid *pose* (a translation ``center`` and a ``rotation`` matrix; :meth:`Shape.transformed`
composes another onto it) and may be *kinematic*: given a ``velocity`` and / or an
``angular_velocity`` (about its centre; one number in 2D), it moves on by them in every step, and
``World.set_shape_pose`` changes them between steps.

=================  ==================================================  ==========================
shape              solid                                               phi
=================  ==================================================  ==========================
``Sphere``         a ball (a hill, an obstacle)                        exact
``Bowl``           outside a sphere (the course's spherical terrain)   exact
``Plane``          the side opposite ``normal``                        exact
``Box``            a box, optionally rotated                           exact
``Capsule``        a segment swept by a ball                           exact
``Cylinder``       a finite cylinder with flat caps                    exact
``Cone``           a truncated cone (frustum) with flat caps           exact
``Torus``          a torus                                             exact
``HeightField``    below a terrain z = h(x, y) (y = h(x) in 2D)        approximate (a bound)
``Union`` ...      CSG by min / max: ``Union``, ``Intersection``,       exact only in places
                   ``Difference``, ``Inside`` (the complement)         (docs/physics.md section 1)
``SDF``            a user's Numba function of one point                 the user's
=================  ==================================================  ==========================

This module holds the base class, the spheres and bowls, and planes; :mod:`.solids` boxes,
capsules and the solids of revolution, :mod:`.heightfield`, :mod:`.csg` and :mod:`.user` the rest.
Every shape becomes a row of the kernels' :class:`~.table.ShapeTable` (:func:`.pack.pack_table`).
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from ... import _validate as V
from .evaluate import evaluate
from .pack import pack_table
from .sdf import PLANE, ROUND
from .table import OP_NEGATE

__all__ = [
    "Shape",
    "Sphere",
    "Bowl",
    "Plane",
    "rotation_matrix",
]


# ---------------------------------------------------------------------------------------------
# Argument helpers
# ---------------------------------------------------------------------------------------------


def _point(name: str, value: Any, d: int | None = None) -> tuple[float, ...]:
    arr = V.real_array(name, value, ndim=(1,), finite=False)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {tuple(float(c) for c in arr)}")
    if arr.shape[0] not in (2, 3):
        raise ValueError(f"{name} must have 2 or 3 coordinates, got {arr.shape[0]}")
    if d is not None and arr.shape[0] != d:
        raise ValueError(f"{name} must have {d} coordinates (the shape is {d}D), got {arr.shape[0]}")
    return tuple(float(c) for c in arr)


def rotation_matrix(axis_or_angle: Any, angle: float | None = None) -> np.ndarray:
    """A rotation matrix: ``rotation_matrix(angle)`` in 2D (radians, counter-clockwise),
    ``rotation_matrix(axis, angle)`` in 3D (right-handed about ``axis``)."""
    if angle is None:
        th = V.real("angle", axis_or_angle)
        c, s = math.cos(th), math.sin(th)
        return np.array([[c, -s], [s, c]])
    k = np.array(_point("axis", axis_or_angle, 3))
    n = float(np.linalg.norm(k))
    if not n > 0.0:
        raise ValueError(f"axis must be a non-zero vector, got {tuple(k)}")
    k /= n
    th = V.real("angle", angle)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(th) * K + (1.0 - math.cos(th)) * K @ K


def _rotation(name: str, value: Any, d: int) -> np.ndarray:
    if value is None:
        return np.eye(d)
    R = V.real_array(name, value, shape=(d, d))
    if np.abs(R.T @ R - np.eye(d)).max() > 1e-9 or np.linalg.det(R) < 0.0:
        raise ValueError(
            f"{name} must be a rotation matrix ({d}x{d}, orthonormal, determinant +1), got {V.describe(R.tolist())}"
        )
    return R


def _axis_rotation(axis: tuple[float, ...]) -> np.ndarray:
    """A rotation taking the last axis to the unit vector ``axis`` (the identity for the last axis)."""
    d = len(axis)
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    e = np.zeros(d)
    e[-1] = 1.0
    if d == 2:
        # angle from e_y to a, counter-clockwise
        th = math.atan2(-a[0], a[1])
        return rotation_matrix(th)
    c = float(a @ e)
    if c > 1.0 - 1e-15:
        return np.eye(3)
    if c < -1.0 + 1e-15:
        return np.diag([1.0, -1.0, -1.0])  # half turn about x
    k = np.cross(e, a)
    return rotation_matrix(k, math.atan2(float(np.linalg.norm(k)), c))


def _axis_and_rotation(axis: Any, rotation: Any, d: int) -> np.ndarray:
    if axis is not None and rotation is not None:
        raise ValueError("give axis or rotation, not both")
    if axis is None:
        return _rotation("rotation", rotation, d)
    a = _point("axis", axis, d)
    if not np.linalg.norm(a) > 0.0:
        raise ValueError(f"axis must be a non-zero vector, got {a}")
    return _axis_rotation(a)


def _as_points(points: Any, d: int) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[-1:] != (d,):
        raise ValueError(f"points must have last dimension {d} (the shape's dimension), got shape {pts.shape}")
    return pts


def _n_samples(n: Any) -> int:
    return V.integer("n_samples", n, 1)


# ---------------------------------------------------------------------------------------------
# The base
# ---------------------------------------------------------------------------------------------


class Shape:
    """A solid bounded by the zero level set of phi, with a pose and an optional motion.

    Subclasses set ``center`` (d floats), ``rotation`` ((d, d)), ``sign`` (+1 for the shape, -1 for
    its complement) and implement :meth:`_local_samples`, and the kernel packing (``kind``,
    :meth:`_par`, :meth:`_bound`, :meth:`_inner`: :func:`.pack.pack_table`).
    """

    kind = -1  # the shape table's kind code (:data:`.sdf.KIND_NAMES`)
    center: tuple[float, ...]
    rotation: np.ndarray
    sign: float = 1.0
    velocity: tuple[float, ...] | None = None
    angular_velocity: tuple[float, ...] | None = None

    def _init_pose(self, center: Any, rotation: np.ndarray | None, velocity: Any, angular_velocity: Any) -> None:
        c = _point("center", center)
        d = len(c)
        self.center = c
        rot = np.eye(d) if rotation is None else np.array(rotation, dtype=np.float64)
        rot.flags.writeable = False
        self.rotation = rot
        self.sign = 1.0
        self._set_motion(velocity, angular_velocity)

    def _set_motion(self, velocity: Any, angular_velocity: Any) -> None:
        d = self.dim
        self.velocity = None if velocity is None else _point("velocity", velocity, d)
        if angular_velocity is None:
            self.angular_velocity = None
        elif d == 2:
            w = V.real_array("angular_velocity", angular_velocity, ndim=(0, 1)).reshape(-1)
            if w.shape != (1,):
                raise ValueError(
                    f"angular_velocity must be one number in 2D (about the out-of-plane axis), got {w.tolist()}"
                )
            self.angular_velocity = (float(w[0]),)
        else:
            self.angular_velocity = _point("angular_velocity", angular_velocity, 3)

    @property
    def dim(self) -> int:
        return len(self.center)

    @property
    def kinematic(self) -> bool:
        """Whether the shape was given a motion (it may then move, also at zero velocity)."""
        return self.velocity is not None or self.angular_velocity is not None

    def transformed(self, translation: Any = None, rotation: Any = None) -> Shape:
        """The shape moved rigidly: rotated by ``rotation`` about the origin, then translated."""
        d = self.dim
        R = _rotation("rotation", rotation, d)
        t = np.zeros(d) if translation is None else np.array(_point("translation", translation, d))
        out = copy.copy(self)
        rot = R @ self.rotation
        rot.flags.writeable = False
        out.rotation = rot
        out.center = tuple(float(c) for c in R @ np.asarray(self.center) + t)
        out._packed = None
        return out

    # -- evaluation (through the kernels' own functions) ----------------------------------------
    _packed: Any = None

    def _single(self) -> Any:
        if self._packed is None:
            self._packed = pack_table([self], 1, self.dim).table
        return self._packed

    def _evaluate(self, points: Any) -> np.ndarray:
        pts = _as_points(points, self.dim)
        flat = np.ascontiguousarray(pts.reshape(-1, self.dim))
        out = np.zeros((flat.shape[0], 1, 4))
        evaluate(self._single(), 0, flat, out, (0.0,) * self.dim)
        return out[:, 0, :].reshape(pts.shape[:-1] + (4,))

    def phi(self, points: Any) -> np.ndarray:
        """Signed distance of each point (shape ``points.shape[:-1]``)."""
        return self._evaluate(points)[..., 0]

    def grad_phi(self, points: Any) -> np.ndarray:
        """Outward unit normal of the solid at each point (same shape as ``points``)."""
        return self._evaluate(points)[..., 1 : 1 + self.dim]

    # -- boundary samples --------------------------------------------------------------------------
    def surface_points(self, n_samples: int, window: tuple[Any, float] | None = None) -> np.ndarray:
        """About ``n_samples`` points on the boundary, spread evenly. An unbounded boundary (a
        plane, a height field beyond its grid) is sampled within ``window`` = (centre, radius)."""
        n = _n_samples(n_samples)
        local = self._local_samples(n, window)
        return local @ self.rotation.T + np.asarray(self.center)

    def _local_samples(self, n: int, window: tuple[Any, float] | None) -> np.ndarray:
        raise NotImplementedError

    def _window_local(self, window: tuple[Any, float] | None) -> tuple[np.ndarray, float]:
        """The sampling window in the shape's frame (default: a ball of radius 1 at its centre)."""
        d = self.dim
        if window is None:
            return np.zeros(d), 1.0
        c = np.asarray(window[0], dtype=np.float64) - np.asarray(self.center)
        return c @ self.rotation, float(window[1])

    # -- kernel packing --------------------------------------------------------------------------
    def _par(self) -> list[float]:
        return []

    def _bound(self) -> float:
        """Radius about the centre enclosing the solid shape (inf if unbounded)."""
        return math.inf

    def _inner(self) -> float:
        """Radius about the centre of a ball inside the shape (0 if none is known)."""
        return 0.0

    def _program(self, pos: np.ndarray, rot: np.ndarray, leaves: list, ops: list) -> None:
        """Append this shape, placed at (pos, rot) in a CSG shape's frame, to its postfix program:
        the leaf (kind, pos, rot, par), then OP_NEGATE for a complement."""
        ops.append(len(leaves))
        leaves.append((self.kind, np.array(pos), np.array(rot), self._par()))
        if self.sign < 0.0:
            ops.append(OP_NEGATE)

    def _describe_pose(self) -> str:
        out = f"center={self.center}"
        if not np.array_equal(self.rotation, np.eye(self.dim)):
            out += f", rotation={np.round(self.rotation, 6).tolist()}"
        if self.velocity is not None:
            out += f", velocity={self.velocity}"
        if self.angular_velocity is not None:
            out += f", angular_velocity={self.angular_velocity}"
        return out

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._describe_pose()})"


def _sphere_dirs(n: int, d: int) -> np.ndarray:
    """n unit vectors spread evenly: a circle in 2D, a Fibonacci sphere in 3D."""
    if d == 2:
        t = 2.0 * np.pi * (np.arange(n) + 0.5) / n
        return np.stack([np.cos(t), np.sin(t)], axis=-1)
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    rho = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    t = np.pi * (1.0 + 5.0**0.5) * k
    return np.stack([rho * np.cos(t), rho * np.sin(t), z], axis=-1)


# ---------------------------------------------------------------------------------------------
# Spheres and bowls (the course's shapes)
# ---------------------------------------------------------------------------------------------


class _Round(Shape):
    """A sphere surface (centre, radius) with a side that is solid; subclasses fix the side."""

    kind = ROUND

    def __init__(self, center: Any, radius: Any, *, velocity: Any = None, angular_velocity: Any = None) -> None:
        self._init_pose(center, None, velocity, angular_velocity)
        self.radius = V.positive("radius", radius)
        self.sign = type(self).sign

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, _Round)
            and type(other) is type(self)
            and self.center == other.center
            and self.radius == other.radius
            and self.velocity == other.velocity
            and self.angular_velocity == other.angular_velocity
        )

    def __hash__(self) -> int:
        return hash((type(self).__name__, self.center, self.radius))

    def phi(self, points: Any) -> np.ndarray:
        pts = _as_points(points, self.dim)
        dist = np.linalg.norm(pts - np.asarray(self.center), axis=-1)
        return self.sign * (dist - self.radius)

    def grad_phi(self, points: Any) -> np.ndarray:
        pts = _as_points(points, self.dim)
        rel = pts - np.asarray(self.center)
        dist = np.linalg.norm(rel, axis=-1, keepdims=True)
        up = np.zeros(self.dim)
        up[-1] = 1.0
        safe = np.where(dist > 0.0, dist, 1.0)
        return np.where(dist > 0.0, self.sign * rel / safe, up)

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        return self.radius * _sphere_dirs(n, self.dim)

    def _par(self) -> list[float]:
        return [self.radius]

    def _bound(self) -> float:
        return self.radius

    def _inner(self) -> float:
        return self.radius

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._describe_pose()}, radius={self.radius:g})"


class Sphere(_Round):
    """A solid ball of terrain (a hill, an obstacle): phi = |x - c| - R."""

    sign = 1.0


class Bowl(_Round):
    """The inside of a sphere (the course's "spherical terrain"): phi = R - |x - c|. The same as
    ``Inside(Sphere(c, R))``."""

    sign = -1.0


# ---------------------------------------------------------------------------------------------
# Primitives
# ---------------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------------
# Planes
# ---------------------------------------------------------------------------------------------


def _disc_samples(n: int, d: int, center: np.ndarray, radius: float) -> np.ndarray:
    """Points spread over the disc (3D) or segment (2D) of ``radius`` about ``center`` in the local
    z = center[-1] plane (sunflower spiral)."""
    if d == 2:
        t = (np.arange(n) + 0.5) / n * 2.0 - 1.0
        return np.stack([center[0] + radius * t, np.full(n, center[-1])], axis=-1)
    k = np.arange(n) + 0.5
    rho = radius * np.sqrt(k / n)
    t = np.pi * (1.0 + 5.0**0.5) * k
    return np.stack([center[0] + rho * np.cos(t), center[1] + rho * np.sin(t), np.full(n, center[-1])], axis=-1)


class Plane(Shape):
    """The half-space on the side opposite ``normal`` of the plane through ``point``: phi = (x - p) . n."""

    kind = PLANE

    def __init__(self, point: Any, normal: Any, *, velocity: Any = None, angular_velocity: Any = None) -> None:
        p = _point("point", point)
        n = np.array(_point("normal", normal, len(p)))
        if not np.linalg.norm(n) > 0.0:
            raise ValueError(f"normal must be a non-zero vector, got {tuple(n)}")
        self._init_pose(p, _axis_rotation(tuple(n)), velocity, angular_velocity)

    @property
    def point(self) -> tuple[float, ...]:
        return self.center

    @property
    def normal(self) -> np.ndarray:
        return self.rotation[:, -1].copy()

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        c, radius = self._window_local(window)
        c = c.copy()
        c[-1] = 0.0
        return _disc_samples(n, self.dim, c, radius)

    def __repr__(self) -> str:
        return f"Plane(point={self.point}, normal={tuple(np.round(self.normal, 12))})"


def _project(shape: Shape, points: np.ndarray, keep_tol: float, iterations: int = 12) -> np.ndarray:
    """Points moved onto the zero level set by x <- x - phi grad phi (Newton's step on a distance),
    keeping those that end within ``keep_tol`` of it."""
    x = np.array(points, dtype=np.float64)
    for _ in range(iterations):
        ev = shape._evaluate(x)
        x = x - ev[:, :1] * ev[:, 1 : 1 + shape.dim]
    ev = shape._evaluate(x)
    return x[np.abs(ev[:, 0]) <= keep_tol]
