"""The state part of a :class:`~.world.World`: its sizes, views of its state, writing a state, and
the diagnostics of a state (energy, penetration, momenta)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ... import _validate as V
from .. import diagnostics as _diagnostics
from ..model import Model, State

__all__ = ["StateView", "Penetration"]


class Penetration:
    """``(worlds, out)``: each listed world's largest overlap as a fraction of the smaller radius in
    contact, into ``out`` (the diagnostics kernel over the World's state, grid and scratch)."""

    def __init__(self, state: State, model: Model, runner: Any, grid: Any, gravity: tuple) -> None:
        self.state, self.model, self.runner, self.grid, self.gravity = state, model, runner, grid, gravity

    def __call__(self, worlds: np.ndarray, out: np.ndarray) -> None:
        scratch = self.runner.scratch.partners
        x = self.state.positions
        _diagnostics.world_max_penetration(worlds, x, self.grid, scratch, self.model, self.gravity, out)


class StateView:
    """A World's state: views of its buffers, writing them, and what is measured of them.

    Args:
        state: the ``(B, n, d)`` position and velocity buffers; ``spin``: the rotation's
            (:class:`~..model.Spin`, or None); ``model``: the scene; ``runner``: what steps them
            (its scratch, its caches to forget after a write); ``grid``: the broadphase's.
        batched: the World was given a world axis (views then keep it).
        gravity: the gravity vector; ``rotation``: the balls spin.
        penetration: the :class:`Penetration` of this state.
        check_start: the guard's :class:`~.guard.StartCheck` (called for written positions).
    """

    def __init__(
        self,
        state: State,
        spin: Any,
        model: Model,
        runner: Any,
        grid: Any,
        batched: bool,
        gravity: tuple,
        rotation: bool,
        penetration: Penetration,
        check_start: Callable[[np.ndarray], None],
    ) -> None:
        self._state, self._spin, self._model, self._runner, self._grid = state, spin, model, runner, grid
        self._batched, self.gravity, self.rotation = batched, gravity, rotation
        self._check_start = check_start
        self.penetration_into = penetration
        self._scalar = np.zeros(state.positions.shape[0])
        self._all_worlds = np.arange(state.positions.shape[0], dtype=np.int64)

    @property
    def n_worlds(self) -> int:
        return self._state.positions.shape[0]

    @property
    def n_balls(self) -> int:
        return self._state.positions.shape[1]

    @property
    def dim(self) -> int:
        return self._state.positions.shape[2]

    def _view(self, arr: np.ndarray) -> np.ndarray:
        out = arr if self._batched else arr[0]
        out = out.view()
        out.flags.writeable = False  # write through set_state, which keeps caches coherent
        return out

    @property
    def positions(self) -> np.ndarray:
        """Current centres, shaped as given (read-only view; change them with ``set_state``)."""
        return self._view(self._state.positions)

    @positions.setter
    def positions(self, value: Any) -> None:
        self.set_state(positions=value)

    @property
    def velocities(self) -> np.ndarray:
        """Current velocities, shaped as given (read-only view)."""
        return self._view(self._state.velocities)

    @velocities.setter
    def velocities(self, value: Any) -> None:
        self.set_state(velocities=value)

    @property
    def angular_velocities(self) -> np.ndarray:
        """``World.angular_velocities`` (its docstring says what it does)."""
        if self._spin is None:
            R = 3 if self.dim == 3 else 1
            return self._view(np.zeros(self._state.positions.shape[:2] + (R,)))
        return self._view(self._spin.w)  # (zeros without rotation: 1 / I = 0 keeps them so)

    @angular_velocities.setter
    def angular_velocities(self, value: Any) -> None:
        self.set_state(angular_velocities=value)

    def set_state(
        self, positions: Any = None, velocities: Any = None, worlds: Any = None, angular_velocities: Any = None
    ) -> None:
        """``World.set_state`` (its docstring says what it does)."""
        if worlds is not None and np.asarray(worlds).dtype.kind not in "iu":
            raise ValueError(f"worlds must be integer world indices, got dtype {np.asarray(worlds).dtype}")
        chosen = np.arange(self.n_worlds) if worlds is None else np.atleast_1d(np.asarray(worlds, dtype=np.int64))
        if chosen.size and (chosen.min() < 0 or chosen.max() >= self.n_worlds):
            raise ValueError(f"worlds must index 0..{self.n_worlds - 1}, got {worlds!r}")
        idx: Any = slice(None) if worlds is None else chosen
        x = self._state.positions
        target = (chosen.size,) + x.shape[1:]
        if angular_velocities is not None and not self.rotation:
            raise ValueError(
                "angular_velocities: this World has rotation=False (its balls do not spin); pass rotation=True"
            )
        items = [("positions", positions, x), ("velocities", velocities, self._state.velocities)]
        if self.rotation and self._spin is not None:
            items.append(("angular_velocities", angular_velocities, self._spin.w))
        for name, value, dest in items:
            if value is None:
                continue
            arr = V.real_array(name, value)
            if not self._batched and worlds is None:
                arr = arr[None] if arr.ndim == 2 else arr
            want = target[:2] + dest.shape[2:]
            if arr.shape != want:
                raise ValueError(
                    f"{name} must have shape {want if self._batched or worlds is not None else want[1:]}, got {np.shape(value)}"
                )
            dest[idx] = arr
        if positions is not None:
            self._check_start(chosen.astype(np.int64))
            if self._spin is not None:
                self._spin.clock[idx] += 2  # every stamp is now stale: no contact continues
        self._runner.forget(idx, end_history=positions is not None)

    def invalidate_cache(self, worlds: Any = None) -> None:
        """``World.invalidate_cache`` (its docstring says what it does)."""
        self._runner.forget(slice(None) if worlds is None else worlds)

    def _per_world(self, out: np.ndarray) -> Any:
        return out.copy() if self._batched else float(out[0])

    def energy(self) -> Any:
        """``World.energy`` (its docstring says what it does)."""
        x, v = self._state
        buf = self._runner.scratch.partners
        _diagnostics.world_energy(x, v, self._grid, buf, self._model, self.gravity, self._scalar)
        if self._spin is not None:
            sp = self._spin
            if self.rotation:
                inertia = np.broadcast_to(1.0 / sp.inv_inertia, sp.w.shape[:2])  # ((n,) or per world (B, n))
                self._scalar += 0.5 * np.einsum("bnk,bnk,bn->b", sp.w, sp.w, inertia)
            if sp.kt > 0.0 and self._runner.lists is not None:  # (the list keeps them per list slot)
                self._scalar += self._runner.lists.spring_energy()
            elif sp.kt > 0.0:
                live = sp.stamp == sp.clock[:, None, None]
                self._scalar += 0.5 * sp.kt * np.einsum("bij,bijk,bijk->b", live, sp.hist, sp.hist)
        return self._per_world(self._scalar)

    def max_penetration(self) -> Any:
        """Largest overlap as a fraction of the (smaller) radius in contact, per world."""
        self.penetration_into(self._all_worlds, self._scalar)
        return self._per_world(self._scalar)

    def _ball_masses(self) -> np.ndarray:
        """The masses, ``(B, n)`` (each world's own when the World is per-world)."""
        return np.broadcast_to(1.0 / self._model.inv_mass, self._state.positions.shape[:2])

    def momentum(self) -> np.ndarray:
        """Total linear momentum per world, ``(d,)`` or ``(B, d)``."""
        p = np.einsum("bnd,bn->bd", self._state.velocities, self._ball_masses())
        return p if self._batched else p[0]

    def angular_momentum(self) -> np.ndarray:
        """``World.angular_momentum`` (its docstring says what it does)."""
        x, v = self._state
        m = self._ball_masses()[..., None]
        if self.dim == 3:
            L = np.cross(x, m * v).sum(axis=1)
        else:
            L = (x[..., 0] * v[..., 1] - x[..., 1] * v[..., 0])[..., None] * m
            L = L.sum(axis=1)
        if self.rotation and self._spin is not None:
            inertia = np.broadcast_to(1.0 / self._spin.inv_inertia, self._spin.w.shape[:2])
            L = L + np.einsum("bnk,bn->bk", self._spin.w, inertia)
        return L if self._batched else L[0]
