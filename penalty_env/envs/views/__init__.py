"""Observation modes of the PenaltyBalls envs: the state vector, a height map around the pusher,
a small image, or several of them as a ``Dict``.

:class:`Views` is built from a :class:`~.scene.PenaltyBallsScene` and an ``obs_mode``. It gives
the single observation space (``space``) and fills the observations of a batch of worlds
(``observe``): one Numba call per batch and mode, spread over threads for large batches as the
scene's step is. The single env, the native vector env and the SB3 ``VecEnv`` all observe through
it, so a world's observation does not depend on which env holds it.

* ``"state"``: the scene's own observation vector, as the step kernel wrote it (the default; the
  envs then keep their plain path and never call this module).
* ``"heightmap"``: float32 ``(cells, cells)`` in 3D, ``(cells,)`` in 2D: cells of edge ``cell``
  centred on the pusher, ``[i, j]`` at x = pusher x + (i - (cells - 1) / 2) cell (and y with j);
  each the height above the bowl's lowest point of whatever is highest over the cell's centre:
  the terrain there, or the top of any ball (pusher, ball, obstacles, grains) over it,
  z + sqrt(r^2 - rho^2) at horizontal distance rho < r from the ball's centre. Clipped to
  [0, 2R]. The terrain is the bowl (its closed form; solid, so the cap 2R, beyond its rim), the
  arena (the floor at 0; the cap beyond the walls) or the bumpy ground (the height field's nodes,
  bilinear, held at the edge beyond it, the bowl where that is higher).
* ``"rgb"``: uint8 ``(size, size, 3)``: a top view (3D, x right, y up) or a side view (2D, x
  right, z up) ``2 VIEW_HALF_WIDTH`` metres across, centred on the bowl's bottom, as the
  renderer's frames are: the terrain's image (computed once per terrain, per world on the bumpy
  ground and redrawn only when the world's ``terrain_version`` changes), the goal as a green
  disc of the success radius, and every ball as a flat disc in its colour (the renderer's
  palette), grains first, then the obstacles, the pusher and the ball on top. A ball outside the
  view is drawn small at the border, as in the renderer.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from gymnasium import spaces

from ... import _validate as V
from ..._jit import compile_notice, entry_point
from ...physics.stepping import runner as runner_module
from ..terrains import TerrainHeights
from .raster import (
    VIEW_HALF_WIDTH,
    heightmap_worlds,
    rgb_worlds,
    terrain_images,
)

__all__ = ["Views", "StateView", "ViewSubject", "OBS_MODES", "VIEW_PARAMETERS", "pop_view_kwargs", "check_obs_mode"]

OBS_MODES = ("state", "heightmap", "rgb")

# the views' keyword arguments: default, allowed range, meaning (the env docstring's table)
VIEW_PARAMETERS: dict[str, tuple[Any, Any, Any, str]] = {
    "heightmap_cells": (16, 2, 64, "obs_mode 'heightmap': cells per horizontal axis"),
    "heightmap_cell": (0.1, 0.01, 1.0, "obs_mode 'heightmap': cell edge, m"),
    "rgb_size": (64, 16, 256, "obs_mode 'rgb': image width and height, pixels"),
}

# threads: a batch is split when worlds x this reaches the runner's threshold (about 16 worlds
# for an image, 64 for a height map)
_RGB_WORK = 128
_HEIGHTMAP_WORK = 32


def check_obs_mode(obs_mode: Any) -> tuple[str, ...] | str:
    """``obs_mode`` checked: one of :data:`OBS_MODES`, or a non-empty tuple or list of distinct
    ones (returned as a tuple: a ``Dict`` observation). Anything else raises ValueError naming the
    argument, the value and the allowed values."""
    allowed = f"one of {OBS_MODES} or a non-empty tuple or list of distinct ones"
    if isinstance(obs_mode, str):
        if obs_mode not in OBS_MODES:
            raise ValueError(f"obs_mode must be {allowed}, got {obs_mode!r}")
        return obs_mode
    if isinstance(obs_mode, (tuple, list)):
        modes = tuple(obs_mode)
        bad = [m for m in modes if not isinstance(m, str) or m not in OBS_MODES]
        if not modes or bad or len(set(modes)) != len(modes):
            what = f"unknown mode(s) {bad!r}" if bad else "empty" if not modes else "a mode repeated"
            raise ValueError(f"obs_mode must be {allowed}, got {obs_mode!r} ({what})")
        return modes
    raise ValueError(f"obs_mode must be {allowed}, got {V.describe(obs_mode)} ({type(obs_mode).__name__})")


def pop_view_kwargs(kwargs: dict[str, Any]) -> dict[str, Any]:
    """Take the views' keyword arguments (``obs_mode`` and :data:`VIEW_PARAMETERS`) out of an env's
    ``kwargs`` (the rest are the scene's), checked (before the scene is built)."""
    out = {k: kwargs.pop(k) for k in ("obs_mode", *VIEW_PARAMETERS) if k in kwargs}
    if "obs_mode" in out:
        out["obs_mode"] = check_obs_mode(out["obs_mode"])
    for name in VIEW_PARAMETERS:
        if name in out:
            out[name] = _check_parameter(name, out[name])
    return out


def _check_parameter(name: str, value: Any) -> Any:
    default, lo, hi, meaning = VIEW_PARAMETERS[name]
    if isinstance(default, int):
        return V.integer(name, value, lo, hi, meaning)
    return V.in_range(name, value, lo, hi, meaning)


class ViewSubject(NamedTuple):
    """What a task shows its views (its ``view_subject()``): live arrays, read at every call."""

    dim: int
    n_worlds: int
    state_space: spaces.Box  # the task's state vector (one world's)
    state: np.ndarray  # (B, size) float32: the task's state vectors
    world: Any  # the World (its positions: ``world.runner.physics.x``)
    radii: np.ndarray  # (B, n): each world's radii
    colors: np.ndarray  # (n, 3), 0..255: each ball's colour
    order: np.ndarray  # the balls in drawing order (the last on top)
    focus: np.ndarray | None  # (B, d): where each world's height map is centred; None: ball 0
    goal: np.ndarray  # (B, d): the goal drawn in the image (NaN: none)
    goal_radius: float
    terrain: TerrainHeights  # the ground's height (:mod:`..terrains`)
    terrain_per_world: bool  # drawn anew at resets: one image per world
    terrain_version: np.ndarray  # (B,): bumped at every reset that redraws a world's terrain
    height_bound: float  # the height map's upper bound


class StateView:
    """The engine's view of a task observed by its state vector alone (the task's ``obs``)."""

    is_state = True

    def __init__(self, scene: Any) -> None:
        self.scene = scene
        self.space = scene.observation_space

    def observe(self, worlds: Sequence[int] | np.ndarray | None = None) -> np.ndarray:
        return self.scene.obs.copy() if worlds is None else self.scene.obs[worlds]

    def item(self, batch: np.ndarray, t: int) -> np.ndarray:
        return batch[t].copy()


class Views:
    """The observations of a scene's worlds in the mode ``obs_mode`` (see the module docstring).

    Args:
        scene: the :class:`~.scene.PenaltyBallsScene` observed.
        obs_mode: ``"state"``, ``"heightmap"``, ``"rgb"``, or a tuple or list of them (a ``Dict``
            observation keyed by mode).
        heightmap_cells, heightmap_cell, rgb_size: :data:`VIEW_PARAMETERS`.

    ``space`` is the single observation space; ``observe(worlds)`` the batch of the listed worlds
    (an array with a leading world axis, or a dict of them); ``single(b)`` world b's alone.
    """

    def __init__(
        self,
        scene: Any,
        obs_mode: Any = "state",
        heightmap_cells: int = VIEW_PARAMETERS["heightmap_cells"][0],
        heightmap_cell: float = VIEW_PARAMETERS["heightmap_cell"][0],
        rgb_size: int = VIEW_PARAMETERS["rgb_size"][0],
    ) -> None:
        mode = check_obs_mode(obs_mode)
        self.scene = scene
        self.obs_mode = mode
        self.modes: tuple[str, ...] = (mode,) if isinstance(mode, str) else mode
        self.is_dict = not isinstance(mode, str)
        self.is_state = mode == "state"
        self.heightmap_cells: int = _check_parameter("heightmap_cells", heightmap_cells)
        self.heightmap_cell: float = _check_parameter("heightmap_cell", heightmap_cell)
        self.rgb_size: int = _check_parameter("rgb_size", rgb_size)
        subject = self.subject = scene.view_subject()
        d = subject.dim
        self.height_bound = subject.height_bound
        H, S = self.heightmap_cells, self.rgb_size
        self.heightmap_shape = (H, H) if d == 3 else (H,)
        self.rgb_shape = (S, S, 3)
        self.scale = S / (2.0 * VIEW_HALF_WIDTH)  # pixels per metre
        self.ground = 0.8 * S  # 2D: the pixel row of z = 0
        singles: dict[str, spaces.Space] = {
            "state": subject.state_space,
            "heightmap": spaces.Box(0.0, np.float32(self.height_bound), self.heightmap_shape, dtype=np.float32),
            "rgb": spaces.Box(0, 255, self.rgb_shape, dtype=np.uint8),
        }
        self.space: spaces.Space = (
            spaces.Dict({m: singles[m] for m in self.modes}) if self.is_dict else singles[self.modes[0]]
        )
        self._all = np.arange(subject.n_worlds, dtype=np.int64)
        self._backgrounds: np.ndarray | None = None
        self._kernels: dict[str, Any] = {}

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_kernels"] = {}  # compiled code: found again (cached) on first use after unpickling
        return state

    # ------------------------------------------------------------------ observing
    def observe(self, worlds: Sequence[int] | np.ndarray | None = None) -> Any:
        """The observations of ``worlds`` (default: every world), stacked in that order: one array
        with a leading axis, or (a ``Dict`` mode) a dict of them keyed by mode. Fresh arrays."""
        idx = self._all if worlds is None else np.ascontiguousarray(worlds, dtype=np.int64)
        out = {m: self._observe(m, idx) for m in self.modes}
        return out if self.is_dict else out[self.modes[0]]

    def single(self, b: int) -> Any:
        """World b's observation (no world axis)."""
        return self.item(self.observe(np.array([b], dtype=np.int64)), 0)

    def item(self, batch: Any, t: int) -> Any:
        """Row t of a batch from :meth:`observe` (a copy)."""
        if self.is_dict:
            return {m: batch[m][t].copy() for m in self.modes}
        return batch[t].copy()

    def _observe(self, mode: str, idx: np.ndarray) -> np.ndarray:
        v = self.subject
        k = idx.size
        if mode == "state":
            return v.state[idx]
        x = v.world.runner.physics.x
        if mode == "heightmap":
            H = self.heightmap_cells
            W = H if v.dim == 3 else 1
            hm = np.empty((k, H, W), dtype=np.float32)
            focus = x[:, 0] if v.focus is None else v.focus
            tail = (x, focus, v.radii, v.terrain, W, self.heightmap_cell, 0.0, self.height_bound)
            self._dispatch("heightmap", heightmap_worlds, idx, hm, tail, _HEIGHTMAP_WORK)
            return hm if v.dim == 3 else hm.reshape(k, H)
        backgrounds, background_of = self._terrain_images(idx)
        img = np.empty((k,) + self.rgb_shape, dtype=np.uint8)
        tail_rgb = (
            x,
            v.radii,
            v.colors,
            v.order,
            v.goal,
            v.goal_radius,
            backgrounds,
            background_of,
            self.scale,
            self.ground,
        )
        self._dispatch("rgb", rgb_worlds, idx, img, tail_rgb, _RGB_WORK)
        return img

    def _dispatch(self, name: str, fn: Any, idx: np.ndarray, out: np.ndarray, tail: tuple, work: int) -> None:
        """``fn(worlds, out rows, *tail)`` over the batch, split over threads when it is large."""
        chunks = runner_module.split(idx, work) if idx.size > 1 else [idx]
        calls, start = [], 0
        for c in chunks:
            calls.append((c, out[start : start + c.size]) + tail)
            start += c.size
        kernel = self._kernels.get(name)
        if kernel is None:
            with compile_notice(f"{name} observation"):
                kernel = self._kernels[name] = entry_point(fn, calls[0])
        runner_module.dispatch(kernel, calls)

    # ------------------------------------------------------------------ the terrain
    def _terrain_images(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The terrain images and each world's row in them: one image for the bowl and the arena
        (the same in every world), one per world on the bumpy ground, redrawn for the worlds of
        ``idx`` whose ``terrain_version`` changed since it was drawn."""
        s = self.subject
        S = self.rgb_size
        per_world = s.terrain_per_world
        if self._backgrounds is None:
            count = s.n_worlds if per_world else 1
            self._backgrounds = np.zeros((count, S, S, 3), dtype=np.uint8)
            self._background_of = np.arange(s.n_worlds, dtype=np.int64) if per_world else np.zeros(s.n_worlds, np.int64)
            self._drawn = np.full(s.n_worlds, -1, dtype=np.int64)  # the terrain version drawn per world
            if not per_world:
                self._draw(np.zeros(1, dtype=np.int64))
                self._drawn[:] = 0
        if per_world:
            stale = idx[s.terrain_version[idx] != self._drawn[idx]]
            if stale.size:
                self._draw(stale)
                self._drawn[stale] = s.terrain_version[stale]
        return self._backgrounds, self._background_of

    def _draw(self, worlds: np.ndarray) -> None:
        rows = self._background_of[worlds]
        tail = (self.subject.terrain, self.scale, self.ground, self.subject.dim)
        assert self._backgrounds is not None
        calls = [(c, rows[c0 : c0 + c.size], self._backgrounds) + tail for c0, c in self._chunked(worlds)]
        kernel = self._kernels.get("terrain")
        if kernel is None:
            with compile_notice("terrain image"):
                kernel = self._kernels["terrain"] = entry_point(terrain_images, calls[0])
        runner_module.dispatch(kernel, calls)

    def _chunked(self, worlds: np.ndarray) -> list[tuple[int, np.ndarray]]:
        chunks = runner_module.split(worlds, _RGB_WORK * 8) if worlds.size > 1 else [worlds]
        out, start = [], 0
        for c in chunks:
            out.append((start, c))
            start += c.size
        return out
