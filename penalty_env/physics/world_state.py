"""The state side of a :class:`~.world.World`: its sizes, views of its state, writing a state, and
the diagnostics of a state (energy, penetration, momenta)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as V
from . import diagnostics as _diagnostics
from .model import Model, State

__all__ = ["StateAccess"]


class StateAccess:
    """A World's state methods (its buffers: ``_state``, ``_spin``, ``_runner``, ``_status``...)."""

    _state: State
    _model: Model
    _batched: bool
    _spin: Any
    _runner: Any
    _status: np.ndarray
    _scalar: np.ndarray
    _grid: Any
    _all_worlds: np.ndarray
    rotation: bool
    integrator: str
    stepping: str
    gravity: tuple
    masses: np.ndarray
    _check_start: Callable[[np.ndarray], None]  # the guard's start-overlap warning
    _max_penetration_of: Callable[[np.ndarray, np.ndarray], None]  # World's diagnostics entry

    @property
    def n_worlds(self) -> int:
        return self._state.positions.shape[0]

    @property
    def n_balls(self) -> int:
        return self._state.positions.shape[1]

    @property
    def dim(self) -> int:
        return self._state.positions.shape[2]

    @property
    def model(self) -> Model:
        """The scene's static description (radii, masses, terrain, every contact parameter)."""
        return self._model

    @property
    def spin(self) -> Any:
        """The rotation's parameters and buffers (:class:`~.model.Spin`: inverse inertias, rolling
        resistance, tangential history), or None for balls that neither spin nor carry a history."""
        return self._spin

    @property
    def state(self) -> State:
        """The World's own ``(B, n, d)`` position and velocity buffers, always batched. For code
        that fuses its own per-step work with the core's kernels (the environments do): after
        writing them directly, call :meth:`invalidate_cache` for the worlds written."""
        return self._state

    @property
    def runner(self) -> Any:
        """The runner that steps this World (its path, buffers and thread pool)."""
        return self._runner

    @property
    def event_buffers(self) -> Any:
        """The event location's buffers and counters (``events.stats(world)`` sums them), or None."""
        return self._runner.event_buffers

    @property
    def status(self) -> np.ndarray:
        """Per world, after the last step: 0 ok, 1 NaN or inf, 2 implicit Euler's solve did not converge."""
        out = self._status.view()
        out.flags.writeable = False
        return out

    @property
    def cg_tol(self) -> float:
        """implicit Euler: the conjugate gradients' relative residual tolerance (default 1e-10)."""
        return float(self._cg()[0])

    @cg_tol.setter
    def cg_tol(self, value: float) -> None:
        self._cg()[0] = V.positive("cg_tol", value)

    @property
    def cg_max_iter(self) -> int:
        """implicit Euler: the largest number of conjugate-gradient iterations per step."""
        return int(self._cg()[1])

    @cg_max_iter.setter
    def cg_max_iter(self, value: int) -> None:
        self._cg()[1] = V.integer("cg_max_iter", value, 1)

    def _cg(self) -> np.ndarray:
        work = self._runner.work
        if not hasattr(work, "cg"):
            raise AttributeError(f"cg_tol and cg_max_iter belong to implicit_euler, not {self.integrator}")
        return work.cg

    def neighbour_list_stats(self, world: int = 0) -> dict:
        """The neighbour list of one world (``stepping='neighbour_list'``): builds so far, balls
        escaped now, mean listed neighbours per ball at the last build, and its capacity."""
        if self._runner.lists is None:
            raise ValueError(f"this World steps {self.stepping!r}, without a neighbour list")
        return self._runner.lists.stats(V.integer("world", world, 0, self.n_worlds - 1))

    @property
    def force_evaluations_per_step(self) -> int:
        """Full contact passes per step (implicit Euler: one, plus its CG iterations' products)."""
        return 4 if self.integrator == "rk4" else 1

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
        """Current angular velocities, ``(n, 3)`` in 3D and ``(n, 1)`` in 2D (about the axis out of
        the plane), ``(B, n, .)`` when batched (read-only view; zeros when ``rotation=False``)."""
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
        """Overwrite positions, velocities and/or (with rotation) angular velocities, of all worlds or
        of the worlds indexed by ``worlds`` (then the arrays are ``(len(worlds), n, .)``). New
        positions end every contact's tangential history in those worlds."""
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
        self._runner.forget(idx)

    def _world_index(self, worlds: Any) -> Any:
        if worlds is None:
            return slice(None)
        if np.asarray(worlds).dtype.kind not in "iu":
            raise ValueError(f"worlds must be integer world indices, got dtype {np.asarray(worlds).dtype}")
        chosen = np.atleast_1d(np.asarray(worlds, dtype=np.int64))
        if chosen.size and (chosen.min() < 0 or chosen.max() >= self.n_worlds):
            raise ValueError(f"worlds must index 0..{self.n_worlds - 1}, got {worlds!r}")
        return chosen

    def invalidate_cache(self, worlds: Any = None) -> None:
        """Forget what was derived from the state (velocity Verlet's cached acceleration, a large
        world's neighbour list and storage order), after writing ``state``'s arrays directly."""
        self._runner.forget(slice(None) if worlds is None else worlds)

    def _per_world(self, out: np.ndarray) -> Any:
        return out.copy() if self._batched else float(out[0])

    def energy(self) -> Any:
        """Kinetic + gravitational + penalty-spring potential (1/2 ks overlap^2), per world; with
        rotation also the rotational kinetic energy (1/2 I w^2) and the tangential springs' (1/2 kt
        xi^2, the history model)."""
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
        self._max_penetration_of(self._all_worlds, self._scalar)
        return self._per_world(self._scalar)

    def _ball_masses(self) -> np.ndarray:
        """The masses, ``(B, n)`` (each world's own when the World is per-world)."""
        return np.broadcast_to(1.0 / self._model.inv_mass, self._state.positions.shape[:2])

    def momentum(self) -> np.ndarray:
        """Total linear momentum per world, ``(d,)`` or ``(B, d)``."""
        p = np.einsum("bnd,bn->bd", self._state.velocities, self._ball_masses())
        return p if self._batched else p[0]

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the origin per world, sum of m x cross v + I w: ``(3,)`` in
        3D, ``(1,)`` in 2D (about the axis out of the plane), ``(B, .)`` when batched."""
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
