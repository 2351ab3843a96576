"""The terrain part of a :class:`~.world.World`: each shape's pose per world, height fields' heights,
and the terrain's signed distance at points."""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import _validate as V
from ..geometry.evaluate import evaluate, evaluate_shape
from ..geometry.heightfield import HeightField
from ..geometry.table import DIRECT, INDEX, MOVING, ShapeTable, pose_columns
from ..geometry.user import SDF
from .checks import world_index

__all__ = ["TerrainView", "per_world", "probe_user_sdf"]


def per_world(name: str, value: Any, shape: tuple[int, ...], count: int) -> np.ndarray:
    """``value`` of ``shape``, or one per world (``(count,) + shape``); finite."""
    arr = V.real_array(name, value)
    if arr.shape == (1,) and shape == ():
        arr = arr.reshape(())
    if arr.shape != shape and arr.shape != (count,) + shape:
        raise ValueError(
            f"{name} must have shape {shape} (all chosen worlds) or {(count,) + shape} (one per world), got {arr.shape}"
        )
    return arr


class TerrainView:
    """A World's terrain: its shapes' poses and heights per world, read and written, and the signed
    distance at points.

    Args:
        terrain: the World's shapes; ``rows``: each one's row in ``table``, the shape table the
            kernels read (its pose and height columns are per world).
        n_worlds, dim: the World's sizes; ``gravity``: its gravity (the table's evaluation takes it).
        forget: ``(worlds)`` -> the runner forgets what it derived of those worlds (after a move).
    """

    def __init__(
        self, terrain: tuple, rows: tuple, table: ShapeTable, n_worlds: int, dim: int, gravity: tuple, forget: Any
    ) -> None:
        self.terrain, self._rows, self._table = terrain, rows, table
        self.n_worlds, self.dim, self.gravity = n_worlds, dim, gravity
        self._forget = forget

    def _world_index(self, worlds: Any) -> Any:
        return world_index(worlds, self.n_worlds)

    def _slot(self, shape: Any) -> tuple[int, int]:
        """(terrain index, table row) of a shape that may move."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        row = self._rows[k]
        if self._table.flags[row] & DIRECT:
            raise ValueError(
                f"terrain[{k}] is a static {type(self.terrain[k]).__name__}: static spheres and bowls are shared by "
                f"every world and cannot move; give it velocity=(0.0,) * d at construction to make it kinematic"
            )
        return k, row

    def _pose_rows(self, row: int) -> np.ndarray:
        """The (B, P) pose rows of a table row (a view into the model's arrays)."""
        return self._table.pose[:, row]

    def shape_pose(self, shape: int, world: int = 0) -> dict[str, np.ndarray]:
        """``World.shape_pose`` (its docstring says what it does)."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        b = V.integer("world", world, 0, self.n_worlds - 1)
        d = self.dim
        if self._table.flags[self._rows[k]] & DIRECT:
            t = self.terrain[k]
            return {
                "position": np.array(t.center),
                "rotation": np.eye(d),
                "velocity": np.zeros(d),
                "angular_velocity": np.zeros(3 if d == 3 else 1),
            }
        row = self._pose_rows(self._rows[k])[b]
        cols = pose_columns(d)
        omega = row[cols["angular_velocity"]]
        return {
            "position": row[cols["position"]].copy(),
            "rotation": row[cols["rotation"]].reshape(d, d).copy(),
            "velocity": row[cols["velocity"]].copy(),
            "angular_velocity": omega.copy() if d == 3 else omega[2:].copy(),
        }

    def set_shape_pose(
        self,
        shape: int,
        position: Any = None,
        rotation: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
        worlds: Any = None,
    ) -> None:
        """``World.set_shape_pose`` (its docstring says what it does)."""
        k, row = self._slot(shape)
        d = self.dim
        idx = self._world_index(worlds)
        count = self.n_worlds if worlds is None else len(np.atleast_1d(idx))
        if (velocity is not None or angular_velocity is not None) and not self._table.flags[row] & MOVING:
            raise ValueError(
                f"terrain[{k}] was made static (it does not move with every step): give it velocity=(0.0,) * {d} "
                f"at construction to set its velocity or angular velocity"
            )
        rows = self._pose_rows(row)
        cols = pose_columns(d)
        values = []
        if position is not None:
            values.append(("position", per_world("position", position, (d,), count)))
        if rotation is not None:
            R = per_world("rotation", rotation, (d, d), count)
            for m in R.reshape(-1, d, d):
                if np.abs(m.T @ m - np.eye(d)).max() > 1e-9 or np.linalg.det(m) < 0.0:
                    raise ValueError(
                        f"rotation must be a rotation matrix ({d}x{d}, orthonormal, det +1), got {m.tolist()}"
                    )
            values.append(("rotation", R.reshape(R.shape[:-2] + (d * d,))))
        if velocity is not None:
            values.append(("velocity", per_world("velocity", velocity, (d,), count)))
        if angular_velocity is not None:
            w = per_world("angular_velocity", angular_velocity, (3,) if d == 3 else (1,), count)
            if d == 2:
                full = np.zeros(w.shape[:-1] + (3,))
                full[..., 2] = w[..., 0]
                w = full
            values.append(("angular_velocity", w))
        for column, value in values:  # all checked before any is written
            if worlds is None:
                rows[:, cols[column]] = value
            else:
                rows[idx, cols[column]] = value
        self._forget(idx)

    def set_heights(self, shape: int, heights: Any, worlds: Any = None) -> None:
        """``World.set_heights`` (its docstring says what it does)."""
        k, row = self._slot(shape)
        hf = self.terrain[k]
        if not isinstance(hf, HeightField):
            raise ValueError(f"terrain[{k}] is a {type(hf).__name__}, not a HeightField")
        nx, ny = hf.grid_shape
        idx = self._world_index(worlds)
        count = self.n_worlds if worlds is None else len(np.atleast_1d(idx))
        shape_ = (nx,) if self.dim == 2 else (nx, ny)
        h = per_world("heights", heights, shape_, count)
        table = self._table
        start = int(table.shape[row, INDEX])
        flat = h.reshape(h.shape[: h.ndim - len(shape_)] + (nx * ny,))
        table.heights[idx, start : start + nx * ny] = flat
        self._forget(idx)

    def shape_heights(self, shape: int, world: int = 0) -> np.ndarray:
        """``World.shape_heights`` (its docstring says what it does)."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        b = V.integer("world", world, 0, self.n_worlds - 1)
        hf = self.terrain[k]
        if not isinstance(hf, HeightField):
            raise ValueError(f"terrain[{k}] is a {type(hf).__name__}, not a HeightField")
        nx, ny = hf.grid_shape
        table = self._table
        start = int(table.shape[self._rows[k], INDEX])
        flat = table.heights[b, start : start + nx * ny].copy()
        return flat if self.dim == 2 else flat.reshape(nx, ny)

    def height_table(self, shape: int) -> tuple[np.ndarray, int]:
        """``World.height_table`` (its docstring says what it does)."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        if not isinstance(self.terrain[k], HeightField):
            raise ValueError(f"terrain[{k}] is a {type(self.terrain[k]).__name__}, not a HeightField")
        table = self._table
        return table.heights, int(table.shape[self._rows[k], INDEX])

    def shape_distance(self, shape: int, points: Any, world: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """``World.shape_distance`` (its docstring says what it does)."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        b = V.integer("world", world, 0, self.n_worlds - 1)
        pts, flat = self._points(points)
        row = self._rows[k]
        if self._table.flags[row] & DIRECT:
            phi, normal = self.terrain[k].phi(flat), self.terrain[k].grad_phi(flat)
        else:
            ev = self.evaluate(b, flat)
            phi, normal = ev[:, row, 0], ev[:, row, 1 : 1 + self.dim]
        return phi.reshape(pts.shape[:-1]), normal.reshape(pts.shape)

    def shape_distances(self, shape: int, points: Any, worlds: Any) -> tuple[np.ndarray, np.ndarray]:
        """``World.shape_distances`` (its docstring says what it does)."""
        k = V.integer("shape", shape, 0, len(self.terrain) - 1, "an index into terrain")
        if worlds is None:
            raise ValueError("worlds must be integer world indices (one per row of points), got None")
        idx = self._world_index(worlds)
        pts = V.real_array("points", points)
        if pts.ndim < 2 or pts.shape[0] != idx.size or pts.shape[-1] != self.dim:
            raise ValueError(
                f"points must have shape ({idx.size}, ..., {self.dim}) (one row per world of worlds), got {pts.shape}"
            )
        flat = np.ascontiguousarray(pts.reshape(idx.size, -1, self.dim))
        row = self._rows[k]
        if self._table.flags[row] & DIRECT:  # (a static sphere or bowl: the same in every world)
            both = flat.reshape(-1, self.dim)
            phi, normal = self.terrain[k].phi(both), self.terrain[k].grad_phi(both)
        else:
            ev = np.zeros(flat.shape[:2] + (4,))
            evaluate_shape(self._table, row, idx, flat, ev, self.gravity)
            phi, normal = ev[..., 0], ev[..., 1 : 1 + self.dim]
        return phi.reshape(pts.shape[:-1]), normal.reshape(pts.shape)

    def _points(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        pts = V.real_array("points", points)
        if pts.shape[-1:] != (self.dim,):
            raise ValueError(f"points must have last dimension {self.dim}, got shape {pts.shape}")
        return pts, np.ascontiguousarray(pts.reshape(-1, self.dim))

    def evaluate(self, b: int, flat: np.ndarray) -> np.ndarray:
        """(m, S, 4): phi and the normal of every table row of world b at the points ``flat``."""
        ev = np.zeros((len(flat), self._table.count, 4))
        evaluate(self._table, b, flat, ev, self.gravity)
        return ev

    def terrain_distance(self, points: Any, world: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """``World.terrain_distance`` (its docstring says what it does)."""
        b = V.integer("world", world, 0, self.n_worlds - 1)
        pts, flat = self._points(points)
        d = self.dim
        phi = np.full(len(flat), np.inf)
        normal = np.zeros((len(flat), d))
        flags = self._table.flags
        general = [k for k in range(len(self.terrain)) if not flags[self._rows[k]] & DIRECT]
        for k, shape in enumerate(self.terrain):
            if flags[self._rows[k]] & DIRECT:
                p, n = shape.phi(flat), shape.grad_phi(flat)
                closer = p < phi
                phi = np.where(closer, p, phi)
                normal = np.where(closer[:, None], n, normal)
        if general:
            rows = sorted(self._rows[k] for k in general)  # the table's order
            ev = self.evaluate(b, flat)[:, rows]
            k = np.argmin(ev[:, :, 0], axis=1)
            best = ev[np.arange(len(flat)), k]
            closer = best[:, 0] < phi
            phi = np.where(closer, best[:, 0], phi)
            normal = np.where(closer[:, None], best[:, 1 : 1 + d], normal)
        return phi.reshape(pts.shape[:-1]), normal.reshape(pts.shape)


def probe_user_sdf(shape: Any, x: np.ndarray) -> None:
    """Refuse a user SDF that is not finite where the balls start or on a
    lattice over their bounding box grown by twice its size (at least 2 either side) each way."""
    lo, hi = x.reshape(-1, x.shape[-1]).min(0), x.reshape(-1, x.shape[-1]).max(0)
    span = np.maximum(hi - lo, 1.0)
    axes = [np.linspace(lo[k] - 2.0 * span[k], hi[k] + 2.0 * span[k], 7) for k in range(x.shape[-1])]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, x.shape[-1])
    points = np.concatenate([x.reshape(-1, x.shape[-1])[:4096], lattice])
    assert isinstance(shape, SDF)
    shape.probe(points)
