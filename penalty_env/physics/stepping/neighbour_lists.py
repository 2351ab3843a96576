"""The Python side of large worlds: one neighbour list per world of a batch, grown when a ball has
more neighbours than it holds, and each world stepped through :func:`.large.run_large` (parallel
over its balls) or :func:`.large.run_large_serial` (on the calling thread)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._jit import entry_point
from ..broadphase.verlet import SlimModel, new_large_world
from ..contact.listed import PAIR_BLOCK, PAIR_ROWS
from .common import STATUS_OK
from .large import LARGE_WORLD_MAX_ESCAPES, NEIGHBOUR_SKIN, run_large, run_large_serial

__all__ = ["NeighbourLists"]


class NeighbourLists:
    """One neighbour list (:class:`~..broadphase.verlet.LargeWorld`) per world of a batch, and its
    stepping.

    ``model`` is the World's :class:`~..model.Model`; each world gets a
    :class:`~..broadphase.verlet.SlimModel` of it whose radii and inverse masses follow its storage
    order, and whose cell size is wide enough for the list's reach, and a full Model sharing those
    arrays, with its own world's shape table, for the serial passes.
    """

    def __init__(self, model: Any, B: int, n: int, d: int, threads: int) -> None:
        self.n, self.d = n, d
        self.threads = max(1, threads)
        self.radii = np.array(model.radii)
        self.inv_mass = np.array(model.inv_mass)
        self.skin = NEIGHBOUR_SKIN * 2.0 * float(self.radii.max())
        self.worlds: list[tuple[Any, SlimModel]] = []
        self.full: list[Any] = []  # per world: its Model with its own shape table (world b's as world 0)
        self._entry: Any = None  # run_large_serial's compiled entry
        for b in range(B):
            radii, inv_mass = self.radii.copy(), self.inv_mass.copy()  # permuted with the storage
            cell = model.cell_size + self.skin
            core = SlimModel.of(model, radii=radii, inv_mass=inv_mass, cell_size=cell)
            self.worlds.append((self._new(4 * (d - 1) ** 2 + 5), core))
            self.full.append(
                model._replace(radii=radii, inv_mass=inv_mass, cell_size=cell, shapes=model.shapes.world(b))
            )
        self.reset()

    def _new(self, cap: int) -> Any:
        escapes = int(np.clip(self.n // 256, 64, LARGE_WORLD_MAX_ESCAPES))
        return new_large_world(self.n, self.d, cap, self.threads, escapes, PAIR_ROWS, PAIR_BLOCK, self.skin)

    def reset(self, worlds: Any = slice(None)) -> None:
        """A world's storage order and list are history: after new state, start afresh, so the
        world steps exactly as a new World made from that state would."""
        for b in np.atleast_1d(np.arange(len(self.worlds))[worlds]):
            lw, model = self.worlds[b]
            lw.perm[:] = np.arange(self.n)
            lw.state[0] = 0
            model.radii[:] = self.radii
            model.inv_mass[:] = self.inv_mass

    def step(
        self,
        integ: int,
        n: int,
        dt: float,
        x: np.ndarray,
        v: np.ndarray,
        ext: np.ndarray,
        has_ext: bool,
        g: tuple,
        status: np.ndarray,
        worlds: Any = None,
        serial: bool = False,
    ) -> None:
        """Advance ``worlds`` (default: every world) by n steps, world after world: each parallel
        over its balls (:func:`run_large`) or, with ``serial``, on the calling thread alone
        (:func:`run_large_serial`, releasing the GIL: the runner steps a batch so, a share of the
        worlds per thread). Both give the same result, bit for bit."""
        for b in range(len(self.worlds)) if worlds is None else worlds:
            w = slice(b, b + 1)
            done = 0
            while done < n:
                lw, model = self.worlds[b]
                if serial:
                    args = (integ, n - done, dt, x[w], v[w], ext[w], has_ext, model, g, status[w], lw, 1, self.full[b])
                    done += self._serial_entry(args)(*args)
                else:
                    threads = self.threads
                    done += run_large(
                        integ, n - done, dt, x[w], v[w], ext[w], has_ext, model, g, status[w], lw, threads, self.full[b]
                    )
                if status[b] != STATUS_OK:
                    break
                if done < n:  # a ball has more neighbours than the list holds: grow it, go on
                    grown = self._new(int(lw.state[1]) + 9)
                    for field in ("perm", "state"):
                        getattr(grown, field)[:] = getattr(lw, field)
                    self.worlds[b] = (grown, model)

    def _serial_entry(self, args: tuple) -> Any:
        """:func:`run_large_serial` compiled for these argument types, called without Numba's
        per-call type resolution (a microsecond per field of each NamedTuple argument, paid per
        world and call). Every argument's type is fixed by the World."""
        if self._entry is None:
            self._entry = entry_point(run_large_serial, args)
        return self._entry

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_entry"] = None  # compiled code: found again (cached) on first use after unpickling
        return state

    def stats(self, b: int = 0) -> dict:
        """World b's list: ``builds`` so far, balls ``escaped`` now, ``listed_per_ball`` (mean listed
        neighbours at the last build), ``largest`` (the most any ball had), ``capacity`` (slots per
        ball), ``near_terrain`` (per ball, in the user's order: within a skin of a shape at the build,
        so tested against the terrain until it escapes)."""
        lw = self.worlds[b][0]
        near = np.zeros(self.n, dtype=bool)
        near[lw.perm] = lw.near != 0
        return {
            "builds": int(lw.state[2]),
            "escaped": int(lw.state[3]),
            "listed_per_ball": float(lw.count.mean()),
            "largest": int(lw.state[1]),
            "capacity": int(lw.nbr.shape[1]),
            "near_terrain": near,
        }
