"""Shapes into the kernels' :class:`~.table.ShapeTable` (the Python side of the table).

It reads each shape's kind code (:data:`.sdf.KIND_NAMES`) and what that kind holds, and imports no
shape class: the shapes import it (a shape evaluates itself through a one-shape table)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from .sdf import CSG, HEIGHTS, KIND_NAMES, ROUND, USER
from .table import (
    CSG_MAX_DEPTH,
    DIRECT,
    INDEX,
    LEAF_PARAMETERS,
    MOVING,
    OP_NEGATE,
    P0,
    SHAPE_COLUMNS,
    ShapeTable,
    empty_table,
    pose_columns,
    pose_size,
)

__all__ = ["PackedTerrain", "pack_table", "is_static_round", "user_addresses"]


class PackedTerrain(NamedTuple):
    """A terrain as a table, and the table row of each of its shapes (in terrain order)."""

    table: ShapeTable
    rows: tuple[int, ...]


def is_static_round(shape: Any) -> bool:
    """A static Sphere or Bowl: its force is added to a ball as it is computed (table.DIRECT)."""
    return shape.kind == ROUND and not shape.kinematic


def _table_order(shapes: Sequence[Any]) -> list[int]:
    """The table's row order of ``shapes`` (indices): static spheres and bowls first, in their
    order; then the rest by kind, each kind in their order (:mod:`.table`)."""
    direct = [k for k, s in enumerate(shapes) if is_static_round(s)]
    rest = sorted((k for k, s in enumerate(shapes) if not is_static_round(s)), key=lambda k: (shapes[k].kind, k))
    return direct + rest


def _omega3(shape: Any) -> tuple[float, float, float]:
    w = shape.angular_velocity
    if w is None:
        return (0.0, 0.0, 0.0)
    return (0.0, 0.0, w[0]) if shape.dim == 2 else (w[0], w[1], w[2])


def _pose_row(shape: Any, d: int) -> np.ndarray:
    cols = pose_columns(d)
    row = np.zeros(pose_size(d))
    row[cols["position"]] = shape.center
    row[cols["rotation"]] = shape.rotation.ravel()
    row[cols["velocity"]] = shape.velocity if shape.velocity is not None else 0.0
    row[cols["angular_velocity"]] = _omega3(shape)
    return row


def _program_arrays(shapes: list[Any], d: int) -> tuple[np.ndarray, np.ndarray]:
    """(prog, leaves) of the CSG shapes: each program's length and ops, each leaf's row."""
    programs = [s.program() for s in shapes]
    L = max([len(ops) for _, ops in programs], default=0)
    M = max([len(leaves) for leaves, _ in programs], default=1)
    prog = np.zeros((len(shapes), 1 + L), dtype=np.int64)
    rows = np.zeros((len(shapes), M, 1 + d + d * d + LEAF_PARAMETERS))
    for k, (leaves, ops) in enumerate(programs):
        prog[k, 0] = len(ops)
        prog[k, 1 : 1 + len(ops)] = ops
        for j, (code, p, r, par) in enumerate(leaves):
            par = list(par) + [0.0] * (LEAF_PARAMETERS - len(par))
            rows[k, j] = np.concatenate([[code], p, np.asarray(r).ravel(), par])
        depth = sp = 0
        for op in ops:  # the stack's depth: +1 a leaf, -1 a binary operation
            sp += 1 if op >= 0 else (0 if op == OP_NEGATE else -1)
            depth = max(depth, sp)
        if depth > CSG_MAX_DEPTH:
            raise ValueError(
                f"a CSG shape nests too deep: its evaluation holds {depth} operands at once, at most "
                f"{CSG_MAX_DEPTH} (list more operands in one Union or Intersection instead of nesting them)"
            )
    if not shapes:
        prog = np.zeros((0, 1), dtype=np.int64)
    return prog, rows


def user_addresses(shapes: Sequence[Any]) -> np.ndarray:
    """(U, 2) the addresses of the user SDFs' callbacks, in table order (compiled on first use)."""
    users = [shapes[k] for k in _table_order(shapes) if shapes[k].kind == USER]
    out = np.zeros((len(users), 2), dtype=np.int64)
    for u, s in enumerate(users):
        out[u] = s.addresses()
    return out


def pack_table(shapes: Sequence[Any], B: int, d: int) -> PackedTerrain:
    """The :class:`~.table.ShapeTable` of ``shapes`` for B worlds (each world's poses and heights a
    copy of the shapes' own), and each shape's row."""
    shapes = list(shapes)
    if not shapes:
        return PackedTerrain(empty_table(B, d), ())
    order = _table_order(shapes)
    S = len(shapes)
    kind = np.array([shapes[k].kind for k in order], dtype=np.int64)
    flags = np.array(
        [(DIRECT if is_static_round(shapes[k]) else 0) | (MOVING if shapes[k].kinematic else 0) for k in order],
        dtype=np.int64,
    )
    table_shape = np.zeros((S, SHAPE_COLUMNS))
    pose = np.zeros((B, S, pose_size(d)))
    fields = [s for s in (shapes[k] for k in order) if s.kind == HEIGHTS]
    H = sum(f.grid_shape[0] * f.grid_shape[1] for f in fields)
    heights = np.zeros((B, H))
    csgs = [s for s in (shapes[k] for k in order) if s.kind == CSG]
    offset = 0
    for row, k in enumerate(order):
        s = shapes[k]
        if s.kind < 0 or s.kind >= len(KIND_NAMES):
            raise TypeError(f"terrain shape {k} ({type(s).__name__}) has no kernel kind")
        par = s._par6() if s.kind == HEIGHTS else s._par()
        table_shape[row, :P0] = (s.sign, s._bound(), s._inner())
        table_shape[row, P0 : P0 + len(par)] = par
        if s.kind == HEIGHTS:
            n = s.grid_shape[0] * s.grid_shape[1]
            table_shape[row, INDEX] = offset
            heights[:, offset : offset + n] = s.heights.ravel()
            offset += n
        elif s.kind == CSG:
            table_shape[row, INDEX] = csgs.index(s)
        elif s.kind == USER:
            table_shape[row, INDEX] = sum(shapes[j].kind == USER for j in order[:row])
        pose[:, row] = _pose_row(s, d)
    prog, leaves = _program_arrays(csgs, d)
    table = ShapeTable(
        kind=kind,
        flags=flags,
        shape=table_shape,
        pose=pose,
        heights=heights,
        prog=prog,
        leaves=leaves,
        user=user_addresses(shapes),
    )
    rows = [0] * S
    for row, k in enumerate(order):
        rows[k] = row
    return PackedTerrain(table, tuple(rows))
