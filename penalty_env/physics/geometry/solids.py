"""Boxes, capsules and the solids of revolution (cylinders, cones, tori): their parameters, bounds
and boundary samples (their signed distances are :mod:`.sdf`'s)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ... import _validate as V
from .sdf import BOX, CAPSULE, CONE, CYLINDER, TORUS
from .shapes import Shape, _axis_and_rotation, _axis_rotation, _point, _rotation, _sphere_dirs

__all__ = ["Box", "Capsule", "Cylinder", "Cone", "Torus"]


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

    kind = BOX

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
        return list(self.half_extents)

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

    kind = CAPSULE

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
        return [self.half_length, self.radius]

    def _bound(self) -> float:
        return self.half_length + self.radius

    def _inner(self) -> float:
        return self.radius

    def __repr__(self) -> str:
        return f"Capsule(a={self.a}, b={self.b}, radius={self.radius:g})"


class Cylinder(Shape):
    """A finite cylinder of ``radius`` and ``half_height`` along ``axis`` (default the last axis),
    with flat caps; in 2D the rectangle of half widths (radius, half_height). Exact."""

    kind = CYLINDER

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
        return [self.radius, self.half_height]

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

    kind = CONE

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
        return [self.bottom_radius, self.top_radius, self.half_height]

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

    kind = TORUS

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
        return [self.major_radius, self.minor_radius]

    def _bound(self) -> float:
        return self.major_radius + self.minor_radius

    def __repr__(self) -> str:
        return f"Torus({self._describe_pose()}, major_radius={self.major_radius:g}, minor_radius={self.minor_radius:g})"
