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

Static spheres and bowls run in the core's original, fastest code; every other shape is packed
into a :class:`~.geometry.Geometry` (the kernels' view) by :func:`pack_geometry`.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from .. import _validate as V
from . import geometry as G

__all__ = [
    "Shape",
    "Sphere",
    "Bowl",
    "Plane",
    "Box",
    "Capsule",
    "Cylinder",
    "Cone",
    "Torus",
    "HeightField",
    "Union",
    "Intersection",
    "Difference",
    "Inside",
    "SDF",
    "rotation_matrix",
    "SPHERE",
    "BOWL",
    "pack_terrain",
    "pack_geometry",
]

SPHERE = 0  # solid ball: phi = |x - c| - R (the static spheres' kernel code)
BOWL = 1  # the inside of a sphere is free space, the solid is outside it: phi = R - |x - c|


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
    its complement) and implement :meth:`_local_samples`, and the kernel packing (``group``,
    :meth:`_par`, :meth:`_bound`, :meth:`_inner`).
    """

    group = ""  # the Geometry group: a primitive kind, "heights", "csg" or "user"
    kind = -1  # SPHERE / BOWL for the static spheres' kernel code
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
            self._packed = pack_geometry([self], 1, self.dim)[0]
        return self._packed

    def _evaluate(self, points: Any) -> np.ndarray:
        pts = _as_points(points, self.dim)
        flat = np.ascontiguousarray(pts.reshape(-1, self.dim))
        out = np.zeros((flat.shape[0], 1, 4))
        G.evaluate(self._single(), 0, flat, out)
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
        return [0.0] * G.N_PAR

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
        leaves.append((G.KIND_CODES[self.group], np.array(pos), np.array(rot), self._par()))
        if self.sign < 0.0:
            ops.append(G.OP_NEGATE)

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

    group = "rounds"

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
        return [self.radius, 0.0, 0.0, 0.0]

    def _bound(self) -> float:
        return self.radius

    def _inner(self) -> float:
        return self.radius

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._describe_pose()}, radius={self.radius:g})"


class Sphere(_Round):
    """A solid ball of terrain (a hill, an obstacle): phi = |x - c| - R."""

    kind = SPHERE
    sign = 1.0


class Bowl(_Round):
    """The inside of a sphere (the course's "spherical terrain"): phi = R - |x - c|. The same as
    ``Inside(Sphere(c, R))``."""

    kind = BOWL
    sign = -1.0


# ---------------------------------------------------------------------------------------------
# Primitives
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

    group = "planes"

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


def _face_samples(n: int, h: np.ndarray) -> np.ndarray:
    """Points spread over the faces of the box of half extents h, by area (edges of a rectangle in 2D)."""
    d = len(h)
    out = []
    if d == 2:
        per = 4.0 * (h[0] + h[1])
        for axis in range(2):
            other = 1 - axis
            m = max(1, int(round(n * 2.0 * h[other] / per)))
            t = ((np.arange(m) + 0.5) / m * 2.0 - 1.0) * h[other]
            for s in (-1.0, 1.0):
                pts = np.zeros((m, 2))
                pts[:, axis] = s * h[axis]
                pts[:, other] = t
                out.append(pts)
        return np.concatenate(out)
    area = [4.0 * h[1] * h[2], 4.0 * h[0] * h[2], 4.0 * h[0] * h[1]]
    total = 2.0 * sum(area)
    for axis in range(3):
        u, w = [k for k in range(3) if k != axis]
        m = max(1, int(round(math.sqrt(n * area[axis] / total * h[u] / max(h[w], 1e-300)))))
        k = max(1, int(round(n * area[axis] / total / m)))
        gu = ((np.arange(m) + 0.5) / m * 2.0 - 1.0) * h[u]
        gw = ((np.arange(k) + 0.5) / k * 2.0 - 1.0) * h[w]
        U, W = np.meshgrid(gu, gw, indexing="ij")
        for s in (-1.0, 1.0):
            pts = np.zeros((U.size, 3))
            pts[:, axis] = s * h[axis]
            pts[:, u] = U.ravel()
            pts[:, w] = W.ravel()
            out.append(pts)
    return np.concatenate(out)


class Box(Shape):
    """A box of ``half_extents`` about ``center``, rotated by ``rotation`` (its local axes are the
    columns). Exact: phi = |max(u, 0)| + min(max_k u_k, 0), u = |R^T (x - c)| - h."""

    group = "boxes"

    def __init__(
        self,
        center: Any,
        half_extents: Any,
        rotation: Any = None,
        *,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        c = _point("center", center)
        h = V.real_array("half_extents", half_extents, shape=(len(c),))
        if not np.all(h > 0.0):
            raise ValueError(f"half_extents must all be > 0, got {h.tolist()}")
        self._init_pose(c, _rotation("rotation", rotation, len(c)), velocity, angular_velocity)
        self.half_extents = tuple(float(x) for x in h)

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        return _face_samples(n, np.asarray(self.half_extents))

    def _par(self) -> list[float]:
        return list(self.half_extents) + [0.0] * (G.N_PAR - self.dim)

    def _bound(self) -> float:
        return float(np.linalg.norm(self.half_extents))

    def _inner(self) -> float:
        return float(min(self.half_extents))

    def __repr__(self) -> str:
        return f"Box({self._describe_pose()}, half_extents={self.half_extents})"


def _revolve(profile_r: np.ndarray, profile_z: np.ndarray, weights: np.ndarray, n: int, d: int) -> np.ndarray:
    """Points of a surface of revolution from points (r, z) of its meridian, each weighted by the
    area it stands for (3D: around the axis; 2D: both sides of it)."""
    if d == 2:
        side = np.where(np.arange(len(profile_r)) % 2 == 0, 1.0, -1.0)
        return np.stack([side * profile_r, profile_z], axis=-1)
    p = weights / weights.sum()
    counts = np.maximum(1, np.round(p * n).astype(int))
    out = []
    for r, z, m in zip(profile_r, profile_z, counts):
        t = 2.0 * np.pi * (np.arange(m) + 0.5) / m
        out.append(np.stack([r * np.cos(t), r * np.sin(t), np.full(m, z)], axis=-1))
    return np.concatenate(out)


def _meridian_segments(n: int, d: int, segments: list[tuple[float, float, float, float]]) -> np.ndarray:
    """Sample a surface of revolution whose meridian is the polyline of ``segments`` (r0, z0, r1, z1)."""
    lengths = np.array([math.hypot(r1 - r0, z1 - z0) for r0, z0, r1, z1 in segments])
    if d == 2:
        total = 2.0 * lengths.sum()
        rs, zs = [], []
        for (r0, z0, r1, z1), L in zip(segments, lengths):
            m = max(1, int(round(n * 2.0 * L / total)))
            t = (np.arange(m) + 0.5) / m
            rs.append(r0 + t * (r1 - r0))
            zs.append(z0 + t * (z1 - z0))
        r = np.concatenate(rs)
        z = np.concatenate(zs)
        return np.concatenate([np.stack([r, z], -1), np.stack([-r, z], -1)])
    # 3D: rings along each segment, ring count by area, points per ring by circumference
    areas = [math.pi * (r0 + r1) * L for (r0, z0, r1, z1), L in zip(segments, lengths)]
    total = sum(areas)
    rings_r, rings_z, weights = [], [], []
    for (r0, z0, r1, z1), L, A in zip(segments, lengths, areas):
        share = n * A / total
        m = max(1, int(round(math.sqrt(share * L / max(math.pi * (r0 + r1), 1e-300)))))
        t = (np.arange(m) + 0.5) / m
        rr = r0 + t * (r1 - r0)
        rings_r.append(rr)
        rings_z.append(z0 + t * (z1 - z0))
        weights.append(np.maximum(rr, 1e-300) * L / m)
    return _revolve(np.concatenate(rings_r), np.concatenate(rings_z), np.concatenate(weights), n, 3)


class Capsule(Shape):
    """The segment a-b swept by a ball of ``radius`` (a stadium in 2D): phi = dist(x, ab) - r."""

    group = "capsules"

    def __init__(self, a: Any, b: Any, radius: Any, *, velocity: Any = None, angular_velocity: Any = None) -> None:
        pa = np.array(_point("a", a))
        pb = np.array(_point("b", b, len(pa)))
        self.radius = V.positive("radius", radius)
        axis = pb - pa
        length = float(np.linalg.norm(axis))
        rot = _axis_rotation(tuple(axis)) if length > 0.0 else np.eye(len(pa))
        self._init_pose(0.5 * (pa + pb), rot, velocity, angular_velocity)
        self.half_length = 0.5 * length

    @property
    def a(self) -> tuple[float, ...]:
        return tuple(np.asarray(self.center) - self.half_length * self.rotation[:, -1])

    @property
    def b(self) -> tuple[float, ...]:
        return tuple(np.asarray(self.center) + self.half_length * self.rotation[:, -1])

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        h, r, d = self.half_length, self.radius, self.dim
        caps = 2.0 * np.pi * r if d == 2 else 4.0 * np.pi * r * r
        side = 2.0 * 2.0 * h if d == 2 else 2.0 * np.pi * r * 2.0 * h
        m_caps = max(2, int(round(n * caps / (caps + side))))
        dirs = r * _sphere_dirs(m_caps, d)
        dirs[:, -1] += np.where(dirs[:, -1] >= 0.0, h, -h)
        if h == 0.0:
            return dirs
        body = _meridian_segments(max(1, n - m_caps), d, [(r, -h, r, h)])
        return np.concatenate([dirs, body])

    def _par(self) -> list[float]:
        return [self.half_length, self.radius, 0.0, 0.0]

    def _bound(self) -> float:
        return self.half_length + self.radius

    def _inner(self) -> float:
        return self.radius

    def __repr__(self) -> str:
        return f"Capsule(a={self.a}, b={self.b}, radius={self.radius:g})"


class Cylinder(Shape):
    """A finite cylinder of ``radius`` and ``half_height`` along ``axis`` (default the last axis),
    with flat caps; in 2D the rectangle of half widths (radius, half_height). Exact."""

    group = "cylinders"

    def __init__(
        self,
        center: Any,
        radius: Any,
        half_height: Any,
        *,
        axis: Any = None,
        rotation: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        c = _point("center", center)
        self.radius = V.positive("radius", radius)
        self.half_height = V.positive("half_height", half_height)
        self._init_pose(c, _axis_and_rotation(axis, rotation, len(c)), velocity, angular_velocity)

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        r, h = self.radius, self.half_height
        return _meridian_segments(n, self.dim, [(0.0, -h, r, -h), (r, -h, r, h), (r, h, 0.0, h)])

    def _par(self) -> list[float]:
        return [self.radius, self.half_height, 0.0, 0.0]

    def _bound(self) -> float:
        return math.hypot(self.radius, self.half_height)

    def _inner(self) -> float:
        return min(self.radius, self.half_height)

    def __repr__(self) -> str:
        return f"Cylinder({self._describe_pose()}, radius={self.radius:g}, half_height={self.half_height:g})"


class Cone(Shape):
    """A truncated cone (frustum) along ``axis`` (default the last axis): radius ``bottom_radius``
    at -half_height, ``top_radius`` at +half_height (0 for a pointed cone), flat caps; in 2D the
    trapezoid of that slice. A hopper's funnel is ``Difference`` of two. Exact."""

    group = "cones"

    def __init__(
        self,
        center: Any,
        bottom_radius: Any,
        top_radius: Any,
        half_height: Any,
        *,
        axis: Any = None,
        rotation: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        c = _point("center", center)
        self.bottom_radius = V.non_negative("bottom_radius", bottom_radius)
        self.top_radius = V.non_negative("top_radius", top_radius)
        if not max(self.bottom_radius, self.top_radius) > 0.0:
            raise ValueError(
                f"bottom_radius and top_radius must not both be 0, got {bottom_radius!r} and {top_radius!r}"
            )
        self.half_height = V.positive("half_height", half_height)
        self._init_pose(c, _axis_and_rotation(axis, rotation, len(c)), velocity, angular_velocity)

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        r0, r1, h = self.bottom_radius, self.top_radius, self.half_height
        segs = [(0.0, -h, r0, -h), (r0, -h, r1, h), (r1, h, 0.0, h)]
        return _meridian_segments(n, self.dim, [s for s in segs if abs(s[0] - s[2]) + abs(s[1] - s[3]) > 0.0])

    def _par(self) -> list[float]:
        return [self.bottom_radius, self.top_radius, self.half_height, 0.0]

    def _bound(self) -> float:
        return math.hypot(max(self.bottom_radius, self.top_radius), self.half_height)

    def __repr__(self) -> str:
        return (
            f"Cone({self._describe_pose()}, bottom_radius={self.bottom_radius:g}, top_radius={self.top_radius:g}, "
            f"half_height={self.half_height:g})"
        )


class Torus(Shape):
    """A torus about ``axis`` (default the last axis): tube radius ``minor_radius`` around a circle
    of ``major_radius``; in 2D its slice (two discs). phi = |(rho - R, z)| - r, exact."""

    group = "tori"

    def __init__(
        self,
        center: Any,
        major_radius: Any,
        minor_radius: Any,
        *,
        axis: Any = None,
        rotation: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        c = _point("center", center)
        self.major_radius = V.positive("major_radius", major_radius)
        self.minor_radius = V.positive("minor_radius", minor_radius)
        self._init_pose(c, _axis_and_rotation(axis, rotation, len(c)), velocity, angular_velocity)

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        R, r, d = self.major_radius, self.minor_radius, self.dim
        if d == 2:
            dirs = r * _sphere_dirs(max(1, n // 2), 2)
            return np.concatenate([dirs + np.array([R, 0.0]), dirs - np.array([R, 0.0])])
        m = max(3, int(round(math.sqrt(n * r / R)))) if R > 0 else 8
        v = 2.0 * np.pi * (np.arange(m) + 0.5) / m
        return _revolve(R + r * np.cos(v), r * np.sin(v), R + r * np.cos(v), n, 3)

    def _par(self) -> list[float]:
        return [self.major_radius, self.minor_radius, 0.0, 0.0]

    def _bound(self) -> float:
        return self.major_radius + self.minor_radius

    def __repr__(self) -> str:
        return f"Torus({self._describe_pose()}, major_radius={self.major_radius:g}, minor_radius={self.minor_radius:g})"


class HeightField(Shape):
    """The solid below a terrain z = h(x, y) (3D) or y = h(x) (2D), interpolated bilinearly
    (linearly) between grid nodes and held at its edge values beyond the grid.

    Args:
        heights: ``(nx, ny)`` (3D) or ``(nx,)`` (2D) node heights, at least 2 nodes per axis:
            ``heights[i, j]`` is h at ``origin + (i, j) * cell_size``.
        cell_size: node spacing (one number, or one per horizontal axis), > 0.
        origin: the horizontal position of node 0 (default the origin).

    phi = (z - h) / sqrt(1 + |grad h|^2): the distance to the surface's tangent plane at the foot
    of the point, exact for a tilted plane; for a surface of curvature at most K it is within
    K delta^2 / 2 of the true distance, delta = z - h (docs/physics.md section 1). The heights may
    be changed per world between steps (``World.set_heights``).
    """

    group = "heights"

    def __init__(
        self,
        heights: Any,
        cell_size: Any,
        origin: Any = None,
        *,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        h = V.real_array("heights", heights, ndim=(1, 2))
        d = h.ndim + 1
        if any(m < 2 for m in h.shape):
            raise ValueError(f"heights must have at least 2 nodes along each axis, got shape {h.shape}")
        cs = V.real_array("cell_size", cell_size, ndim=(0, 1)).reshape(-1)
        if cs.size == 1:
            cs = np.repeat(cs, d - 1)
        if cs.shape != (d - 1,) or not np.all(cs > 0.0):
            raise ValueError(
                f"cell_size must be one number > 0 or {d - 1} of them, got {np.asarray(cell_size).tolist()}"
            )
        o = np.zeros(d - 1) if origin is None else V.real_array("origin", origin, ndim=(0, 1)).reshape(-1)
        if o.shape != (d - 1,):
            raise ValueError(f"origin must have {d - 1} coordinate(s) (the horizontal axes), got {o.tolist()}")
        self.heights = h.reshape(h.shape[0], -1)
        self.heights.flags.writeable = False
        self.cell_size = tuple(float(c) for c in cs)
        self.origin = tuple(float(c) for c in o)
        self._init_pose((0.0,) * d, None, velocity, angular_velocity)

    @property
    def grid_shape(self) -> tuple[int, int]:
        return (self.heights.shape[0], self.heights.shape[1])

    def _par6(self) -> list[float]:
        nx, ny = self.grid_shape
        cy = self.cell_size[1] if self.dim == 3 else 1.0
        oy = self.origin[1] if self.dim == 3 else 0.0
        return [float(nx), float(ny), self.cell_size[0], cy, self.origin[0], oy]

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        d = self.dim
        lo = np.asarray(self.origin)
        hi = lo + (np.array(self.grid_shape[: d - 1]) - 1) * np.asarray(self.cell_size)
        if window is not None:
            c, radius = self._window_local(window)
            lo = np.maximum(lo, c[: d - 1] - radius)
            hi = np.minimum(hi, c[: d - 1] + radius)
            if np.any(hi < lo):
                return np.zeros((0, d))
        if d == 2:
            xs = lo[0] + (hi[0] - lo[0]) * (np.arange(n) + 0.5) / n
            flat = xs[:, None]
        else:
            m = max(1, int(round(math.sqrt(n))))
            g0 = lo[0] + (hi[0] - lo[0]) * (np.arange(m) + 0.5) / m
            g1 = lo[1] + (hi[1] - lo[1]) * (np.arange(m) + 0.5) / m
            X, Y = np.meshgrid(g0, g1, indexing="ij")
            flat = np.stack([X.ravel(), Y.ravel()], -1)
        # the surface point above each: phi at z = 0 is -h n_z, so h = -phi / n_z (exact)
        pts = np.concatenate([flat, np.zeros((len(flat), 1))], axis=1)
        ev = self._evaluate_local(pts)
        pts[:, -1] = -ev[:, 0] / ev[:, d]
        return pts

    def _evaluate_local(self, pts: np.ndarray) -> np.ndarray:
        world = pts @ self.rotation.T + np.asarray(self.center)
        return self._evaluate(world)

    def __repr__(self) -> str:
        return f"HeightField(grid={self.grid_shape}, cell_size={self.cell_size}, origin={self.origin})"


# ---------------------------------------------------------------------------------------------
# CSG
# ---------------------------------------------------------------------------------------------


def _operands(name: str, shapes: Sequence[Any], at_least: int) -> tuple[Shape, ...]:
    ops = tuple(shapes)
    if len(ops) < at_least:
        raise ValueError(f"{name} needs at least {at_least} shapes, got {len(ops)}")
    for k, s in enumerate(ops):
        if not isinstance(s, Shape):
            raise V.ArgumentTypeError(f"{name}'s operand {k} must be a Shape, got {V.describe(s)}")
        if s.dim != ops[0].dim:
            raise ValueError(f"{name}'s operands must have one dimension, got {ops[0].dim}D and {s.dim}D")
        if s.kinematic:
            raise ValueError(
                f"{name}'s operand {k} ({type(s).__name__}) has a motion of its own: give the motion to the {name}"
            )
        if isinstance(s, HeightField):
            raise ValueError(f"{name}'s operand {k} is a HeightField, which cannot be part of a CSG shape")
        if isinstance(s, SDF) or (isinstance(s, _CSG) and _holds_user(s)):
            raise ValueError(
                f"{name}'s operand {k} is (or holds) a user SDF, which cannot be part of a CSG shape: "
                f"compose it inside your own phi (min, max, -) instead"
            )
    return ops


def _holds_user(shape: Shape) -> bool:
    return any(isinstance(s, SDF) or (isinstance(s, _CSG) and _holds_user(s)) for s in getattr(shape, "operands", ()))


class _CSG(Shape):
    """A CSG shape: its operands are placed in its frame (their own poses), and it has a pose."""

    group = "csg"
    op = ""

    def __init__(self, operands: tuple[Shape, ...], velocity: Any, angular_velocity: Any) -> None:
        self.operands = operands
        self._init_pose((0.0,) * operands[0].dim, None, velocity, angular_velocity)

    def _program(self, pos: np.ndarray, rot: np.ndarray, leaves: list, ops: list) -> None:
        """Each operand's program (placed by its pose in this frame, this frame at (pos, rot)),
        joined left to right by this shape's operation; OP_NEGATE for a complement."""
        code = {"union": G.OP_UNION, "intersection": G.OP_INTERSECTION, "difference": G.OP_DIFFERENCE}[self.op]
        for k, s in enumerate(self.operands):
            s._program(rot @ np.asarray(s.center) + pos, rot @ s.rotation, leaves, ops)
            if k > 0:
                ops.append(code)
        if self.sign < 0.0:
            ops.append(G.OP_NEGATE)

    def program(self) -> tuple[list, list]:
        """(leaves, ops): this shape's postfix program in its own frame (:func:`.geometry.csg_sdf`)."""
        leaves: list = []
        ops: list = []
        d = self.dim
        sign, self.sign = self.sign, 1.0  # the shape's own sign is applied outside its program
        try:
            self._program(np.zeros(d), np.eye(d), leaves, ops)
        finally:
            self.sign = sign
        return leaves, ops

    def _placed(self) -> list[tuple[float, float, float]]:
        """(distance of each operand's centre from this frame's origin, its bound, its inner)."""
        return [(float(np.linalg.norm(s.center)), s._bound(), s._inner()) for s in self.operands]

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        """Samples of every operand's boundary kept where they lie on this shape's boundary (the
        boundary of a CSG shape is made of pieces of its operands'), then projected onto the zero
        level set (x <- x - phi grad phi)."""
        per = max(8, n // len(self.operands) * 2)
        wl = None
        if window is not None:
            c, radius = self._window_local(window)
            wl = (c, radius)
        cand = np.concatenate([s.surface_points(per, wl) for s in self.operands])
        world = cand @ self.rotation.T + np.asarray(self.center)
        return _project(self, world, keep_tol=1e-9 * (1.0 + np.abs(world).max())) @ self.rotation - (
            np.asarray(self.center) @ self.rotation
        )


class Union(_CSG):
    """The union of shapes: phi = min of theirs. Exact outside; inside, a bound where two solids
    overlap (the depth it gives near a crease is too small)."""

    op = "union"

    def __init__(self, *shapes: Shape, velocity: Any = None, angular_velocity: Any = None) -> None:
        super().__init__(_operands("Union", shapes, 2), velocity, angular_velocity)

    def _bound(self) -> float:
        return max(c + b for c, b, _ in self._placed())

    def _inner(self) -> float:
        return max(0.0, max(i - c for c, _, i in self._placed()))


class Intersection(_CSG):
    """The intersection of shapes: phi = max of theirs. Exact inside; outside, a bound near edges."""

    op = "intersection"

    def __init__(self, *shapes: Shape, velocity: Any = None, angular_velocity: Any = None) -> None:
        super().__init__(_operands("Intersection", shapes, 2), velocity, angular_velocity)

    def _bound(self) -> float:
        return min(c + b for c, b, _ in self._placed())

    def _inner(self) -> float:
        return max(0.0, min(i - c for c, _, i in self._placed()))


class Difference(_CSG):
    """``a`` minus ``b``: phi = max(phi_a, -phi_b). A bound where the cut meets a's surface."""

    op = "difference"

    def __init__(self, a: Shape, b: Shape, *, velocity: Any = None, angular_velocity: Any = None) -> None:
        super().__init__(_operands("Difference", (a, b), 2), velocity, angular_velocity)

    def _bound(self) -> float:
        c, b, _ = self._placed()[0]
        return c + b


def Inside(shape: Shape) -> Shape:
    """The complement of ``shape``: its interior becomes free space, phi = -phi_shape. A container
    (``Inside(Box(...))``) feels only its nearest wall at a ball; in a corner, build it from planes
    instead (one force per wall; docs/physics.md section 1). ``Inside(Sphere(c, R))`` is ``Bowl(c, R)``."""
    if not isinstance(shape, Shape):
        raise V.ArgumentTypeError(f"Inside's shape must be a Shape, got {V.describe(shape)}")
    if isinstance(shape, HeightField):
        raise ValueError("Inside(HeightField) is the air above it: give the terrain upside down instead")
    if isinstance(shape, _Round):
        cls = Bowl if isinstance(shape, Sphere) else Sphere
        return cls(shape.center, shape.radius, velocity=shape.velocity, angular_velocity=shape.angular_velocity)
    out = copy.copy(shape)
    out.sign = -shape.sign
    out._packed = None
    return out


# ---------------------------------------------------------------------------------------------
# User SDFs
# ---------------------------------------------------------------------------------------------


class SDF(Shape):
    """A user's own shape: ``phi``, a ``numba.njit`` function of one point (a tuple of d floats)
    returning its signed distance (< 0 inside the solid), and optionally ``grad``, a ``numba.njit``
    function of the point returning a tuple of d floats (central differences otherwise).

    ``dim`` says whether points are 2- or 3-tuples. ``bounds`` = (lower corner, upper corner)
    bounds the boundary for :meth:`surface_points` (and so for :func:`implicit_overlap`). phi
    should be a distance or a bound of it (|grad phi| <= 1); the neighbour-list path tests every
    ball against it at every step. A ``World`` refuses a phi that is not jitted or not finite
    where it probes it. The step is compiled for the function itself, in every new process (Numba
    cannot cache code that calls a Python-level function object).
    """

    group = "user"

    def __init__(
        self,
        phi: Callable[..., float],
        grad: Callable[..., Any] | None = None,
        *,
        dim: int,
        bounds: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        d = V.integer("dim", dim, 2, 3)
        for name, fn in (("phi", phi), ("grad", grad)):
            if name == "grad" and fn is None:
                continue
            if not _is_jitted(fn):
                raise V.ArgumentTypeError(
                    f"{name} must be a numba.njit function of one point (a tuple of {d} floats), got {V.describe(fn)}"
                )
        self.phi_function = phi
        self.grad_function = grad
        self.bounds = None
        if bounds is not None:
            b = V.real_array("bounds", bounds, shape=(2, d))
            if not np.all(b[1] > b[0]):
                raise ValueError(f"bounds must be (lower, upper) with upper > lower on every axis, got {b.tolist()}")
            self.bounds = b
        self._init_pose((0.0,) * d, None, velocity, angular_velocity)

    def probe(self, points: np.ndarray) -> None:
        """Refuse (ValueError) a phi that raises or is not finite at ``points`` (world frame)."""
        try:
            ev = self._evaluate(points)
        except Exception as exc:  # a user function may fail in any way: report it
            raise ValueError(f"SDF phi={self.phi_function!r} fails on the probe points: {exc}") from exc
        bad = ~np.all(np.isfinite(ev[..., : 1 + self.dim]), axis=-1)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ValueError(
                f"SDF phi={getattr(self.phi_function, '__name__', self.phi_function)!r} is not finite (or its "
                f"gradient is not) at the probe point {np.asarray(points).reshape(-1, self.dim)[k].tolist()}: "
                f"a terrain's phi must be finite everywhere the balls can go"
            )

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        if self.bounds is None:
            raise ValueError("SDF.surface_points needs the shape's bounds: SDF(phi, ..., bounds=(lower, upper))")
        rng = np.random.default_rng(0)
        lo, hi = self.bounds
        start = lo + (hi - lo) * rng.random((4 * n, self.dim))
        world = start @ self.rotation.T + np.asarray(self.center)
        pts = _project(self, world, keep_tol=1e-7 * (1.0 + float(np.abs(hi - lo).max())))
        return (pts - np.asarray(self.center)) @ self.rotation

    def __repr__(self) -> str:
        name = getattr(self.phi_function, "__name__", "?")
        return f"SDF(phi={name}, dim={self.dim}, {self._describe_pose()})"


def _is_jitted(fn: Any) -> bool:
    from numba.core.registry import CPUDispatcher

    return isinstance(fn, CPUDispatcher)


def _project(shape: Shape, points: np.ndarray, keep_tol: float, iterations: int = 12) -> np.ndarray:
    """Points moved onto the zero level set by x <- x - phi grad phi (Newton's step on a distance),
    keeping those that end within ``keep_tol`` of it."""
    x = np.array(points, dtype=np.float64)
    for _ in range(iterations):
        ev = shape._evaluate(x)
        x = x - ev[:, :1] * ev[:, 1 : 1 + shape.dim]
    ev = shape._evaluate(x)
    return x[np.abs(ev[:, 0]) <= keep_tol]


# ---------------------------------------------------------------------------------------------
# Packing for the kernels
# ---------------------------------------------------------------------------------------------


def pack_terrain(terrain: Iterable[Shape] | None, d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kernel arrays (kind (S,), center (S, d), radius (S,)) of the static spheres and bowls."""
    shapes = tuple(terrain) if terrain is not None else ()
    for k, s in enumerate(shapes):
        if not isinstance(s, _Round) or s.kinematic:
            raise ValueError(f"terrain[{k}] must be a static Sphere or Bowl, got {s!r}")
        if s.dim != d:
            raise ValueError(f"terrain[{k}] is {s.dim}D but positions are {d}D")
    kind = np.array([s.kind for s in shapes], dtype=np.int64)
    center = np.array([s.center for s in shapes], dtype=np.float64).reshape(len(shapes), d)
    radius = np.array([s.radius for s in shapes], dtype=np.float64)  # type: ignore[attr-defined]
    return kind, center, radius


def is_static_round(shape: Shape) -> bool:
    """A static Sphere or Bowl: the shapes that run in the core's original code."""
    return isinstance(shape, _Round) and not shape.kinematic


def _omega3(shape: Shape) -> tuple[float, float, float]:
    w = shape.angular_velocity
    if w is None:
        return (0.0, 0.0, 0.0)
    return (0.0, 0.0, w[0]) if shape.dim == 2 else (w[0], w[1], w[2])


def _pose_rows(shapes: Sequence[Shape], B: int, d: int) -> np.ndarray:
    """(B, S, P) pose rows (:func:`.geometry.pose_columns`), each world a copy of the shapes' own."""
    cols = G.pose_columns(d)
    pose = np.zeros((B, len(shapes), G.pose_size(d)))
    for s, shape in enumerate(shapes):
        pose[:, s, cols["position"]] = shape.center
        pose[:, s, cols["rotation"]] = shape.rotation.ravel()
        pose[:, s, cols["velocity"]] = shape.velocity if shape.velocity is not None else 0.0
        pose[:, s, cols["angular_velocity"]] = _omega3(shape)
    return pose


def _shape_rows(shapes: Sequence[Shape], params: Sequence[Sequence[float]]) -> np.ndarray:
    """(S, 3 + P) shape rows: sign, bound, inner, then the parameters."""
    return np.array([[s.sign, s._bound(), s._inner(), *par] for s, par in zip(shapes, params)], dtype=np.float64)


def pack_geometry(shapes: Sequence[Shape], B: int, d: int) -> tuple[Any, list[tuple[str, int]]]:
    """The kernels' :class:`~.geometry.Geometry` of ``shapes`` (none of them a static Sphere or
    Bowl) for B worlds, each shape's pose copied to every world; and where each shape went, as
    (group, index within it). Returns (None, []) for no shapes."""
    shapes = list(shapes)
    if not shapes:
        return None, []
    fields: dict[str, Any] = dict.fromkeys(G.Geometry._fields)
    where: list[tuple[str, int]] = []
    by_group: dict[str, list[Shape]] = {}
    for s in shapes:
        by_group.setdefault(s.group, []).append(s)
        where.append((s.group, len(by_group[s.group]) - 1))
    for name in G.PRIMITIVE_KINDS:
        group = by_group.get(name)
        if group:
            cls: Any = G.GROUP_CLASSES[name]
            fields[name] = cls(_pose_rows(group, B, d), _shape_rows(group, [s._par() for s in group]))
    if by_group.get("heights"):
        group = by_group["heights"]
        NX = max(s.grid_shape[0] for s in group)  # type: ignore[attr-defined]
        NY = max(s.grid_shape[1] for s in group)  # type: ignore[attr-defined]
        heights = np.zeros((B, len(group), NX, NY))
        for k, s in enumerate(group):
            nx, ny = s.grid_shape  # type: ignore[attr-defined]
            heights[:, k, :nx, :ny] = s.heights  # type: ignore[attr-defined]
        fields["heights"] = G.HeightGroup(
            _pose_rows(group, B, d),
            _shape_rows(group, [s._par6() for s in group]),  # type: ignore[attr-defined]
            heights,
        )
    if by_group.get("csg"):
        group = by_group["csg"]
        programs = [s.program() for s in group]  # type: ignore[attr-defined]
        L = max(len(ops) for _, ops in programs)
        M = max(len(leaves) for leaves, _ in programs)
        S = len(group)
        prog = np.zeros((S, 1 + L), dtype=np.int64)
        rows = np.zeros((S, M, 1 + d + d * d + G.N_PAR))
        for k, (leaves, ops) in enumerate(programs):
            prog[k, 0] = len(ops)
            prog[k, 1 : 1 + len(ops)] = ops
            for j, (code, p, r, par) in enumerate(leaves):
                rows[k, j] = np.concatenate([[code], p, np.asarray(r).ravel(), par])
            depth = sp = 0
            for op in ops:  # the stack's depth: +1 a leaf, -1 a binary operation
                sp += 1 if op >= 0 else (0 if op == G.OP_NEGATE else -1)
                depth = max(depth, sp)
            if depth > G.CSG_MAX_DEPTH:
                raise ValueError(
                    f"a CSG shape nests too deep: its evaluation holds {depth} operands at once, at most "
                    f"{G.CSG_MAX_DEPTH} (list more operands in one Union or Intersection instead of nesting them)"
                )
        fields["csg"] = G.CSGGroup(_pose_rows(group, B, d), _shape_rows(group, [[] for _ in group]), prog, rows)
    if by_group.get("user"):
        fields["user"] = tuple(
            G.UserShape(
                _pose_rows([s], B, d)[:, 0],
                _shape_rows([s], [[]])[0],
                s.phi_function,  # type: ignore[attr-defined]
                s.grad_function,  # type: ignore[attr-defined]
                (0.0,) * d,
            )
            for s in by_group["user"]
        )
    fields["motion"] = np.zeros(1) if any(s.kinematic for s in shapes) else None
    fields["dim"] = (0.0,) * d
    return G.Geometry(**fields), where
