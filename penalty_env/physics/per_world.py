"""Per-world physics parameters: the accessors through which the kernels read a :class:`~.model.Model`
whose parameters differ between the worlds of a batch (domain randomisation).

A :class:`~.model.Model` holds its contact scalars (``ks, kd, ks_terrain, kd_terrain, mu, kf``) as
floats, its ``radii`` and ``inv_mass`` as ``(n,)`` arrays and its motors' ``max_force`` as an ``(m,)``
array: one scene for every world. A *per-world* model holds them as ``(B,)``, ``(B, n)`` and ``(B, m)``
arrays instead (and a :class:`~.model.Spin` its ``inv_inertia`` as ``(B, n)`` and ``kr`` as ``(B,)``).
The kernels never index those arrays themselves: they read the model through the accessors here,
which Numba resolves at compile time from the model's type.

* :func:`world_model` (and :func:`world_spin`): world b's model, with floats and ``(n,)`` arrays, as
  a fixed scene's. For a fixed model it returns the model itself, so a fixed scene compiles exactly
  the code it compiled before (no copy, no branch, the same types downstream); for a per-world model
  it builds world b's view (a tuple of views: no allocation), and everything downstream compiles once
  more for nothing new, since the view has the fixed model's types. The scalar path, the diagnostics
  and the environments' kernel call it once per world.
* :func:`lane_model`, :func:`lane`, :func:`lane_law`: the SIMD-lanes path steps a block of worlds
  per vector, so its parameters become vectors too. :func:`lane_model` copies the block's parameters
  into the lanes layout once per block (a per-thread ``(rows, LANES)`` scratch, :func:`lane_rows`)
  and returns a model whose scalars are ``(LANES,)`` rows and whose per-ball arrays are ``(n, LANES)``;
  :func:`lane` reads lane w of such a row (or returns a float as it is). For a fixed model both are
  the identity.
"""

from __future__ import annotations

import numpy as np
from numba import types

from .._jit import overload_kernel
from .model import Model, Motors, Spin

__all__ = [
    "PER_WORLD_FIELDS",
    "is_per_world",
    "world_model",
    "world_spin",
    "lane_buffers",
    "lane_model",
    "lane",
    "lane_law",
    "lane_rows",
    "of_world",
    "friction_on",
]

# the Model's fields that a per-world model holds per world (a float or (n,) array become (B,) or (B, n))
PER_WORLD_FIELDS = ("radii", "inv_mass", "ks", "kd", "ks_terrain", "kd_terrain", "mu", "kf")


def is_per_world(model: Model) -> bool:
    """Whether a (Python) model holds its parameters per world."""
    return isinstance(model.ks, np.ndarray)


def _field(tup: types.BaseNamedTuple, name: str) -> types.Type:
    return tup.types[tup.fields.index(name)]


def _typed_per_world(model: types.Type) -> bool:
    return isinstance(_field(model, "ks"), types.Array)


def world_model(model, b):
    """World b's model, its parameters as a fixed scene's (jitted code only)."""
    raise NotImplementedError("world_model is called from jitted code")


@overload_kernel(world_model, hot=True)
def _world_model(model, b):
    if not _typed_per_world(model):
        return lambda model, b: model

    def impl(model, b):
        m = model.motors
        return Model(
            model.radii[b],
            model.inv_mass[b],
            model.ks[b],
            model.kd[b],
            model.ks_terrain[b],
            model.kd_terrain[b],
            model.no_tension,
            model.mu[b],
            model.kf[b],
            model.cell_size,
            model.shapes,
            Motors(m.ball, m.max_force[b], m.inv_max_speed, m.axes),
        )

    return impl


def world_spin(spin, b):
    """World b's rotation parameters (its ``inv_inertia`` (n,) and ``kr``; jitted code only)."""
    raise NotImplementedError("world_spin is called from jitted code")


@overload_kernel(world_spin, hot=True)
def _world_spin(spin, b):
    if isinstance(spin, types.NoneType) or not isinstance(_field(spin, "kr"), types.Array):
        return lambda spin, b: spin

    def impl(spin, b):
        s = spin
        return Spin(
            s.kt, s.kd_t, s.mu_r, s.kr[b], s.dt, s.w, s.alpha, s.inv_inertia[b], s.w0, s.sw, s.hist, s.stamp, s.clock
        )

    return impl


def lane_rows(n: int, motors: int) -> int:
    """Rows of the lanes path's parameter scratch of a per-world scene: the six contact scalars, then
    the radii and inverse masses (n rows each), then the motors' stall forces (one row each)."""
    return 6 + 2 * n + motors


