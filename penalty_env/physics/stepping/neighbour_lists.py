"""The Python side of large worlds: one neighbour list per world of a batch, grown when a ball has
more neighbours than it holds, and each world stepped through :func:`.large.run_large` (parallel
over its balls) or :func:`.large.run_large_serial` (on the calling thread); spinning balls through
:func:`.large_spin.run_large_spin` and its serial twin, with their springs per list slot
(:mod:`..broadphase.history`), whose tables grow the same way."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._jit import compile_notice, entry_point
from ..broadphase.history import CARRY_NEEDED, OVERFLOW_NEEDED, ListHistory, new_list_history
from ..broadphase.verlet import SlimModel, new_large_world
from ..contact.listed import PAIR_BLOCK, PAIR_ROWS
from ..contact.listed_spin import SPIN_BLOCK, SPIN_ROWS
from ..geometry.table import DIRECT
from ..model import Spin
from .common import STATUS_OK
from .large import LARGE_WORLD_MAX_ESCAPES, NEIGHBOUR_SKIN, run_large, run_large_serial
from .large_spin import run_large_spin, run_large_spin_serial

__all__ = ["NeighbourLists"]


class NeighbourLists:
    """One neighbour list (:class:`~..broadphase.verlet.LargeWorld`) per world of a batch, and its
    stepping.

    ``model`` is the World's :class:`~..model.Model`; each world gets a
    :class:`~..broadphase.verlet.SlimModel` of it whose radii and inverse masses follow its storage
    order, and whose cell size is wide enough for the list's reach, and a full Model sharing those
    arrays, with its own world's shape table, for the serial passes.

    ``spin`` (the World's :class:`~..model.Spin`, or None): the balls spin. Each world then keeps a
    Spin of its own in storage order (its springs per list slot and per ball and shape), the escaped
    balls' tables (a Spin sharing its arrays but the springs) and a
    :class:`~..broadphase.history.ListHistory`; the World's Spin keeps the angular velocities in
    ball order and the step counters (``clock``), which every step call hands to the kernel.
    """

    # the first sizes of a world's history tables (each grows when short): springs per escaped
    # ball's table, and live springs per ball in the compact table of a rebuild
    PER_ESCAPE = 8
    CARRY_PER_BALL = {2: 2, 3: 4}

    def __init__(self, model: Any, B: int, n: int, d: int, threads: int, spin: Spin | None = None) -> None:
        self.n, self.d = n, d
        self.threads = max(1, threads)
        self.radii = np.array(model.radii)
        self.inv_mass = np.array(model.inv_mass)
        self.skin = NEIGHBOUR_SKIN * 2.0 * float(self.radii.max())
        self.worlds: list[tuple[Any, SlimModel]] = []
        self.full: list[Any] = []  # per world: its Model with its own shape table (world b's as world 0)
        self._entry: Any = None  # run_large_serial's (or run_large_spin_serial's) compiled entry
        self._parallel_called = False  # (the first parallel call may compile: said once, compile_notice)
        self.spin = spin
        self.spins: list[tuple[Spin, Spin, ListHistory]] = []  # per world: (its Spin, the escaped tables, the rest)
        self.shapes = model.shapes.count
        for b in range(B):
            radii, inv_mass = self.radii.copy(), self.inv_mass.copy()  # permuted with the storage
            cell = model.cell_size + self.skin
            core = SlimModel.of(model, radii=radii, inv_mass=inv_mass, cell_size=cell)
            self.worlds.append((self._new(4 * (d - 1) ** 2 + 5), core))
            self.full.append(
                model._replace(radii=radii, inv_mass=inv_mass, cell_size=cell, shapes=model.shapes.world(b))
            )
            if spin is not None:
                self.spins.append(self._new_spin(spin, self.worlds[-1][0], model.shapes))
        self.reset()

    def _new_spin(self, spin: Spin, lw: Any, table: Any) -> tuple[Spin, Spin, ListHistory]:
        """One world's spin state for the list ``lw`` (with history: its listed springs packed in
        the list's order, its terrain springs per ball and shape; see :mod:`..broadphase.history`)."""
        n, R = self.n, spin.w.shape[2]
        cap, E = lw.nbr.shape[1], lw.escapes.shape[0]
        history = spin.kt > 0.0
        rows, cols = (n, self.shapes) if history else (1, 1)
        sp = spin._replace(
            w=np.zeros((1, n, R)),
            alpha=np.zeros((1, n, R)),
            inv_inertia=np.array(spin.inv_inertia),  # (permuted with the storage)
            w0=np.zeros((1, 1, R)),
            sw=np.zeros((1, 1, R)),
            hist=np.zeros((1, rows, max(cols, 1), 3)),
            stamp=np.full((1, rows, max(cols, 1)), -1, dtype=np.int64),
            clock=np.zeros(1, dtype=np.int64),  # (the World's counter is handed in at each call)
        )
        K = self.PER_ESCAPE if history else 1
        over = sp._replace(hist=np.zeros((1, E, K, 3)), stamp=np.full((1, E, K), -1, dtype=np.int64))
        rounds = [s for s in range(table.count) if table.flags[s] & DIRECT]
        carry = self.CARRY_PER_BALL[self.d] * n if history else 1
        block = SPIN_ROWS * SPIN_BLOCK
        threads = lw.moved.shape[0]
        lh = new_list_history(n, cap if history else 0, cols, E, K, carry, rounds, threads, block)
        return sp, over, lh

    def _new(self, cap: int) -> Any:
        escapes = int(np.clip(self.n // 256, 64, LARGE_WORLD_MAX_ESCAPES))
        return new_large_world(self.n, self.d, cap, self.threads, escapes, PAIR_ROWS, PAIR_BLOCK, self.skin)

    def reset(self, worlds: Any = slice(None), end_history: bool = False) -> None:
        """A world's storage order and list are history: after new state, start afresh, so the
        world steps exactly as a new World made from that state would. ``end_history`` (new
        positions): the listed pairs' springs end too (they carry no stamp: a rebuild would carry
        every nonzero one into the new state's contacts); the terrain's and the escaped balls'
        tables end by their stamps (the World's spin clock)."""
        for b in np.atleast_1d(np.arange(len(self.worlds))[worlds]):
            lw, model = self.worlds[b]
            if end_history and self.spins:
                lh = self.spins[b][2]
                lh.pair_springs[:] = 0.0
                lh.carry_hist[:] = 0.0
            if self.spins:  # the spins to ball order (the list's springs wait for the rebuild's carry)
                sp = self.spins[b][0]
                assert self.spin is not None
                sp.inv_inertia[:] = self.spin.inv_inertia
                if sp.kt > 0.0:
                    sp.hist[0][lw.perm] = sp.hist[0].copy()
                    sp.stamp[0][lw.perm] = sp.stamp[0].copy()
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
                if self.spins:
                    done += self._step_spin(b, integ, n - done, dt, x[w], v[w], ext[w], has_ext, g, status[w], serial)
                elif serial:
                    args = (integ, n - done, dt, x[w], v[w], ext[w], has_ext, model, g, status[w], lw, 1, self.full[b])
                    done += self._serial_entry(args)(*args)
                else:
                    args = (
                        integ,
                        n - done,
                        dt,
                        x[w],
                        v[w],
                        ext[w],
                        has_ext,
                        model,
                        g,
                        status[w],
                        lw,
                        self.threads,
                        self.full[b],
                    )
                    done += self._parallel(run_large, args)
                if status[b] != STATUS_OK:
                    break
                if done < n and not (self.spins and self._grow_history(b)):
                    # a ball has more neighbours than the list holds: grow it, go on
                    grown = self._new(int(lw.state[1]) + 9)
                    for field in ("perm", "state"):
                        getattr(grown, field)[:] = getattr(lw, field)
                    self.worlds[b] = (grown, model)
                    if self.spins:
                        self._widen_springs(b, lw, grown)

    def _step_spin(
        self, b: int, integ: int, n: int, dt: float, x, v, ext, has_ext: bool, g, status, serial: bool
    ) -> int:
        """World b's steps with its balls spinning (:func:`run_large_spin`, or its serial twin): the
        World's angular velocities and step counter (``clock``) of that world handed in."""
        assert self.spin is not None
        lw, model = self.worlds[b]
        sp, over, lh = self.spins[b]
        clock = self.spin.clock[b : b + 1]
        sp, over = sp._replace(clock=clock), over._replace(clock=clock)
        w = self.spin.w[b : b + 1]
        threads = 1 if serial else self.threads
        args = (integ, n, dt, x, v, w, ext, has_ext, model, g, status, lw, sp, over, lh, threads, self.full[b])
        if serial:
            return int(self._serial_entry(args)(*args))
        return int(self._parallel(run_large_spin, args))

    def _parallel(self, fn: Any, args: tuple) -> int:
        """``fn(*args)`` (:func:`run_large` or :func:`run_large_spin`), the first call in a
        :class:`compile_notice` (it may compile for seconds)."""
        if getattr(self, "_parallel_called", False):  # (a pickle of an older World lacks it)
            return int(fn(*args))
        self._parallel_called = True
        with compile_notice("neighbour-list step, parallel" + (" (spinning)" if self.spins else "")):
            return int(fn(*args))

    def _grow_history(self, b: int) -> bool:
        """After a spinning world's steps stopped short: grow the table that was too small (the
        compact table of a rebuild, or the escaped balls' tables, keeping their springs). False when
        neither was: then the list itself was."""
        sp, over, lh = self.spins[b]
        if lh.state[CARRY_NEEDED] > 0:
            size = int(lh.state[CARRY_NEEDED]) + self.n // 4 + 16
            lh = lh._replace(carry_partner=np.zeros(size, dtype=np.int64), carry_hist=np.zeros((size, 3)))
            lh.state[CARRY_NEEDED] = 0
        elif lh.state[OVERFLOW_NEEDED] > 0:
            K = int(lh.state[OVERFLOW_NEEDED]) + 4
            E, old = over.stamp.shape[1], over.stamp.shape[2]
            hist, stamp = np.zeros((1, E, K, 3)), np.full((1, E, K), -1, dtype=np.int64)
            partner = np.full((1, E, K), -1, dtype=np.int64)
            hist[:, :, :old], stamp[:, :, :old], partner[:, :, :old] = over.hist, over.stamp, lh.over_partner
            over = over._replace(hist=hist, stamp=stamp)
            lh = lh._replace(over_partner=partner)
            lh.state[OVERFLOW_NEEDED] = 0
        else:
            return False
        self.spins[b] = (sp, over, lh)
        return True

    def _widen_springs(self, b: int, lw: Any, grown: Any) -> None:
        """A grown list: its packed springs as many (the old ones wait, saved, for the rebuild that
        fills the grown list)."""
        sp, over, lh = self.spins[b]
        if sp.kt > 0.0:
            lh = lh._replace(pair_springs=np.zeros((self.n * grown.nbr.shape[1], 3)))
        self.spins[b] = (sp, over, lh)

    def _serial_entry(self, args: tuple) -> Any:
        """:func:`run_large_serial` (or :func:`run_large_spin_serial`) compiled for these argument types, called without Numba's
        per-call type resolution (a microsecond per field of each NamedTuple argument, paid per
        world and call). Every argument's type is fixed by the World."""
        if self._entry is None:
            with compile_notice("neighbour-list step" + (" (spinning)" if self.spins else "")):
                self._entry = entry_point(run_large_spin_serial if self.spins else run_large_serial, args)
        return self._entry

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_entry"] = None  # compiled code: found again (cached) on first use after unpickling
        return state

    def _live(self, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World b's live springs: of its listed pairs (a mask of ``pair_springs``: not zero), of
        the terrain (a mask of its Spin's: written in the last step), of the escaped balls' tables
        (likewise)."""
        assert self.spin is not None
        sp, over, lh = self.spins[b]
        c = self.spin.clock[b]
        listed = np.zeros(len(lh.pair_springs), dtype=bool)
        listed[: lh.pair_first[-1]] = np.any(lh.pair_springs[: lh.pair_first[-1]] != 0.0, axis=1)
        return listed, sp.stamp[0] == c, over.stamp[0] == c

    def live_springs(self, b: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """World b's live tangential springs in the user's ball order, as the scalar path keeps them:
        ``(pairs, xi, shapes, xi_shapes)``, pairs ``(k, 2)`` ball indices i < j with their springs
        from i's side (the scalar path's ``hist[b, i, j]``), sorted; shapes ``(k', 2)`` (ball, shape
        row) with theirs (``hist[b, i, n + s]``). A listed spring that is zero is a new contact's
        (not listed here)."""
        sp, over, lh = self.spins[b]
        lw = self.worlds[b][0]
        listed, terrain, escaped = self._live(b)
        perm, cnt = lw.perm, lw.count
        rows = np.repeat(np.arange(self.n), cnt)
        cols = np.arange(lh.pair_first[-1]) - lh.pair_first[rows]
        keep = listed[: lh.pair_first[-1]]
        rows, cols = rows[keep], cols[keep]
        i, j = perm[rows], perm[lw.nbr[rows, cols]]
        xi = lh.pair_springs[: lh.pair_first[-1]][keep]
        e, k = np.nonzero(escaped)
        a, p = lw.escapes[e], lh.over_partner[0, e, k]
        lo, hi = np.minimum(a, p), np.maximum(a, p)  # (kept from the lower slot's side)
        i, j = np.concatenate([i, perm[lo]]), np.concatenate([j, perm[hi]])
        xi = np.concatenate([xi, over.hist[0, e, k]])
        xi = np.where((i < j)[:, None], xi, -xi)  # (from the lower ball's side)
        pairs = np.stack([np.minimum(i, j), np.maximum(i, j)], axis=1)
        order = np.lexsort((pairs[:, 1], pairs[:, 0]))
        rows, cols = np.nonzero(terrain)
        shapes = np.stack([perm[rows], cols], axis=1)
        sorder = np.lexsort((shapes[:, 1], shapes[:, 0]))
        return pairs[order], xi[order], shapes[sorder], sp.hist[0, rows, cols][sorder]

    def spring_energy(self) -> np.ndarray:
        """Per world, the tangential springs' energy: 1/2 kt xi^2 summed over the live springs of
        the list, the terrain and the escaped balls' tables."""
        out = np.zeros(len(self.worlds))
        for b, (sp, over, lh) in enumerate(self.spins):
            if sp.kt > 0.0:
                listed, terrain, escaped = self._live(b)
                xi2 = np.einsum("i,ik,ik->", listed, lh.pair_springs, lh.pair_springs)
                xi2 += np.einsum("ij,ijk,ijk->", terrain, sp.hist[0], sp.hist[0])
                out[b] = 0.5 * sp.kt * (xi2 + np.einsum("ij,ijk,ijk->", escaped, over.hist[0], over.hist[0]))
        return out

    def stats(self, b: int = 0) -> dict:
        """World b's list: ``builds`` so far, balls ``escaped`` now, ``listed_per_ball`` (mean listed
        neighbours at the last build), ``largest`` (the most any ball had), ``capacity`` (slots per
        ball), ``near_terrain`` (per ball, in the user's order: within a skin of a shape at the build,
        so tested against the terrain until it escapes), ``springs`` (spinning balls with history: the
        live tangential springs, of pairs and of the terrain)."""
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
            "springs": self._springs(b),
        }

    def _springs(self, b: int) -> int:
        """World b's live tangential springs (0 without history)."""
        if not self.spins or not self.spins[b][0].kt > 0.0:
            return 0
        return int(sum(mask.sum() for mask in self._live(b)))
