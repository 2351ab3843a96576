"""The shape table: a scene's terrain as data the kernels read (MuJoCo dispatches on a geom-type
table, Warp on shape arrays: adding a scene never builds new code).

Every shape is a row. Its ``kind`` (:data:`.sdf.KIND_NAMES`) selects the signed distance function,
its ``shape`` row holds its sign (+1 the solid, -1 its complement), a bounding radius about its
centre (inf if unbounded), an inner radius (0 if none) and its parameters, and each world holds
its *pose* (centre, rotation, velocity, angular velocity: the shape moves rigidly, per world).
Height fields keep their node heights per world in one flat buffer, CSG shapes their postfix
programs, user SDFs the addresses of their compiled functions.

The rows come in a fixed order, which is the order in which a ball's terrain forces are summed and
the order of the tangential springs' history slots: the static spheres and bowls first (in terrain
order; each adds its force to the ball as it is computed), then every other shape by kind, in the
order of :data:`.sdf.KIND_NAMES` and within a kind in terrain order (their forces are summed in a
register and added once).

=====================  =========================================================================
array                  contents
=====================  =========================================================================
``kind``   (S,)        the kind code
``flags``  (S,)        ``DIRECT`` (a static sphere or bowl: its force is added as it goes),
                       ``MOVING`` (kinematic: its pose advances, its surface has a velocity)
``shape``  (S, Q)      SIGN, BOUND, INNER, then the parameters P0.. (height fields: nx, ny, cell
                       x, cell y, origin x, origin y), then INDEX (the shape's offset in
                       ``heights``, its row in ``prog`` / ``leaves``, or its row in ``user``)
``pose``   (B, S, P)   per world: centre (d), rotation (d x d, row-major), velocity (d), angular
                       velocity (3; the z one in 2D)
``heights`` (B, H)     every height field's nodes (nx x ny, row-major), per world
``prog``   (C, 1 + L)  each CSG shape's program: its length, then leaf indices (>= 0) and OP_ codes
``leaves`` (C, M, K)   each CSG shape's leaves: kind code, centre (d), rotation (d x d), P0..P2
``user``   (U, 2)      each user SDF: the address of its phi and of its gradient (0: none)
=====================  =========================================================================
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = [
    "ShapeTable",
    "DIRECT",
    "MOVING",
    "SIGN",
    "BOUND",
    "INNER",
    "P0",
    "INDEX",
    "SHAPE_COLUMNS",
    "LEAF_PARAMETERS",
    "OP_UNION",
    "OP_INTERSECTION",
    "OP_DIFFERENCE",
    "OP_NEGATE",
    "CSG_MAX_DEPTH",
    "pose_size",
    "pose_columns",
    "empty_table",
]

DIRECT, MOVING = 1, 2  # bits of ``flags``
SIGN, BOUND, INNER, P0 = 0, 1, 2, 3  # columns of ``shape``; the parameters start at P0
INDEX = P0 + 6  # ... and after the (up to) six parameters, the shape's index into its buffer
SHAPE_COLUMNS = INDEX + 1
LEAF_PARAMETERS = 3  # a CSG leaf's parameters (a primitive's)
OP_UNION, OP_INTERSECTION, OP_DIFFERENCE, OP_NEGATE = -1, -2, -3, -4  # a leaf is its index >= 0
CSG_MAX_DEPTH = 4  # operands a CSG program may hold pending at once (its stack lives in registers)


class ShapeTable(NamedTuple):
    """A scene's terrain shapes as arrays (see the module docstring)."""

    kind: np.ndarray
    flags: np.ndarray
    shape: np.ndarray
    pose: np.ndarray
    heights: np.ndarray
    prog: np.ndarray
    leaves: np.ndarray
    user: np.ndarray

    @property
    def count(self) -> int:
        return int(self.kind.shape[0])

    @property
    def moving(self) -> bool:
        """Whether any shape is kinematic (then poses advance with every step)."""
        return bool(np.any(self.flags & MOVING))

    def world(self, b: int) -> ShapeTable:
        """World b's table as a one-world table whose per-world arrays are views of this one's."""
        return self._replace(pose=self.pose[b : b + 1], heights=self.heights[b : b + 1])


def pose_size(d: int) -> int:
    """Columns of a pose row in d dimensions."""
    return 2 * d + d * d + 3


def pose_columns(d: int) -> dict[str, slice]:
    """Where the centre, rotation, velocity and angular velocity sit in a pose row."""
    return {
        "position": slice(0, d),
        "rotation": slice(d, d + d * d),
        "velocity": slice(d + d * d, 2 * d + d * d),
        "angular_velocity": slice(2 * d + d * d, 2 * d + d * d + 3),
    }


def empty_table(B: int, d: int) -> ShapeTable:
    """A table without shapes (the arrays' types are those of any table: nothing compiles again)."""
    return ShapeTable(
        kind=np.zeros(0, dtype=np.int64),
        flags=np.zeros(0, dtype=np.int64),
        shape=np.zeros((0, SHAPE_COLUMNS)),
        pose=np.zeros((B, 0, pose_size(d))),
        heights=np.zeros((B, 0)),
        prog=np.zeros((0, 1), dtype=np.int64),
        leaves=np.zeros((0, 1, 1 + d + d * d + LEAF_PARAMETERS)),
        user=np.zeros((0, 2), dtype=np.int64),
    )