def lane_buffers(lane_scratch):
    """(the block scratch, the parameter scratch) of a thread's lanes scratch: an array (a fixed
    scene: the parameter scratch is a placeholder, never read) or the pair (array, (rows, LANES))
    of a per-world scene (jitted code only)."""
    raise NotImplementedError("lane_buffers is called from jitted code")


@overload_kernel(lane_buffers, hot=True)
def _lane_buffers(lane_scratch):
    if isinstance(lane_scratch, types.Array):
        return lambda lane_scratch: (lane_scratch, lane_scratch[5, 0])
    return lambda lane_scratch: (lane_scratch[0], lane_scratch[1])


def lane_model(model, block, W, P):
    """The model of a block of W worlds (lane w holds world ``block[w]``) in the lanes layout, its
    per-world parameters copied into ``P`` (jitted code only; the model itself when fixed)."""
    raise NotImplementedError("lane_model is called from jitted code")


@overload_kernel(lane_model)
def _lane_model(model, block, W, P):
    if not _typed_per_world(model):
        return lambda model, block, W, P: model

    def impl(model, block, W, P):
        n = model.radii.shape[1]
        m = model.motors
        q = m.ball.shape[0]
        for w in range(W):
            b = block[w]
            P[0, w] = model.ks[b]
            P[1, w] = model.kd[b]
            P[2, w] = model.ks_terrain[b]
            P[3, w] = model.kd_terrain[b]
            P[4, w] = model.mu[b]
            P[5, w] = model.kf[b]
            for i in range(n):
                P[6 + i, w] = model.radii[b, i]
                P[6 + n + i, w] = model.inv_mass[b, i]
            for k in range(q):
                P[6 + 2 * n + k, w] = m.max_force[b, k]
        return Model(
            P[6 : 6 + n],
            P[6 + n : 6 + 2 * n],
            P[0],
            P[1],
            P[2],
            P[3],
            model.no_tension,
            P[4],
            P[5],
            model.cell_size,
            model.shapes,
            Motors(m.ball, P[6 + 2 * n : 6 + 2 * n + q], m.inv_max_speed, m.axes),
        )

    return impl


def lane(x, w):
    """Lane w of a lanes-layout parameter row, or a fixed scene's float as it is (jitted code only)."""
    raise NotImplementedError("lane is called from jitted code")


@overload_kernel(lane, hot=True)
def _lane(x, w):
    if isinstance(x, types.Array):
        return lambda x, w: x[w]
    return lambda x, w: x


def lane_law(model, w):
    """The contact law's scalars of lane w as a fixed scene's model, for the lanes path's calls into
    the scalar terrain law (which reads ``ks_terrain, kd_terrain, no_tension, mu, kf`` and takes the
    radius as an argument: the per-ball rows stay lane rows, unread). The model itself when fixed
    (jitted code only)."""
    raise NotImplementedError("lane_law is called from jitted code")


@overload_kernel(lane_law, hot=True)
def _lane_law(model, w):
    if not _typed_per_world(model):
        return lambda model, w: model

    def impl(model, w):
        m = model.motors
        return Model(
            model.radii[0],
            model.inv_mass[0],
            model.ks[w],
            model.kd[w],
            model.ks_terrain[w],
            model.kd_terrain[w],
            model.no_tension,
            model.mu[w],
            model.kf[w],
            model.cell_size,
            model.shapes,
            Motors(m.ball, m.max_force[:, 0], m.inv_max_speed, m.axes),
        )

    return impl


def of_world(x, b):
    """World b's entry of a per-world ``(B,)`` array, or a fixed scene's float as it is (jitted code
    only; for the few per-world values outside the model, such as the environments' push offset)."""
    raise NotImplementedError("of_world is called from jitted code")


@overload_kernel(of_world, hot=True)
def _of_world(x, b):
    if isinstance(x, types.Array):
        return lambda x, b: x[b]
    return lambda x, b: x


def friction_on(mu):
    """Whether to compute friction in a lanes loop: ``mu > 0`` for a fixed scene's float (the same
    in every lane: LLVM unswitches the loop); always for a per-world lane row (a lane whose mu is 0
    gets a zero friction force, min(kf |u|, 0) / |u| = 0), so that the loop has no per-lane branch
    and stays vectorised (jitted code only)."""
    raise NotImplementedError("friction_on is called from jitted code")


@overload_kernel(friction_on, hot=True)
def _friction_on(mu):
    if isinstance(mu, types.Array):
        return lambda mu: True
    return lambda mu: mu > 0.0
