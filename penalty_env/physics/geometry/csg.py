"""Constructive solid geometry: unions, intersections, differences and complements of shapes.

A CSG shape is a postfix program over its leaves (primitives placed in its frame), which the kernels
evaluate on a small stack (:func:`.evaluate.csg_sdf`): data, so a new tree compiles nothing.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np

from ... import _validate as V
from .heightfield import HeightField
from .sdf import CSG
from .shapes import Bowl, Shape, Sphere, _project, _Round
from .table import OP_DIFFERENCE, OP_INTERSECTION, OP_NEGATE, OP_UNION
from .user import SDF

__all__ = ["Union", "Intersection", "Difference", "Inside"]


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

    kind = CSG
    op = ""

    def __init__(self, operands: tuple[Shape, ...], velocity: Any, angular_velocity: Any) -> None:
        self.operands = operands
        self._init_pose((0.0,) * operands[0].dim, None, velocity, angular_velocity)

    def _program(self, pos: np.ndarray, rot: np.ndarray, leaves: list, ops: list) -> None:
        """Each operand's program (placed by its pose in this frame, this frame at (pos, rot)),
        joined left to right by this shape's operation; OP_NEGATE for a complement."""
        code = {"union": OP_UNION, "intersection": OP_INTERSECTION, "difference": OP_DIFFERENCE}[self.op]
        for k, s in enumerate(self.operands):
            s._program(rot @ np.asarray(s.center) + pos, rot @ s.rotation, leaves, ops)
            if k > 0:
                ops.append(code)
        if self.sign < 0.0:
            ops.append(OP_NEGATE)

    def program(self) -> tuple[list, list]:
        """(leaves, ops): this shape's postfix program in its own frame (:func:`.evaluate.csg_sdf`)."""
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
