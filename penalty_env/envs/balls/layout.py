"""The observation's layout, defined once: the env's kernel, its bounds and the scripted pusher read it.

An observation is a flat float32 vector of fields, each d long (d = 2 or 3). A field is a body's
position, its velocity, the goal, or a difference of two of them. :class:`ObservationLayout` lists
the fields in order for a scene with ``n_obstacles`` obstacles, gives each field's slice, writes
the Markdown table of the env docstring, and computes the bounds; the kernel
(:func:`.kernel.observe`) writes the fields in this order, unrolled (reading the table per
entry doubled the observation's instructions), and clips each entry to the same bounds;
``tests/envs/test_observation_layout.py`` checks the kernel against the table.

Bodies: 0 the pusher, 1 the ball, 2.. the obstacles; :data:`GOAL` stands for the goal.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["ObservationLayout", "Field", "POSITION", "VELOCITY", "DIFFERENCE", "GOAL"]

POSITION, VELOCITY, DIFFERENCE = 0, 1, 2  # what a field holds
GOAL = -1  # the goal, as a "body" of a field


class Field(NamedTuple):
    name: str
    kind: int  # POSITION, VELOCITY or DIFFERENCE (of body ``a`` minus body ``b``)
    a: int
    b: int = 0


def _fields(n_obstacles: int) -> list[Field]:
    out = [
        Field("pusher position", POSITION, 0),
        Field("pusher velocity", VELOCITY, 0),
        Field("ball position", POSITION, 1),
        Field("ball velocity", VELOCITY, 1),
        Field("goal position", POSITION, GOAL),
        Field("ball - pusher", DIFFERENCE, 1, 0),
        Field("goal - ball", DIFFERENCE, GOAL, 1),
    ]
    for j in range(n_obstacles):
        out += [Field(f"obstacle {j} position", POSITION, 2 + j), Field(f"obstacle {j} velocity", VELOCITY, 2 + j)]
    return out


class ObservationLayout:
    """The fields of a PenaltyBalls observation for ``dim`` and ``n_obstacles``.

    Positions are relative to the bowl's lowest point, the last axis up; their bounds are the
    bowl's box (``pos_bound`` = R: -R..R across, 0..2R up), velocities +-``vel_bound``,
    differences +-2R.
    """

    def __init__(
        self,
        dim: int,
        n_obstacles: int,
        pos_bound: float,
        vel_bound: float,
        heightmap: tuple[int, float] | None = None,
    ) -> None:
        self.dim = int(dim)
        self.fields = _fields(int(n_obstacles))
        # with sand, after the fields: the sand's depth in (cells, edge) cells around the ball
        # (cells^(d-1) entries, row-major: x, then y), each in 0..2R
        self.heightmap = heightmap
        self.heightmap_offset = len(self.fields) * self.dim
        self.heightmap_size = 0 if heightmap is None else int(heightmap[0]) ** (self.dim - 1)
        self.size = self.heightmap_offset + self.heightmap_size
        self.pos_bound = float(pos_bound)
        self.vel_bound = float(vel_bound)
        # the kernel's copy of the table: one row (kind, a, b) per field
        self.table = np.array([(f.kind, f.a, f.b) for f in self.fields], dtype=np.int64)
        self.low, self.high = self._bounds()

    def slice(self, name: str) -> slice:
        """Where field ``name`` lives in the observation."""
        for k, f in enumerate(self.fields):
            if f.name == name:
                return slice(k * self.dim, (k + 1) * self.dim)
        raise KeyError(f"no observation field {name!r}; fields: {[f.name for f in self.fields]}")

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """float64 bounds per entry (the kernel clips to these; the space holds their float32)."""
        d, pb, vb = self.dim, self.pos_bound, self.vel_bound
        pos_lo = np.array([-pb] * (d - 1) + [0.0])
        pos_hi = np.array([pb] * (d - 1) + [2.0 * pb])
        vel = np.full(d, vb)
        rel = np.full(d, 2.0 * pb)
        low, high = [], []
        for f in self.fields:
            if f.kind == POSITION:
                low.append(pos_lo)
                high.append(pos_hi)
            elif f.kind == VELOCITY:
                low.append(-vel)
                high.append(vel)
            else:
                low.append(-rel)
                high.append(rel)
        low.append(np.zeros(self.heightmap_size))
        high.append(np.full(self.heightmap_size, 2.0 * pb))
        return np.concatenate(low), np.concatenate(high)

    def markdown(self) -> str:
        """The docstring table: index range, field, bounds."""
        rows = ["| Index | Observation | Min | Max |", "|---|---|---|---|"]
        for k, f in enumerate(self.fields):
            lo, hi = {
                POSITION: ("-R (up: 0)", "R (up: 2R)"),
                VELOCITY: ("-v_bound", "v_bound"),
                DIFFERENCE: ("-2R", "2R"),
            }[f.kind]
            rows.append(f"| {k * self.dim} : {(k + 1) * self.dim} | {f.name} | {lo} | {hi} |")
        if self.heightmap is not None:
            cells, edge = self.heightmap
            grid = f"{cells} x {cells}" if self.dim == 3 else f"{cells}"
            order = " (row-major: x, then y)" if self.dim == 3 else " (along x)"
            rows.append(
                f"| {self.heightmap_offset} : {self.size} | sand depth in {grid} cells of {edge:g} m centred on "
                f"the ball{order}: the highest grain top in the cell above the bare floor under that grain, 0 "
                f"if none | 0 | 2R |"
            )
        return "\n".join(rows)
