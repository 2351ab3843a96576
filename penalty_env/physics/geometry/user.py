"""User SDFs: a user's own ``numba.njit`` signed distance function as a terrain shape."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba import cfunc, types

from ... import _validate as V
from .sdf import USER
from .shapes import Shape, _project

__all__ = ["SDF"]

_PHI_SIGNATURE = types.float64(types.float64, types.float64, types.float64)
_GRAD_SIGNATURE = types.void(types.float64, types.float64, types.float64, types.CPointer(types.float64))


def _callbacks(phi: Any, grad: Any, d: int) -> tuple[Any, Any]:
    """phi (and grad) wrapped as C callbacks taking three coordinates (the last ignored in 2D), as
    :func:`.evaluate.user_sdf` calls them."""
    if d == 3:

        def phi_c(q0, q1, q2):
            return float(phi((q0, q1, q2)))

        def grad_c(q0, q1, q2, out):
            g = grad((q0, q1, q2))
            out[0] = float(g[0])
            out[1] = float(g[1])
            out[2] = float(g[2])

    else:

        def phi_c(q0, q1, q2):
            return float(phi((q0, q1)))

        def grad_c(q0, q1, q2, out):
            g = grad((q0, q1))
            out[0] = float(g[0])
            out[1] = float(g[1])
            out[2] = 0.0

    c_phi = cfunc(_PHI_SIGNATURE, error_model="numpy")(phi_c)
    c_grad = None if grad is None else cfunc(_GRAD_SIGNATURE, error_model="numpy")(grad_c)
    return c_phi, c_grad


class SDF(Shape):
    """A user's own shape: ``phi``, a ``numba.njit`` function of one point (a tuple of d floats)
    returning its signed distance (< 0 inside the solid), and optionally ``grad``, a ``numba.njit``
    function of the point returning a tuple of d floats (central differences otherwise).

    ``dim`` says whether points are 2- or 3-tuples. ``bounds`` = (lower corner, upper corner)
    bounds the boundary for :meth:`surface_points` (and so for :func:`implicit_overlap`). phi
    should be a distance or a bound of it (|grad phi| <= 1); the neighbour-list path tests every
    ball against it at every step. A ``World`` refuses a phi that is not jitted or not finite
    where it probes it. The kernels call the functions through their addresses (each compiled
    once per process as a small C callback, :meth:`addresses`), so the step itself is compiled
    once and cached for any user shape.
    """

    kind = USER

    def __init__(
        self,
        phi: Callable[..., float],
        grad: Callable[..., Any] | None = None,
        *,
        dim: int,
        bounds: Any = None,
        velocity: Any = None,
        angular_velocity: Any = None,
    ) -> None:
        d = V.integer("dim", dim, 2, 3)
        for name, fn in (("phi", phi), ("grad", grad)):
            if name == "grad" and fn is None:
                continue
            if not _is_jitted(fn):
                raise V.ArgumentTypeError(
                    f"{name} must be a numba.njit function of one point (a tuple of {d} floats), got {V.describe(fn)}"
                )
        self.phi_function = phi
        self.grad_function = grad
        self.bounds = None
        if bounds is not None:
            b = V.real_array("bounds", bounds, shape=(2, d))
            if not np.all(b[1] > b[0]):
                raise ValueError(f"bounds must be (lower, upper) with upper > lower on every axis, got {b.tolist()}")
            self.bounds = b
        self._callbacks: tuple[Any, Any] | None = None
        self._init_pose((0.0,) * d, None, velocity, angular_velocity)

    def addresses(self) -> tuple[int, int]:
        """The addresses of phi and of its gradient (0 without one) as C callbacks of the kernels'
        signature (compiled on first use in this process)."""
        if self._callbacks is None:
            self._callbacks = _callbacks(self.phi_function, self.grad_function, self.dim)
        c_phi, c_grad = self._callbacks
        return int(c_phi.address), (0 if c_grad is None else int(c_grad.address))

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_callbacks"] = None  # compiled code: made again on first use after unpickling
        state["_packed"] = None
        return state

    def probe(self, points: np.ndarray) -> None:
        """Refuse (ValueError) a phi that raises or is not finite at ``points`` (world frame)."""
        try:
            ev = self._evaluate(points)
        except Exception as exc:  # a user function may fail in any way: report it
            raise ValueError(f"SDF phi={self.phi_function!r} fails on the probe points: {exc}") from exc
        bad = ~np.all(np.isfinite(ev[..., : 1 + self.dim]), axis=-1)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ValueError(
                f"SDF phi={getattr(self.phi_function, '__name__', self.phi_function)!r} is not finite (or its "
                f"gradient is not) at the probe point {np.asarray(points).reshape(-1, self.dim)[k].tolist()}: "
                f"a terrain's phi must be finite everywhere the balls can go"
            )

    def _local_samples(self, n: int, window: Any) -> np.ndarray:
        if self.bounds is None:
            raise ValueError("SDF.surface_points needs the shape's bounds: SDF(phi, ..., bounds=(lower, upper))")
        rng = np.random.default_rng(0)
        lo, hi = self.bounds
        start = lo + (hi - lo) * rng.random((4 * n, self.dim))
        world = start @ self.rotation.T + np.asarray(self.center)
        pts = _project(self, world, keep_tol=1e-7 * (1.0 + float(np.abs(hi - lo).max())))
        return (pts - np.asarray(self.center)) @ self.rotation

    def __repr__(self) -> str:
        name = getattr(self.phi_function, "__name__", "?")
        return f"SDF(phi={name}, dim={self.dim}, {self._describe_pose()})"


def _is_jitted(fn: Any) -> bool:
    from numba.core.registry import CPUDispatcher

    return isinstance(fn, CPUDispatcher)
